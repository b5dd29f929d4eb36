#include "morse/core/session.hpp"

#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include "morse/core/error.hpp"

namespace morse {

Session::Session(int* argc, char*** argv, const char* help) {
  MORSE_CALL(SlepcInitialize(argc, argv, nullptr, help));
  // PETSc errors become morse::Error exceptions carrying PETSc's message (MORSE_CALL); the
  // default handler would also print a traceback on every rank.
  MORSE_CALL(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
}

Session::~Session() { (void)SlepcFinalize(); }

bool huge_pages_requested() {
  const char* t = std::getenv("GLIBC_TUNABLES");
  return t && std::strstr(t, "glibc.malloc.hugetlb=1");
}

void use_huge_pages(char** argv) {
  const char* off = std::getenv("MORSE_HUGEPAGES");
  if (off && std::strcmp(off, "0") == 0) return;
  const char* t = std::getenv("GLIBC_TUNABLES");
  // Already set (by us after the re-exec, or by the user, whatever the value): never loop.
  if (t && std::strstr(t, "glibc.malloc.hugetlb")) return;
  // Under valgrind /proc/self/exe is the valgrind tool, not morse: never re-execute there.
  const char* pre = std::getenv("LD_PRELOAD");
  if (pre && std::strstr(pre, "vgpreload")) return;
  std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (mode.find("[madvise]") == std::string::npos && mode.find("[always]") == std::string::npos) return;
  const std::string v = t && *t ? std::string(t) + ":glibc.malloc.hugetlb=1" : std::string("glibc.malloc.hugetlb=1");
  if (setenv("GLIBC_TUNABLES", v.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // The re-exec failed (no /proc, say): go on as we are, with the variable restored.
  if (t)
    setenv("GLIBC_TUNABLES", t, 1);
  else
    unsetenv("GLIBC_TUNABLES");
}

int world_rank() {
  int r = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &r);
  return r;
}

int world_size() {
  int s = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &s);
  return s;
}

}  // namespace morse
