#include "morse/eigen/eigen.hpp"

#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

#include "eigen/detail/singular.hpp"
#include "eigen/detail/testing.hpp"
#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/core/units.hpp"

namespace morse::eigen {

PetscInt& detail::drop_for_test() {
  static PetscInt n = 0;
  return n;
}

void set_default_option(const std::string& name, const std::string& value) {
  PetscBool has = PETSC_FALSE;
  MORSE_CALL(PetscOptionsHasName(nullptr, nullptr, name.c_str(), &has));
  if (!has) MORSE_CALL(PetscOptionsSetValue(nullptr, name.c_str(), value.c_str()));
}

PetscInt mumps_null_pivots(Mat F) {
  PetscInt n = 0;
  MORSE_CALL(MatMumpsGetInfog(F, 28, &n));
  return n;
}

namespace detail {

void check_null_pivots(MPI_Comm comm, Mat F, double shift, const std::string& what) {
  // INFOG(28) is global: every rank takes the same branch.
  const bool singular = any_rank(comm, mumps_null_pivots(F) > 0);
  if (!singular) {
    // At a shift <= 0, K - sigma M of a positive semi-definite K has no negative pivot (Sylvester):
    // one means K itself is indefinite, which no eigen solver can recover from.
    PetscInt negative = 0;
    if (shift <= 0.0) MORSE_CALL(MatMumpsGetInfog(F, 12, &negative));
    collective_check(
        comm, negative > 0 ? cat(what, ": K - sigma M has ", negative, " negative pivot(s) at sigma = ", shift,
                                 " <= 0, so K is not positive semi-definite (Sylvester's law of inertia): check the "
                                 "material constants, inverted elements, or the sign of an assembled K")
                           : std::string());
    return;
  }
  if (shift == 0.0) throw SingularAtZero(what);
  collective_check(comm, cat(what, ": K - sigma M is singular at the shift sigma = ", shift,
                             " (an eigenvalue lies at the shift); move the shift"));
}

double stiffness_scale(Mat K, Mat M) {
  UVec dk, dm;
  MORSE_CALL(MatCreateVecs(K, dk.ptr(), nullptr));
  MORSE_CALL(VecDuplicate(dk.get(), dm.ptr()));
  MORSE_CALL(MatGetDiagonal(K, dk.get()));
  MORSE_CALL(MatGetDiagonal(M, dm.get()));
  PetscInt m = 0;
  MORSE_CALL(VecGetLocalSize(dk.get(), &m));
  const PetscScalar *k = nullptr, *d = nullptr;
  MORSE_CALL(VecGetArrayRead(dk.get(), &k));
  MORSE_CALL(VecGetArrayRead(dm.get(), &d));
  double r = 0;
  for (PetscInt i = 0; i < m; ++i)
    if (PetscRealPart(d[i]) > 0) r = std::max(r, PetscRealPart(k[i]) / PetscRealPart(d[i]));
  MORSE_CALL(VecRestoreArrayRead(dm.get(), &d));
  MORSE_CALL(VecRestoreArrayRead(dk.get(), &k));
  MPI_Allreduce(MPI_IN_PLACE, &r, 1, MPI_DOUBLE, MPI_MAX, PetscObjectComm(reinterpret_cast<PetscObject>(K)));
  return r;
}

}  // namespace detail

Mat Eigenpairs::factor() const {
  if (block_factor) return block_factor.get();
  if (!eps || slicing) return nullptr;
  ST st;
  KSP ksp;
  PC pc;
  MORSE_CALL(EPSGetST(eps.get(), &st));
  MORSE_CALL(STGetKSP(st, &ksp));
  MORSE_CALL(KSPGetPC(ksp, &pc));
  PetscBool is_chol = PETSC_FALSE;
  MORSE_CALL(PetscObjectTypeCompare((PetscObject)pc, PCCHOLESKY, &is_chol));
  if (!is_chol) return nullptr;
  Mat F = nullptr;
  MORSE_CALL(PCFactorGetMatrix(pc, &F));
  return F;
}

namespace {

// Progress of the eigen solve on rank 0: converged pairs out of those wanted.
struct MonitorContext {
  Progress* progress;
  PetscInt wanted;
};

PetscErrorCode progress_monitor(EPS, PetscInt, PetscInt nconv, PetscScalar*, PetscScalar*, PetscReal*, PetscInt,
                                void* ctx) {
  auto* c = static_cast<MonitorContext*>(ctx);
  if (c->wanted > 0) c->progress->update(static_cast<double>(std::min(nconv, c->wanted)));
  return PETSC_SUCCESS;
}

}  // namespace

InertiaCounter::InertiaCounter(Mat K, Mat M, const std::string& prefix, Mat reuse) : K_(K), M_(M) {
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)K, &comm));
  MORSE_CALL(MatDuplicate(K, MAT_COPY_VALUES, A_.ptr()));
  prefix_ = prefix + "inertia_";
  MORSE_CALL(MatSetOptionsPrefix(A_.get(), prefix_.c_str()));
  // K and M assembled by morse share their pattern (same elements, full element blocks); the
  // fast axpy is used only when every rank sees the same number of stored entries.
  MatInfo ik, im;
  MORSE_CALL(MatGetInfo(K, MAT_LOCAL, &ik));
  MORSE_CALL(MatGetInfo(M, MAT_LOCAL, &im));
  same_pattern_ = !any_rank(comm, ik.nz_used != im.nz_used);
  // K - sigma M has K's pattern only if M's is the same.
  if (same_pattern_) reuse_ = reuse;
}

