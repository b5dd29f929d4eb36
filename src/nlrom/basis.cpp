// Reduction bases of seed 003 §3.2: Craig–Bampton, Craig–Bampton + modal derivatives (eq. 20–24,
// selection by W_ij and modified Gram–Schmidt), POD + constraint modes (eq. 10, 14–16), and the
// reduced operators.
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <random>

#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"
#include "morse/core/log.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "nlrom/modal_damping.hpp"

namespace morse::nlrom {

namespace {

// A distributed vector gathered on every rank.
std::vector<double> to_all(Vec x) {
  VecScatter sc;
  Vec all;
  MORSE_CALL(VecScatterCreateToAll(x, &sc, &all));
  MORSE_CALL(VecScatterBegin(sc, x, all, INSERT_VALUES, SCATTER_FORWARD));
  MORSE_CALL(VecScatterEnd(sc, x, all, INSERT_VALUES, SCATTER_FORWARD));
  PetscInt n;
  MORSE_CALL(VecGetSize(all, &n));
  std::vector<double> out(n);
  const double* a;
  MORSE_CALL(VecGetArrayRead(all, &a));
  std::copy(a, a + n, out.begin());
  MORSE_CALL(VecRestoreArrayRead(all, &a));
  MORSE_CALL(VecScatterDestroy(&sc));
  MORSE_CALL(VecDestroy(&all));
  return out;
}

// Copies columns [c0, c0 + n) of A into columns [d0, d0 + n) of B (same row layout).
void copy_columns(Mat A, PetscInt c0, Mat B, PetscInt d0, PetscInt n) {
  for (PetscInt j = 0; j < n; ++j) {
    Vec a, b;
    MORSE_CALL(MatDenseGetColumnVecRead(A, c0 + j, &a));
    MORSE_CALL(MatDenseGetColumnVecWrite(B, d0 + j, &b));
    MORSE_CALL(VecCopy(a, b));
    MORSE_CALL(MatDenseRestoreColumnVecWrite(B, d0 + j, &b));
    MORSE_CALL(MatDenseRestoreColumnVecRead(A, c0 + j, &a));
  }
}

UMat dense_like(Mat A, PetscInt cols) {
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)A, &comm));
  PetscInt m, N;
  MORSE_CALL(MatGetLocalSize(A, &m, nullptr));
  MORSE_CALL(MatGetSize(A, &N, nullptr));
  UMat B;
  MORSE_CALL(MatCreateDense(comm, m, PETSC_DECIDE, N, cols, nullptr, B.ptr()));
  MORSE_CALL(MatZeroEntries(B.get()));
  MORSE_CALL(MatAssemblyBegin(B.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(B.get(), MAT_FINAL_ASSEMBLY));
  return B;
}

// Linear reduced response (trapezoidal rule, undamped, zero initial state) under f(t) =
// sum_l factor_l(t) p_l; returns q at every step (n_steps + 1 rows of r).
std::vector<double> linear_training(const std::vector<double>& M, const std::vector<double>& K, PetscInt r,
                                    const dyn::Loads& loads, const std::vector<std::vector<double>>& p, double dt,
                                    double tfinal) {
  const PetscInt n_steps = static_cast<PetscInt>(std::ceil(tfinal / dt - 1e-9));
  std::vector<double> A(r * r), q(r, 0.0), v(r, 0.0), rhs(r), f0(r, 0.0), f1(r), out;
  for (PetscInt i = 0; i < r * r; ++i) A[i] = 4.0 / (dt * dt) * M[i] + K[i];
  std::vector<PetscBLASInt> piv(r);
  PetscBLASInt n = static_cast<PetscBLASInt>(r), one = 1, info = 0;
  LAPACKgetrf_(&n, &n, A.data(), &n, piv.data(), &info);
  MORSE_CHECK(info == 0, "nlrom training: singular reduced iteration matrix");
  auto force = [&](double t, std::vector<double>& f) {
    std::fill(f.begin(), f.end(), 0.0);
    for (std::size_t l = 0; l < p.size(); ++l) {
      const double c = loads.factor(l, t);
      for (PetscInt i = 0; i < r; ++i) f[i] += c * p[l][i];
    }
  };
  force(0.0, f0);
  out.insert(out.end(), q.begin(), q.end());
  for (PetscInt s = 1; s <= n_steps; ++s) {
    force(s * dt, f1);
    // (4/h^2 M + K) q1 = f0 + f1 - K q0 + M (4/h^2 q0 + 4/h v0)
    for (PetscInt i = 0; i < r; ++i) {
      double x = f0[i] + f1[i];
      for (PetscInt j = 0; j < r; ++j)
        x += -K[i * r + j] * q[j] + M[i * r + j] * (4.0 / (dt * dt) * q[j] + 4.0 / dt * v[j]);
      rhs[i] = x;
    }
    const char tr = 'T';  // A is row-major (symmetric anyway)
    LAPACKgetrs_(&tr, &n, &one, A.data(), &n, piv.data(), rhs.data(), &n, &info);
    for (PetscInt i = 0; i < r; ++i) {
      v[i] = 2.0 * (rhs[i] - q[i]) / dt - v[i];
      q[i] = rhs[i];
    }
    f0 = f1;
    out.insert(out.end(), q.begin(), q.end());
  }
  return out;
}

}  // namespace

