#include "morse/mesh/stator.hpp"

#include "morse/core/error.hpp"

namespace morse::mesh {

Mesh generate_stator(const StatorSpec&) { throw Error("stator generator: not implemented yet"); }

PetscErrorCode stator_spec_from_options(MPI_Comm, StatorSpec*) { return PETSC_SUCCESS; }

}  // namespace morse::mesh