PetscInt InertiaCounter::count(double sigma) {
  if (calls_ > 0) MORSE_CALL(MatCopy(K_, A_.get(), SAME_NONZERO_PATTERN));
  MORSE_CALL(MatAXPY(A_.get(), -sigma, M_, same_pattern_ ? SAME_NONZERO_PATTERN : UNKNOWN_NONZERO_PATTERN));
  MatFactorInfo info;
  MORSE_CALL(MatFactorInfoInitialize(&info));
  if (reuse_) {
    // The caller's factor, analysed on K's pattern with ICNTL(13) = 1: refactored in place,
    // with room for the delayed pivots of an indefinite matrix.
    MORSE_CALL(MatMumpsSetIcntl(reuse_, 14, 50));
    MORSE_CALL(MatCholeskyFactorNumeric(reuse_, A_.get(), &info));
    ++calls_;
    PetscInt nneg = 0;
    MORSE_CALL(MatGetInertia(reuse_, &nneg, nullptr, nullptr));
    return nneg;
  }
  if (!F_) {
    // K - sigma M is indefinite: MUMPS's symmetric indefinite LDL^T (not flagged SPD), with the
    // inertia available in parallel (ICNTL(13) = 1) and room for delayed pivots (ICNTL(14)).
    MORSE_CALL(MatGetFactor(A_.get(), cholesky_solver(A_.get()), MAT_FACTOR_CHOLESKY, F_.ptr()));
    MORSE_CALL(MatMumpsSetIcntl(F_.get(), 14, 50));
    // -<prefix>inertia_mat_mumps_* reach this factorization, but ICNTL(13) = 1 (the inertia in
    // parallel needs it) is set after them.
    MORSE_CALL(MatSetOptionsPrefix(F_.get(), prefix_.c_str()));
    MORSE_CALL(MatSetFromOptions(F_.get()));
    MORSE_CALL(MatMumpsSetIcntl(F_.get(), 13, 1));
    MORSE_CALL(MatCholeskyFactorSymbolic(F_.get(), A_.get(), nullptr, &info));
  }
  MORSE_CALL(MatCholeskyFactorNumeric(F_.get(), A_.get(), &info));
  ++calls_;
  PetscInt nneg = 0;
  MORSE_CALL(MatGetInertia(F_.get(), &nneg, nullptr, nullptr));
  return nneg;
}

// Steps of count_cutoff: from the ratio of the diagonals (a high, safe start), then steps along
// the estimated local power law N ~ sigma^p (secant in log-log, p starting at 3/2 as for a 3D
// solid) kept inside the bracket, with the geometric mean as fallback.
double count_cutoff(Mat K, Mat M, PetscInt nev, const std::string& prefix, const std::string& what,
                    PetscInt* factorizations, PetscInt* count) {
  InertiaCounter c(K, M, prefix);
  UVec dk, dm;
  MORSE_CALL(MatCreateVecs(K, nullptr, dk.ptr()));
  MORSE_CALL(MatCreateVecs(K, nullptr, dm.ptr()));
  MORSE_CALL(MatGetDiagonal(K, dk.get()));
  MORSE_CALL(MatGetDiagonal(M, dm.get()));
  PetscScalar tk = 0, tm = 0;
  MORSE_CALL(VecSum(dk.get(), &tk));
  MORSE_CALL(VecSum(dm.get(), &tm));
  MORSE_CHECK(PetscRealPart(tk) > 0 && PetscRealPart(tm) > 0, what, ": K or M has a non-positive trace");
  double hi = PetscRealPart(tk) / PetscRealPart(tm), lo = 0;
  PetscInt n_hi = c.count(hi);
  for (int k = 0; n_hi < nev; ++k) {
    MORSE_CHECK(k < 40, what, ": no cutoff with ", nev, " eigenvalues below it was found");
    hi *= 4;
    n_hi = c.count(hi);
  }
  double s_prev = hi, p = 1.5;
  PetscInt n_prev = n_hi;
  for (int it = 0; it < 12 && n_hi > 1.2 * nev; ++it) {
    double sig = s_prev * std::pow(1.08 * nev / std::max<PetscInt>(n_prev, 1), 1.0 / p);
    if (!(sig > lo && sig < hi)) sig = lo > 0 ? std::sqrt(lo * hi) : 0.25 * hi;
    const PetscInt n_sig = c.count(sig);
    if (n_sig > 0 && n_prev > 0 && n_sig != n_prev)
      p = std::clamp(std::log(static_cast<double>(n_prev) / n_sig) / std::log(s_prev / sig), 0.5, 3.0);
    if (n_sig >= nev)
      hi = sig, n_hi = n_sig;
    else
      lo = sig;
    s_prev = sig;
    n_prev = n_sig;
  }
  *factorizations = c.factorizations();
  *count = n_hi;
  return hi;
}

namespace {

// The number of eigenvalues below the cutoff b of a slicing solve on [a, b], from the inertias
// SLEPc computed at the ends of the interval, or from a new LDL^T factorization if it did not
// report them.
PetscInt inertia_below(EPS eps, Mat K, Mat M, double a, double b, const std::string& prefix) {
  PetscInt n = 0;
  PetscReal* shifts = nullptr;
  PetscInt* inertias = nullptr;
  PetscInt at_a = -1, at_b = -1;
  if (EPSKrylovSchurGetInertias(eps, &n, &shifts, &inertias) == 0 && n > 0) {
    for (PetscInt i = 0; i < n; ++i) {
      if (shifts[i] == a) at_a = inertias[i];
      if (shifts[i] == b) at_b = inertias[i];
    }
    PetscFree(shifts);
    PetscFree(inertias);
  }
  if (at_a >= 0 && at_b >= 0) return at_b - at_a;
  InertiaCounter c(K, M, prefix);
  return c.count(b) - (a < 0 ? 0 : c.count(a));
}

}  // namespace

