// Load case and implicit time integration of the rotor–stator assembly (docs/rampup-theory.md §5).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "lapack.hpp"
#include "morse/core/error.hpp"
#include "morse/rampup/rampup.hpp"

namespace morse::rampup {

double LoadCase::speed(double t) const {
  if (kind == Kind::Constant || t >= ramp_time) return omega_max;
  return omega_max * t / ramp_time;
}
double LoadCase::acceleration(double t) const {
  return kind == Kind::Ramp && t < ramp_time ? omega_max / ramp_time : 0.0;
}
double LoadCase::angle(double t) const {
  if (kind == Kind::Constant) return omega_max * t;
  if (t < ramp_time) return 0.5 * omega_max * t * t / ramp_time;
  return 0.5 * omega_max * ramp_time + omega_max * (t - ramp_time);
}

namespace {

// Solver of S = cM M + cD (C + omega G) + cK K.
class StepSolver {
 public:
  virtual ~StepSolver() = default;
  virtual void factor(double cM, double cD, double cK, double omega) = 0;
  virtual void solve(const double* b, double* x) = 0;
};

// Dense LU of the whole matrix (reference path, O(n^3) per factorization).
class DenseSolver : public StepSolver {
 public:
  explicit DenseSolver(const Assembly& a) : A_(a.dense()), n_(A_.n), S_(static_cast<std::size_t>(n_) * n_), piv_(n_) {}
  void factor(double cM, double cD, double cK, double omega) override {
    const std::size_t nn = static_cast<std::size_t>(n_) * n_;
    // Row-major S is column-major S^T: solve with "T".
    for (std::size_t g = 0; g < nn; ++g) S_[g] = cM * A_.M[g] + cD * (A_.C[g] + omega * A_.G[g]) + cK * A_.K[g];
    PetscBLASInt n = n_, info = 0;
    LAPACKgetrf_(&n, &n, S_.data(), &n, piv_.data(), &info);
    MORSE_CHECK(info == 0, "rampup: the effective matrix is singular (LAPACK getrf info = ", info, ")");
  }
  void solve(const double* b, double* x) override {
    std::copy(b, b + n_, x);
    PetscBLASInt n = n_, one = 1, info = 0;
    LAPACKgetrs_("T", &n, &one, S_.data(), &n, piv_.data(), x, &n, &info);
  }

