// Full-order implicit dynamics (see morse/dyn/dyn.hpp).
//
// Residual of a step, scaled by 2 (u0, v0 known; unknown u1, v1 = 2 (u1 - u0)/h - v0):
//   R(u1) = (2/h) M (v1 - v0) + C (v0 + v1) + 2 f_alg(u0, u1) - (f_e(t0) + f_e(t1)),
// with 2 f_alg = K (u0 + u1) + 2 g_mid(u0, u1)   (energy scheme),
//              = K (u0 + u1) + g(u0) + g(u1)     (trapezoidal scheme),
//              = K (u0 + u1)                      (linear twin).
// Iteration matrix J = (4/h^2) M + (2/h) C + K_T, with K_T the (midpoint) tangent; for the energy
// scheme the exact derivative has a small unsymmetric part (F_b instead of F_mid in one factor),
// which is left out: it only slows the (already modified) Newton iterations by O(|u1 - u0|).
//
// Newton = Krylov (trapezoidal): the Newton system J x = R is solved by CG with J applied
// matrix-free (exact K_T(u1) product, no assembly) and the last MUMPS factor of J as the
// preconditioner. The factor costs ~35 back-solves on the 60k blade, so it is refreshed only when
// CG slows down; Newton itself stays exact (quadratic), unlike modified Newton.
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>

#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/eigen/eigen.hpp"

namespace morse::dyn {

namespace {

// Solves J x = b with a MUMPS Cholesky factor of A = J - U diag(c) U^T and the
// Sherman–Morrison–Woodbury formula for the low-rank part (modal damping).
class IterationSolver {
 public:
  IterationSolver(MPI_Comm comm, const std::string& prefix) {
    MORSE_CALL(KSPCreate(comm, ksp_.ptr()));
    MORSE_CALL(KSPSetOptionsPrefix(ksp_.get(), prefix.c_str()));
    MORSE_CALL(KSPSetType(ksp_.get(), KSPPREONLY));
    PC pc;
    MORSE_CALL(KSPGetPC(ksp_.get(), &pc));
    MORSE_CALL(PCSetType(pc, PCCHOLESKY));
    MORSE_CALL(PCFactorSetMatSolverType(pc, cholesky_solver(comm)));
    MORSE_CALL(KSPSetFromOptions(ksp_.get()));
  }
  /// Low-rank term U diag(c) U^T (U dense, columns; c > 0). Set before factor().
  void set_low_rank(std::vector<UVec> U, std::vector<double> c) {
    U_ = std::move(U);
    c_ = std::move(c);
  }
  void factor(Mat A) {
    MORSE_CALL(KSPSetOperators(ksp_.get(), A, A));
    MORSE_CALL(KSPSetUp(ksp_.get()));
    const std::size_t k = U_.size();
    if (k == 0) return;
    Z_.resize(k);
    cap_.assign(k * k, 0.0);
    for (std::size_t j = 0; j < k; ++j) {
      if (!Z_[j]) MORSE_CALL(VecDuplicate(U_[j].get(), Z_[j].ptr()));
      MORSE_CALL(KSPSolve(ksp_.get(), U_[j].get(), Z_[j].get()));
    }
    // cap = diag(1/c) + U^T A^-1 U, row-major, then its LU (replicated on every rank).
    for (std::size_t i = 0; i < k; ++i) {
      std::vector<PetscScalar> dots(k);
      std::vector<Vec> zs;
      for (auto& z : Z_) zs.push_back(z.get());
      MORSE_CALL(VecMDot(U_[i].get(), static_cast<PetscInt>(k), zs.data(), dots.data()));
      for (std::size_t j = 0; j < k; ++j) cap_[i * k + j] = dots[j];
      cap_[i * k + i] += 1.0 / c_[i];
    }
    piv_.assign(k, 0);
    PetscBLASInt n = static_cast<PetscBLASInt>(k), info = 0;
    LAPACKgetrf_(&n, &n, cap_.data(), &n, piv_.data(), &info);
    MORSE_CHECK(info == 0, "fom: the modal damping capacitance matrix is singular (LAPACK getrf info ", info, ")");
  }
  void solve(Vec b, Vec x) {
    MORSE_CALL(KSPSolve(ksp_.get(), b, x));
    const std::size_t k = U_.size();
    if (k == 0) return;
    std::vector<PetscScalar> y(k);
    std::vector<Vec> us;
    for (auto& u : U_) us.push_back(u.get());
    MORSE_CALL(VecMDot(x, static_cast<PetscInt>(k), us.data(), y.data()));
    // cap is stored row-major: LAPACK sees its transpose, so solve with 'T'.
    PetscBLASInt n = static_cast<PetscBLASInt>(k), one = 1, info = 0;
    const char trans = 'T';
    LAPACKgetrs_(&trans, &n, &one, cap_.data(), &n, piv_.data(), y.data(), &n, &info);
    for (std::size_t j = 0; j < k; ++j) MORSE_CALL(VecAXPY(x, -y[j], Z_[j].get()));
  }

