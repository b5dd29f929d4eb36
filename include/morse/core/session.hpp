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

/// Rank of PETSC_COMM_WORLD.
int world_rank();
/// Size of PETSC_COMM_WORLD.
int world_size();

}  // namespace morse