Eigenpairs solve_eigen(Mat K, Mat M, const EigenSettings& s, Vec sign_ref) {
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)K, &comm));
  options::add_prefix(s.prefix, options::Solver::Eigen);
  char solver[32] = "";
  std::snprintf(solver, sizeof solver, "%s", s.solver.c_str());
  auto get_options = [&]() -> PetscErrorCode {
    PetscOptionsBegin(comm, s.prefix.c_str(), "morse eigen solver", "");
    PetscCall(MorseOptionsString("-eigen_solver",
                                 "Eigen solver: block (block shift-invert Krylov-Schur, multi-RHS "
                                 "solves, BLAS-3) or krylovschur (SLEPc, one vector at a time, spectrum slicing)",
                                 "", solver, solver, sizeof solver, nullptr));
    PetscOptionsEnd();
    return PETSC_SUCCESS;
  };
  MORSE_CALL(get_options());
  const std::string which = solver;
  MORSE_CHECK(which == "block" || which == "krylovschur", "-", s.prefix, "eigen_solver ", which,
              ": expected block or krylovschur");
  auto solve = [&](const EigenSettings& st) {
    return which == "block" ? solve_eigen_block(K, M, st, sign_ref) : solve_eigen_krylovschur(K, M, st, sign_ref);
  };
  try {
    auto out = solve(s);
    out.shift = s.shift;
    return out;
  } catch (const detail::SingularAtZero& e) {
    if (!s.allow_singular) throw Error(e.what());
    // K is singular: the model moves freely (a free-free part, or one held only at an interface
    // that the caller left free). As Lanczos codes do, solve again about a negative shift, where
    // K - sigma M is positive definite: the nev lowest are still the nev nearest the shift, the
    // rigid-body modes come first at zero frequency, and the Sylvester checks hold about it.
    EigenSettings shifted = s;
    PetscInt below = 0;
    double lo = 0, hi = 0;
    const auto t0 = std::chrono::steady_clock::now();
    {
      StageTimer timer(comm, s.stage + "AutoShift");
      shifted.shift = detail::auto_shift(K, M, s.prefix, &below, &lo, &hi);
    }
    print0(comm,
           "  %s: K is singular (rigid-body or mechanism modes): %d eigenvalue(s) below %.4g Hz, the next in [%.4g, "
           "%.4g] Hz (Sylvester inertia counts, %.1f s): shift-invert about sigma = %.6g (rad/s)^2 (= -(%.6g Hz)^2) "
           "instead of 0\n",
           s.what.c_str(), (int)below, hz(lo > 0 ? lo : hi), hz(lo), hz(hi),
           std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), shifted.shift,
           hz(-shifted.shift));
    auto out = solve(shifted);
    out.shift = shifted.shift;
    return out;
  }
}

double detail::auto_shift(Mat K, Mat M, const std::string& prefix, PetscInt* below, double* lowest_lo,
                          double* lowest_hi) {
  // A shift-invert solve about sigma amplifies the zero modes by 1/|sigma| against 1/lambda_1 for
  // the lowest nonzero eigenvalue lambda_1. The factorization of K - sigma M, of condition
  // lambda_max / |sigma|, leaves a backward error eps lambda_max |y| in every solve, and y is
  // dominated by the zero modes: measured, the flexible modes' residuals grow as
  // 5e-17 lambda_1 / |sigma| (1.5e-8 for lambda_1 / |sigma| = 3e8 on a coarse free box), while a
  // shift far below lambda_1 slows convergence (|sigma| = 3000 lambda_1: 5 times the restarts on
  // the free blade). So sigma is put 10 to 1000 times below lambda_1, which Sylvester's inertia
  // brackets by counts at 1e-10, 1e-8, ... of the stiffness scale (one factorization each; a fine mesh,
  // whose scale is far above lambda_1, needs two). When eigenvalues lie below the first count,
  // sigma = -1e-11 scale is at most 10 times below them, which is what is wanted.
  const double scale = stiffness_scale(K, M);
  InertiaCounter c(K, M, prefix);
  double tau = 1e-10 * scale, sigma = -0.1 * tau;
  *below = c.count(tau);
  *lowest_lo = 0;
  *lowest_hi = tau;
  for (int j = 0; j < 12; ++j) {
    const PetscInt next = c.count(100 * tau);
    if (next > *below) {
      *lowest_lo = tau;
      *lowest_hi = 100 * tau;
      break;
    }
    tau *= 100;
    sigma = -0.1 * tau;
  }
  return sigma;
}