 private:
  AssembledMatrices A_;
  PetscBLASInt n_;
  std::vector<double> S_;
  std::vector<PetscBLASInt> piv_;
};

// Static condensation onto the bearings (docs/rampup-theory.md §5.2): the stator block is
// Delta + B_s^T Kb B_s with Delta diagonal, the rotor block is banded, and they couple only
// through the m bearing directions. Unknowns (r, y), y = B_s eta the stator bearing motions:
//   [A_r, -B_r^T Kb; -F Kb B_r, I + F Kb] [r; y] = [b_r; B_s Delta^-1 b_eta],
//   F = B_s Delta^-1 B_s^T (m x m, fixed while cM, cD, cK are), then eta from
//   Delta eta = b_eta + B_s^T Kb (B_r r - y).
class CondensedSolver : public StepSolver {
 public:
  explicit CondensedSolver(const Assembly& a)
      : a_(a), N_(a.n_stator()), R_(a.n_rotor()), m_(static_cast<int>(a.couplings().size())), bw_(a.rotor_bandwidth()) {
    ldab_ = 3 * bw_ + 1;
    ab_.resize(static_cast<std::size_t>(ldab_) * R_);
    piv_.resize(R_);
    dinv_.resize(N_);
    kb_.resize(m_);
    F_.resize(static_cast<std::size_t>(m_) * m_);
    X_.resize(static_cast<std::size_t>(R_) * m_);
    Sy_.resize(static_cast<std::size_t>(m_) * m_);
    pivy_.resize(m_);
    y_.resize(m_);
    r1_.resize(R_);
  }
  void factor(double cM, double cD, double cK, double omega) override {
    const auto& cp = a_.couplings();
    if (cM != cM_ || cD != cD_ || cK != cK_) {
      cM_ = cM;
      cD_ = cD;
      cK_ = cK;
      omega_ = std::nan("");
      const auto& om2 = a_.stator_omega2();
      const auto& cs = a_.stator_damping();
      for (int i = 0; i < N_; ++i) {
        const double d = cM + cD * cs[i] + cK * om2[i];
        MORSE_CHECK(d != 0.0, "rampup: stator mode ", i, " has a zero effective stiffness");
        dinv_[i] = 1.0 / d;
      }
      // Intershaft bearings are in the rotor band: no condensed coupling.
      for (int j = 0; j < m_; ++j) kb_[j] = cp[j].rotor_index2 >= 0 ? 0.0 : cK * cp[j].k + cD * cp[j].c;
      for (int j = 0; j < m_; ++j)
        for (int l = 0; l < m_; ++l) {
          double s = 0.0;
          if (cp[j].stator_offset >= 0 && cp[j].stator_offset == cp[l].stator_offset)
            for (int p = 0; p < cp[j].n_modes; ++p) s += cp[j].phi[p] * cp[l].phi[p] * dinv_[cp[j].stator_offset + p];
          F_[j + static_cast<std::size_t>(m_) * l] = s;  // column-major
        }
    }
    if (omega == omega_) return;
    omega_ = omega;
    if (R_ == 0) return;
    // Band LU of the rotor block at this speed (LAPACK band storage, kl = ku = bw).
    std::fill(ab_.begin(), ab_.end(), 0.0);
    const auto &bM = a_.band_M(), &bC = a_.band_C(), &bK = a_.band_K(), &bG = a_.band_G();
    const std::size_t ld = 2 * static_cast<std::size_t>(bw_) + 1;
    for (int j = 0; j < R_; ++j)
      for (int i = std::max(0, j - bw_); i < std::min(R_, j + bw_ + 1); ++i) {
        const std::size_t b = ld * j + static_cast<std::size_t>(bw_ + i - j);
        ab_[static_cast<std::size_t>(2 * bw_ + i - j) + static_cast<std::size_t>(ldab_) * j] =
            cM * bM[b] + cD * (bC[b] + omega * bG[b]) + cK * bK[b];
      }
    for (int j = 0; j < m_; ++j)
      ab_[static_cast<std::size_t>(2 * bw_) + static_cast<std::size_t>(ldab_) * cp[j].rotor_index] += kb_[j];
    PetscBLASInt n = R_, kl = bw_, info = 0;
    dgbtrf_(&n, &n, &kl, &kl, ab_.data(), &ldab_, piv_.data(), &info);
    MORSE_CHECK(
        info == 0, "rampup: the rotor block of the ",
        cD == 0.0 && cK == 0.0 ? "mass matrix is singular (a massless rotor DOF)" : "effective matrix is singular",
        " (LAPACK gbtrf info = ", info, ")");
    if (m_ == 0) return;
    // X = A_r^-1 B_r^T Kb, then S_y = I + F Kb (I - B_r X).
    std::fill(X_.begin(), X_.end(), 0.0);
    for (int j = 0; j < m_; ++j) X_[cp[j].rotor_index + static_cast<std::size_t>(R_) * j] = kb_[j];
    PetscBLASInt nrhs = m_;
    dgbtrs_("N", &n, &kl, &kl, &nrhs, ab_.data(), &ldab_, piv_.data(), X_.data(), &n, &info);
    std::vector<double> E(static_cast<std::size_t>(m_) * m_);
    for (int l = 0; l < m_; ++l)
      for (int j = 0; j < m_; ++j)
        E[l + static_cast<std::size_t>(m_) * j] =
            kb_[l] * ((l == j ? 1.0 : 0.0) - X_[cp[l].rotor_index + static_cast<std::size_t>(R_) * j]);
    for (int i = 0; i < m_; ++i)
      for (int j = 0; j < m_; ++j) {
        double s = i == j ? 1.0 : 0.0;
        for (int l = 0; l < m_; ++l)
          s += F_[i + static_cast<std::size_t>(m_) * l] * E[l + static_cast<std::size_t>(m_) * j];
        Sy_[i + static_cast<std::size_t>(m_) * j] = s;
      }
    PetscBLASInt mm = m_;
    LAPACKgetrf_(&mm, &mm, Sy_.data(), &mm, pivy_.data(), &info);
    MORSE_CHECK(info == 0, "rampup: the condensed bearing system is singular (LAPACK getrf info = ", info, ")");
  }
  void solve(const double* b, double* x) override {
    const auto& cp = a_.couplings();
    const double* be = b;
    const double* br = b + N_;
    double* eta = x;
    double* r = x + N_;
    std::copy(br, br + R_, r1_.begin());
    PetscBLASInt n = R_, kl = bw_, one = 1, info = 0;
    if (R_ > 0) dgbtrs_("N", &n, &kl, &kl, &one, ab_.data(), &ldab_, piv_.data(), r1_.data(), &n, &info);
    for (int j = 0; j < m_; ++j) {
      double s = 0.0;
      if (cp[j].stator_offset >= 0)
        for (int p = 0; p < cp[j].n_modes; ++p)
          s += cp[j].phi[p] * be[cp[j].stator_offset + p] * dinv_[cp[j].stator_offset + p];
      y_[j] = s;
    }
    for (int j = 0; j < m_; ++j)
      for (int l = 0; l < m_; ++l) y_[j] += F_[j + static_cast<std::size_t>(m_) * l] * kb_[l] * r1_[cp[l].rotor_index];
    if (m_ > 0) {
      PetscBLASInt mm = m_;
      LAPACKgetrs_("N", &mm, &one, Sy_.data(), &mm, pivy_.data(), y_.data(), &mm, &info);
    }
    for (int i = 0; i < R_; ++i) {
      double s = r1_[i];
      for (int j = 0; j < m_; ++j) s += X_[i + static_cast<std::size_t>(R_) * j] * y_[j];
      r[i] = s;
    }
    for (int i = 0; i < N_; ++i) eta[i] = be[i];
    for (int j = 0; j < m_; ++j) {
      if (cp[j].stator_offset < 0) continue;
      const double f = kb_[j] * (r[cp[j].rotor_index] - y_[j]);
      for (int p = 0; p < cp[j].n_modes; ++p) eta[cp[j].stator_offset + p] += cp[j].phi[p] * f;
    }
    for (int i = 0; i < N_; ++i) eta[i] *= dinv_[i];
  }

