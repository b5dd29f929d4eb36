// morse/fe/nonlinear.hpp: geometric nonlinearity of the full model. Total-Lagrangian
// St Venant–Kirchhoff solids (seed 003, eq. 1 and 20):
//
//   H = grad_X u,  F = I + H,  E = (H + H^T + H^T H) / 2  (Green–Lagrange),
//   S = lambda tr(E) I + 2 mu E  (second Piola–Kirchhoff),  P = F S,
//   f_int(u)_a = int_V0 P grad N_a dV = K u + g_nl(u),
//
// where K is the linear stiffness of fe::assemble() and g_nl holds exactly the quadratic and
// cubic terms of f_int (computed directly, not as f_int - K u, so that small displacements lose
// no digits). The tangent is K_T(u) = K + d g_nl / du, symmetric:
//
//   K_T[a i][b k] = int [ (g_a . S g_b) d_ik + lambda (F g_a)_i (F g_b)_k
//                        + mu (g_a . g_b) (F F^T)_ik + mu (F g_b)_i (F g_a)_k ] dV,
//
// with g_a = grad N_a. Every integral uses the quadrature of the linear K (stiffness_rule), so
// K_T(0) = K and g_nl(0) = 0 exactly. The strain energy is W = int (lambda/2 tr(E)^2 + mu E:E).
//
// Distribution: the same DOF numbering and clamp elimination as fe::assemble (DofLayout), each rank
// evaluates its own elements on its owned + ghost DOFs (one VecScatter) and contributions to
// ghost DOFs are added to their owners. K_T reuses K's non-zero pattern.
//
// A model with rigid or interpolation elements or MPCs (Model::constraints, u = T u_bar, theory
// §1.1): the element loops see the nodes' translations u = T u_bar, and every force is returned on
// the model's DOFs, T^T g(T u_bar); the tangent is T^T K_T(T u_bar) T (MatPtAP), the linear part
// the model's K_bar = T^T K T. Exact: the constrained motions are the subspace u = T u_bar, on which
// the energy is W(T u_bar) and its gradient and Hessian are these.
//
// The midpoint ("algorithmic") forces serve the energy-conserving time integrator of dyn/
// (Simo & Tarnow 1992): for two states u_a, u_b,
//   f_alg(u_a, u_b) = int (I + (H_a + H_b)/2) S((E_a + E_b)/2) grad N dV,
// which satisfies f_alg . (u_b - u_a) = W(u_b) - W(u_a) exactly for St Venant–Kirchhoff, and
// equals f_int(u) when u_a = u_b.
#pragma once

#include <petscmat.h>
#include <petscvec.h>

#include <vector>

#include "morse/core/handle.hpp"
#include "morse/fe/model.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::fe {

/// Strain energy split of a displacement field.
struct StrainEnergy {
  double linear = 0.0;     ///< u^T K u / 2 (seed 003 eq. 46's potential part)
  double nonlinear = 0.0;  ///< W(u) - u^T K u / 2 (cubic and quartic terms)
  double total() const { return linear + nonlinear; }
};

/// St Venant–Kirchhoff internal forces and tangent of a distributed model. Holds the physical
/// shape-function gradients at every stiffness quadrature point of the local elements (computed
/// once), the local-to-global DOF scatter and work vectors. K must be the stiffness of
/// fe::assemble() for the same mesh, DOF map and materials; it is referenced, not copied, and
/// must outlive this object. Not copyable.
class Svk {
 public:
  /// Collective. Materials as in fe::assemble (mesh material, else `fallback`).
  Svk(const mesh::LocalMesh& lm, const DofLayout& dofs, const mesh::Material& fallback, Mat K);
  /// The forces of a mesh model on its own DOFs: with constraints, on u_bar through T (above),
  /// the elements on the nodes' layout and stiffness (ConstraintMap::full, K_nodes); without, as
  /// the constructor above with md.dofs and md.K. md must outlive this object. Collective.
  Svk(const Model& md, const mesh::Material& fallback);
  ~Svk();
  Svk(const Svk&) = delete;
  Svk& operator=(const Svk&) = delete;

  /// g = g_nl(u). Collective.
  void nonlinear_force(Vec u, Vec g) const;
  /// f = f_int(u) = K u + g_nl(u). Collective.
  void internal_force(Vec u, Vec f) const;
  /// A matrix with K's layout and non-zero pattern, for tangent() (with constraints, the product
  /// T^T K T that tangent() refills). Collective.
  UMat create_tangent() const;
  /// Kt = K_T(u) = K + d g_nl/du (Kt from create_tangent()). Collective.
  void tangent(Vec u, Mat Kt) const;
  /// y = K_T(u) v without assembling K_T (one pass over the elements plus K v; the Jacobian
  /// product of Newton–Krylov solvers). Collective.
  void tangent_apply(Vec u, Vec v, Vec y) const;
  /// The two halves of tangent_apply for many products at one state: tangent_point(u) stores
  /// grad u and S at every quadrature point (18 doubles each), then tangent_apply_nonlinear(v, y)
  /// gives y = (K_T(u) - K) v. Collective.
  void tangent_point(Vec u) const;
  void tangent_apply_nonlinear(Vec v, Vec y) const;
  /// Strain energy of u. Collective.
  StrainEnergy energy(Vec u) const;

