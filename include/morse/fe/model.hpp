// morse/fe/model.hpp: the model every command works on (fe::Model: the layout of its free DOFs,
// K, M, optional C and, for a mesh model, the mesh), DOF numbering and assembly of the
// distributed stiffness K and consistent mass M of linear isotropic elasticity.
//
// A model comes from a mesh (fe::mesh_model, here) or from assembled matrices
// (io::matrix_model, io/matrix_model.hpp, which reads the matrix formats of io).
//
// Clamped DOFs are eliminated (they get no equation); no penalty is used. Each rank owns the
// free DOFs of its owned nodes, numbered contiguously (rank by rank, nodes in global order, then
// x, y, z), so the global DOF numbering is the PETSc ownership of K and M.
#pragma once

#include <petscmat.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "morse/core/handle.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::fe {

/// The parallel layout of a model's free DOFs, i.e. of the rows of K and M: this rank owns the
/// contiguous rows first .. first + n_owned - 1 of n_global (the PETSc ownership of K and M). The
/// same type serves a mesh model (fe::number_dofs) and a model read from assembled matrices
/// (io/matrix_model.hpp).
struct DofLayout {
  MPI_Comm comm = MPI_COMM_NULL;
  PetscInt n_owned = 0;               ///< free DOFs owned by this rank
  PetscInt first = 0;                 ///< first global DOF owned by this rank
  PetscInt n_global = 0;              ///< free DOFs in all
  std::int64_t n_clamped_global = 0;  ///< eliminated DOFs in all
  /// Mesh model: global DOF of component d of local node k at 3k+d, or -1 if eliminated. Empty
  /// for a matrix model (no mesh).
  std::vector<PetscInt> node_dof;
  /// What each owned row is: node (grid) id and component 1..6 (1..3 the x, y, z translations;
  /// 4..6 rotations, matrix input only), row first + i at i.
  std::vector<std::int64_t> node;
  std::vector<int> component;
  /// Named row sets (a mesh's node sets: the free rows of their nodes; a matrix model's row
  /// sets): the owned free rows of each set, global and ascending. Every rank knows every name.
  std::map<std::string, std::vector<PetscInt>> sets;
};

/// A free row with its labels (DofLayout::node, component).
struct LabeledRow {
  PetscInt row;
  std::int64_t node;
  int component;
};

/// Free rows of row set `set` with their labels, sorted by (node id, component): the boundary
/// order of a superelement. Every rank gets the whole list. Throws (collectively) for an unknown
/// or empty set, listing the sets; `role` starts the message (e.g. "boundary set"). Collective.
std::vector<LabeledRow> set_rows(const DofLayout& dofs, const std::string& set, const std::string& role);

/// The labels of all free rows on rank 0 (in row order): node ids and components; other ranks
/// get empty vectors. Collective.
void gather_labels(const DofLayout& dofs, std::vector<std::int64_t>* node, std::vector<std::int64_t>* component);

/// Numbers the free DOFs. clamp_sets names node sets whose three translations are eliminated;
/// the name mesh::kDeckBoundarySet stands for the DOFs fixed by *BOUNDARY in the deck. The row
/// labels are the node ids and components 1..3; every node set of the mesh is a row set.
/// Throws (collectively) if a named set does not exist or is empty. Collective.
DofLayout number_dofs(const mesh::LocalMesh& lm, const std::vector<std::string>& clamp_sets);

/// Assembled operators.
struct Operators {
  UMat K;               ///< MPIAIJ stiffness on the free DOFs (owned rows as in DofLayout)
  UMat M;               ///< MPIAIJ consistent mass, same layout and non-zero pattern as K
  double volume = 0.0;  ///< total volume of the mesh
  double mass = 0.0;    ///< total mass, sum of rho * element volume
};

/// Assembles K and M with exact preallocation. Elements without a material (elem_material < 0)
/// use `fallback`, which must then be valid (E > 0, -1 < nu < 0.5, rho > 0). Throws
/// (collectively) on an inverted or degenerate element, naming its id and the mesh source, or
/// on a missing/invalid material. Collective.
Operators assemble(const mesh::LocalMesh& lm, const DofLayout& dofs, const mesh::Material& fallback);

