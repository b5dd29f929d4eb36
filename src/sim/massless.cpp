// Central differences on massless-boundary models (see sim/massless.hpp).
#include "sim/massless.hpp"

#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "morse/core/error.hpp"

namespace morse::sim::detail {

namespace {

// max_i sum_j |A_ij| of an n x n row-major matrix.
double max_row_sum(const std::vector<double>& A, std::size_t n) {
  double m = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    double s = 0.0;
    for (std::size_t j = 0; j < n; ++j) s += std::abs(A[i * n + j]);
    m = std::max(m, s);
  }
  return m;
}

}  // namespace

void massless_step_operators(const nlrom::ReducedModel& m, double h, std::vector<double>* P1, std::vector<double>* P2,
                             std::vector<double>* P3) {
  const std::size_t r = static_cast<std::size_t>(m.r), nb = static_cast<std::size_t>(m.n_static), ni = r - nb;
  std::vector<double> Di(ni * ni);
  for (std::size_t i = 0; i < ni; ++i)
    for (std::size_t j = 0; j < ni; ++j)
      Di[i * ni + j] = 2.0 * m.M[(nb + i) * r + nb + j] + h * m.C[(nb + i) * r + nb + j];
  Di = inverse(Di, ni, "simulate: the internal mass of the massless model is singular");
  P1->assign(r * r, 0.0), P2->assign(r * r, 0.0), P3->assign(r * r, 0.0);
  for (std::size_t b = 0; b < nb; ++b) (*P1)[b * r + b] = 2.0, (*P2)[b * r + b] = -1.0;  // u_b extrapolated
  for (std::size_t i = 0; i < ni; ++i) {
    const double* di = &Di[i * ni];
    for (std::size_t c = 0; c < r; ++c) {  // P1 = Di (4M - 2h^2 K) over every column, P2 = Di (hC - 2M)
      double a = 0.0, b = 0.0;
      for (std::size_t k = 0; k < ni; ++k) {
        const std::size_t row = (nb + k) * r + c;
        a += di[k] * (4.0 * m.M[row] - 2.0 * h * h * m.K[row]);
        b += di[k] * (h * m.C[row] - 2.0 * m.M[row]);
      }
      (*P1)[(nb + i) * r + c] = a;
      (*P2)[(nb + i) * r + c] = b;
    }
    for (std::size_t k = 0; k < ni; ++k) (*P3)[(nb + i) * r + nb + k] = 2.0 * h * h * di[k];
  }
}

void check_contact_on_boundary(const nlrom::ReducedModel& m, const ContactSettings& c) {
  for (const auto& node : c.nodes)
    MORSE_CHECK(node.dof + 3 <= static_cast<std::size_t>(m.n_b), "simulate: contact node DOF ", node.dof,
                " is not a boundary coordinate of the massless model (", m.n_b,
                " boundary coordinates): contact nodes must belong to the boundary set");
}

std::shared_ptr<CubicKernel> MasslessBoundary::raw_kernel(const nlrom::ReducedModel& m) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  std::vector<double> I(r * r, 0.0);
  for (std::size_t i = 0; i < r; ++i) I[i * r + i] = 1.0;
  return std::make_shared<CubicKernel>(m.g, I, KernelLayout::Auto);
}

MasslessBoundary::MasslessBoundary(const nlrom::ReducedModel& m, const ContactSettings* contact, double t_final,
                                   bool nonlinear, std::shared_ptr<CubicKernel> g,
                                   std::shared_ptr<TangentKernel> tangent)
    : r_(static_cast<std::size_t>(m.r)),
      nb_(static_cast<std::size_t>(m.n_static)),
      nonlinear_(nonlinear),
      g_(std::move(g)),
      tangent_(std::move(tangent)) {
  MORSE_CHECK(m.massless && nb_ > 0 && nb_ < r_, "simulate: not a massless-boundary model");
  const std::size_t ni = r_ - nb_;
  Kbb_.assign(nb_ * nb_, 0.0);
  for (std::size_t a = 0; a < nb_; ++a)
    for (std::size_t b = 0; b < nb_; ++b) Kbb_[a * nb_ + b] = m.K[a * r_ + b];
  D_ = inverse(Kbb_, nb_,
               "simulate: the stiffness K_ss of the static coordinates of the massless model is singular: a boundary "
               "node has no stiffness (an isolated node)");
  norm_D_ = max_row_sum(D_, nb_);
  Kbi_.assign(nb_ * ni, 0.0);
  for (std::size_t a = 0; a < nb_; ++a)
    for (std::size_t i = 0; i < ni; ++i) Kbi_[a * ni + i] = m.K[a * r_ + nb_ + i];
  if (nonlinear_) {
    if (!g_) g_ = raw_kernel(m);
    if (!tangent_) tangent_ = std::make_shared<TangentKernel>(m.g);
    g_val_.assign(r_, 0.0);
    J_.assign(r_ * r_, 0.0);
  }
  if (contact && !contact->nodes.empty()) {
    check_contact_on_boundary(m, *contact);
    P_.assign(r_ * r_, 0.0);  // the compliance on the boundary rows
    for (std::size_t a = 0; a < nb_; ++a)
      for (std::size_t b = 0; b < nb_; ++b) P_[a * r_ + b] = D_[a * nb_ + b];
    contact_.emplace(*contact, P_, r_, t_final);
  }
  rhs_.assign(nb_, 0.0), base_.assign(nb_, 0.0), last_.assign(nb_, 0.0);
}

