// morse/nlrom/nlrom.hpp: nonlinear reduced-order models of seed 003 (§3.2–3.3): reduction bases
// that keep the boundary translations physical (q = [u_b; eta], eq. 9) and the reduced
// St Venant–Kirchhoff force as a cubic polynomial (eq. 25–28),
//
//   g~(q) = Phi^T g_nl(Phi q) = sum_{i<=j} A_ij q_i q_j + sum_{i<=j<=k} B_ijk q_i q_j q_k,
//
// identified either by STEP (eq. 29–37: N = r^3/6 + r^2 + 5r/6 evaluations of g_nl at imposed
// displacements, optionally POD-filtered, eq. 38–39) or projected exactly element by element.
// For St Venant–Kirchhoff both are exact, so they agree to round-off.
#pragma once

#include <petscmat.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/handle.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/io/h5.hpp"

namespace morse::nlrom {

/// Number of monomials q_i q_j (i <= j) and q_i q_j q_k (i <= j <= k) of r coordinates.
inline std::size_t n_quadratic(std::size_t r) { return r * (r + 1) / 2; }
inline std::size_t n_cubic(std::size_t r) { return r * (r + 1) * (r + 2) / 6; }

/// The reduced nonlinear force, seed 003 eq. 28. Rows are monomials in lexicographic order of
/// i <= j (<= k); columns are the r outputs m (A~^m_ij = A[row(i,j) * r + m]).
struct CubicForce {
  std::size_t r = 0;
  std::vector<double> A;  ///< n_quadratic(r) x r, row-major
  std::vector<double> B;  ///< n_cubic(r) x r, row-major
  /// g = g~(q) (reference evaluation, O(r^4)). g has r entries.
  void evaluate(const double* q, double* g) const;
  /// J = dg~/dq at q (r x r, row-major: J[p r + m] = dg_p/dq_m), 3 n_cubic(r) r + 2 n_quadratic(r) r
  /// multiply-adds.
  void jacobian(const double* q, double* J) const;
  /// Largest |A| and |B| entries (scales for comparisons).
  double max_abs_A() const;
  double max_abs_B() const;
};

/// Exact projection (fe::Svk::project_tensors). Collective.
CubicForce exact_forces(const fe::Svk& svk, Mat Phi);

struct StepSettings {
  /// Target displacement of the imposed fields [m]: q_i = displacement / max|phi_i| (seed 003
  /// §4.2: "of the order of 1 cm" on the blade). -step_displacement.
  double displacement = 0.01;
  /// POD filtering (eq. 38–39): if set, the forces are g^f = Phi_f Phi_f^T g_nl, with Phi_f
  /// orthonormal columns (MPIDENSE, K's row layout).
  Mat filter = nullptr;
  PetscInt chunk = 64;  ///< displacement fields per element pass
};

/// STEP identification (eq. 29–37). Every rank evaluates its own elements for blocks of imposed
/// fields and projects them locally; one reduction at the end. Collective.
CubicForce step_forces(const fe::Svk& svk, Mat Phi, const StepSettings& s);

/// Number of STEP evaluations, eq. 37.
inline std::size_t step_evaluations(std::size_t r) { return 2 * r + 3 * r * (r - 1) / 2 + r * (r - 1) * (r - 2) / 6; }

// ------------------------------------------------------------------------------------------
// Reduction bases (seed 003 §3.2). Coordinates q = [u_b; eta]: the first n_b columns are the
// constraint modes (identity on the boundary DOFs), every other column vanishes on the boundary,
// so u_b = q_b stays physical (eq. 9).

enum class BasisKind { CB, CBMD, POD };

struct BasisSettings {
  BasisKind kind = BasisKind::CB;
  std::string boundary_set;    ///< -boundary
  PetscInt n_fixed = 0;        ///< -nlrom_num_fixed_modes (CB, CB + MD)
  PetscInt n_derivatives = 0;  ///< -nlrom_num_derivatives (CB + MD)
  PetscInt n_pod = 0;          ///< -nlrom_num_pod (POD)
  std::string snapshots;       ///< -nlrom_snapshots: a morse fom file (POD; POD filtering)
  /// Modified Gram–Schmidt: a vector whose M-norm falls below mgs_tol times its norm before the
  /// projection is dependent and dropped (-nlrom_mgs_tol).
  double mgs_tol = 1e-6;
  /// Training of the modal-derivative selection (eq. 24): a linear CB reduced simulation
  /// (trapezoidal rule, undamped) under these loads from 0 to training_tfinal in steps of
  /// training_dt.
  const dyn::Loads* training = nullptr;
  double training_tfinal = 0.0;
  double training_dt = 0.0;
  /// Order in which the modal derivatives enter the basis: by descending W_ij (eq. 24), or a
  /// random order (a fixed-seed shuffle, the same on every rank: seed 003 Fig. 9's control).
  bool random_derivatives = false;  ///< -nlrom_derivative_selection random
  unsigned derivative_seed = 1;     ///< -nlrom_derivative_seed
  std::string prefix = "nlrom_";    ///< options prefix of the fixed-interface eigen solve
};

struct Basis {
  BasisKind kind = BasisKind::CB;
  cb::CBResult cb;                             ///< boundary layout (n_b, node ids, DOFs) and the CB part (CB, CB + MD)
  UMat V;                                      ///< the basis, MPIDENSE n_free x r
  PetscInt n_b = 0, n_fixed = 0, n_extra = 0;  ///< r = n_b + n_fixed + n_extra
  std::vector<std::string> labels;             ///< one per column
  /// CB + MD: every pair (i <= j) of CB coordinates with its weight W_ij (eq. 24), the chosen
  /// order (descending W) and which pairs entered the basis after MGS.
  std::vector<std::pair<PetscInt, PetscInt>> md_pairs;
  std::vector<double> md_weights;
  std::vector<int> md_selected;             ///< 1 if the pair's derivative is a basis column
  std::vector<double> pod_singular_values;  ///< POD: all singular values of the snapshots
  double seconds = 0.0;                     ///< t1 of seed 003 §4.3.2
  PetscInt r() const { return n_b + n_fixed + n_extra; }
};

/// Modal derivatives with the interface fixed (eq. 22 restricted to the interior):
///   psi_ij = -K_ii^-1 (dK_T/dq_i phi_j)_i,  psi_ij = 0 on the boundary,
/// for the given pairs of columns of T, with one MUMPS factorization and one block solve.
/// dK_T/dq_i phi_j = d^2 g_nl(0)[phi_i, phi_j] is evaluated exactly (the odd part of
/// (K_T(e phi_i) - K) phi_j in e). Returns MPIDENSE n_free x pairs. Collective.
UMat modal_derivatives(const fe::Svk& svk, Mat T, const std::vector<PetscInt>& boundary_dofs,
                       const std::vector<std::pair<PetscInt, PetscInt>>& pairs);

/// V^T x, gathered on every rank (e.g. a reduced load pattern). Collective.
std::vector<double> project_vector(Mat V, Vec x);

/// Builds the basis of a mesh model; svk holds the model's forces (built on md.K). Throws
/// (collectively) for a basis larger than the model, a missing snapshot file, or missing
/// training settings. Collective.
Basis build_basis(const fe::Model& md, const fe::Svk& svk, const BasisSettings& s);

/// The number of vectors r the basis of s will have at most (boundary DOFs + fixed-interface
/// modes + derivatives or POD vectors), known before it is built. Throws (collectively) for a
/// missing or empty boundary set and for a basis larger than the model. Collective.
PetscInt basis_size(const fe::Model& md, const BasisSettings& s);

/// Bytes every rank holds while the reduced force of r coordinates is identified: the tensors A
/// and B (r n_quadratic(r) + r n_cubic(r) doubles: 14.8 GB for r = 324) and, for STEP, its
/// imposed fields and their reduced forces (2 r step_evaluations(r) doubles).
double force_bytes(std::size_t r, bool step);
/// Refuses (every rank alike) a basis of r vectors whose reduced force cannot fit in the memory
/// available (the ranks of a node adding up), before the basis is built: "nlrom r = 324 needs
/// 14.8 GB for the cubic tensor; 23 GB available". Collective.
void check_force_memory(MPI_Comm comm, std::size_t r, bool step);

/// The POD basis of a snapshot matrix X (n_free x n_s, MPIDENSE) by the method of snapshots:
/// X^T X = U S^2 U^T (replicated, LAPACK), modes X U S^-1 for the n largest values, orthonormal
/// in the Euclidean inner product. sigma receives every singular value (descending). Collective.
UMat pod(Mat X, PetscInt n, std::vector<double>* sigma);

/// The POD filter of the reduced force (eq. 38): the nonlinear forces g_nl of the snapshots of the
/// fom file `file` (dyn::read_fom_snapshots), compressed to their n leading POD vectors (Phi_f,
/// MPIDENSE, K's row layout; StepSettings::filter). Throws (collectively) if n exceeds the number
/// of snapshots, naming -nlrom_filter_pod and the file. Collective.
UMat force_filter(const fe::Model& md, const fe::Svk& svk, const std::string& file, PetscInt n);

/// -nlrom_damping_modes all: modal damping on every mode of the reduced model (project_model), or
/// on every dynamic mode of a massless one (make_massless).
inline constexpr PetscInt kAllModes = -1;

/// The settings of the offline stage (`morse nlrom`): the basis, the identification of the reduced
/// force and the reduced modal damping.
struct OfflineSettings {
  BasisSettings basis;              ///< boundary_set: -boundary, set by the caller (not read here)
  std::string basis_name = "cb";    ///< -nlrom_basis cb|cbmd|pod (sets basis.kind)
  std::string forces = "step";      ///< -nlrom_forces step|exact|none (none: linear, no tensors stored)
  PetscInt n_filter = 0;            ///< -nlrom_filter_pod: POD filter vectors of g_nl (0: none)
  double step_displacement = 0.01;  ///< -step_displacement (StepSettings::displacement)
  double damping_xi = 0.0;          ///< -nlrom_damping_modal (project_model's xi)
  PetscInt damping_modes = 0;       ///< -nlrom_damping_modes K|all (project_model's k; all: kAllModes)
  bool rayleigh_given = false;      ///< -nlrom_rayleigh given (rayleigh_damping)
  double rayleigh_alpha = 0.0;      ///< -nlrom_rayleigh alpha,beta: C~ = alpha M~ + beta K~
  double rayleigh_beta = 0.0;
  /// -nlrom_boundary_mass carrying|massless: the boundary keeps its mass (seed 003), or is
  /// massless (make_massless; the damping then acts on the dynamic coordinates only).
  bool massless = false;
  double massless_fmax = 0.0;  ///< -nlrom_massless_fmax: modes above it are residual (quasi-static); 0: n_b of them
  /// -nlrom_massless_interior static|scaled: the residual combinations that vanish on the boundary
  /// (z) are quasi-static (MacNeal, static: solved with the boundary at every step) or keep a mass
  /// raised so that none is above -nlrom_massless_fmax (scaled: selective mass scaling; only the
  /// boundary is static). scaled needs -nlrom_massless_fmax > 0.
  bool massless_scaled = false;
  /// -nlrom_mass_scaling_fmax F [Hz]: selective mass scaling of a mass-carrying model
  /// (scale_modal_mass): the modes above F are moved to F with their shapes kept; 0: none.
  double mass_scaling_fmax = 0.0;
  std::string error;  ///< a bad option value, naming the option (raised by the caller, after -help)
  /// Reads -nlrom_basis, -nlrom_num_fixed_modes, -nlrom_num_derivatives, -nlrom_num_pod,
  /// -nlrom_snapshots, -nlrom_training_tfinal, -nlrom_training_dt, -nlrom_mgs_tol,
  /// -nlrom_derivative_selection weight|random, -nlrom_derivative_seed, -nlrom_forces,
  /// -step_displacement, -nlrom_filter_pod, -nlrom_damping_modal, -nlrom_damping_modes K|all,
  /// -nlrom_rayleigh alpha,beta, -nlrom_boundary_mass, -nlrom_massless_fmax, -nlrom_massless_interior and
  /// -nlrom_mass_scaling_fmax (docs/user-guide.md), then validates them with
  /// basis.boundary_set (call it after setting that): the first bad value (unknown basis or force
  /// method, no boundary set, damping ratio outside [0, 1), a mode count neither a count nor all,
  /// Rayleigh damping with modal damping or with a massless boundary, a filter without snapshots, ...)
  /// is recorded in `error`. Uses PetscOptionsBegin: returns a PETSc error code. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
  /// The damping model asked for, as /nlrom@damping records it: "rayleigh" (-nlrom_rayleigh),
  /// "modal" (-nlrom_damping_modal > 0 on K > 0 or all modes) or "none".
  std::string damping() const;
};

// ------------------------------------------------------------------------------------------
// The reduced model.

struct ReducedModel {
  PetscInt r = 0, n_b = 0;
  std::vector<double> M, K, C;        ///< r x r row-major, identical on every rank
  CubicForce g;                       ///< reduced nonlinear force
  std::vector<double> damping_omega;  ///< reduced natural angular frequencies carrying xi
  /// Massless boundary (make_massless): the rows and columns of the first n_static coordinates of
  /// M and C are zero (the n_b boundary coordinates, then the internal modes made quasi-static);
  /// they are in static equilibrium at every instant (sim::integrate).
  bool massless = false;
  PetscInt n_static = 0;
};

// ------------------------------------------------------------------------------------------
// Massless boundary (Monjaraz-Tec, Gross & Krack 2022; docs/theory.md §11): the mass of the boundary
// coordinates is removed, so that a contact node has none and the critical step of central
// differences is set by the dynamic modes. MacNeal's method applied to the reduced model (K~, M~)
// of a basis with physical boundary coordinates (eq. 9): with x_k, w_k its modes with the boundary
// free (M-normalized), the n_d lowest are the dynamic coordinates eta and the others are residual;
// their static flexibility at the boundary, G = sum_res x_k x_k[b]^T / w_k, gives the attachment
// columns Psi = G G_bb^-1 (the identity on the boundary), and
//
//   q~ = Psi u_b + Z z + (X_D - Psi X_D[b, :]) eta,
//
// with Z the residual combinations that vanish on the boundary (none if n_d = r - n_b). The new
// coordinates [u_b; z; eta] span the same subspace (r of them), K and the nonlinear force are exact on
// it, and the kinetic energy keeps eta's alone (eta^T eta / 2): the mass of the residual part (the
// boundary's and z's) is dropped. With the boundary free and no force on it, the model's modes are
// exactly the n_d lowest of (K~, M~). u_b and z are in static equilibrium at every instant.

/// The change of basis T (r x r, row-major, q_old = T q_new) of a reduced model (M, K) with n_b
/// boundary coordinates first, as above: the dynamic modes are those up to fmax_hz (0: all but the
/// n_b highest, the fewest residual modes MacNeal's flexibility needs), at most r - n_b. *n_static
/// receives n_b + the number of z coordinates. Throws if the residual flexibility at the boundary
/// is singular (a boundary coordinate that no residual mode moves), naming -nlrom_massless_fmax.
std::vector<double> massless_transform(const std::vector<double>& M, const std::vector<double>& K, PetscInt r,
                                       PetscInt n_b, double fmax_hz, PetscInt* n_static);

/// The labels of a basis after massless_transform: the boundary's kept, then "quasi-static mode k"
/// (or "mass-scaled mode k" if scaled) and "dynamic mode k" (held-boundary modes, ascending). Called
/// on every rank alike.
void relabel_massless(Basis* basis, PetscInt n_static, bool scaled = false);

/// The basis V S (MPIDENSE, V's layout), for S of massless_transform. Collective.
UMat transform_basis(Mat V, const std::vector<double>& S);

/// Makes the model projected on the basis V T (massless_transform) massless: M = diag(0, I) (the
/// residual mass dropped; the dynamic coordinates are M-normalized modes), C zero on the first
/// n_static coordinates, and modal damping xi on the first k modes (k = kAllModes: every dynamic
/// mode) of the model with its static coordinates free (condensed statically:
/// K_dd - K_ds K_ss^-1 K_sd with M_dd), on the dynamic coordinates only:
/// C_dd = sum 2 xi w_k (M_dd x_k)(M_dd x_k)^T. Sets rm->massless, rm->n_static and
/// rm->damping_omega. Throws if K_ss is not positive definite (a boundary node without stiffness)
/// or k exceeds the dynamic coordinates.
///
/// scaled_fmax > 0 (-nlrom_massless_interior scaled): the z coordinates [n_b, n_static) are not
/// made static but keep a mass m_z = max(1, K_zz / w_c^2), w_c = 2 pi scaled_fmax (selective mass
/// scaling): z is K-orthogonal to u_b and eta (theory §11.7), so the linear model's z frequencies
/// become min(w_z, w_c) and the rest is unchanged; only the boundary is static (rm->n_static = n_b).
/// Their response to forces well below w_c stays quasi-static to O((w / w_c)^2), and no
/// equilibrium of z has to be solved (a cubic model can lose it under contact: a limit point).
void make_massless(ReducedModel* rm, PetscInt n_static, double xi, PetscInt k, double scaled_fmax = 0.0);

/// The critical step of central differences on a massless model: 2 / omega_max of (K_dd, M_dd),
/// the dynamic part with the static coordinates held (contact can only stiffen the dynamics up to
/// this bound; free, they are softer). *free_boundary (if not null) receives the step of the model
/// with its static coordinates condensed (no contact).
double massless_critical_step(const ReducedModel& m, double* free_boundary = nullptr);
/// The eigenvalues omega^2 of a reduced model with its boundary free, ascending: of (K, M), or
/// for a massless model of its dynamic block with the static coordinates condensed (M is singular).
std::vector<double> free_eigenvalues(const ReducedModel& m);
/// The same with only the directions `held` of the static coordinates held (n_static x n_h,
/// row-major, e.g. the normals of the contact nodes: a contact that slides holds nothing else)
/// and the rest of them condensed: between the free and the all-held steps.
double massless_critical_step(const ReducedModel& m, const std::vector<double>& held, std::size_t n_held);

/// A `morse nlrom` file as the online stage uses it: the reduced model, the basis on every node
/// of the mesh and the node sets, identical on every rank.
struct StoredModel {
  std::string file, units = "SI";
  ReducedModel model;
  std::vector<double> basis;                             ///< [r][node][3]
  std::vector<std::int64_t> node_ids;                    ///< node of each basis row
  std::map<std::string, std::vector<std::size_t>> sets;  ///< node set -> basis rows (ascending id)
  std::vector<double> coords;                            ///< [node][3] reference positions (/mesh/coordinates)
  std::vector<std::int64_t> boundary_nodes;              ///< the boundary set's nodes, ascending
  /// What the boundary coordinates q[0..n_b) are (eq. 9): node id and component 1..6 (1..3 the
  /// x, y, z translations; 4..6 the rotations of a six-DOF point), in node order, then component.
  std::vector<std::int64_t> boundary_dof_node;
  std::vector<int> boundary_dof_component;