/// What eliminating a mesh's rigid elements, interpolation elements and linear constraints left
/// behind (fe/constraints.hpp): u = T u_bar maps the model's DOFs u_bar (its rows) to the free
/// translations u of the mesh's nodes (the layout `full`, which number_dofs gave).
struct ConstraintMap {
  UMat T;                         ///< MPIAIJ, rows as `full`, columns as the model's DOFs
  DofLayout full;                 ///< the nodes' free translations, before elimination
  UMat K_nodes;                   ///< the stiffness on `full` before elimination (fe::Svk's elements);
                                  ///< null if the model was built without it (mesh_model)
  std::int64_t n_dependent = 0;   ///< DOFs eliminated (dependent), nodes' and points'
  std::int64_t n_point_dofs = 0;  ///< DOFs of six-DOF points kept as the model's DOFs
  std::int64_t n_rigid = 0, n_interpolation = 0, n_linear = 0;
  std::vector<std::int64_t> point_ids;  ///< the six-DOF points, ascending (every rank)
  std::vector<double> point_coords;     ///< their coordinates, 3 each
};

/// A model: the layout of its free DOFs and its operators on them; a mesh model also holds its
/// distributed mesh. Move-only (it owns K, M, C).
struct Model {
  std::optional<mesh::LocalMesh> mesh;      ///< the distributed mesh; none for a matrix model
  DofLayout dofs;                           ///< rows of K, M and C
  UMat K;                                   ///< MPIAIJ stiffness on the free DOFs
  UMat M;                                   ///< MPIAIJ mass, same layout
  UMat C;                                   ///< MPIAIJ viscous damping (matrix input with -matrices_C), else null
  double volume = 0.0;                      ///< mesh model: total volume
  double mass = 0.0;                        ///< mesh model: total mass, sum of rho * element volume
  std::string units;                        ///< unit system recorded in the output ("unknown" if not known)
  std::string source;                       ///< the mesh file, or the K file of a matrix model
  double asymmetry_K = 0, asymmetry_M = 0;  ///< matrix model: measured max |A - A^T| / max |A|
  /// Mesh model with rigid/interpolation elements or linear constraints: the elimination (its
  /// dofs are then the independent DOFs, node translations and point DOFs); else empty.
  std::shared_ptr<const ConstraintMap> constraints;
};

/// What a mesh model is made of (the model options of docs/user-guide.md).
struct MeshInput {
  std::string path;                ///< mesh file (.msh, .inp, .bdf/.dat/.nas), read by mesh::read_and_distribute
  std::string units;               ///< overrides the mesh's unit system if not empty
  bool skip_unsupported = false;   ///< Nastran: skip element cards morse cannot represent
  std::vector<std::string> clamp;  ///< node sets eliminated (number_dofs)
  mesh::Material material;         ///< for elements without a material (assemble's fallback)
  std::vector<mesh::Material> set_materials;  ///< per element set (name = set), overriding the mesh's
  /// Node sets added to the mesh (-mesh_node_set_NAME): name, external node ids.
  std::vector<std::pair<std::string, std::vector<std::int64_t>>> node_sets;
  /// Spiders (mesh::add_spiders) on these node sets (-mesh_spiders), of this type and radius.
  std::vector<std::string> spider_sets;
  double spider_radius = 0;
  mesh::SpiderType spider_type = mesh::SpiderType::Interpolation;
};

/// Reads and distributes the mesh, applies the set materials and the added node sets, numbers
/// the free DOFs and assembles K and M. Throws (collectively) as read_and_distribute,
/// mesh::add_node_set, number_dofs and assemble do. A deck's rigid and interpolation elements and
/// MPCs are eliminated (eliminate_constraints, with keep_node_stiffness). Collective.
Model mesh_model(MPI_Comm comm, const MeshInput& in, bool keep_node_stiffness = true);

/// What `morse mesh info` reports of a distributed mesh beyond its sets: the global element count
/// per type, the volume, the smallest Jacobian determinant (min_jacobian) and its element, the
/// inverted elements and the nodes with DOFs fixed by *BOUNDARY. Identical on every rank.
struct MeshQuality {
  std::vector<std::int64_t> per_type;  ///< elements per mesh::ElementType
  double volume = 0;
  double min_jacobian = 1e300;
  std::int64_t worst_element = -1;  ///< element id of min_jacobian
  std::int64_t n_inverted = 0;      ///< elements with min_jacobian <= 0
  std::int64_t n_fixed_nodes = 0;   ///< nodes with *BOUNDARY DOFs
};
/// Computes the MeshQuality of lm. Collective.
MeshQuality mesh_quality(MPI_Comm comm, const mesh::LocalMesh& lm);

}  // namespace morse::fe
