// morse/core/session.hpp: initializes and finalizes MPI, PETSc and SLEPc.
//
// Declare one Session first in main() (or in the test main); every PETSc object must be
// destroyed before it goes out of scope.
#pragma once

#include <slepcsys.h>

namespace morse {

class Session {
 public:
  /// Calls SlepcInitialize. help is the text printed by -help before the option list.
  Session(int* argc, char*** argv, const char* help = nullptr);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

/// Puts the process's heap on transparent huge pages, before anything else runs: if the kernel
/// offers them on request (/sys/kernel/mm/transparent_hugepage/enabled is [madvise] or
/// [always]) and glibc has not been told yet, re-executes the program (same pid, same
/// arguments, so mpirun does not notice) with GLIBC_TUNABLES=glibc.malloc.hugetlb=1 added, and
/// glibc then asks for huge pages on every heap and mmap'ed block. MUMPS's factors, fronts and
/// the dense eigen bases are hundreds of MB, touched first in 4 KB pages otherwise: on a 2-core
/// VM, 350,000 page faults took 1.5 s per rank of a 9 s rotor-37 modes run (bench/README.md).
/// MORSE_HUGEPAGES=0 in the environment turns it off. Returns only if nothing was re-executed.
/// Call it first in main(), before MPI is initialized.
void use_huge_pages(char** argv);
/// Whether glibc was told to use huge pages (GLIBC_TUNABLES has glibc.malloc.hugetlb=1).
bool huge_pages_requested();

/// Rank of PETSC_COMM_WORLD.
int world_rank();
/// Size of PETSC_COMM_WORLD.
int world_size();

}  // namespace morse