std::vector<double> project_vector(Mat V, Vec x) {
  UVec y;
  MORSE_CALL(MatCreateVecs(V, y.ptr(), nullptr));
  MORSE_CALL(MatMultTranspose(V, x, y.get()));
  return to_all(y.get());
}

UMat modal_derivatives(const fe::Svk& svk, Mat T, const std::vector<PetscInt>& boundary_dofs,
                       const std::vector<std::pair<PetscInt, PetscInt>>& pairs) {
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)T, &comm));
  StageTimer stage(comm, "ModalDerivatives");
  Mat K = svk.stiffness();
  PetscInt lo, hi;
  MORSE_CALL(MatGetOwnershipRange(K, &lo, &hi));
  std::vector<PetscInt> own_b;
  for (PetscInt g : boundary_dofs)
    if (g >= lo && g < hi) own_b.push_back(g);
  // Right-hand sides -(dK_T/dq_i phi_j), zero on the boundary.
  const PetscInt np = static_cast<PetscInt>(pairs.size());
  UMat Rhs = dense_like(T, np), Psi = dense_like(T, np);
  UVec up, um, yp, ym, ti;
  MORSE_CALL(MatCreateVecs(K, up.ptr(), um.ptr()));
  for (UVec* v : {&yp, &ym, &ti}) MORSE_CALL(VecDuplicate(up.get(), v->ptr()));
  std::vector<PetscInt> by_i(np);
  std::iota(by_i.begin(), by_i.end(), 0);
  std::stable_sort(by_i.begin(), by_i.end(), [&](PetscInt a, PetscInt b) { return pairs[a].first < pairs[b].first; });
  PetscInt current = -1;
  double eps = 0.0;
  for (PetscInt idx : by_i) {
    const PetscInt i = pairs[idx].first, j = pairs[idx].second;
    if (i != current) {
      current = i;
      Vec c;
      MORSE_CALL(MatDenseGetColumnVecRead(T, i, &c));
      MORSE_CALL(VecCopy(c, ti.get()));
      MORSE_CALL(MatDenseRestoreColumnVecRead(T, i, &c));
      double m;
      MORSE_CALL(VecNorm(ti.get(), NORM_INFINITY, &m));
      MORSE_CHECK(m > 0, "modal derivatives: basis vector ", i, " is zero");
      eps = 1e-6 / m;  // the result is exact for any eps; small keeps the cubic part tiny
    }
    Vec cj;
    MORSE_CALL(MatDenseGetColumnVecRead(T, j, &cj));
    // (K_T(+e t_i) - K) t_j - (K_T(-e t_i) - K) t_j = 2 e d^2g[t_i, t_j]
    MORSE_CALL(VecCopy(ti.get(), up.get()));
    MORSE_CALL(VecScale(up.get(), eps));
    svk.tangent_point(up.get());
    svk.tangent_apply_nonlinear(cj, yp.get());
    MORSE_CALL(VecScale(up.get(), -1.0));
    svk.tangent_point(up.get());
    svk.tangent_apply_nonlinear(cj, ym.get());
    MORSE_CALL(MatDenseRestoreColumnVecRead(T, j, &cj));
    Vec b;
    MORSE_CALL(MatDenseGetColumnVecWrite(Rhs.get(), idx, &b));
    MORSE_CALL(VecWAXPY(b, -1.0, yp.get(), ym.get()));  // ym - yp = -2 e d^2g
    MORSE_CALL(VecScale(b, 0.5 / eps));
    for (PetscInt g : own_b) MORSE_CALL(VecSetValue(b, g, 0.0, INSERT_VALUES));
    MORSE_CALL(VecAssemblyBegin(b));
    MORSE_CALL(VecAssemblyEnd(b));
    MORSE_CALL(MatDenseRestoreColumnVecWrite(Rhs.get(), idx, &b));
  }
  // K with the boundary rows and columns replaced by the identity: its interior block is K_ii.
  UMat Kb;
  MORSE_CALL(MatDuplicate(K, MAT_COPY_VALUES, Kb.ptr()));
  MORSE_CALL(MatZeroRowsColumns(Kb.get(), static_cast<PetscInt>(own_b.size()), own_b.data(), 1.0, nullptr, nullptr));
  MORSE_CALL(MatSetOption(Kb.get(), MAT_SYMMETRIC, PETSC_TRUE));
  UMat F;
  MORSE_CALL(MatGetFactor(Kb.get(), cholesky_solver(Kb.get()), MAT_FACTOR_CHOLESKY, F.ptr()));
  MORSE_CALL(MatMumpsSetIcntl(F.get(), 24, 1));
  MatFactorInfo info;
  MORSE_CALL(MatFactorInfoInitialize(&info));
  MORSE_CALL(MatCholeskyFactorSymbolic(F.get(), Kb.get(), nullptr, &info));
  MORSE_CALL(MatCholeskyFactorNumeric(F.get(), Kb.get(), &info));
  const PetscInt nulls = eigen::mumps_null_pivots(F.get());
  MORSE_CHECK(nulls == 0, "modal derivatives: K_ii is singular (", nulls, " null pivots); check -clamp and -boundary");
  if (np > 0) MORSE_CALL(MatMatSolve(F.get(), Rhs.get(), Psi.get()));
  return Psi;
}

