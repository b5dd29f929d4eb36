// bench/fuzz/fuzz_common.hpp: shared part of the libFuzzer targets (bench/fuzz/run.sh).
// Each target writes the input bytes to a temporary file and calls one morse reader on it. A
// reader may reject the input only by throwing morse::Error (or by its documented error return);
// any other exception, a crash, a sanitizer report, a hang (-timeout) or a large allocation
// (-rss_limit_mb) is a finding.
#pragma once

#include <petscsys.h>
#include <mpi.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "morse/core/error.hpp"

namespace morse_fuzz {

/// Initializes PETSc (and MPI) once, on PETSC_COMM_SELF semantics: one process, no signal
/// handler of PETSc (libFuzzer and the sanitizers handle the signals).
inline void init(int* argc, char*** argv) {
  (void)argc;
  (void)argv;
  static bool done = false;
  if (done) return;
  done = true;
  static int pargc = 3;
  static char a0[] = "fuzz", a1[] = "-no_signal_handler", a2[] = "-skip_petscrc";
  static char* pargv_data[] = {a0, a1, a2, nullptr};
  static char** pargv = pargv_data;
  if (PetscInitialize(&pargc, &pargv, nullptr, nullptr) != 0) std::abort();
  // Not finalized: libFuzzer exits with exit() from its own threads; MPI is torn down by the OS.
}

/// Writes the bytes to a file in /dev/shm (else /tmp) ending in `ext` (e.g. ".msh"); the same
/// name for the whole run of this process.
inline std::string write_input(const uint8_t* data, size_t size, const char* ext) {
  static std::string dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
  std::string path = dir + "/morse_fuzz_" + std::to_string(getpid()) + ext;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

}  // namespace morse_fuzz

/// Defines LLVMFuzzerInitialize (PETSc once) and LLVMFuzzerTestOneInput, which writes the input
/// to a file ending in EXT and runs BODY with `path` naming it; morse::Error is the reader's
/// accepted way to refuse an input.
#define MORSE_FUZZ_TARGET(EXT, BODY)                                        \
  extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {            \
    morse_fuzz::init(argc, argv);                                           \
    return 0;                                                               \
  }                                                                         \
  extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) { \
    const std::string path = morse_fuzz::write_input(data, size, EXT);      \
    try {                                                                   \
      BODY                                                                  \
    } catch (const morse::Error&) {                                         \
    }                                                                       \
    std::remove(path.c_str());                                              \
    return 0;                                                               \
  }