  std::size_t r() const { return static_cast<std::size_t>(model.r); }
  /// Phi^T f for a unit force per node of `set` along `dir` (normalized here).
  std::vector<double> nodal_pattern(const std::string& set, const double dir[3]) const;
  /// Appends u = Phi q at the nodes of `set` (node-major, x y z).
  void displacements(const std::string& set, const double* q, std::vector<double>* out) const;
  /// u = Phi q at every node ([node][3], nodes as node_ids).
  std::vector<double> field(const double* q) const;
  /// Basis rows of (node id, component) pairs (a fom file's DOF map); throws naming the first
  /// node that the model lacks.
  std::vector<std::size_t> dof_rows(const std::vector<std::int64_t>& node_ids,
                                    const std::vector<std::int64_t>& components) const;
  /// Appends (Phi q) at the DOF rows of dof_rows().
  void dof_values(const std::vector<std::size_t>& rows, const double* q, std::vector<double>* out) const;
  /// The row m with u_r = m . q: the radial displacement e_r . (Phi q) of the one node of `set`,
  /// e_r = (x, y, 0) / |(x, y)| of its reference position. Throws, naming `option` and the set,
  /// if the set does not hold exactly one node or the node lies on the rotation axis.
  std::vector<double> radial_row(const std::string& set, const std::string& option) const;
  /// The boundary coordinate j of each node of `set` whose translations are q[j..j+2] (x, y, z),
  /// in the set's order. Throws naming the first node of the set that is not a boundary node of
  /// the basis with its three translations (a node outside the boundary, or a partly clamped one).
  std::vector<std::size_t> boundary_translations(const std::string& set) const;
  /// The least-squares coordinates of a nodal field (3 values per basis node): argmin ||Phi q - u||,
  /// by the normal equations on the stored basis. *rel_residual receives ||Phi q - u|| / ||u||.
  std::vector<double> fit(const std::vector<double>& u, double* rel_residual) const;
};

/// Reads /nlrom/{M,K,C,A,B,basis,boundary_nodes,boundary_dofs}, /mesh/{node_ids,coordinates}, /meta/units and the node
/// sets `sets` of a `morse nlrom` file on rank 0 and broadcasts them. Throws (collectively) naming the file and the
/// missing or inconsistent dataset, or the missing set (listing the file's sets). Collective.
StoredModel read_stored_model(MPI_Comm comm, const std::string& file, const std::vector<std::string>& sets);

/// How a `morse nlrom` file's model was built, recorded as attributes of /nlrom.
struct StoredInfo {
  std::string basis = "cb";                      ///< -nlrom_basis: cb, cbmd or pod
  std::string forces = "step";                   ///< -nlrom_forces: step or exact
  std::string boundary_set;                      ///< the interface node set
  std::string derivative_selection = "weight";   ///< cbmd: weight or random
  double step_displacement = 0;                  ///< -step_displacement (STEP)
  PetscInt filter_pod = 0;                       ///< -nlrom_filter_pod
  std::string damping = "none";                  ///< none, modal or rayleigh (OfflineSettings::damping)
  double modal_damping_ratio = 0;                ///< -nlrom_damping_modal
  double rayleigh_alpha = 0, rayleigh_beta = 0;  ///< -nlrom_rayleigh
  double t2_forces_seconds = 0;                  ///< offline time of the forces (t1 is basis.seconds)
  double t3_projection_seconds = 0;              ///< offline time of the projection
  std::string massless_interior;                 ///< massless: static or scaled (-nlrom_massless_interior)
  double massless_fmax = 0;                      ///< massless: -nlrom_massless_fmax [Hz]
  double mass_scaling_fmax = 0;                  ///< -nlrom_mass_scaling_fmax [Hz] (0: none)
  std::size_t mass_scaled_modes = 0;             ///< the modes it scaled
};

/// Writes what read_stored_model reads (docs/hdf5-schema.md, /nlrom): /mesh (the mesh gathered on
/// rank 0), /nlrom/node_sets (every node set of lm), /nlrom/{M,K,C} (rm), /nlrom/{A,B} (rm.g),
/// /nlrom/basis (the columns of basis.V at every node, [r][node][3]), /nlrom/labels,
/// /nlrom/boundary_nodes, /nlrom/boundary_dofs, the modal-derivative pairs and weights (cbmd), the POD singular values
/// (pod), the damped frequencies, and the attributes of info. /meta is the command's.
/// T (a model with constraints, fe::ConstraintMap): basis.V is on the model's DOFs and every
/// column is written expanded, u = T v, on `dofs`, the nodes' layout (fe::node_layout): the
/// dependent nodes move with their elements. Collective (gathers the mesh and the basis).
void write_stored_model(io::H5Output& out, const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const Basis& basis,
                        const ReducedModel& rm, const StoredInfo& info, Mat T = nullptr);

/// A fingerprint of the model's numbers (K~, M~, C~, the cubic force, r, the massless layout):
/// 16 hex digits of a 64-bit FNV-1a hash of their bytes. Two files of the same model give the same
/// text; a model rebuilt with other options (at the same path) another. Not collective.
std::string fingerprint(const ReducedModel& m);

/// M~ = V^T M V, K~ = V^T K V (symmetrized), and modal damping xi on the first k modes of the
/// reduced model itself (k = kAllModes: all r of them): C~ = sum 2 xi w_k (M~ x_k)(M~ x_k)^T, with
/// x_k the M~-normalized modes of (K~, M~) (theory §8.6). Throws if k exceeds r. Collective.
ReducedModel project_model(MPI_Comm comm, Mat V, Mat K, Mat M, double xi, PetscInt k);

/// Replaces rm->C by the modal damping of project_model: xi on the first k modes of (K~, M~)
/// (k = kAllModes: all of them); zero if xi or k is 0. Sets rm->damping_omega. Called on every
/// rank alike.
void modal_damping(ReducedModel* rm, double xi, PetscInt k);

/// Selective mass scaling of a mass-carrying reduced model (-nlrom_mass_scaling_fmax F; theory
/// §8.7): every mode x_k of (K~, M~) above w_c = 2 pi F gets the modal mass w_k^2 / w_c^2 instead of 1,
///   M~' = M~ + sum_{w_k > w_c} (w_k^2 / w_c^2 - 1) (M~ x_k)(M~ x_k)^T,
/// so it keeps its shape at the frequency w_c, and the modes below are unchanged (shapes, masses,
/// frequencies). The highest frequency of the free model is then w_c, and that of any model with
/// contact constraints no higher (Cauchy interlacing): the critical step of central differences
/// is at least 2 / w_c. Apply damping after it (modal_damping, rayleigh_damping). Returns the
/// number of modes scaled. Throws for a massless model or F not finite and > 0.
std::size_t scale_modal_mass(ReducedModel* rm, double fmax_hz);

/// Rayleigh damping of a mass-carrying reduced model: C~ = alpha M~ + beta K~ (replacing C~; every
/// mode m gets the ratio alpha / (2 w_m) + beta w_m / 2; theory §8.6). rm->damping_omega is cleared
/// (it lists modally damped modes). Throws for a massless model (Rayleigh damping is not defined on
/// its zero-mass block) or a negative or non-finite coefficient. Called on every rank alike.
void rayleigh_damping(ReducedModel* rm, double alpha, double beta);

}  // namespace morse::nlrom