UMat pod(Mat X, PetscInt n, std::vector<double>* sigma) {
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)X, &comm));
  PetscInt ns = 0, m = 0;
  MORSE_CALL(MatGetSize(X, nullptr, &ns));
  MORSE_CALL(MatGetLocalSize(X, &m, nullptr));
  MORSE_CHECK(n > 0 && n <= ns, "POD: ", n, " modes asked from ", ns, " snapshots");
  auto C = cb::transpose_product(comm, X, X);  // ns x ns, identical on every rank
  std::vector<double> w(ns), work(1);
  PetscBLASInt nn = static_cast<PetscBLASInt>(ns), lwork = -1, info = 0;
  LAPACKsyev_("V", "U", &nn, C.data(), &nn, w.data(), work.data(), &lwork, &info);
  lwork = static_cast<PetscBLASInt>(work[0]);
  work.resize(lwork);
  LAPACKsyev_("V", "U", &nn, C.data(), &nn, w.data(), work.data(), &lwork, &info);
  MORSE_CHECK(info == 0, "POD: LAPACK syev failed (info ", info, ")");
  // Descending; C's columns (LAPACK column-major) are the eigenvectors.
  sigma->resize(ns);
  for (PetscInt k = 0; k < ns; ++k) (*sigma)[k] = std::sqrt(std::max(0.0, w[ns - 1 - k]));
  // X^T X squares the condition number: below sqrt(eps) sigma_1 a singular value is round-off.
  MORSE_CHECK((*sigma)[n - 1] > 1e-7 * (*sigma)[0], "POD: ", n,
              " modes asked but the snapshots span fewer "
              "independent fields (sigma_",
              n, " / sigma_1 = ", (*sigma)[n - 1] / std::max((*sigma)[0], 1e-300), " < 1e-7)");
  std::vector<double> U(static_cast<std::size_t>(ns) * n);
  for (PetscInt k = 0; k < n; ++k)
    for (PetscInt i = 0; i < ns; ++i) U[k * ns + i] = C[(ns - 1 - k) * ns + i] / (*sigma)[k];
  UMat P = dense_like(X, n);
  const PetscScalar* x;
  PetscScalar* p;
  PetscInt ldx, ldp;
  MORSE_CALL(MatDenseGetLDA(X, &ldx));
  MORSE_CALL(MatDenseGetLDA(P.get(), &ldp));
  MORSE_CALL(MatDenseGetArrayRead(X, &x));
  MORSE_CALL(MatDenseGetArrayWrite(P.get(), &p));
  if (m > 0) {
    PetscBLASInt bm = static_cast<PetscBLASInt>(m), bn = static_cast<PetscBLASInt>(n), bk = nn,
                 lx = static_cast<PetscBLASInt>(ldx), lp = static_cast<PetscBLASInt>(ldp);
    const double one = 1.0, zero = 0.0;
    BLASgemm_("N", "N", &bm, &bn, &bk, &one, x, &lx, U.data(), &bk, &zero, p, &lp);
  }
  MORSE_CALL(MatDenseRestoreArrayWrite(P.get(), &p));
  MORSE_CALL(MatDenseRestoreArrayRead(X, &x));
  return P;
}

