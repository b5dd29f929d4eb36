// morse/core/session.hpp: initializes and finalizes MPI, PETSc and SLEPc.
//
// Declare one Session first in main() (or in the test main); every PETSc object must be
// destroyed before it goes out of scope.
#pragma once

#include <slepcsys.h>

#include <string>

namespace morse {

class Session {
 public:
  /// Initializes MPI (unless it is already), checks the options files (options_file_error(),
  /// collective: every rank throws morse::Error, MPI finalized again), then calls
  /// SlepcInitialize. help is the text printed by -help before the option list.
  Session(int* argc, char*** argv, const char* help = nullptr);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

 private:
  bool began_mpi_ = false;
};

/// The options files PETSc would read, checked before it reads them: every -options_file of argv
/// and of the PETSC_OPTIONS variable, and every -options_file inside those files, recursively (a
/// line "-options_file name"; a relative name is relative to the working directory, as PETSc
/// opens it). Returns the first problem as one line, "" if none: a file that cannot be opened or
/// is a directory ("-options_file nope.opts: cannot open (No such file or directory)", inside a
/// file "a.opts:3: -options_file nope.opts: ..."), a -options_file without a name, or a file that
/// includes itself, directly or through others ("options files include each other: a.opts ->
/// b.opts -> a.opts"), which PETSc follows until the stack overflows, or more options than
/// kMaxGivenOptions. Names with ${...} and YAML
/// files are left to PETSc. Not collective.
std::string options_file_error(int argc, char** argv);

/// Options that may be given in all (command line, PETSC_OPTIONS, rc and options files): PETSc's
/// database holds 512, and the solvers add their defaults. options_file_error refuses more,
/// naming the source that gives the most.
constexpr long kMaxGivenOptions = 400;

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

/// Rank of PETSC_COMM_WORLD; outside PETSc's lifetime (a Session that failed, or after it), the
/// rank in MPI_COMM_WORLD recorded by the last Session (0 if none).
int world_rank();
/// Size of PETSC_COMM_WORLD.
int world_size();

}  // namespace morse
