// morse/mesh/stator.hpp: an engine-stator-like component generator (quadratic elements).
#pragma once

#include <petscsys.h>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Parameters of the stator generator (options prefix -stator_).
struct StatorSpec {
  std::string size = "default";  ///< "default" (100-200k DOF) or "coarse" (fast tests)
  int n_vanes = 0;               ///< number of radial vanes (0 = default)
};

/// Builds the stator. Deterministic.
Mesh generate_stator(const StatorSpec& spec);

/// Reads the -stator_* options into spec. PETSc error zone.
PetscErrorCode stator_spec_from_options(MPI_Comm comm, StatorSpec* spec);

}  // namespace morse::mesh