namespace {

// M-orthonormalizes `cand` columns (in the given order) against `base` columns (M-orthonormal)
// and the accepted ones, two passes of modified Gram–Schmidt; keeps at most `want`. Returns the
// accepted candidate indices; accepted vectors are written to out (columns from d0).
std::vector<PetscInt> mgs(Mat M, Mat base, PetscInt b0, PetscInt nb, Mat cand, const std::vector<PetscInt>& order,
                          PetscInt want, double tol, Mat out, PetscInt d0) {
  std::vector<PetscInt> taken;
  UVec v, Mv;
  MORSE_CALL(MatCreateVecs(M, v.ptr(), Mv.ptr()));
  auto mdot = [&](Vec a, Vec b) {
    MORSE_CALL(MatMult(M, b, Mv.get()));
    double d;
    MORSE_CALL(VecDot(a, Mv.get(), &d));
    return d;
  };
  for (PetscInt c : order) {
    if (static_cast<PetscInt>(taken.size()) >= want) break;
    Vec x;
    MORSE_CALL(MatDenseGetColumnVecRead(cand, c, &x));
    MORSE_CALL(VecCopy(x, v.get()));
    MORSE_CALL(MatDenseRestoreColumnVecRead(cand, c, &x));
    const double n0 = std::sqrt(std::max(0.0, mdot(v.get(), v.get())));
    if (!(n0 > 0)) continue;
    for (int pass = 0; pass < 2; ++pass) {
      for (PetscInt k = 0; k < nb; ++k) {
        Vec b;
        MORSE_CALL(MatDenseGetColumnVecRead(base, b0 + k, &b));
        MORSE_CALL(VecAXPY(v.get(), -mdot(b, v.get()), b));
        MORSE_CALL(MatDenseRestoreColumnVecRead(base, b0 + k, &b));
      }
      for (std::size_t k = 0; k < taken.size(); ++k) {
        Vec b;
        MORSE_CALL(MatDenseGetColumnVecRead(out, d0 + static_cast<PetscInt>(k), &b));
        MORSE_CALL(VecAXPY(v.get(), -mdot(b, v.get()), b));
        MORSE_CALL(MatDenseRestoreColumnVecRead(out, d0 + static_cast<PetscInt>(k), &b));
      }
    }
    const double n1 = std::sqrt(std::max(0.0, mdot(v.get(), v.get())));
    if (n1 < tol * n0) continue;  // dependent
    MORSE_CALL(VecScale(v.get(), 1.0 / n1));
    Vec y;
    MORSE_CALL(MatDenseGetColumnVecWrite(out, d0 + static_cast<PetscInt>(taken.size()), &y));
    MORSE_CALL(VecCopy(v.get(), y));
    MORSE_CALL(MatDenseRestoreColumnVecWrite(out, d0 + static_cast<PetscInt>(taken.size()), &y));
    taken.push_back(c);
  }
  return taken;
}

std::vector<std::string> cb_labels(const cb::CBResult& c) {
  static const char* const component[] = {"x", "y", "z", "rx", "ry", "rz"};
  std::vector<std::string> l;
  for (PetscInt j = 0; j < c.n_b; ++j)
    l.push_back(cat("u_b node ", c.boundary_dof_node[j], " ", component[c.boundary_dof_component[j] - 1]));
  for (PetscInt j = 0; j < c.n_phi; ++j) l.push_back(cat("phi ", j + 1));
  return l;
}

}  // namespace