 private:
  const Assembly& a_;
  int N_, R_, m_, bw_;
  PetscBLASInt ldab_ = 1;
  double cM_ = std::nan(""), cD_ = std::nan(""), cK_ = std::nan(""), omega_ = std::nan("");
  std::vector<double> ab_, dinv_, kb_, F_, X_, Sy_, y_, r1_;
  std::vector<PetscBLASInt> piv_, pivy_;
};

// The twist of the free stations (docs/rampup-theory.md §4.3): M phi'' + C phi' + K phi = f(t) on
// the free DOFs (the driven ones are held at 0), by the lateral step's scheme; the effective
// matrix is constant, so it is factored once.
class TorsionStepper {
 public:
  TorsionStepper(const Assembly& a, double a0, double a1, double al)
      : a_(a), free_(a.free_twists()), nf_(static_cast<int>(free_.size())) {
    const std::size_t n = static_cast<std::size_t>(a.n_torsion()), nf = static_cast<std::size_t>(nf_);
    for (auto* v : {&phi_, &dphi_, &ddphi_, &f0_, &f1_}) v->assign(n, 0.0);
    M_.resize(nf * nf);
    C_.resize(nf * nf);
    K_.resize(nf * nf);
    for (std::size_t p = 0; p < nf; ++p)
      for (std::size_t q = 0; q < nf; ++q) {
        const std::size_t g = static_cast<std::size_t>(free_[p]) * n + static_cast<std::size_t>(free_[q]);
        M_[p * nf + q] = a.torsion_M()[g];
        C_[p * nf + q] = a.torsion_C()[g];
        K_[p * nf + q] = a.torsion_K()[g];
      }
    S_.resize(nf * nf);
    piv_.resize(nf);
    Sm_ = M_;
    pivm_.resize(nf);
    for (std::size_t g = 0; g < nf * nf; ++g) S_[g] = a0 * M_[g] + (1.0 + al) * (a1 * C_[g] + K_[g]);
    PetscBLASInt m = nf_, info = 0;
    if (nf_ == 0) return;
    LAPACKgetrf_(&m, &m, Sm_.data(), &m, pivm_.data(), &info);
    MORSE_CHECK(info == 0,
                "rampup: the torsional mass matrix is singular (a twist DOF without inertia: a massless "
                "shaft station with no disk; LAPACK getrf info = ",
                info, ")");
    LAPACKgetrf_(&m, &m, S_.data(), &m, piv_.data(), &info);
    MORSE_CHECK(info == 0, "rampup: the torsional effective matrix is singular (LAPACK getrf info = ", info, ")");
  }
  // Initial acceleration at rest: M phi'' = f(0).
  void start(double omega, double omega_dot) {
    a_.torsion_load(omega, omega_dot, f0_.data());
    std::vector<double> b = gather(f0_);
    solve(Sm_, pivm_, b);
    scatter(b, &ddphi_);
  }
  // One step to omega1, omega_dot1 with the scheme's coefficients.
  void step(double omega1, double omega_dot1, double h, double a0, double a1, double a2, double a3, double a4,
            double a5, double gam, double al) {
    a_.torsion_load(omega1, omega_dot1, f1_.data());
    const std::size_t nf = static_cast<std::size_t>(nf_);
    const std::vector<double> x = gather(phi_), v = gather(dphi_), acc = gather(ddphi_), f0 = gather(f0_),
                              f1 = gather(f1_);
    std::vector<double> rhs(nf), wm(nf), wc(nf);
    for (std::size_t p = 0; p < nf; ++p) {
      wm[p] = a0 * x[p] + a2 * v[p] + a3 * acc[p];
      wc[p] = a1 * x[p] + a4 * v[p] + a5 * acc[p];
    }
    for (std::size_t p = 0; p < nf; ++p) {
      double s = (1.0 + al) * f1[p] - al * f0[p];
      for (std::size_t q = 0; q < nf; ++q) {
        s += M_[p * nf + q] * wm[q] + (1.0 + al) * C_[p * nf + q] * wc[q];
        if (al != 0.0) s += al * (C_[p * nf + q] * v[q] + K_[p * nf + q] * x[q]);
      }
      rhs[p] = s;
    }
    solve(S_, piv_, rhs);
    for (std::size_t p = 0; p < nf; ++p) {
      const std::size_t i = static_cast<std::size_t>(free_[p]);
      const double an = a0 * (rhs[p] - x[p]) - a2 * v[p] - a3 * acc[p];
      dphi_[i] += h * ((1.0 - gam) * acc[p] + gam * an);
      ddphi_[i] = an;
      phi_[i] = rhs[p];
      MORSE_CHECK(std::isfinite(rhs[p]), "rampup: the torsional state is not finite");
    }
    f0_.swap(f1_);
  }
  void torques(double omega, double omega_dot, double* drive, double* gearbox) const {
    a_.torsion_state(phi_.data(), dphi_.data(), ddphi_.data(), omega, omega_dot, drive, gearbox);
  }

