#include "morse/mesh/blade.hpp"

#include "morse/core/error.hpp"

namespace morse::mesh {

Mesh generate_blade(const BladeSpec&) { throw Error("blade generator: not implemented yet"); }

PetscErrorCode blade_spec_from_options(MPI_Comm, BladeSpec*) { return PETSC_SUCCESS; }

}  // namespace morse::mesh
