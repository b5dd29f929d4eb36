// morse/mesh/blade.hpp: a rotor-37-like compressor blade generator (quadratic 15-node wedges).
#pragma once

#include <petscsys.h>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Parameters of the blade generator (options prefix -blade_).
struct BladeSpec {
  int n_chord = 0;   ///< cells along the chord (0 = default for the size)
  int n_thick = 0;   ///< cells across the thickness
  int n_span = 0;    ///< cells along the span
  std::string size = "default";  ///< "default" (~20k nodes) or "coarse" (fast tests)
  double thickness_scale = 1.0;  ///< calibration factor on the thickness distribution
};

/// Builds the blade. Deterministic: the same spec gives the same mesh, bit for bit.
Mesh generate_blade(const BladeSpec& spec);

/// Reads the -blade_* options into spec. PETSc error zone.
PetscErrorCode blade_spec_from_options(MPI_Comm comm, BladeSpec* spec);

}  // namespace morse::mesh
