#include "morse/core/session.hpp"

#include "morse/core/error.hpp"

namespace morse {

Session::Session(int* argc, char*** argv, const char* help) {
  MORSE_CALL(SlepcInitialize(argc, argv, nullptr, help));
  // PETSc errors become morse::Error exceptions carrying PETSc's message (MORSE_CALL); the
  // default handler would also print a traceback on every rank.
  MORSE_CALL(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
}

Session::~Session() { (void)SlepcFinalize(); }

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