void MasslessBoundary::update_tangent(const double* q) {
  tangent_->apply(q, g_val_.data(), J_.data());
  std::vector<double> Kt(Kbb_);
  for (std::size_t a = 0; a < nb_; ++a)
    for (std::size_t b = 0; b < nb_; ++b) Kt[a * nb_ + b] += 0.5 * (J_[a * r_ + b] + J_[b * r_ + a]);
  try {
    D_ = inverse(Kt, nb_, "tangent");
  } catch (const Error&) {
    return;  // a singular tangent (a limit point): keep the previous compliance
  }
  ++tangent_updates_;
  norm_D_ = max_row_sum(D_, nb_);
  if (contact_) {
    for (std::size_t a = 0; a < nb_; ++a)
      for (std::size_t b = 0; b < nb_; ++b) P_[a * r_ + b] = D_[a * nb_ + b];
    contact_->set_compliance(P_);
  }
}

void MasslessBoundary::solve(double* q, const double* qm, double h, double t, const double* fb) {
  const std::size_t ni = r_ - nb_;
  const double* eta = q + nb_;
  for (std::size_t a = 0; a < nb_; ++a) {  // f_b - K_bi eta, fixed during the iteration
    double x = fb ? fb[a] : 0.0;
    const double* k = &Kbi_[a * ni];
    for (std::size_t i = 0; i < ni; ++i) x -= k[i] * eta[i];
    base_[a] = x;
  }
  constexpr int kMaxIt = 100;
  double change = 0.0, prev_change = std::numeric_limits<double>::infinity();
  for (int it = 0; it < kMaxIt; ++it) {
    ++iterations_;
    if (nonlinear_) g_->apply(q, g_val_.data());  // at the current iterate
    // R = K_bb u + g_b - (f_b - K_bi eta); u_free = u - D R.
    double force = 0.0;  // the size of the forces in R, for the round-off level of the iterate
    for (std::size_t a = 0; a < nb_; ++a) {
      const double ga = nonlinear_ ? g_val_[a] : 0.0;
      double ku = 0.0;
      const double* k = &Kbb_[a * nb_];
      for (std::size_t b = 0; b < nb_; ++b) ku += k[b] * q[b];
      rhs_[a] = ku + ga - base_[a];
      last_[a] = q[a];
      force = std::max({force, std::abs(ku), std::abs(ga), std::abs(base_[a])});
    }
    for (std::size_t a = 0; a < nb_; ++a) {
      double u = 0.0;
      const double* d = &D_[a * nb_];
      for (std::size_t b = 0; b < nb_; ++b) u += d[b] * rhs_[b];
      q[a] = last_[a] - u;
    }
    if (contact_) contact_->correct(q, qm, h, t);
    if (!nonlinear_) return;
    double size = 0.0;
    change = 0.0;
    for (std::size_t a = 0; a < nb_; ++a)
      size = std::max(size, std::abs(q[a])), change = std::max(change, std::abs(q[a] - last_[a]));
    // Converged: a change of 1e-10, or one at the round-off level of the update D R, whose terms
    // (K_bb u, g_b, f_b - K_bi eta) cancel: 64 eps ||D|| max|term| (measured on rotor 37 with
    // modal derivatives: a floor of 1e-7 to 4e-7 of the boundary displacement), or a change that
    // stopped falling below 1e-6.
    const double noise = 64.0 * std::numeric_limits<double>::epsilon() * norm_D_ * force;
    if (change <= std::max(1e-10 * size, noise) || size == 0.0) return;
    if (it >= 2 && change >= 0.5 * prev_change && change <= 1e-6 * size) return;
    if (it >= 1 && change > 0.1 * prev_change && change > 10.0 * noise) update_tangent(q);  // slow: the tangent here
    prev_change = change;
  }
  throw Error(cat("simulate: the static equilibrium of the massless boundary did not converge in ", kMaxIt,
                  " iterations at t = ", t, " (last change ", change,
                  " of the static coordinates, with the tangent): the boundary has reached a limit point"));
}