  /// g_nl of many fields in one pass over the elements: column j of G = g_nl(column j of U).
  /// U and G are dense (MATDENSE) with K's row layout and the same number of columns; fields are
  /// processed in chunks of `chunk` columns (memory: chunk x local DOFs). Collective.
  void nonlinear_force_block(Mat U, Mat G, PetscInt chunk = 32) const;

  /// g = f_alg(ua, ub) - K (ua + ub)/2 (midpoint algorithmic force, see the file comment).
  /// Collective.
  void midpoint_nonlinear_force(Vec ua, Vec ub, Vec g) const;
  /// Kt = the symmetric midpoint tangent: K_T with F = I + (H_a + H_b)/2 and
  /// S = S((E_a + E_b)/2); equals K_T(u) for ua = ub. Collective.
  void midpoint_tangent(Vec ua, Vec ub, Mat Kt) const;

  Mat stiffness() const { return K_; }

  // ---- Reduced forces (seed 003 §3.3). Phi, W: MPIDENSE with K's row layout.

  /// Gt(:, f) = W^T g_nl(Phi Q(:, f)) for nf coefficient vectors Q (r x nf, column-major, the same
  /// on every rank), r = columns of Phi. Each rank evaluates its own elements and projects the
  /// element forces on its local rows of W (no ghost exchange of forces), in chunks of `chunk`
  /// fields; one reduction at the end. W == nullptr means W = Phi. Returns (cols of W) x nf,
  /// column-major, on every rank. Collective.
  std::vector<double> reduced_nonlinear_forces(Mat Phi, Mat W, const std::vector<double>& Q, PetscInt nf,
                                               PetscInt chunk = 64) const;

  /// Exact projection of g_nl onto Phi (St Venant–Kirchhoff is exactly cubic):
  ///   Phi^T g_nl(Phi q) = sum_{i<=j} A_ij q_i q_j + sum_{i<=j<=k} B_ijk q_i q_j q_k,
  /// integrated element by element with the stiffness quadrature. A: n2 x r and B: n3 x r,
  /// row-major (row = monomial in lexicographic order of i <= j (<= k), column = output), where
  /// n2 = r(r+1)/2 and n3 = r(r+1)(r+2)/6; identical on every rank. Collective.
  void project_tensors(Mat Phi, std::vector<double>* A, std::vector<double>* B) const;

 private:
  enum Output { kForce = 1, kTangent = 2, kEnergy = 4, kApply = 8, kPoint = 16 };
  // Runs the element loop over nv local field pairs (a, b), each of size n_local_ (compact
  // local DOFs). b == nullptr means b = a. g: nv x n_local_ (added), Kt: MatSetValues(ADD).
  // kPoint (alone): fills point_cache_ from a. kApply (alone): g += (K_T(u*) - K) a for the
  // direction a, u* being the state cached by kPoint.
  void element_loop(int what, int nv, const double* a, const double* b, double* g, Mat Kt, double* energy) const;
  void to_local(Vec u, Vec local) const;
  // Columns of a dense matrix on the compact local DOFs: n_local_ x cols, column-major.
  std::vector<double> local_columns(Mat A) const;
  void add_to_global(Vec local, Vec g) const;

  MPI_Comm comm_;
  Mat K_;
  PetscInt n_local_ = 0;  // owned + ghost free DOFs of the local elements
  // Per local element.
  std::vector<int> type_n_;             // nodes per element
  std::vector<std::int64_t> elem_off_;  // into elem_pos_ / elem_glob_
  std::vector<PetscInt> elem_pos_;      // compact local DOF (3 per node, -1 clamped)
  std::vector<PetscInt> elem_glob_;     // global DOF (-1 clamped)
  std::vector<int> elem_nq_;            // quadrature points
  std::vector<std::int64_t> grad_off_;  // into grad_ (3 n nq) and wdet_ via wdet_off_
  std::vector<std::int64_t> wdet_off_;
  std::vector<double> grad_, wdet_;
  std::vector<double> lambda_, mu_;
  Unique<VecScatter, VecScatterDestroy> scatter_;
  UVec la_, lb_, lg_;  // local work vectors (sequential, n_local_)
  // Constraints: u = T u_bar. Kn_ is the stiffness on the nodes' layout (K_ without constraints),
  // wf_ a vector of that layout, Ktn_ the nodes' tangent that tangent() projects.
  Mat T_ = nullptr, Kn_ = nullptr;
  UVec wf_;
  mutable UMat Ktn_;
  mutable std::vector<double> point_cache_;  // per quadrature point: H (9), S (9) of tangent_point()
};

}  // namespace morse::fe
