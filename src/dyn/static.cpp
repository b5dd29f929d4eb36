// Nonlinear statics by load stepping with SNES Newton (see morse/dyn/dyn.hpp).
#include <petscsnes.h>

#include <algorithm>
#include <cmath>

#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/dyn/dyn.hpp"

namespace morse::dyn {

namespace {

struct Ctx {
  const fe::Svk* svk = nullptr;
  Vec F = nullptr;
  double lambda = 0.0;
  bool linear = false;
  double rtol = 1e-9;
  double scale = 0.0;  // max(||lambda f||, ||K u||) at the last residual evaluation
  UVec Ku;
  std::string error;
};

// PETSc callbacks: the PETSc error zone. A morse::Error is kept and reported after the solve.
PetscErrorCode residual(SNES, Vec u, Vec r, void* p) {
  auto* c = static_cast<Ctx*>(p);
  try {
    MORSE_CALL(MatMult(c->svk->stiffness(), u, c->Ku.get()));
    if (c->linear)
      MORSE_CALL(VecSet(r, 0.0));
    else
      c->svk->nonlinear_force(u, r);
    MORSE_CALL(VecAXPY(r, 1.0, c->Ku.get()));
    MORSE_CALL(VecAXPY(r, -c->lambda, c->F));
    double ku, f;
    MORSE_CALL(VecNorm(c->Ku.get(), NORM_2, &ku));
    MORSE_CALL(VecNorm(c->F, NORM_2, &f));
    c->scale = std::max(ku, std::abs(c->lambda) * f);
  } catch (const Error& e) {
    c->error = e.what();
    return PETSC_ERR_LIB;
  }
  return PETSC_SUCCESS;
}

PetscErrorCode jacobian(SNES, Vec u, Mat, Mat P, void* p) {
  auto* c = static_cast<Ctx*>(p);
  try {
    if (c->linear)
      MORSE_CALL(MatCopy(c->svk->stiffness(), P, SAME_NONZERO_PATTERN));
    else
      c->svk->tangent(u, P);
  } catch (const Error& e) {
    c->error = e.what();
    return PETSC_ERR_LIB;
  }
  return PETSC_SUCCESS;
}

// Converged when ||R|| <= rtol max(||lambda f||, ||K u||): the residual is measured against the
// internal forces, whose round-off floor can lie far above the load when membrane forces are
// large; plus PETSc's own tests (maximum iterations, NaN, divergence).
PetscErrorCode converged(SNES snes, PetscInt it, PetscReal xnorm, PetscReal gnorm, PetscReal fnorm,
                         SNESConvergedReason* reason, void* p) {
  auto* c = static_cast<Ctx*>(p);
  PetscCall(SNESConvergedDefault(snes, it, xnorm, gnorm, fnorm, reason, nullptr));
  if (*reason == SNES_CONVERGED_ITERATING && fnorm <= c->rtol * c->scale) *reason = SNES_CONVERGED_FNORM_ABS;
  return PETSC_SUCCESS;
}

using USNES = Unique<SNES, SNESDestroy>;

}  // namespace

PetscErrorCode StaticSettings::set_from_options(MPI_Comm comm) {
  PetscBool lin = linear ? PETSC_TRUE : PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse static options", "");
  PetscCall(MorseOptionsBool("-static_linear", "Linear solution K u = f (for comparison)", "", lin, &lin, nullptr));
  PetscCall(MorseOptionsReal("-static_time", "Time at which the loads are evaluated [s]", "", time, &time, nullptr));
  PetscCall(MorseOptionsReal("-static_load_factor", "Final load factor on the loads", "", load_factor, &load_factor,
                             nullptr));
  PetscCall(MorseOptionsInt("-static_steps", "Initial number of equal load increments", "", steps, &steps, nullptr));
  PetscCall(MorseOptionsInt("-static_max_cutbacks", "Halvings of a failed increment before giving up", "", max_cutbacks,
                            &max_cutbacks, nullptr));
  PetscCall(MorseOptionsReal("-static_rtol", "Newton tolerance: ||R|| <= rtol max(||lambda f||, ||K u||)", "", rtol,
                             &rtol, nullptr));
  PetscCall(MorseOptionsInt("-static_max_it", "Newton iterations per increment", "", max_it, &max_it, nullptr));
  PetscOptionsEnd();
  linear = lin;
  if (steps <= 0)
    error = cat("-static_steps must be positive (got ", steps, ")");
  else if (max_cutbacks < 0)
    error = cat("-static_max_cutbacks must be >= 0 (got ", max_cutbacks, ")");
  else if (!(rtol > 0 && max_it > 0))
    error = "-static_rtol and -static_max_it must be positive";
  return PETSC_SUCCESS;
}

StaticResult solve_static(const fe::Svk& svk, const Loads& loads, const StaticSettings& s) {
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)svk.stiffness(), &comm));
  MORSE_CHECK(s.steps > 0, "static: the number of load steps must be positive (got ", s.steps, ")");
  MORSE_CHECK(std::isfinite(s.load_factor), "static: the load factor must be finite");
  StageTimer timer(comm, "Static");
  StaticResult res;
  UVec F;
  MORSE_CALL(MatCreateVecs(svk.stiffness(), res.u.ptr(), F.ptr()));
  MORSE_CALL(VecSet(res.u.get(), 0.0));
  loads.evaluate(s.time, F.get());
  MORSE_CALL(VecNorm(F.get(), NORM_2, &res.load_norm));
  if (res.load_norm == 0.0 || s.load_factor == 0.0) {
    print0(comm,
           "morse static: the load at t = %g is zero: u = 0 (harmonic loads with phase 0 vanish at "
           "t = 0; see -static_time and -load_<SET>_phase)\n",
           s.time);
    return res;
  }

  Ctx ctx;
  ctx.svk = &svk;
  ctx.F = F.get();
  ctx.linear = s.linear;
  USNES snes;
  UMat J = svk.create_tangent();
  UVec r, u_prev;
  MORSE_CALL(VecDuplicate(F.get(), r.ptr()));
  MORSE_CALL(VecDuplicate(F.get(), u_prev.ptr()));
  MORSE_CALL(SNESCreate(comm, snes.ptr()));
  MORSE_CALL(SNESSetOptionsPrefix(snes.get(), s.prefix.c_str()));
  options::add_prefix(s.prefix, options::Solver::Nonlinear);
  MORSE_CALL(SNESSetFunction(snes.get(), r.get(), residual, &ctx));
  MORSE_CALL(SNESSetJacobian(snes.get(), J.get(), J.get(), jacobian, &ctx));
  MORSE_CALL(SNESSetType(snes.get(), s.linear ? SNESKSPONLY : SNESNEWTONLS));
  // The convergence test is converged() (s.rtol); PETSc's relative and step tests are off (a
  // step-length test can stop a stalled solve as "converged").
  ctx.rtol = s.rtol;
  MORSE_CALL(VecDuplicate(F.get(), ctx.Ku.ptr()));
  MORSE_CALL(SNESSetTolerances(snes.get(), 0.0, 0.0, 0.0, s.max_it, -1));
  MORSE_CALL(SNESSetConvergenceTest(snes.get(), converged, &ctx, nullptr));
  KSP ksp;
  PC pc;
  MORSE_CALL(SNESGetKSP(snes.get(), &ksp));
  MORSE_CALL(KSPSetType(ksp, KSPPREONLY));
  MORSE_CALL(KSPGetPC(ksp, &pc));
  MORSE_CALL(PCSetType(pc, PCCHOLESKY));
  MORSE_CALL(PCFactorSetMatSolverType(pc, cholesky_solver(comm)));
  // Full Newton steps by default: on bending-dominated structures the first step of an increment
  // raises ||R|| (spurious membrane strain of a rotated linear guess) and a residual-decrease
  // line search (bt) then stalls at tiny steps; measured on the elastica test: basic 5-7
  // iterations per increment, cp 5-23, bt > 25 with repeated cut-backs. A failed increment is cut
  // back instead. -static_snes_linesearch_type bt|cp|l2 selects a line search.
  SNESLineSearch ls;
  MORSE_CALL(SNESGetLineSearch(snes.get(), &ls));
  MORSE_CALL(SNESLineSearchSetType(ls, SNESLINESEARCHBASIC));
  MORSE_CALL(SNESSetFromOptions(snes.get()));

  double done = 0.0;
  const double target = s.load_factor;
  const double d0 = target / static_cast<double>(s.steps);
  double d = d0;
  PetscInt cuts = 0;
  Progress progress(comm, "static", 1.0);
  while (std::abs(done - target) > 1e-12 * std::abs(target)) {
    double next = done + d;
    if ((d > 0 && next > target) || (d < 0 && next < target) || std::abs(target - next) < 1e-9 * std::abs(d0))
      next = target;
    MORSE_CALL(VecCopy(res.u.get(), u_prev.get()));
    ctx.lambda = next;
    PetscErrorCode ierr = SNESSolve(snes.get(), nullptr, res.u.get());
    collective_check(comm, ctx.error);
    MORSE_CALL(ierr);
    SNESConvergedReason reason;
    MORSE_CALL(SNESGetConvergedReason(snes.get(), &reason));
    StaticIncrement inc;
    inc.lambda = next;
    MORSE_CALL(SNESGetIterationNumber(snes.get(), &inc.newton_iterations));
    MORSE_CALL(SNESGetFunctionNorm(snes.get(), &inc.residual));
    inc.converged = reason > 0 && std::isfinite(inc.residual);
    inc.reason = SNESConvergedReasons[reason];
    res.history.push_back(inc);
    // After the first increment the SNES, its KSP, PC and factor have read their options: one
    // under the static prefix that none of them read is a misspelling, refused before the rest.
    if (res.history.size() == 1) options::check_prefix_used(comm, s.prefix, "the static solver");
    if (inc.converged) {
      if (s.linear)
        print0(comm, "  static: load factor %-12.6g linear solve\n", next);
      else
        print0(comm, "  static: load factor %-12.6g converged in %2d Newton iteration(s), ||R|| = %.3e (%s)\n", next,
               (int)inc.newton_iterations, inc.residual, inc.reason.c_str());
      done = next;
      cuts = 0;
      d = std::abs(d) < std::abs(d0) ? std::min(std::abs(d0), 1.5 * std::abs(d)) * (d0 > 0 ? 1 : -1) : d;
      progress.update(done / target);
      continue;
    }
    MORSE_CALL(VecCopy(u_prev.get(), res.u.get()));
    ++cuts;
    if (cuts > s.max_cutbacks)
      throw Error(cat("static: the increment to load factor ", next, " did not converge (", inc.reason, ") after ",
                      s.max_cutbacks, " cut-backs; last converged load factor ", done,
                      " (raise -static_steps or -static_max_cutbacks, or check that the model is restrained)"));
    d *= 0.5;
    print0(comm, "  static: load factor %.6g did not converge (%s, ||R|| = %.3e); cutting the increment back to %.6g\n",
           next, inc.reason.c_str(), inc.residual, d);
  }
  return res;
}

}  // namespace morse::dyn
