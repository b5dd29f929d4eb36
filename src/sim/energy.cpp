// The energy balance of central differences (morse/sim/sim.hpp, EnergyWork).
#include <algorithm>
#include <cmath>

#include "morse/core/error.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/sim/sim.hpp"
#include "sim/contact.hpp"

namespace morse::sim {

namespace {
// v^T M v / 2 + q_a^T K q_b / 2, v = (q_b - q_a) / h.
double quadratic_energy(const nlrom::ReducedModel& m, const double* qa, const double* qb, double h) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  std::vector<double> v(r);
  for (std::size_t i = 0; i < r; ++i) v[i] = (qb[i] - qa[i]) / h;
  double e = 0.0;
  for (std::size_t i = 0; i < r; ++i) {
    double mv = 0.0, kq = 0.0;
    for (std::size_t j = 0; j < r; ++j) mv += m.M[i * r + j] * v[j], kq += m.K[i * r + j] * qb[j];
    e += 0.5 * (v[i] * mv + qa[i] * kq);
  }
  return e;
}
}  // namespace

double discrete_energy(const nlrom::ReducedModel& m, const double* qa, const double* qb, double h,
                       const CubicKernelBatch& potential) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  MORSE_CHECK(potential.r() == r, "energy: a potential kernel of r = ", potential.r(), " for a model of r = ", r);
  std::vector<double> q(r);
  for (std::size_t i = 0; i < r; ++i) q[i] = 0.5 * (qa[i] + qb[i]);
  return quadratic_energy(m, qa, qb, h) + potential.potential(q.data());
}

double discrete_energy(const nlrom::ReducedModel& m, const double* qa, const double* qb, double h, bool nonlinear) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  double e = quadratic_energy(m, qa, qb, h);
  if (nonlinear) {
    std::vector<double> q(r), qn(r), gp(r), gm(r);
    for (std::size_t i = 0; i < r; ++i) q[i] = 0.5 * (qa[i] + qb[i]), qn[i] = -q[i];
    m.g.evaluate(q.data(), gp.data());
    m.g.evaluate(qn.data(), gm.data());
    for (std::size_t i = 0; i < r; ++i) e += q[i] * ((gp[i] + gm[i]) / 6.0 + (gp[i] - gm[i]) / 8.0);
  }
  return e;
}

double StepState::balance_energy() const {
  MORSE_CHECK(energy_qa && energy_qb && model, "simulate: no energy balance in this run");
  return discrete_energy(*model, energy_qa, energy_qb, dt, nonlinear);
}

namespace detail {

EnergyLedger::EnergyLedger(const nlrom::ReducedModel& m, const ContactSettings* contact, double h)
    : r_(static_cast<std::size_t>(m.r)), h_(h), d_(r_) {
  double cmax = 0.0;
  for (double c : m.C) cmax = std::max(cmax, std::abs(c));
  if (cmax > 0) {
    std::vector<double> I(r_ * r_, 0.0), X;
    for (std::size_t i = 0; i < r_; ++i) I[i * r_ + i] = 1.0;
    const auto c = eigen::dense_eigenvalues(static_cast<int>(r_), m.C, I, &X);
    std::vector<std::size_t> keep;
    for (std::size_t k = 0; k < r_; ++k)
      if (std::abs(c[k]) > 1e-14 * cmax) keep.push_back(k), cv_.push_back(c[k]);
    // cw_[i][j] = component i of eigenvector keep[j]: y = W^T d is then a sum of columns scaled by
    // d_i, whose inner loop over j has no reduction (it vectorizes).
    for (std::size_t i = 0; i < r_; ++i)
      for (std::size_t k : keep) cw_.push_back(X[i * r_ + k]);
    y_.assign(cv_.size(), 0.0);
  }
  if (contact && !contact->nodes.empty()) {
    normals_ = contact_normals(*contact);
    for (const auto& n : contact->nodes) dofs_.push_back(n.dof);
  }
}

void EnergyLedger::add(const double* qm, const double* qp, const std::vector<ReducedLoad>& loads, double t,
                       const double* lam, const double* fric) {
  for (std::size_t i = 0; i < r_; ++i) d_[i] = 0.5 * (qp[i] - qm[i]);
  for (const auto& l : loads) {
    const double c = l.factor(t);
    double x = 0.0;
    for (std::size_t i = 0; i < r_; ++i) x += l.p[i] * d_[i];
    w_.external += c * x;
  }
  if (const std::size_t nk = cv_.size(); nk > 0) {  // d^T C d / h = sum_k c_k (w_k . d)^2 / h
    double* __restrict y = y_.data();
    for (std::size_t k = 0; k < nk; ++k) y[k] = 0.0;
    for (std::size_t i = 0; i < r_; ++i) {
      const double di = d_[i];
      const double* __restrict w = &cw_[i * nk];
      for (std::size_t k = 0; k < nk; ++k) y[k] += w[k] * di;
    }
    double x = 0.0;
    for (std::size_t k = 0; k < nk; ++k) x += cv_[k] * y[k] * y[k];
    w_.damping += x / h_;
  }
  if (!lam) return;
  for (std::size_t k = 0; k < dofs_.size(); ++k) {
    const double* d = &d_[dofs_[k]];
    const double* n = &normals_[3 * k];
    const double* f = &fric[3 * k];
    w_.normal += lam[k] * (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
    w_.friction += f[0] * d[0] + f[1] * d[1] + f[2] * d[2];
  }
}

}  // namespace detail

}  // namespace morse::sim