Eigenpairs solve_eigen_krylovschur(Mat K, Mat M, const EigenSettings& s, Vec sign_ref) {
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)K, &comm));
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(K, &n, nullptr));
  bool slicing = s.omega2_max > 0;
  double omega2_max = s.omega2_max;
  MORSE_CHECK(slicing || s.nev > 0, s.what, ": the number of modes must be positive (got ", s.nev, ")");
  MORSE_CHECK(slicing || s.nev <= n, s.what, ": ", s.nev, " modes requested but the problem has only ", n, " DOFs");
  PetscInt count_slicing = s.count_slicing;
  auto get_options = [&]() -> PetscErrorCode {
    PetscOptionsBegin(comm, s.prefix.c_str(), "morse eigen solver", "");
    PetscCall(MorseOptionsInt("-count_slicing",
                              "Find N lowest modes by inertia search + spectrum slicing when N >= this (0: never)", "",
                              count_slicing, &count_slicing, nullptr));
    PetscOptionsEnd();
    return PETSC_SUCCESS;
  };
  MORSE_CALL(get_options());
  MORSE_CHECK(count_slicing >= 0, "-", s.prefix, "count_slicing must be >= 0 (got ", count_slicing, ")");
  const bool count_by_slicing =
      !slicing && count_slicing > 0 && s.nev >= count_slicing && s.shift == 0.0 && 4 * s.nev <= n;
  const std::string p = "-" + s.prefix;
  {
    // Krylov-Schur's slicing partitions: SLEPc takes a count that does not divide the ranks, or
    // exceeds them, and crashes in its subcommunicator split; check it as the block solver does.
    PetscInt parts = 1;
    PetscBool given = PETSC_FALSE;
    MORSE_CALL(PetscOptionsGetInt(nullptr, nullptr, (p + "eps_krylovschur_partitions").c_str(), &parts, &given));
    int size = 1;
    MPI_Comm_size(comm, &size);
    MORSE_CHECK(!given || (parts >= 1 && parts <= size && size % parts == 0), p, "eps_krylovschur_partitions ", parts,
                " must divide the number of ranks (", size, ")");
    MORSE_CHECK(!given || parts == 1 || slicing || count_by_slicing, p,
                "eps_krylovschur_partitions applies to spectrum slicing only (a cutoff, or -", s.prefix,
                "count_slicing with as many modes)");
  }
  set_default_option(p + "st_ksp_type", "preonly");
  set_default_option(p + "st_pc_type", "cholesky");
  set_default_option(p + "st_pc_factor_mat_solver_type", "mumps");
  set_default_option(p + "st_mat_mumps_icntl_24", "1");  // detect null pivots (singular K)
  if (slicing || count_by_slicing) set_default_option(p + "st_mat_mumps_icntl_13", "1");  // inertia in parallel

  Eigenpairs out;
  if (count_by_slicing) {
    StageTimer timer(comm, s.stage + "SliceCutoff");
    auto t0 = std::chrono::steady_clock::now();
    omega2_max = count_cutoff(K, M, s.nev, s.prefix, s.what, &out.inertia_counts, &out.inertia_count);
    slicing = true;
    out.slice_omega2 = omega2_max;
    print0(comm, "  %s: the %d lowest by spectrum slicing below %.6g Hz (cutoff from %d inertia counts, %.1f s)\n",
           s.what.c_str(), (int)s.nev, hz(omega2_max), (int)out.inertia_counts,
           std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  out.slicing = slicing;
  MORSE_CALL(EPSCreate(comm, out.eps.ptr()));
  EPS eps = out.eps.get();
  MORSE_CALL(EPSSetOptionsPrefix(eps, s.prefix.c_str()));
  options::add_prefix(s.prefix, options::Solver::Eigen);
  MORSE_CALL(EPSSetOperators(eps, K, M));
  MORSE_CALL(EPSSetProblemType(eps, EPS_GHEP));
  MORSE_CALL(EPSSetType(eps, EPSKRYLOVSCHUR));
  ST st;
  MORSE_CALL(EPSGetST(eps, &st));
  MORSE_CALL(STSetType(st, STSINVERT));
  MORSE_CALL(EPSSetTolerances(eps, s.tol, 500));
  // Purification (one extra solve per eigenvector) only helps a singular M; the consistent mass
  // is positive definite. -<prefix>eps_purify turns it back on.
  MORSE_CALL(EPSSetPurify(eps, PETSC_FALSE));
  if (slicing) {
    MORSE_CALL(EPSSetWhichEigenpairs(eps, EPS_ALL));
    MORSE_CALL(EPSSetInterval(eps, -1e-6 * omega2_max, omega2_max));
  } else {
    MORSE_CALL(EPSSetWhichEigenpairs(eps, EPS_TARGET_MAGNITUDE));
    MORSE_CALL(EPSSetTarget(eps, s.shift));
    // A Krylov method finds a second copy of a repeated eigenvalue only after the first has
    // converged; asking for a few more pairs than needed keeps such copies from being missed.
    MORSE_CALL(
        EPSSetDimensions(eps, std::min(n, s.nev + std::max<PetscInt>(4, s.nev / 10)), PETSC_DEFAULT, PETSC_DEFAULT));
  }
  MORSE_CALL(EPSSetFromOptions(eps));
  {
    auto t0 = std::chrono::steady_clock::now();
    StageTimer timer(comm, s.stage + "Factor");
    MORSE_CALL(EPSSetUp(eps));
    out.factor_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  // A misspelled solver option, said before the solve (SLEPc reads its view and error options,
  // and a sliced solve its children's, only later: those are checked at the end of the run).
  options::notice_prefix_unused(comm, s.prefix + "eps_", "the eigen solver of the " + s.what,
                                {"view", "converged_reason", "error_", "krylovschur_"});
  options::notice_prefix_unused(comm, s.prefix + "st_", "the eigen solver of the " + s.what, {"view"});
  if (Mat F = out.factor()) detail::check_null_pivots(comm, F, s.shift, s.what);
  {
    StageTimer timer(comm, s.stage + "EigenSolve");
    Progress progress(comm, s.what, static_cast<double>(slicing ? 1 : s.nev));
    MonitorContext ctx{&progress, slicing ? 0 : s.nev};
    MORSE_CALL(EPSMonitorSet(eps, progress_monitor, &ctx, nullptr));
    MORSE_CALL(EPSSolve(eps));
    MORSE_CALL(EPSMonitorCancel(eps));
  }
  if (slicing) {
    MORSE_CALL(EPSKrylovSchurGetPartitions(eps, &out.partitions));
    if (out.partitions > 1)
      print0(comm, "  %s: slices solved concurrently on %d subcommunicators\n", s.what.c_str(), (int)out.partitions);
  }
  PetscInt nconv = 0;
  MORSE_CALL(EPSGetConverged(eps, &nconv));
  MORSE_CALL(EPSGetIterationNumber(eps, &out.iterations));
  if (!slicing || count_by_slicing)
    MORSE_CHECK(nconv >= s.nev, s.what, ": only ", nconv, " of ", s.nev, " eigenpairs converged; increase -", s.prefix,
                "eps_max_it or -", s.prefix,
                count_by_slicing ? "eps_ncv, or solve with one shift (-" + s.prefix + "count_slicing 0)"
                                 : std::string("eps_ncv"));
  // Every mode, guaranteed: the pairs found below the cutoff against Sylvester's inertia.
  const PetscInt found = nconv - (slicing ? std::min(detail::drop_for_test(), nconv) : 0);
  if (slicing) {
    if (!count_by_slicing) out.inertia_count = inertia_below(eps, K, M, -1e-6 * omega2_max, omega2_max, s.prefix);
    collective_check(
        comm, found == out.inertia_count
                  ? std::string()
                  : cat(s.what, ": ", found, " eigenpairs found below ", hz(omega2_max),
                        " Hz but Sylvester's inertia of K - omega^2 M counts ", out.inertia_count, ": the solve ",
                        found < out.inertia_count ? "missed modes" : "returned spurious pairs", "; tighten -", s.prefix,
                        "eps_tol or raise -", s.prefix, "eps_ncv"));
    print0(comm, "  %s: %d pairs below %.6g Hz = Sylvester inertia count of K - omega^2 M (every mode found)\n",
           s.what.c_str(), (int)found, hz(omega2_max));
  }
  const PetscInt n_out = slicing && !count_by_slicing ? found : s.nev;
  MORSE_CHECK(n_out > 0, s.what, ": no eigenvalue below the cutoff (omega^2 = ", omega2_max, ")");

  std::vector<std::pair<double, PetscInt>> order;
  {
    StageTimer extract(comm, s.stage + "EigenVectors");
    for (PetscInt i = 0; i < nconv; ++i) {
      PetscScalar kr, ki;
      MORSE_CALL(EPSGetEigenvalue(eps, i, &kr, &ki));
      order.emplace_back(PetscRealPart(kr), i);
    }
    std::sort(order.begin(), order.end());
    if (!slicing) {
      // One shift: the n_out pairs nearest the shift (the lowest for a shift at or below the
      // spectrum), in ascending order; the others follow.
      std::stable_sort(order.begin(), order.end(), [&](const auto& a, const auto& b) {
        return std::abs(a.first - s.shift) < std::abs(b.first - s.shift);
      });
      std::sort(order.begin(), order.begin() + std::min<PetscInt>(n_out, nconv));
    }
    PetscInt m_local = 0;
    MORSE_CALL(MatGetLocalSize(K, &m_local, nullptr));
    MORSE_CALL(MatCreateDense(comm, m_local, PETSC_DECIDE, n, n_out, nullptr, out.V.ptr()));
    UVec Mx;
    MORSE_CALL(MatCreateVecs(K, nullptr, Mx.ptr()));
    auto m_norm2 = [&](Vec x) {
      PetscScalar xMx = 0;
      MORSE_CALL(MatMult(M, x, Mx.get()));
      MORSE_CALL(VecDot(x, Mx.get(), &xMx));
      return PetscRealPart(xMx);
    };
    // SLEPc returns the eigenvectors of a generalized Hermitian problem normalized in the B (= M)
    // norm. That is checked on the first and the last vector (two products with M instead of one
    // per mode: ~10 ms each on a 150k-DOF model, i.e. 10 s for 1000 modes); a solver chosen on
    // the command line that does not normalize so gets every vector normalized explicitly.
    bool normalized = true;
    for (PetscInt j : {PetscInt(0), n_out - 1}) {
      Vec x;
      MORSE_CALL(MatDenseGetColumnVecWrite(out.V.get(), j, &x));
      MORSE_CALL(EPSGetEigenvector(eps, order[j].second, x, nullptr));
      normalized = normalized && std::abs(m_norm2(x) - 1.0) < 1e-10;
      MORSE_CALL(MatDenseRestoreColumnVecWrite(out.V.get(), j, &x));
    }
    for (PetscInt j = 0; j < n_out; ++j) {
      out.omega2.push_back(order[j].first);
      Vec x;
      MORSE_CALL(MatDenseGetColumnVecWrite(out.V.get(), j, &x));
      MORSE_CALL(EPSGetEigenvector(eps, order[j].second, x, nullptr));
      if (!normalized) MORSE_CALL(VecScale(x, 1.0 / std::sqrt(m_norm2(x))));
      MORSE_CALL(MatDenseRestoreColumnVecWrite(out.V.get(), j, &x));
    }
  }
  PetscReal tol = s.tol;
  PetscInt max_it = 0;
  MORSE_CALL(EPSGetTolerances(eps, &tol, &max_it));
  finish_pairs(K, M, s, std::max<double>(tol, s.tol), sign_ref, &out);
  if (!slicing) {
    // One shift: the other converged pairs may tie with the last one returned.
    std::vector<double> extra;
    for (PetscInt j = n_out; j < nconv; ++j) extra.push_back(order[j].first);
    check_count_by_inertia(K, M, s, extra, &out);
  }
  return out;
}

double zero_threshold(Mat K, Mat M) { return detail::zero_threshold(detail::stiffness_scale(K, M)); }

std::vector<UVec> zero_mode_references(Vec sign_ref, PetscInt k) {
  std::vector<UVec> W(static_cast<std::size_t>(k));
  PetscInt m = 0;
  MORSE_CALL(VecGetLocalSize(sign_ref, &m));
  const PetscScalar* u = nullptr;
  MORSE_CALL(VecGetArrayRead(sign_ref, &u));
  for (PetscInt j = 0; j < k; ++j) {
    MORSE_CALL(VecDuplicate(sign_ref, W[static_cast<std::size_t>(j)].ptr()));
    PetscScalar* a = nullptr;
    MORSE_CALL(VecGetArray(W[static_cast<std::size_t>(j)].get(), &a));
    for (PetscInt i = 0; i < m; ++i) a[i] = std::cos(kTwoPi * static_cast<double>(j + 1) * (PetscRealPart(u[i]) - 0.5));
    MORSE_CALL(VecRestoreArray(W[static_cast<std::size_t>(j)].get(), &a));
  }
  MORSE_CALL(VecRestoreArrayRead(sign_ref, &u));
  return W;
}

bool canonical_rotation(PetscInt k, const std::vector<double>& C, std::vector<double>* Q_out) {
  // Modified Gram-Schmidt on the columns of C, twice: C = Q R with R's diagonal positive.
  std::vector<double>& Q = *Q_out;
  Q = C;
  for (PetscInt j = 0; j < k; ++j) {
    double* q = &Q[static_cast<std::size_t>(k * j)];
    const double before = std::sqrt(std::inner_product(q, q + k, q, 0.0));
    for (int pass = 0; pass < 2; ++pass)
      for (PetscInt i = 0; i < j; ++i) {
        const double* p = &Q[static_cast<std::size_t>(k * i)];
        const double r = std::inner_product(p, p + k, q, 0.0);
        for (PetscInt a = 0; a < k; ++a) q[a] -= r * p[a];
      }
    const double norm = std::sqrt(std::inner_product(q, q + k, q, 0.0));
    // A reference vector (nearly) dependent on the previous ones on this space.
    if (!(norm > 1e-8 * before)) return false;
    for (PetscInt a = 0; a < k; ++a) q[a] /= norm;
  }
  return true;
}

namespace {

// The zero-frequency (rigid-body) modes among the pairs returned: the leading ones below
// detail::zero_threshold. Their eigenvalue is 0 to round-off and is stored as 0 (the round-off is
// printed). Any M-orthonormal basis of their eigenspace is a solution, and which one a solver
// returns depends on the rank count; with sign_ref, the basis is made canonical: the
// M-orthonormal Gram-Schmidt basis of the M-projections onto the eigenspace of fixed reference
// vectors w_j(u) = cos(2 pi (j+1) u), u = sign_ref - 1/2 (a function of the mesh only). With
// X the basis found and C = X^T M W = Q R (R with a positive diagonal), X Q is that basis, the
// same for any X that spans the space. The count is proved by Sylvester's inertia at the
// threshold unless the checks are off. Returns the number of zero modes put in the canonical
// basis (their signs are fixed by it), else 0. Collective.
PetscInt zero_modes(Mat K, Mat M, const EigenSettings& s, Vec sign_ref, Eigenpairs* out_) {
  Eigenpairs& out = *out_;
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  const auto n_out = static_cast<PetscInt>(out.omega2.size());
  if (n_out == 0 || out.omega2[0] >= 0.5 * std::numeric_limits<double>::max()) return 0;
  const double scale = detail::stiffness_scale(K, M);
  const double tau = zero_threshold(K, M);
  PetscInt k = 0;
  double roundoff = 0;
  while (k < n_out && out.omega2[k] < tau) roundoff = std::max(roundoff, std::abs(out.omega2[k++]));
  if (k == 0) return 0;
  bool canonical = false;
  if (sign_ref && k > 1) {
    const auto W = zero_mode_references(sign_ref, k);
    UVec mw;
    MORSE_CALL(VecDuplicate(sign_ref, mw.ptr()));
    // C (k x k, column-major by reference vector): C[a + k j] = x_a^T M w_j.
    std::vector<double> C(static_cast<std::size_t>(k * k)), Q;
    for (PetscInt j = 0; j < k; ++j) {
      MORSE_CALL(MatMult(M, W[static_cast<std::size_t>(j)].get(), mw.get()));
      for (PetscInt c = 0; c < k; ++c) {
        Vec x;
        PetscScalar d = 0;
        MORSE_CALL(MatDenseGetColumnVecRead(out.V.get(), c, &x));
        MORSE_CALL(VecDot(x, mw.get(), &d));
        MORSE_CALL(MatDenseRestoreColumnVecRead(out.V.get(), c, &x));
        C[static_cast<std::size_t>(c + k * j)] = PetscRealPart(d);
      }
    }
    canonical = canonical_rotation(k, C, &Q);
    if (canonical) {
      PetscScalar* v = nullptr;
      PetscInt lda = 0, rows = 0;
      MORSE_CALL(MatGetLocalSize(out.V.get(), &rows, nullptr));
      MORSE_CALL(MatDenseGetLDA(out.V.get(), &lda));
      MORSE_CALL(MatDenseGetArray(out.V.get(), &v));
      std::vector<double> row(static_cast<std::size_t>(k));
      for (PetscInt r = 0; r < rows; ++r) {
        for (PetscInt j = 0; j < k; ++j) {
          double t = 0;
          for (PetscInt a = 0; a < k; ++a) t += PetscRealPart(v[r + lda * a]) * Q[static_cast<std::size_t>(a + k * j)];
          row[static_cast<std::size_t>(j)] = t;
        }
        for (PetscInt j = 0; j < k; ++j) v[r + lda * j] = row[static_cast<std::size_t>(j)];
      }
      MORSE_CALL(MatDenseRestoreArray(out.V.get(), &v));
    }
  }
  for (PetscInt j = 0; j < k; ++j) out.omega2[j] = 0.0;
  print0(comm,
         "  %s: %d zero-frequency (rigid-body) mode(s): |omega^2| <= %.2e (rad/s)^2 computed, round-off below "
         "1e-12 of the stiffness scale %.3g; stored as 0%s\n",
         s.what.c_str(), (int)k, roundoff, scale, canonical ? ", in a basis fixed by the mesh" : "");

  if (count_check_wanted(comm, s)) {
    // Sylvester: the number of eigenvalues below tau. All of them must be returned, unless every
    // pair returned is a zero mode (then more may exist than were asked for).
    InertiaCounter c(K, M, s.prefix);
    const PetscInt counted = c.count(tau);
    collective_check(comm, counted == k || (k == n_out && counted > k)
                               ? std::string()
                               : cat(s.what, ": Sylvester's inertia counts ", counted, " eigenvalues below ", tau,
                                     " (rad/s)^2 (zero frequency to round-off) but the solve returned ", k,
                                     ": it missed rigid-body modes"));
    print0(comm, "  %s: %d eigenvalue(s) below %.3g (rad/s)^2 = Sylvester inertia count of K - tau M%s\n",
           s.what.c_str(), (int)counted, tau,
           counted > k ? cat(": the model has ", counted, " zero modes, ", k, " asked for").c_str() : "");
  }
  out.zero_modes = k;
  return canonical ? k : 0;
}

}  // namespace

void finish_pairs(Mat K, Mat M, const EigenSettings& s, double tol, Vec sign_ref, Eigenpairs* out_) {
  Eigenpairs& out = *out_;
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  const auto n_out = static_cast<PetscInt>(out.omega2.size());
  const PetscInt fixed = zero_modes(K, M, s, sign_ref, &out);
  if (sign_ref)
    for (PetscInt j = fixed; j < n_out; ++j) {
      Vec x;
      MORSE_CALL(MatDenseGetColumnVecWrite(out.V.get(), j, &x));
      PetscScalar wx = 0;
      MORSE_CALL(VecDot(x, sign_ref, &wx));
      if (PetscRealPart(wx) < 0) MORSE_CALL(VecScale(x, -1.0));
      MORSE_CALL(MatDenseRestoreColumnVecWrite(out.V.get(), j, &x));
    }
  {
    StageTimer timer(comm, s.stage + "EigenResiduals");
    auto r = relative_residuals(K, M, out.V.get(), out.omega2);
    PetscInt worst = 0;
    for (PetscInt j = 0; j < n_out; ++j)
      if (r[j] > r[worst]) worst = j;
    out.max_residual = r[worst];
    collective_check(comm, out.max_residual <= tol
                               ? std::string()
                               : cat(s.what, ": mode ", worst + 1, " (", hz(out.omega2[worst]),
                                     " Hz) has the relative residual ||Kx - w^2 Mx|| / (||K|| ||x||) = ",
                                     out.max_residual, " above the tolerance ", tol));
    print0(comm, "  %s: max relative residual ||Kx - w^2 Mx|| / (||K|| ||x||) = %.2e over %d pairs\n", s.what.c_str(),
           out.max_residual, (int)n_out);
  }
}

bool count_check_wanted(MPI_Comm comm, const EigenSettings& s) {
  PetscBool check = s.check_inertia ? PETSC_TRUE : PETSC_FALSE;
  auto get_options = [&]() -> PetscErrorCode {
    PetscOptionsBegin(comm, s.prefix.c_str(), "morse eigen solver", "");
    PetscCall(MorseOptionsBool("-check_inertia",
                               "Count mode: check by Sylvester's inertia that no eigenvalue nearer the shift than "
                               "those returned was missed (one LDL^T factorization)",
                               "", check, &check, nullptr));
    PetscOptionsEnd();
    return PETSC_SUCCESS;
  };
  MORSE_CALL(get_options());
  return check == PETSC_TRUE;
}

void check_count_by_inertia(Mat K, Mat M, const EigenSettings& s, const std::vector<double>& extra, Eigenpairs* out_) {
  Eigenpairs& out = *out_;
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  const bool check = count_check_wanted(comm, s);
  if (!check || out.omega2.empty()) return;
  // Only zero modes returned: their count is already proved (zero_modes), and a window about the
  // shift that holds them would end inside their round-off.
  if (out.zero_modes == static_cast<PetscInt>(out.omega2.size())) return;
  StageTimer timer(comm, s.stage + "InertiaCheck");
  const auto t0 = std::chrono::steady_clock::now();
  // The window [shift - d, shift + d] holds every pair returned; widened by 1e-6 so that its
  // ends lie off the returned eigenvalues (a factorization at an eigenvalue is singular). K is
  // positive semi-definite, so no eigenvalue lies below a window end <= 0.
  double d = 0, far = 0;
  for (double w : out.omega2)
    if (std::abs(w - s.shift) >= d) d = std::abs(w - s.shift), far = w;
  // The block solver's factor when the caller does not keep it (analysed with ICNTL(13) = 1):
  // refactored in place, so the check needs no symbolic analysis and no second factor.
  const bool reuse = !s.keep_factor && out.block_factor;
  InertiaCounter c(K, M, s.prefix, reuse ? out.block_factor.get() : nullptr);
  auto counted_in = [&](double dd) { return c.count(s.shift + dd) - (s.shift - dd > 0 ? c.count(s.shift - dd) : 0); };
  // Pairs found strictly inside the window: those returned (but the `drop_for_test` lowest) and
  // the other converged ones.
  const auto dropped = std::min<std::size_t>(detail::drop_for_test(), out.omega2.size());
  auto found_in = [&](double dd) {
    PetscInt f = 0;
    for (std::size_t j = dropped; j < out.omega2.size(); ++j) f += std::abs(out.omega2[j] - s.shift) < dd ? 1 : 0;
    for (double w : extra) f += std::abs(w - s.shift) < dd ? 1 : 0;
    return f;
  };
  const double outer = d * (1 + 1e-6) + 1e-300;
  const PetscInt counted = counted_in(outer), found = found_in(outer);
  out.inertia_count = counted;
  out.check_lo = std::max(s.shift - outer, 0.0);
  out.check_hi = s.shift + outer;
  // More eigenvalues than pairs found: either one was missed, or the count cut a cluster whose
  // other copies lie within 1e-6 of the farthest pair returned and did not converge (a tie,
  // which the claim "the nev nearest" allows). The window just inside that pair tells which.
  PetscInt tied = 0;
  if (counted > found) {
    const double inner = d * (1 - 1e-6);
    const PetscInt counted_inner = counted_in(inner), found_inner = found_in(inner);
    if (counted_inner == found_inner) tied = counted - found;
  }
  collective_check(comm,
                   counted == found || tied > 0
                       ? std::string()
                       : cat(s.what, ": Sylvester's inertia of K - omega^2 M counts ", counted, " eigenvalues in [",
                             hz(out.check_lo), ", ", hz(out.check_hi), "] Hz but the solve found ", found, ": it ",
                             counted > found ? "missed modes" : "returned spurious pairs", "; raise -", s.prefix,
                             "block_max_dim (block solver) or -", s.prefix, "eps_ncv (krylovschur)"));
  print0(comm,
         "  %s: %d pairs in [%.6g, %.6g] Hz = Sylvester inertia count of K - omega^2 M (every mode found, %.1f s%s)\n",
         s.what.c_str(), (int)(found + tied), hz(out.check_lo), hz(out.check_hi),
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
         reuse ? ", the solver's factor refactored" : "");
  // The factor now holds K - sigma M at the check's last shift: not the caller's any more.
  if (reuse) out.block_factor.reset();
  if (tied > 0)
    print0(comm,
           "  %s: the farthest pair returned (%.9g Hz) is one of a cluster: %d more eigenvalue(s) within 1e-6 of it "
           "are not returned; every eigenvalue nearer the shift than the cluster is returned\n",
           s.what.c_str(), hz(far), (int)tied);
}

namespace {

// fn(c0, c1, Vb, KV, MV) for the columns [c0, c1) of V, in blocks of 32: Vb the columns, KV and
// MV their products with K and M (the same layout).
template <class Fn>
void for_column_blocks(Mat K, Mat M, Mat V, Fn fn) {
  PetscInt nv = 0;
  MORSE_CALL(MatGetSize(V, nullptr, &nv));
  constexpr PetscInt kBlock = 32;
  for (PetscInt c0 = 0; c0 < nv; c0 += kBlock) {
    const PetscInt c1 = std::min(nv, c0 + kBlock);
    Mat Vb;
    MORSE_CALL(MatDenseGetSubMatrix(V, PETSC_DECIDE, PETSC_DECIDE, c0, c1, &Vb));
    UMat KV, MV;
    MORSE_CALL(MatMatMult(K, Vb, MAT_INITIAL_MATRIX, PETSC_DEFAULT, KV.ptr()));
    MORSE_CALL(MatMatMult(M, Vb, MAT_INITIAL_MATRIX, PETSC_DEFAULT, MV.ptr()));
    fn(c0, c1, Vb, KV.get(), MV.get());
    MORSE_CALL(MatDenseRestoreSubMatrix(V, &Vb));
  }
}

}  // namespace

std::vector<double> relative_residuals(Mat K, Mat M, Mat V, const std::vector<double>& omega2) {
  PetscInt nv = 0;
  MORSE_CALL(MatGetSize(V, nullptr, &nv));
  MORSE_CHECK(static_cast<std::size_t>(nv) == omega2.size(), "relative_residuals: ", nv, " vectors but ", omega2.size(),
              " eigenvalues");
  PetscReal knorm = 0;
  MORSE_CALL(MatNorm(K, NORM_INFINITY, &knorm));
  std::vector<double> r(nv, 0.0);
  for_column_blocks(K, M, V, [&](PetscInt c0, PetscInt c1, Mat Vb, Mat KV, Mat MV) {
    std::vector<PetscReal> xn(c1 - c0), rn(c1 - c0);
    MORSE_CALL(MatGetColumnNorms(Vb, NORM_2, xn.data()));
    for (PetscInt j = c0; j < c1; ++j) {
      Vec kx, mx;
      MORSE_CALL(MatDenseGetColumnVecWrite(KV, j - c0, &kx));
      MORSE_CALL(MatDenseGetColumnVecRead(MV, j - c0, &mx));
      MORSE_CALL(VecAXPY(kx, -omega2[j], mx));
      MORSE_CALL(MatDenseRestoreColumnVecRead(MV, j - c0, &mx));
      MORSE_CALL(MatDenseRestoreColumnVecWrite(KV, j - c0, &kx));
    }
    MORSE_CALL(MatGetColumnNorms(KV, NORM_2, rn.data()));
    for (PetscInt j = c0; j < c1; ++j) r[j] = rn[j - c0] / (knorm * std::max<PetscReal>(xn[j - c0], 1e-300));
  });
  return r;
}

std::vector<double> rayleigh_quotients(Mat K, Mat M, Mat V) {
  PetscInt nv = 0;
  MORSE_CALL(MatGetSize(V, nullptr, &nv));
  std::vector<double> q(nv, 0.0);
  for_column_blocks(K, M, V, [&](PetscInt c0, PetscInt c1, Mat Vb, Mat KV, Mat MV) {
    std::vector<PetscScalar> xk(c1 - c0), xm(c1 - c0);
    for (PetscInt j = c0; j < c1; ++j) {
      Vec x, kx, mx;
      MORSE_CALL(MatDenseGetColumnVecRead(Vb, j - c0, &x));
      MORSE_CALL(MatDenseGetColumnVecRead(KV, j - c0, &kx));
      MORSE_CALL(MatDenseGetColumnVecRead(MV, j - c0, &mx));
      MORSE_CALL(VecDot(kx, x, &xk[j - c0]));
      MORSE_CALL(VecDot(mx, x, &xm[j - c0]));
      MORSE_CALL(MatDenseRestoreColumnVecRead(MV, j - c0, &mx));
      MORSE_CALL(MatDenseRestoreColumnVecRead(KV, j - c0, &kx));
      MORSE_CALL(MatDenseRestoreColumnVecRead(Vb, j - c0, &x));
      q[j] = PetscRealPart(xk[j - c0]) / PetscRealPart(xm[j - c0]);
    }
  });
  return q;
}

std::vector<double> dense_eigenvalues(int n, const std::vector<double>& K, const std::vector<double>& M,
                                      std::vector<double>* vectors, double vectors_max) {
  // Row-major symmetric = column-major symmetric, so the arrays can go to LAPACK as they are.
  std::vector<double> A(K), B(M), w(n);
  PetscBLASInt itype = 1, nn = n, lwork = std::max(1, 8 * n), info = 0;
  std::vector<double> work(lwork);
  const bool all_vectors = vectors && !(vectors_max < std::numeric_limits<double>::infinity());
  LAPACKsygv_(&itype, all_vectors ? "V" : "N", "U", &nn, A.data(), &nn, B.data(), &nn, w.data(), work.data(), &lwork,
              &info);
  MORSE_CHECK(info == 0, "dense generalized eigen solve failed (LAPACK sygv info = ", info,
              "): the reduced mass matrix is not positive definite");
  if (!vectors) return w;
  vectors->assign(static_cast<std::size_t>(n) * n, 0.0);
  PetscBLASInt k = n;
  if (!all_vectors) {
    k = 0;
    while (k < n && w[k] <= vectors_max) ++k;
    if (k == 0) return w;
    A = K;
    B = M;
    PetscBLASInt il = 1, iu = k, found = 0;
    const double unused = 0.0, abstol = 2 * std::numeric_limits<double>::min();  // most accurate (LAPACK)
    std::vector<double> wk(n), Z(static_cast<std::size_t>(n) * k);
    std::vector<PetscBLASInt> iwork(5 * static_cast<std::size_t>(n)), ifail(n);
    LAPACKsygvx_(&itype, "V", "I", "U", &nn, A.data(), &nn, B.data(), &nn, &unused, &unused, &il, &iu, &abstol, &found,
                 wk.data(), Z.data(), &nn, work.data(), &lwork, iwork.data(), ifail.data(), &info);
    MORSE_CHECK(info == 0 && found == k, "dense generalized eigen solve failed (LAPACK sygvx info = ", info, ", ",
                found, " of ", k, " eigenvectors)");
    A.swap(Z);
  }
  for (int i = 0; i < n; ++i)
    for (int m = 0; m < k; ++m)
      (*vectors)[static_cast<std::size_t>(i) * n + m] = A[static_cast<std::size_t>(m) * n + i];
  return w;
}

}  // namespace morse::eigen
