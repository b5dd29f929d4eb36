// morse/io/matrix_model.hpp: a model given by its assembled operators instead of a mesh (Nastran
// DMAP export, another FE code, or morse itself): K, M and optionally C in one of the matrix
// formats of io/matrices.hpp, with the DOF map that names each row (docs/user-guide.md "From
// Nastran"). The result is the same fe::Model as a mesh model's, without a mesh.
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "morse/core/files.hpp"
#include "morse/fe/model.hpp"

namespace morse::io {

/// What a matrix model is made of (the -matrices_* options).
struct MatrixInput {
  std::string K, M, C;             ///< files (C optional)
  std::string dofmap;              ///< DOF map file (optional)
  std::vector<std::string> clamp;  ///< row sets (or node sets) whose rows are removed
  /// Node sets given by node ids (-mesh_node_set_NAME): all rows of those nodes.
  std::vector<std::pair<std::string, std::vector<std::int64_t>>> node_sets;
  double symmetry_tol = 1e-8;  ///< max |A - A^T| / max |A| accepted (then A is symmetrized)
  std::string units;           ///< unit system recorded in the output; empty: "unknown"
};

/// Reads K, M (and C), checks sizes and symmetry (then symmetrizes), reads the DOF map, applies
/// the node sets and the clamp (the rows of the clamped sets are removed). The model's layout
/// holds the free rows in contiguous blocks with their labels and row sets (the DOF map's sets,
/// then the node sets); it has no mesh. Throws (collectively) naming the file or option on: a
/// missing or malformed file, matrices of different sizes, a DOF map of another size, a
/// nonsymmetric K or M (naming the worst entry by row, node and component), an unknown clamp set,
/// a node set naming a node that has no row, a clamp that removes every row. Collective.
fe::Model matrix_model(MPI_Comm comm, const MatrixInput& in);

/// Writes the free-DOF K and M of a mesh model and its DOF map (mesh_dof_map) as
/// <prefix>_K.<ext>, <prefix>_M.<ext> (write_matrix, symmetric; ext: mtx or petsc, as `format`)
/// and <prefix>_dofmap.txt (rank 0). Throws collectively on a write failure. Collective.
void write_model_matrices(MPI_Comm comm, const fe::Model& md, const std::string& prefix, const std::string& format);
/// The files write_model_matrices writes: <prefix>_K.<ext>, <prefix>_M.<ext>, <prefix>_dofmap.txt.
std::vector<std::string> model_matrix_files(const std::string& prefix, const std::string& format);

/// The model input of a command: a mesh (fe::MeshInput, built by fe::mesh_model) or assembled
/// operators (MatrixInput, built by matrix_model), and the output file (-out).
struct ModelInput {
  fe::MeshInput mesh;    ///< path empty: no -mesh
  MatrixInput matrices;  ///< K, M, C, dofmap empty: no -matrices_*
  std::string out;       ///< -out
  std::string error;     ///< a bad option value, raised by check() (after -help)

  bool matrices_given() const {
    return !matrices.K.empty() || !matrices.M.empty() || !matrices.C.empty() || !matrices.dofmap.empty();
  }
  /// Reads -mesh, -mesh_units, -mesh_skip_unsupported, -clamp, -material_E/_nu/_rho,
  /// -material_sets with -material_<set>_E/_nu/_rho, -mesh_node_sets with -mesh_node_set_<name>
  /// (id,id,a-b,...), -matrices_K/_M/_C/_dofmap, -matrices_symmetry_tol and -out (default
  /// default_out). -mesh_units, -clamp and the node sets fill both inputs. A bad node list or a
  /// missing -mesh_node_set_<name> is recorded in `error`. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm, const char* default_out);
  /// Throws (morse::Error, on every rank alike) on a recorded `error`, on matrix input when
  /// needs_mesh is not null (needs_mesh: why the command needs a mesh, named in the message), on
  /// both a mesh and matrices, on -material_* with matrices, and on no model at all. Not collective
  /// (every rank holds the same input).
  void check(const char* needs_mesh = nullptr) const;
  /// The input files named by these options (-mesh, -matrices_K/_M/_C/_dofmap; the file of a
  /// FILE.op4:NAME), for files::prepare_outputs. Not collective.
  std::vector<files::Named> inputs() const;
};

}  // namespace morse::io