PetscInt basis_size(const fe::Model& md, const BasisSettings& s) {
  MORSE_CHECK(!s.boundary_set.empty(), "nlrom: the boundary set (-boundary SET) is required");
  MORSE_CHECK(s.n_fixed >= 0 && s.n_derivatives >= 0 && s.n_pod >= 0, "nlrom: basis sizes must be >= 0");
  const PetscInt n_fixed = s.kind == BasisKind::POD ? 0 : s.n_fixed;
  const PetscInt want_extra = s.kind == BasisKind::CBMD ? s.n_derivatives : s.kind == BasisKind::POD ? s.n_pod : 0;
  cb::CBResult probe;
  cb::set_boundary(md, s.boundary_set, &probe);
  // The boundary coordinates are the boundary set's free DOFs in node order, then component
  // (nlrom::StoredModel::boundary_dof_node): the three translations of a solid node, the six DOFs
  // of a point (the independent node of a rigid or interpolation element).
  const PetscInt r = probe.n_b + n_fixed + want_extra;
  MORSE_CHECK(r <= md.dofs.n_global, "nlrom: a basis of ", r, " vectors (", probe.n_b, " boundary DOFs + ", n_fixed,
              " fixed-interface modes + ", want_extra, " others) is larger than the model (", md.dofs.n_global,
              " free DOFs)");
  return r;
}

double force_bytes(std::size_t r, bool step) {
  const double rr = static_cast<double>(r);
  const double tensor = 8.0 * rr * (rr * (rr + 1) / 2 + rr * (rr + 1) * (rr + 2) / 6);
  const double fields = step ? 16.0 * rr * static_cast<double>(step_evaluations(r)) : 0.0;
  return tensor + fields;
}

void check_force_memory(MPI_Comm comm, std::size_t r, bool step) {
  check_memory(comm, cat("nlrom r = ", r), force_bytes(r, step),
               step ? "the cubic tensor and its STEP fields" : "the cubic tensor");
}