 private:
  UKSP ksp_;
  std::vector<UVec> U_, Z_;
  std::vector<double> c_, cap_;
  std::vector<PetscBLASInt> piv_;
};

double now() { return MPI_Wtime(); }

using VecOp = std::function<void(Vec, Vec)>;

PetscErrorCode shell_mult(Mat A, Vec x, Vec y) {
  PetscFunctionBeginUser;
  void* ctx;
  PetscCall(MatShellGetContext(A, &ctx));
  try {
    (*static_cast<VecOp*>(ctx))(x, y);
  } catch (const std::exception&) {
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_LIB, "fom: Jacobian product failed");
  }
  PetscFunctionReturn(0);
}

PetscErrorCode shell_apply(PC pc, Vec x, Vec y) {
  PetscFunctionBeginUser;
  void* ctx;
  PetscCall(PCShellGetContext(pc, &ctx));
  try {
    (*static_cast<VecOp*>(ctx))(x, y);
  } catch (const std::exception&) {
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_LIB, "fom: preconditioner failed");
  }
  PetscFunctionReturn(0);
}

}  // namespace

void add_option_prefixes(const FomSettings& s) {
  options::add_prefix(s.prefix, options::Solver::Linear);
  options::add_prefix(s.prefix + "krylov_", options::Solver::Linear);
  options::add_prefix(s.prefix + "damping_", options::Solver::Eigen);
}