 private:
  std::vector<double> gather(const std::vector<double>& full) const {
    std::vector<double> out(static_cast<std::size_t>(nf_));
    for (int p = 0; p < nf_; ++p) out[p] = full[free_[p]];
    return out;
  }
  void scatter(const std::vector<double>& part, std::vector<double>* full) const {
    for (int p = 0; p < nf_; ++p) (*full)[free_[p]] = part[p];
  }
  void solve(const std::vector<double>& lu, const std::vector<PetscBLASInt>& piv, std::vector<double>& b) const {
    if (nf_ == 0) return;
    PetscBLASInt m = nf_, one = 1, info = 0;
    // Row-major A is column-major A^T: solve with "T".
    LAPACKgetrs_("T", &m, &one, const_cast<double*>(lu.data()), &m, const_cast<PetscBLASInt*>(piv.data()), b.data(), &m,
                 &info);
  }
  const Assembly& a_;
  std::vector<int> free_;
  int nf_;
  std::vector<double> M_, C_, K_, S_, Sm_, phi_, dphi_, ddphi_, f0_, f1_;
  std::vector<PetscBLASInt> piv_, pivm_;
};

}  // namespace

IntegratorStats integrate(const Assembly& a, const LoadCase& load, const IntegratorSettings& s,
                          const std::function<void(const StepOutput&)>& callback) {
  MORSE_CHECK(s.dt > 0.0 && std::isfinite(s.dt), "rampup: the time step must be positive, got ", s.dt, " s");
  MORSE_CHECK(s.alpha >= -1.0 / 3.0 - 1e-15 && s.alpha <= 0.0, "rampup: HHT alpha must be in [-1/3, 0], got ", s.alpha);
  MORSE_CHECK(s.output_every >= 1, "rampup: output_every must be >= 1, got ", s.output_every);
  MORSE_CHECK(std::isfinite(load.omega_max), "rampup: the top speed must be finite");
  MORSE_CHECK(load.kind == LoadCase::Kind::Constant || load.ramp_time > 0.0,
              "rampup: the ramp time must be positive, got ", load.ramp_time, " s");
  const double t_final = end_time(load, s);
  MORSE_CHECK(t_final > 0.0, "rampup: the final time must be positive (t_final or the ramp time)");
  const int n = a.n();
  const std::size_t nn = static_cast<std::size_t>(n);
  MORSE_CHECK(s.x0.empty() || s.x0.size() == nn, "rampup: x0 has ", s.x0.size(), " values, the model ", n);
  MORSE_CHECK(s.v0.empty() || s.v0.size() == nn, "rampup: v0 has ", s.v0.size(), " values, the model ", n);
  IntegratorStats st;
  double top = 0.0;
  for (const RotorSpec& r : a.rotors()) top = std::max(top, std::fabs(r.speed_ratio * load.omega_max));
  if (top * s.dt > 2.0 * M_PI / 20.0)
    st.warnings.push_back(cat("dt = ", s.dt, " s gives ", 2.0 * M_PI / (top * s.dt),
                              " steps per revolution at the top spin speed (", top,
                              " rad/s); fewer than 20 loses accuracy"));
  const long steps = static_cast<long>(std::ceil(t_final / s.dt - 1e-9));
  const double h = s.dt, al = s.alpha, gam = 0.5 - al, bet = 0.25 * (1.0 - al) * (1.0 - al);
  const double a0 = 1.0 / (bet * h * h), a1 = gam / (bet * h), a2 = 1.0 / (bet * h), a3 = 0.5 / bet - 1.0,
               a4 = gam / bet - 1.0, a5 = h * (0.5 * gam / bet - 1.0);
  std::vector<double> x(s.x0.empty() ? std::vector<double>(nn, 0.0) : s.x0),
      v(s.v0.empty() ? std::vector<double>(nn, 0.0) : s.v0), acc(nn), f0(nn, 0.0), f1(nn), rhs(nn), w(nn), tmp(nn),
      xn(nn);
  const std::size_t nb = 2 * a.bearings().size();
  std::vector<double> force(nb), rdisp(nb), sdisp(nb);
  std::unique_ptr<StepSolver> solver;
  if (s.dense)
    solver = std::make_unique<DenseSolver>(a);
  else
    solver = std::make_unique<CondensedSolver>(a);
  std::unique_ptr<TorsionStepper> twist;
  const std::size_t ndr = a.torsion().drives.size(), ngb = a.torsion().gearboxes.size();
  std::vector<double> drive_torque(ndr), gearbox_torque(ngb);
  if (a.n_torsion() > 0) twist = std::make_unique<TorsionStepper>(a, a0, a1, al);
  const auto start = std::chrono::steady_clock::now();
  // Initial acceleration: M a = f - (C + Omega G) v - K x.
  a.add_unbalance(load.speed(0.0), load.acceleration(0.0), load.angle(0.0), f0.data());
  a.apply(0.0, 1.0, 0.0, load.speed(0.0), v.data(), tmp.data());
  a.apply(0.0, 0.0, 1.0, 0.0, x.data(), w.data());
  for (std::size_t i = 0; i < nn; ++i) rhs[i] = f0[i] - tmp[i] - w[i];
  solver->factor(1.0, 0.0, 0.0, 0.0);
  solver->solve(rhs.data(), acc.data());
  if (twist) twist->start(load.speed(0.0), load.acceleration(0.0));
  auto emit = [&](long k, double t) {
    a.bearing_state(x.data(), v.data(), force.data(), rdisp.data(), sdisp.data());
    StepOutput o;
    if (twist) {
      twist->torques(load.speed(t), load.acceleration(t), drive_torque.data(), gearbox_torque.data());
      o.drive_torque = drive_torque.data();
      o.gearbox_torque = gearbox_torque.data();
    }
    o.step = k;
    o.t = t;
    o.speed = load.speed(t);
    o.x = x.data();
    o.v = v.data();
    o.force = force.data();
    o.rotor_disp = rdisp.data();
    o.stator_disp = sdisp.data();
    if (callback) callback(o);
  };
  emit(0, 0.0);
  for (long k = 0; k < steps; ++k) {
    const double t0 = k * h, t1 = (k + 1) * h, om0 = load.speed(t0), om1 = load.speed(t1);
    std::fill(f1.begin(), f1.end(), 0.0);
    a.add_unbalance(om1, load.acceleration(t1), load.angle(t1), f1.data());
    // rhs = (1+al) f1 - al f0 + M (a0 x + a2 v + a3 acc) + (1+al) D1 (a1 x + a4 v + a5 acc)
    //       + al (D0 v + K x)
    for (std::size_t i = 0; i < nn; ++i) w[i] = a0 * x[i] + a2 * v[i] + a3 * acc[i];
    a.apply(1.0, 0.0, 0.0, 0.0, w.data(), rhs.data());
    for (std::size_t i = 0; i < nn; ++i) {
      rhs[i] += (1.0 + al) * f1[i] - al * f0[i];
      w[i] = a1 * x[i] + a4 * v[i] + a5 * acc[i];
    }
    a.apply(0.0, 1.0 + al, 0.0, om1, w.data(), tmp.data());
    for (std::size_t i = 0; i < nn; ++i) rhs[i] += tmp[i];
    if (al != 0.0) {
      a.apply(0.0, al, 0.0, om0, v.data(), tmp.data());
      for (std::size_t i = 0; i < nn; ++i) rhs[i] += tmp[i];
      a.apply(0.0, 0.0, al, 0.0, x.data(), tmp.data());
      for (std::size_t i = 0; i < nn; ++i) rhs[i] += tmp[i];
    }
    solver->factor(a0, (1.0 + al) * a1, 1.0 + al, om1);
    solver->solve(rhs.data(), xn.data());
    bool finite = true;
    for (std::size_t i = 0; i < nn; ++i) {
      const double an = a0 * (xn[i] - x[i]) - a2 * v[i] - a3 * acc[i];
      v[i] += h * ((1.0 - gam) * acc[i] + gam * an);
      acc[i] = an;
      x[i] = xn[i];
      finite = finite && std::isfinite(xn[i]);
    }
    MORSE_CHECK(finite, "rampup: the state is not finite at t = ", t1, " s (step ", k + 1, ")");
    if (twist) twist->step(om1, load.acceleration(t1), h, a0, a1, a2, a3, a4, a5, gam, al);
    f0.swap(f1);
    ++st.steps;
    if ((k + 1) % s.output_every == 0 || k + 1 == steps) emit(k + 1, t1);
  }
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return st;
}

}  // namespace morse::rampup