Basis build_basis(const fe::Model& md, const fe::Svk& svk, const BasisSettings& s) {
  MORSE_CHECK(md.mesh, "nlrom: the nonlinear basis needs a mesh model");
  MORSE_CHECK(svk.stiffness() == md.K.get(), "nlrom: the SVK forces must be built on the model's K");
  const auto& lm = *md.mesh;
  Mat M = md.M.get();
  MPI_Comm comm = lm.comm;
  const auto t0 = std::chrono::steady_clock::now();
  StageTimer stage(comm, "Basis");
  Mat K = svk.stiffness();
  Basis b;
  b.kind = s.kind;
  basis_size(md, s);  // the settings and the size, before any work: r must not exceed the free DOFs
  cb::CBSettings cs;
  cs.boundary_set = s.boundary_set;
  cs.n_fixed = s.kind == BasisKind::POD ? 0 : s.n_fixed;
  cs.keep_basis = true;
  cs.prefix = s.prefix;
  if (s.kind == BasisKind::POD) {
    MORSE_CHECK(!s.snapshots.empty(), "nlrom: -nlrom_basis pod needs -nlrom_snapshots FILE.h5 (a morse fom file)");
    MORSE_CHECK(s.n_pod > 0, "nlrom: -nlrom_basis pod needs -nlrom_num_pod N > 0");
  }
  if (s.kind == BasisKind::CBMD) {
    MORSE_CHECK(s.n_derivatives > 0, "nlrom: -nlrom_basis cbmd needs -nlrom_num_derivatives N > 0");
    MORSE_CHECK(s.training && !s.training->empty() && s.training_tfinal > 0 && s.training_dt > 0,
                "nlrom: -nlrom_basis cbmd needs a training load (-load_sets ...) and -nlrom_training_tfinal T > 0");
  }
  b.cb = cb::craig_bampton(md, cs);
  b.n_b = b.cb.n_b;
  b.n_fixed = b.cb.n_phi;
  const PetscInt rcb = b.cb.n();
  b.labels = cb_labels(b.cb);

  if (s.kind == BasisKind::CB) {
    b.V = std::move(b.cb.T);
  } else if (s.kind == BasisKind::CBMD) {
    for (PetscInt i = 0; i < rcb; ++i)
      for (PetscInt j = i; j < rcb; ++j) b.md_pairs.emplace_back(i, j);
    auto Psi = modal_derivatives(svk, b.cb.T.get(), b.cb.boundary_dofs, b.md_pairs);
    // W_ij = int |q_i q_j| dt from the linear CB reduced response to the training load (eq. 24).
    std::vector<std::vector<double>> p;
    for (std::size_t l = 0; l < s.training->loads().size(); ++l)
      p.push_back(project_vector(b.cb.T.get(), s.training->pattern(l)));
    auto q = linear_training(b.cb.M, b.cb.K, rcb, *s.training, p, s.training_dt, s.training_tfinal);
    const std::size_t nt = q.size() / rcb;
    b.md_weights.assign(b.md_pairs.size(), 0.0);
    for (std::size_t k = 0; k < b.md_pairs.size(); ++k) {
      const auto [i, j] = b.md_pairs[k];
      double w = 0.0;
      for (std::size_t t = 0; t < nt; ++t) {  // trapezoidal rule in time
        const double v = std::abs(q[t * rcb + i] * q[t * rcb + j]);
        w += (t == 0 || t + 1 == nt) ? 0.5 * v : v;
      }
      b.md_weights[k] = w * s.training_dt;
    }
    std::vector<PetscInt> order(b.md_pairs.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](PetscInt a, PetscInt c) { return b.md_weights[a] > b.md_weights[c]; });
    if (s.random_derivatives) {  // Fisher–Yates with a portable generator: the same order everywhere
      std::mt19937 gen(s.derivative_seed);
      for (std::size_t k = order.size(); k > 1; --k) std::swap(order[k - 1], order[gen() % k]);
    }
    b.V = dense_like(K, rcb + s.n_derivatives);
    copy_columns(b.cb.T.get(), 0, b.V.get(), 0, rcb);
    auto taken = mgs(M, b.cb.T.get(), b.n_b, b.n_fixed, Psi.get(), order, s.n_derivatives, s.mgs_tol, b.V.get(), rcb);
    b.n_extra = static_cast<PetscInt>(taken.size());
    MORSE_CHECK(b.n_extra == s.n_derivatives, "nlrom: only ", b.n_extra, " independent modal derivatives (of ",
                b.md_pairs.size(), " pairs, -nlrom_mgs_tol ", s.mgs_tol, ") but -nlrom_num_derivatives ",
                s.n_derivatives);
    b.md_selected.assign(b.md_pairs.size(), 0);
    for (PetscInt k : taken) {
      b.md_selected[k] = 1;
      b.labels.push_back(cat("psi ", b.md_pairs[k].first + 1, ",", b.md_pairs[k].second + 1));
    }
  } else {
    auto X = dyn::read_fom_snapshots(md, s.snapshots);  // on the model's DOFs (points included)
    PetscInt ns = 0;
    MORSE_CALL(MatGetSize(X.get(), nullptr, &ns));
    MORSE_CHECK(s.n_pod <= ns, "nlrom: -nlrom_num_pod ", s.n_pod, " exceeds the ", ns, " snapshots of ", s.snapshots);
    // Remove the interface part (eq. 15): X_i = X - Psi X_b, so every POD vector vanishes on the
    // boundary.
    std::vector<double> Xb(static_cast<std::size_t>(b.n_b) * ns, 0.0);
    {
      PetscInt lo, hi, ld;
      MORSE_CALL(MatGetOwnershipRange(X.get(), &lo, &hi));
      MORSE_CALL(MatDenseGetLDA(X.get(), &ld));
      const PetscScalar* x;
      MORSE_CALL(MatDenseGetArrayRead(X.get(), &x));
      for (PetscInt j = 0; j < b.n_b; ++j) {
        const PetscInt g = b.cb.boundary_dofs[j];
        if (g >= lo && g < hi)
          for (PetscInt k = 0; k < ns; ++k) Xb[j * ns + k] = x[(g - lo) + static_cast<std::size_t>(ld) * k];
      }
      MORSE_CALL(MatDenseRestoreArrayRead(X.get(), &x));
      MPI_Allreduce(MPI_IN_PLACE, Xb.data(), static_cast<int>(Xb.size()), MPI_DOUBLE, MPI_SUM, comm);
      PetscScalar* xw;
      const PetscScalar* t;
      PetscInt ldt;
      MORSE_CALL(MatDenseGetLDA(b.cb.T.get(), &ldt));
      MORSE_CALL(MatDenseGetArrayRead(b.cb.T.get(), &t));
      MORSE_CALL(MatDenseGetArray(X.get(), &xw));
      for (PetscInt k = 0; k < ns; ++k)
        for (PetscInt j = 0; j < b.n_b; ++j) {
          const double c = Xb[j * ns + k];
          if (c == 0.0) continue;
          for (PetscInt i = 0; i < hi - lo; ++i)
            xw[i + static_cast<std::size_t>(ld) * k] -= c * t[i + static_cast<std::size_t>(ldt) * j];
        }
      MORSE_CALL(MatDenseRestoreArray(X.get(), &xw));
      MORSE_CALL(MatDenseRestoreArrayRead(b.cb.T.get(), &t));
    }
    auto P = pod(X.get(), s.n_pod, &b.pod_singular_values);
    b.V = dense_like(K, b.n_b + s.n_pod);
    copy_columns(b.cb.T.get(), 0, b.V.get(), 0, b.n_b);
    copy_columns(P.get(), 0, b.V.get(), b.n_b, s.n_pod);
    b.n_extra = s.n_pod;
    for (PetscInt k = 0; k < s.n_pod; ++k) b.labels.push_back(cat("pod ", k + 1));
  }
  b.cb.T.reset();
  b.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