FomStats integrate(const fe::Svk& svk, Mat M, const Loads& loads, const FomSettings& s, Vec u_init, Vec v_init,
                   const std::function<void(const StepInfo&)>& callback) {
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)M, &comm));
  MORSE_CHECK(s.dt > 0 && std::isfinite(s.dt), "fom: the time step -fom_dt must be positive (got ", s.dt, ")");
  MORSE_CHECK(s.t_final > 0 && std::isfinite(s.t_final), "fom: the final time -fom_tfinal must be positive (got ",
              s.t_final, ")");
  MORSE_CHECK(s.modal_xi >= 0 && s.damping_modes >= 0, "fom: modal damping ratio and mode count must be >= 0");
  MORSE_CHECK(s.rayleigh_alpha >= 0 && s.rayleigh_beta >= 0, "fom: Rayleigh coefficients must be >= 0");
  MORSE_CHECK(s.newton_max_it > 0 && s.newton_rtol > 0, "fom: Newton settings must be positive");
  MORSE_CHECK(s.krylov_rtol > 0 && s.krylov_rtol < 1 && s.krylov_max_it > 0 && s.krylov_refactor_its > 0,
              "fom: Krylov settings: rtol in (0, 1), iteration counts positive");
  Mat K = svk.stiffness();
  const double h = s.dt;
  const PetscInt n_steps = static_cast<PetscInt>(std::ceil(s.t_final / h - 1e-9));
  FomStats st;
  StageTimer stage(comm, "Fom");
  const double t_start = now();

  UVec u0, v0, u1, v1, F0, F1, R, R_prev, x, w, g0, g1, Cv, tmp;
  MORSE_CALL(MatCreateVecs(K, u0.ptr(), v0.ptr()));
  for (UVec* p : {&u1, &v1, &F0, &F1, &R, &R_prev, &x, &w, &g0, &g1, &Cv, &tmp})
    MORSE_CALL(VecDuplicate(u0.get(), p->ptr()));
  if (u_init)
    MORSE_CALL(VecCopy(u_init, u0.get()));
  else
    MORSE_CALL(VecSet(u0.get(), 0.0));
  if (v_init)
    MORSE_CALL(VecCopy(v_init, v0.get()));
  else
    MORSE_CALL(VecSet(v0.get(), 0.0));

  // Damping: Rayleigh (C = alpha M + beta K) and modal (C = sum 2 xi w_k (M phi_k)(M phi_k)^T).
  add_option_prefixes(s);
  IterationSolver solver(comm, s.prefix);
  std::vector<UVec> Uk;
  std::vector<double> ck;
  if (s.modal_xi > 0 && s.damping_modes > 0) {
    StageTimer t(comm, "DampingModes");
    eigen::EigenSettings es;
    es.nev = s.damping_modes;
    es.prefix = s.prefix + "damping_";
    es.what = "modal damping modes";
    es.stage = "Damping";
    auto eig = eigen::solve_eigen(K, M, es, nullptr);
    for (PetscInt k = 0; k < s.damping_modes; ++k) {
      UVec Mphi;
      MORSE_CALL(VecDuplicate(u0.get(), Mphi.ptr()));
      Vec phi;
      MORSE_CALL(MatDenseGetColumnVecRead(eig.V.get(), k, &phi));
      MORSE_CALL(MatMult(M, phi, Mphi.get()));
      MORSE_CALL(MatDenseRestoreColumnVecRead(eig.V.get(), k, &phi));
      const double omega = std::sqrt(std::max(0.0, eig.omega2[k]));
      st.damping_omega.push_back(omega);
      ck.push_back(2.0 * s.modal_xi * omega);
      Uk.push_back(std::move(Mphi));
    }
  }
  // out += scale sum_k c_k (U_k . v) U_k: the modal damping term, never assembled.
  std::vector<Vec> us;
  for (auto& u : Uk) us.push_back(u.get());
  auto add_modal = [&](Vec v, Vec out, double scale) {
    if (us.empty()) return;
    std::vector<PetscScalar> y(us.size());
    MORSE_CALL(VecMDot(v, static_cast<PetscInt>(us.size()), us.data(), y.data()));
    for (std::size_t k = 0; k < us.size(); ++k) y[k] *= scale * ck[k];
    MORSE_CALL(VecMAXPY(out, static_cast<PetscInt>(us.size()), y.data(), us.data()));
  };
  auto apply_C = [&](Vec v, Vec out) {  // out = C v
    MORSE_CALL(VecSet(out, 0.0));
    if (s.rayleigh_alpha > 0) {
      MORSE_CALL(MatMult(M, v, tmp.get()));
      MORSE_CALL(VecAXPY(out, s.rayleigh_alpha, tmp.get()));
    }
    if (s.rayleigh_beta > 0) {
      MORSE_CALL(MatMult(K, v, tmp.get()));
      MORSE_CALL(VecAXPY(out, s.rayleigh_beta, tmp.get()));
    }
    add_modal(v, out, 1.0);
  };
  if (!Uk.empty()) {
    std::vector<UVec> U;
    std::vector<double> c;
    for (std::size_t k = 0; k < Uk.size(); ++k) {
      UVec copy;
      MORSE_CALL(VecDuplicate(Uk[k].get(), copy.ptr()));
      MORSE_CALL(VecCopy(Uk[k].get(), copy.get()));
      U.push_back(std::move(copy));
      c.push_back(2.0 / h * ck[k]);
    }
    solver.set_low_rank(std::move(U), std::move(c));
  }

  // Iteration matrix A = K_T + (2/h)(alpha M + beta K) + (4/h^2) M.
  UMat A = svk.create_tangent();
  const double cM = 4.0 / (h * h) + 2.0 / h * s.rayleigh_alpha, cK = 2.0 / h * s.rayleigh_beta;
  auto refactor = [&](Vec ua, Vec ub) {
    double t0 = now();
    if (s.linear)
      MORSE_CALL(MatCopy(K, A.get(), SAME_NONZERO_PATTERN));
    else if (s.scheme == Scheme::Energy)
      svk.midpoint_tangent(ua, ub, A.get());
    else
      svk.tangent(ub, A.get());
    if (cK != 0.0) MORSE_CALL(MatAXPY(A.get(), cK, K, SAME_NONZERO_PATTERN));
    MORSE_CALL(MatAXPY(A.get(), cM, M, SAME_NONZERO_PATTERN));
    double t1 = now();
    {
      PetscLogEvent ev = log_event("FomFactor");
      MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
      solver.factor(A.get());
      MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
    }
    st.seconds_tangent += t1 - t0;
    st.seconds_factor += now() - t1;
    ++st.factorizations;
  };

  // Newton–Krylov: matrix-free J = 4/h^2 M + 2/h C + K_T(u1), preconditioned by the factor.
  const bool krylov = s.newton == Newton::Krylov && !s.linear && s.scheme == Scheme::Trapezoidal;
  UMat Alin;  // K + (4/h^2 + 2 alpha/h) M + (2 beta/h) K: the linear part of J
  if (krylov) {
    MORSE_CALL(MatDuplicate(K, MAT_COPY_VALUES, Alin.ptr()));
    MORSE_CALL(MatScale(Alin.get(), 1.0 + 2.0 / h * s.rayleigh_beta));
    MORSE_CALL(MatAXPY(Alin.get(), 4.0 / (h * h) + 2.0 / h * s.rayleigh_alpha, M, SAME_NONZERO_PATTERN));
  }
  VecOp apply_J = [&](Vec in, Vec out) {  // state: svk.tangent_point(u1)
    svk.tangent_apply_nonlinear(in, out);
    MORSE_CALL(MatMultAdd(Alin.get(), in, out, out));
    add_modal(in, out, 2.0 / h);
  };
  VecOp apply_P = [&](Vec in, Vec out) {
    double ts = now();
    solver.solve(in, out);
    st.seconds_solve += now() - ts;
  };
  UMat Jshell;
  UKSP kry;
  if (krylov) {
    PetscInt m, nloc, N;
    MORSE_CALL(MatGetLocalSize(K, &m, &nloc));
    MORSE_CALL(MatGetSize(K, &N, nullptr));
    MORSE_CALL(MatCreateShell(comm, m, m, N, N, &apply_J, Jshell.ptr()));
    MORSE_CALL(MatShellSetOperation(Jshell.get(), MATOP_MULT, (void (*)(void))shell_mult));
    MORSE_CALL(KSPCreate(comm, kry.ptr()));
    MORSE_CALL(KSPSetOptionsPrefix(kry.get(), (s.prefix + "krylov_").c_str()));
    MORSE_CALL(KSPSetType(kry.get(), KSPCG));
    MORSE_CALL(KSPSetNormType(kry.get(), KSP_NORM_UNPRECONDITIONED));
    MORSE_CALL(KSPSetOperators(kry.get(), Jshell.get(), Jshell.get()));
    PC pc;
    MORSE_CALL(KSPGetPC(kry.get(), &pc));
    MORSE_CALL(PCSetType(pc, PCSHELL));
    MORSE_CALL(PCShellSetContext(pc, &apply_P));
    MORSE_CALL(PCShellSetApply(pc, shell_apply));
    MORSE_CALL(KSPSetTolerances(kry.get(), s.krylov_rtol, 0.0, PETSC_DEFAULT, s.krylov_max_it));
    MORSE_CALL(KSPSetFromOptions(kry.get()));
  }
  bool refactor_pending = false;
  // Solves J x = R to the forcing term eta; refactors at u1 when CG fails with a stale factor.
  auto krylov_solve = [&](double eta, bool fresh) {
    PetscInt maxit;
    MORSE_CALL(KSPGetTolerances(kry.get(), nullptr, nullptr, nullptr, &maxit));
    MORSE_CALL(KSPSetTolerances(kry.get(), eta, 0.0, PETSC_DEFAULT, maxit));
    for (int attempt = 0;; ++attempt) {
      PetscLogEvent ev = log_event("FomKrylov");
      MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
      MORSE_CALL(KSPSolve(kry.get(), R.get(), x.get()));
      MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
      KSPConvergedReason reason;
      PetscInt its;
      MORSE_CALL(KSPGetConvergedReason(kry.get(), &reason));
      MORSE_CALL(KSPGetIterationNumber(kry.get(), &its));
      st.krylov_iterations += its;
      if (reason > 0) {
        if (its > s.krylov_refactor_its) refactor_pending = true;
        return;
      }
      if (fresh || attempt > 0)
        throw Error(cat("fom: the Newton system's Krylov solve failed (", KSPConvergedReasons[reason], " after ", its,
                        " iterations) with a fresh factor"));
      refactor(u0.get(), u1.get());
      fresh = true;
    }
  };

  // Energies of the current state.
  Energies en;
  auto kinetic = [&](Vec v) {
    MORSE_CALL(MatMult(M, v, tmp.get()));
    double e;
    MORSE_CALL(VecDot(tmp.get(), v, &e));
    return 0.5 * e;
  };
  auto state_energy = [&](Vec u, Vec v) {
    en.kinetic = kinetic(v);
    if (s.linear) {
      MORSE_CALL(MatMult(K, u, tmp.get()));
      double e;
      MORSE_CALL(VecDot(tmp.get(), u, &e));
      en.strain_linear = 0.5 * e;
      en.strain_nonlinear = 0.0;
    } else {
      auto se = svk.energy(u);
      en.strain_linear = se.linear;
      en.strain_nonlinear = se.nonlinear;
    }
  };

  // g(u0) for the trapezoidal scheme.
  if (!s.linear && s.scheme == Scheme::Trapezoidal) svk.nonlinear_force(u0.get(), g0.get());
  loads.evaluate(0.0, F0.get());
  state_energy(u0.get(), v0.get());
  {
    StepInfo info;
    info.step = 0;
    info.u = u0.get();
    info.v = v0.get();
    info.energy = en;
    callback(info);
  }

  bool have_factor = false;
  Progress progress(comm, "fom", static_cast<double>(n_steps));
  for (PetscInt n = 1; n <= n_steps; ++n) {
    // Once the first step has set every solver up (the factor is made in it), an option under the
    // fom's prefix that none of them read is a misspelling: refuse it now, not after the run.
    if (n == 2) options::check_prefix_used(comm, s.prefix, "the fom's settings and solvers");
    const double t0 = (n - 1) * h, t1 = n * h;
    loads.evaluate(t1, F1.get());
    // Predictor: u1 = u0. Extrapolating with v0 (and the last acceleration) was measured to push
    // Newton out of convergence on the blade under a point load: the trapezoidal rule leaves the
    // unresolved high-frequency velocities of the loaded region undamped (sign flips each step).
    // Extrapolating displacements (u1 = 2 u0 - u_prev) was measured to raise the first residual
    // ~100x and the Newton iterations by 15% (blade, 300 N at LE).
    MORSE_CALL(VecCopy(u0.get(), u1.get()));
    PetscInt it = 0;
    double rnorm = 0.0, rprev = 0.0;
    PetscInt since_factor = 0;
    bool last_fresh = false;
    for (;; ++it) {
      // v1 = 2 (u1 - u0)/h - v0
      MORSE_CALL(VecWAXPY(v1.get(), -1.0, u0.get(), u1.get()));
      MORSE_CALL(VecAXPBY(v1.get(), -1.0, 2.0 / h, v0.get()));
      double tf = now();
      // R = (2/h) M (v1 - v0) + C (v0 + v1) + K (u0 + u1) + nonlinear - (F0 + F1)
      MORSE_CALL(VecWAXPY(w.get(), -1.0, v0.get(), v1.get()));
      MORSE_CALL(MatMult(M, w.get(), R.get()));
      MORSE_CALL(VecScale(R.get(), 2.0 / h));
      double inertia_norm;
      MORSE_CALL(VecNorm(R.get(), NORM_2, &inertia_norm));
      MORSE_CALL(VecWAXPY(w.get(), 1.0, v0.get(), v1.get()));
      apply_C(w.get(), Cv.get());
      MORSE_CALL(VecAXPY(R.get(), 1.0, Cv.get()));
      MORSE_CALL(VecWAXPY(w.get(), 1.0, u0.get(), u1.get()));
      MORSE_CALL(MatMult(K, w.get(), tmp.get()));
      if (!s.linear) {
        if (s.scheme == Scheme::Energy) {
          svk.midpoint_nonlinear_force(u0.get(), u1.get(), g1.get());
          MORSE_CALL(VecAXPY(tmp.get(), 2.0, g1.get()));
        } else {
          svk.nonlinear_force(u1.get(), g1.get());
          MORSE_CALL(VecAXPY(tmp.get(), 1.0, g1.get()));
          MORSE_CALL(VecAXPY(tmp.get(), 1.0, g0.get()));
        }
      }
      double internal_norm, load_norm;
      MORSE_CALL(VecNorm(tmp.get(), NORM_2, &internal_norm));
      MORSE_CALL(VecAXPY(R.get(), 1.0, tmp.get()));
      MORSE_CALL(VecWAXPY(w.get(), 1.0, F0.get(), F1.get()));
      MORSE_CALL(VecNorm(w.get(), NORM_2, &load_norm));
      MORSE_CALL(VecAXPY(R.get(), -1.0, w.get()));
      MORSE_CALL(VecNorm(R.get(), NORM_2, &rnorm));
      st.seconds_force += now() - tf;
      if (!std::isfinite(rnorm))
        throw Error(cat("fom: NaN or infinite residual at t = ", t1, " (step ", n, "); last converged time ", t0,
                        ". Reduce -fom_dt or check the loads"));
      const double scale = std::max({inertia_norm, internal_norm, load_norm});
      if (rnorm <= s.newton_rtol * scale + s.newton_atol) break;
      if (it >= s.newton_max_it)
        throw Error(cat("fom: Newton did not converge at t = ", t1, " (step ", n, ") in ", s.newton_max_it,
                        " iterations (||R|| = ", rnorm, ", tolerance ", s.newton_rtol * scale + s.newton_atol,
                        "); last converged time ", t0, ". Reduce -fom_dt or raise -fom_newton_max_it"));
      if (krylov) {
        // Full Newton steps: on the blade under a point load the first step (tangent at u0)
        // overshoots by orders of magnitude in ||R||, and the tangent at the overshot state is
        // what brings Newton back in 3-4 iterations; backtracking on ||R|| was measured to stall.
        bool fresh = false;
        if (!have_factor || refactor_pending) {
          refactor(u0.get(), u1.get());
          have_factor = true;
          refactor_pending = false;
          fresh = true;
        }
        const double tol = s.newton_rtol * scale + s.newton_atol;
        const double eta = std::min(0.1, std::max(s.krylov_rtol, 0.5 * tol / rnorm));
        rprev = rnorm;
        svk.tangent_point(u1.get());
        krylov_solve(eta, fresh);
        MORSE_CALL(VecAXPY(u1.get(), -1.0, x.get()));
        continue;
      }
      // A step taken with a stale factor that raised the residual is rejected: back to the previous
      // iterate and refactor there (modified Newton may otherwise walk into the compressive range
      // where St Venant-Kirchhoff loses stability, e.g. next to a point load).
      bool rejected = false;
      if (it > 0 && !last_fresh && rnorm > rprev && !s.linear) {
        MORSE_CALL(VecAXPY(u1.get(), 1.0, x.get()));
        MORSE_CALL(VecCopy(R_prev.get(), R.get()));
        rnorm = rprev;
        rejected = true;
        ++st.rejected_steps;
      }
      const bool slow = it > 0 && rnorm > s.refactor_ratio * rprev;
      const bool refactor_now =
          !have_factor || rejected || (s.refactor_every > 0 ? since_factor >= s.refactor_every - 1 || it == 0 : slow);
      if (refactor_now && !(s.linear && have_factor)) {
        refactor(u0.get(), u1.get());
        have_factor = true;
        since_factor = 0;
        last_fresh = true;
      } else {
        ++since_factor;
        last_fresh = false;
      }
      MORSE_CALL(VecCopy(R.get(), R_prev.get()));
      rprev = rnorm;
      double ts = now();
      solver.solve(R.get(), x.get());
      st.seconds_solve += now() - ts;
      MORSE_CALL(VecAXPY(u1.get(), -1.0, x.get()));
    }
    st.newton_iterations += it;
    // Energy bookkeeping: external work (F0+F1)/2 . (u1 - u0), damping loss h v_m^T C v_m.
    MORSE_CALL(VecWAXPY(w.get(), -1.0, u0.get(), u1.get()));
    double work;
    MORSE_CALL(VecWAXPY(tmp.get(), 1.0, F0.get(), F1.get()));
    MORSE_CALL(VecDot(tmp.get(), w.get(), &work));
    en.external_work += 0.5 * work;
    if (s.modal_xi > 0 || s.rayleigh_alpha > 0 || s.rayleigh_beta > 0) {
      MORSE_CALL(VecWAXPY(w.get(), 1.0, v0.get(), v1.get()));
      apply_C(w.get(), Cv.get());
      double loss;
      MORSE_CALL(VecDot(Cv.get(), w.get(), &loss));
      en.damping_loss += 0.25 * h * loss;
    }
    // Advance.
    MORSE_CALL(VecCopy(u1.get(), u0.get()));
    MORSE_CALL(VecCopy(v1.get(), v0.get()));
    MORSE_CALL(VecCopy(F1.get(), F0.get()));
    if (!s.linear && s.scheme == Scheme::Trapezoidal) MORSE_CALL(VecCopy(g1.get(), g0.get()));
    state_energy(u0.get(), v0.get());
    ++st.steps;
    StepInfo info;
    info.step = n;
    info.t = t1;
    info.u = u0.get();
    info.v = v0.get();
    info.energy = en;
    info.newton_iterations = it;
    info.residual = rnorm;
    callback(info);
    progress.update(static_cast<double>(n));
  }
  st.seconds_total = now() - t_start;
  return st;
}

}  // namespace morse::dyn