void integrate_massless(const nlrom::ReducedModel& m, const std::vector<ReducedLoad>& loads, const Settings& s,
                        const std::vector<double>& P1, const std::vector<double>& P2,
                        const std::vector<std::vector<double>>& lp, const CubicKernel* kernel,
                        const std::function<void(const StepState&)>& callback, Stats* st) {
  const std::size_t r = static_cast<std::size_t>(m.r), nb = static_cast<std::size_t>(m.n_static), ni = r - nb;
  const double h = s.dt;
  const bool nonlinear = kernel != nullptr;
  MasslessBoundary boundary(m, &s.contact, s.t_final, nonlinear);
  std::vector<double> fb(nb, 0.0);
  auto boundary_load = [&](double t) {
    std::fill(fb.begin(), fb.end(), 0.0);
    for (const auto& l : loads)
      for (std::size_t a = 0; a < nb; ++a) fb[a] += l.factor(t) * l.p[a];
  };

  std::vector<double> qm(r), q, v;
  initial_state(s, r, &q, &v);
  // The boundary of the initial state is the equilibrium of eta_0 (a given u_b is replaced).
  for (std::size_t a = 0; a < nb; ++a) qm[a] = q[a] - h * v[a];
  boundary_load(0.0);
  boundary.solve(q.data(), qm.data(), h, 0.0, fb.data());
  {  // eta_{-1} = eta_0 - h v_0 + h^2/2 a_0, a_0 = M_ii^-1 (f_i - C_ii v_i - K_i: q - g_i(q_0))
    std::vector<double> rhs(ni, 0.0), gq(r, 0.0);
    if (nonlinear) m.g.evaluate(q.data(), gq.data());
    for (std::size_t i = 0; i < ni; ++i) {
      double x = -gq[nb + i];
      for (const auto& l : loads) x += l.factor(0.0) * l.p[nb + i];
      for (std::size_t j = 0; j < r; ++j) x -= m.K[(nb + i) * r + j] * q[j] + m.C[(nb + i) * r + j] * v[j];
      rhs[i] = x;
    }
    std::vector<double> Mii(ni * ni);
    for (std::size_t i = 0; i < ni; ++i)
      for (std::size_t j = 0; j < ni; ++j) Mii[i * ni + j] = m.M[(nb + i) * r + nb + j];
    const auto Minv = inverse(Mii, ni, "simulate: the internal mass of the massless model is singular");
    for (std::size_t i = 0; i < ni; ++i) {
      double a = 0.0;
      for (std::size_t j = 0; j < ni; ++j) a += Minv[i * ni + j] * rhs[j];
      qm[nb + i] = q[nb + i] - h * v[nb + i] + 0.5 * h * h * a;
    }
  }
  Corrector corr;
  corr.correct = [&](double* qp, const double* qmm, double t) {
    boundary_load(t);
    boundary.solve(qp, qmm, h, t, fb.data());
  };
  if (boundary.has_contact()) {
    corr.nodes = s.contact.nodes.size();
    corr.normal = [&] { return boundary.normal(); };
    corr.friction = [&] { return boundary.friction(); };
    corr.gap = [&] { return boundary.gap(); };
    corr.active = [&] { return boundary.active(); };
    corr.initial_forces = true;  // the initial equilibrium's
    corr.forces_of_state = true;
    corr.contact = &s.contact;
  }
  central_loop(m, loads, s, P1, P2, lp, kernel, corr, std::move(q), std::move(qm), std::move(v), callback, st);
  st->boundary_iterations = boundary.iterations();
  st->tangent_updates = boundary.tangent_updates();
}

}  // namespace morse::sim::detail