ReducedModel project_model(MPI_Comm comm, Mat V, Mat K, Mat M, double xi, PetscInt k) {
  StageTimer stage(comm, "Project");
  ReducedModel rm;
  PetscInt r = 0;
  MORSE_CALL(MatGetSize(V, nullptr, &r));
  rm.r = r;
  rm.K = cb::project_symmetric(comm, K, V);
  rm.M = cb::project_symmetric(comm, M, V);
  modal_damping(&rm, xi, k);
  return rm;
}

namespace detail {

std::vector<double> modal_damping_matrix(std::size_t n, const std::vector<double>& K, const std::vector<double>& M,
                                         double xi, PetscInt k, std::vector<double>* omega) {
  std::vector<double> C(n * n, 0.0);
  if (!(xi > 0 && k > 0)) return C;
  std::vector<double> X;  // M-normalized modes, column m = mode m (row-major)
  const auto w = eigen::dense_eigenvalues(static_cast<int>(n), K, M, &X);
  std::vector<double> Mx(n);
  for (std::size_t m = 0; m < static_cast<std::size_t>(k); ++m) {
    const double om = std::sqrt(std::max(0.0, w[m]));
    omega->push_back(om);
    std::fill(Mx.begin(), Mx.end(), 0.0);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < n; ++j) Mx[i] += M[i * n + j] * X[j * n + m];
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < n; ++j) C[i * n + j] += 2.0 * xi * om * Mx[i] * Mx[j];
  }
  return C;
}

}  // namespace detail

