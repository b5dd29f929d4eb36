// morse/cb/craig_bampton.hpp: the Craig–Bampton superelement (seed 000 §2.1, eq. 1–6; seed 003
// §3.2.2, eq. 17–19).
//
// The boundary (master) DOFs are the free rows of a named set of the model's layout: the three
// translations of every node of a node set of a mesh, or the rows of a row set of a matrix model
// (fe::DofLayout::sets, components 4..6 included). With the
// interior (slave) DOFs i and boundary DOFs b of the clamped model:
//   constraint modes   Psi = -K_ii^{-1} K_ib       (eq. 3)  one MUMPS Cholesky factorization of
//                                                   K_ii and one block solve (MatMatSolve)
//   fixed-interface    K_ii Phi = M_ii Phi Omega    (eq. 4)  SLEPc shift-invert, M_ii-normalized
//   basis              T = [I 0; Psi Phi]           (eq. 5)
//   reduced operators  M_CB = T^T M T, K_CB = T^T K T (eq. 6)
// Reduced DOFs: boundary first (nodes by ascending node id, then x, y, z), then the modal
// coordinates in ascending frequency. When modes are selected by count, the factorization done
// by the eigen solver (shift 0) is reused for the constraint modes, so K_ii is factored once.
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <string>
#include <vector>

#include "morse/fe/model.hpp"

namespace morse::cb {

struct CBSettings {
  std::string boundary_set;    ///< node set (mesh) or row set (matrices) of the interface
  PetscInt n_fixed = -1;       ///< number of fixed-interface modes (-cb_num_fixed_modes), or
  double fmax_hz = -1;         ///< all fixed-interface modes below this frequency (-cb_fmax)
  double damping = 0.0;        ///< modal damping ratio xi of the fixed-interface modes
  bool keep_basis = false;     ///< keep T (Psi and Phi) in the result
  std::string prefix = "cb_";  ///< options prefix of the eigen solver

  /// Reads -boundary (read_boundary_option), -cb_num_fixed_modes, -cb_fmax, -cb_damping and
  /// -cb_write_basis (keep_basis); the fields of the options not given are left unchanged.
  /// Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
};

/// -boundary SET: the node set (or row set) of the interface, read by reduce and select
/// (CBSettings::set_from_options) and by nlrom (the contact nodes). `boundary` is left unchanged
/// if the option is not given. Collective.
PetscErrorCode read_boundary_option(MPI_Comm comm, std::string* boundary);

struct CBResult {
  PetscInt n_b = 0;                                 ///< boundary DOFs
  PetscInt n_phi = 0;                               ///< fixed-interface modes
  std::vector<std::int64_t> boundary_node_ids;      ///< ascending
  std::vector<std::int64_t> boundary_global_nodes;  ///< global node index, same order
  std::vector<PetscInt> boundary_dofs;              ///< free-DOF number of each boundary DOF (reduced order)
  /// What each boundary DOF is, in reduced order: node (grid) id and component 1..6 (1..3 =
  /// x, y, z translations; 4..6 rotations, only from matrix input).
  std::vector<std::int64_t> boundary_dof_node;
  std::vector<int> boundary_dof_component;
  std::vector<double> fixed_omega2;  ///< eigenvalues of eq. 4, ascending
  /// Reduced operators, dense row-major (n_b + n_phi)^2, identical on every rank.
  std::vector<double> M, K, C;
  /// T on the free DOFs of the model (MPIDENSE, n_free x (n_b + n_phi)); only if keep_basis.
  UMat T;
  bool factor_reused = false;
  double factor_seconds = 0;
  PetscInt n() const { return n_b + n_phi; }
};

/// Builds the superelement of a model (mesh or matrices) on the boundary set s.boundary_set.
/// Throws (collectively) for a missing or empty boundary set, a boundary node whose DOFs are
/// clamped (mesh), a singular K_ii, or more modes than interior DOFs. Collective.
CBResult craig_bampton(const fe::Model& md, const CBSettings& s);

/// Fills the boundary layout of out (n_b, boundary_node_ids, boundary_dofs and their labels;
/// boundary_global_nodes for a mesh model) from a named set of the model: the set's free rows
/// ordered by node id then component. Throws (collectively) for a missing or empty set or
/// (mesh) a clamped boundary node. Collective.
void set_boundary(const fe::Model& md, const std::string& set, CBResult* out);

/// Reduced operators from out->T (eq. 6): out->M = T^T M T, out->K = T^T K T (symmetrized) and
/// the modal damping out->C. Collective.
void project(MPI_Comm comm, Mat K, Mat M, double damping, CBResult* out);

/// Rebuilds a superelement's basis from a `morse reduce -cb_write_basis` file (its constraint
/// and fixed-interface modes as nodal fields) for the same mesh model, and projects its K and M
/// on it. The file's mesh (node ids) and boundary nodes must match. Reads on rank 0 and scatters one
/// mode at a time. Throws (collectively) naming the file on any mismatch or missing dataset.
/// Collective.
CBResult load_basis(const fe::Model& md, const std::string& path, const std::string& boundary_set, double damping);

/// T^T A T for a sparse A and an MPIDENSE T (same row layout), symmetrized: row-major
/// (cols of T)^2 on every rank. Collective.
std::vector<double> project_symmetric(MPI_Comm comm, Mat A, Mat T);

/// A^T B for two MPIDENSE matrices with the same row layout: local products summed over the
/// ranks. Returns a row-major (cols of A) x (cols of B) matrix on every rank. Collective.
std::vector<double> transpose_product(MPI_Comm comm, Mat A, Mat B);

/// Reference vector for eigenvector signs (layout of md.K): w(node, d) depends only on the
/// global node index and direction (mesh model) or on the global row (matrix model), so mode
/// signs do not depend on the partition. Collective.
UVec sign_reference(const fe::Model& md);

}  // namespace morse::cb
