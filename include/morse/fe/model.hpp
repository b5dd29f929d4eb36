// morse/fe/model.hpp: DOF numbering and assembly of the distributed stiffness K and consistent
// mass M of linear isotropic elasticity.
//
// Clamped DOFs are eliminated (they get no equation); no penalty is used. Each rank owns the
// free DOFs of its owned nodes, numbered contiguously (rank by rank, nodes in global order, then
// x, y, z), so the global DOF numbering is the PETSc ownership of K and M.
#pragma once

#include <petscmat.h>

#include <string>
#include <vector>

#include "morse/core/handle.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::fe {

/// Global numbering of the free DOFs of a LocalMesh.
struct DofLayout {
  MPI_Comm comm = MPI_COMM_NULL;
  PetscInt n_owned = 0;   ///< free DOFs owned by this rank
  PetscInt first = 0;     ///< first global DOF owned by this rank
  PetscInt n_global = 0;  ///< free DOFs in all
  std::int64_t n_clamped_global = 0;  ///< eliminated DOFs in all
  /// Global DOF of component d of local node k at 3k+d, or -1 if eliminated.
  std::vector<PetscInt> node_dof;
};

/// Numbers the free DOFs. clamp_sets names node sets whose three translations are eliminated;
/// the name mesh::kDeckBoundarySet stands for the DOFs fixed by *BOUNDARY in the deck.
/// Throws (collectively) if a named set does not exist or is empty. Collective.
DofLayout number_dofs(const mesh::LocalMesh& lm, const std::vector<std::string>& clamp_sets);

/// Assembled operators.
struct Operators {
  UMat K;  ///< MPIAIJ stiffness on the free DOFs (owned rows as in DofLayout)
  UMat M;  ///< MPIAIJ consistent mass, same layout and non-zero pattern as K
  double volume = 0.0;  ///< total volume of the mesh
  double mass = 0.0;    ///< total mass, sum of rho * element volume
};

/// Assembles K and M with exact preallocation. Elements without a material (elem_material < 0)
/// use `fallback`, which must then be valid (E > 0, -1 < nu < 0.5, rho > 0). Throws
/// (collectively) on an inverted or degenerate element, naming its id and the mesh source, or
/// on a missing/invalid material. Collective.
Operators assemble(const mesh::LocalMesh& lm, const DofLayout& dofs, const mesh::Material& fallback);

}  // namespace morse::fe