void modal_damping(ReducedModel* rm, double xi, PetscInt k) {
  const PetscInt r = rm->r;
  if (k == kAllModes) k = r;
  MORSE_CHECK(!(xi > 0 && k > r), "nlrom: ", k, " damped modes asked from a reduced model of ", r);
  rm->damping_omega.clear();
  rm->C = detail::modal_damping_matrix(static_cast<std::size_t>(r), rm->K, rm->M, xi, k, &rm->damping_omega);
}

std::size_t scale_modal_mass(ReducedModel* rm, double fmax_hz) {
  MORSE_CHECK(!rm->massless, "nlrom: mass scaling applies to a mass-carrying model (-nlrom_boundary_mass carrying)");
  MORSE_CHECK(std::isfinite(fmax_hz) && fmax_hz > 0, "nlrom: the mass-scaling frequency ", fmax_hz,
              " Hz must be finite and > 0");
  const std::size_t r = static_cast<std::size_t>(rm->r);
  const double wc2 = std::pow(2.0 * M_PI * fmax_hz, 2);
  std::vector<double> X;  // M-normalized modes, column m = mode m (row-major)
  const auto w = eigen::dense_eigenvalues(static_cast<int>(r), rm->K, rm->M, &X);
  // M' = M + sum over the modes above w_c of (w_k / w_c^2 - 1) (M x_k)(M x_k)^T: x_k^T M' x_l =
  // delta_kl max(1, w_k / w_c^2), so mode k keeps its shape at min(w_k, w_c). The additions are
  // computed from the unchanged M and applied at the end.
  std::vector<double> add(r * r, 0.0), Mx(r);
  std::size_t n = 0;
  for (std::size_t m = 0; m < r; ++m) {
    if (w[m] <= wc2) continue;
    ++n;
    const double a = w[m] / wc2 - 1.0;
    for (std::size_t i = 0; i < r; ++i) {
      double x = 0.0;
      for (std::size_t j = 0; j < r; ++j) x += rm->M[i * r + j] * X[j * r + m];
      Mx[i] = x;
    }
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t j = 0; j < r; ++j) add[i * r + j] += a * Mx[i] * Mx[j];
  }
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < r; ++j) rm->M[i * r + j] += 0.5 * (add[i * r + j] + add[j * r + i]);
  return n;
}

void rayleigh_damping(ReducedModel* rm, double alpha, double beta) {
  MORSE_CHECK(!rm->massless,
              "nlrom: Rayleigh damping is not defined on a massless model (its static coordinates have no mass)");
  MORSE_CHECK(std::isfinite(alpha) && std::isfinite(beta) && alpha >= 0 && beta >= 0, "nlrom: Rayleigh damping alpha ",
              alpha, ", beta ", beta, " must be finite and >= 0");
  rm->C.resize(rm->M.size());
  for (std::size_t i = 0; i < rm->C.size(); ++i) rm->C[i] = alpha * rm->M[i] + beta * rm->K[i];
  rm->damping_omega.clear();
}

std::string fingerprint(const ReducedModel& m) {
  std::uint64_t h = 1469598103934665603ULL;  // FNV-1a, 64 bits
  auto bytes = [&](const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 1099511628211ULL;
  };
  auto doubles = [&](const std::vector<double>& v) {
    const std::uint64_t n = v.size();
    bytes(&n, sizeof n);
    bytes(v.data(), v.size() * sizeof(double));
  };
  const std::int64_t head[3] = {m.r, m.massless ? 1 : 0, m.n_static};
  bytes(head, sizeof head);
  for (const auto* v : {&m.K, &m.M, &m.C, &m.g.A, &m.g.B}) doubles(*v);
  char out[17];
  std::snprintf(out, sizeof out, "%016llx", static_cast<unsigned long long>(h));
  return out;
}

}  // namespace morse::nlrom
