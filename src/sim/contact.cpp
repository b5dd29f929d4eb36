// Forward-increment Lagrange-multiplier contact for central differences (see contact.hpp).
//
// With the predictor q* (eq. 41) and P = (M~/h^2 + C~/2h)^-1, a force f_c on the contact DOFs
// moves the state by P f_c (eq. 42). For the active nodes A, each carrying lambda_k along its
// force direction d_k = n - mu t_k (t_k: unit sliding direction of the predictor), the corrected
// gap of node c is  g*_c + sum_k n^T P_ck d_k lambda_k, and W lambda = -g*_A makes every gap of A
// zero. Nodes with lambda < 0 (adhesion) leave A, one at a time (the most negative first), and
// the system is solved again; nodes without penetration never enter.
#include "sim/contact.hpp"

#include <petscsys.h>
#include <petscblaslapack.h>

#include <cmath>

#include "morse/core/error.hpp"

namespace morse::sim::detail {

ContactSolver::ContactSolver(const ContactSettings& c, const std::vector<double>& P, std::size_t r)
    : c_(c), r_(r), n_(c.nodes.size()) {
  const double* nv = c.plane.normal;
  const double nn = std::sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
  MORSE_CHECK(nn > 0 && std::abs(nn - 1.0) < 1e-12, "contact: the plane normal must be a unit vector (norm ", nn, ")");
  MORSE_CHECK(c.mu >= 0 && std::isfinite(c.mu), "contact: the friction coefficient must be >= 0 (got ", c.mu, ")");
  for (const auto& node : c.nodes)
    MORSE_CHECK(node.dof + 3 <= r, "contact: node DOF ", node.dof, " is outside the reduced coordinates (r = ", r, ")");
  for (int d = 0; d < 3; ++d) offset_ += c.plane.point[d] * nv[d];
  Pc_.assign(r * 3 * n_, 0.0);
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t k = 0; k < n_; ++k)
      for (int d = 0; d < 3; ++d) Pc_[i * 3 * n_ + 3 * k + d] = P[i * r + c.nodes[k].dof + d];
  lam_.assign(n_, 0.0);
  fric_.assign(3 * n_, 0.0);
  gap_.assign(n_, 0.0);
  dir_.assign(3 * n_, 0.0);
  act_.assign(n_, 0);
}

void ContactSolver::correct(double* qp, const double* qm, double h) {
  const double* nv = c_.plane.normal;
  std::fill(lam_.begin(), lam_.end(), 0.0);
  std::fill(fric_.begin(), fric_.end(), 0.0);
  std::vector<std::size_t> A;
  for (std::size_t k = 0; k < n_; ++k) {
    const auto& node = c_.nodes[k];
    double g = -offset_, vt[3], vn = 0.0;
    for (int d = 0; d < 3; ++d) {
      g += (node.x[d] + qp[node.dof + d]) * nv[d];
      vt[d] = (qp[node.dof + d] - qm[node.dof + d]) / (2.0 * h);
      vn += vt[d] * nv[d];
    }
    gap_[k] = g;
    // Sliding direction: the tangential part of the predicted velocity.
    double tn = 0.0;
    for (int d = 0; d < 3; ++d) {
      vt[d] -= vn * nv[d];
      tn += vt[d] * vt[d];
    }
    tn = std::sqrt(tn);
    for (int d = 0; d < 3; ++d) dir_[3 * k + d] = nv[d] - (tn > 0.0 ? c_.mu * vt[d] / tn : 0.0);
    if (g < 0.0) A.push_back(k);
  }
  while (!A.empty()) {
    const std::size_t na = A.size();
    W_.assign(na * na, 0.0);
    rhs_.assign(na, 0.0);
    for (std::size_t a = 0; a < na; ++a) {
      const auto& ca = c_.nodes[A[a]];
      rhs_[a] = -gap_[A[a]];
      for (std::size_t b = 0; b < na; ++b) {
        double w = 0.0;  // n^T P(dof_a, dof_b) d_b
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) w += nv[i] * Pc_[(ca.dof + i) * 3 * n_ + 3 * A[b] + j] * dir_[3 * A[b] + j];
        W_[b * na + a] = w;  // column-major for LAPACK
      }
    }
    PetscBLASInt nn = static_cast<PetscBLASInt>(na), one = 1, info = 0;
    std::vector<PetscBLASInt> piv(na);
    LAPACKgesv_(&nn, &one, W_.data(), &nn, piv.data(), rhs_.data(), &nn, &info);
    MORSE_CHECK(info == 0, "contact: singular contact compliance (LAPACK gesv info ", info, ")");
    std::size_t worst = na;
    for (std::size_t a = 0; a < na; ++a)
      if (rhs_[a] < 0.0 && (worst == na || rhs_[a] < rhs_[worst])) worst = a;
    if (worst == na) {
      for (std::size_t a = 0; a < na; ++a) lam_[A[a]] = rhs_[a];
      break;
    }
    A.erase(A.begin() + static_cast<std::ptrdiff_t>(worst));
  }
  active_ = 0;
  for (std::size_t k = 0; k < n_; ++k) {
    if (lam_[k] == 0.0) continue;
    ++active_;
    for (int d = 0; d < 3; ++d) fric_[3 * k + d] = lam_[k] * (dir_[3 * k + d] - nv[d]);
    for (std::size_t i = 0; i < r_; ++i) {
      const double* pc = &Pc_[i * 3 * n_ + 3 * k];
      qp[i] += lam_[k] * (pc[0] * dir_[3 * k] + pc[1] * dir_[3 * k + 1] + pc[2] * dir_[3 * k + 2]);
    }
  }
  for (std::size_t k = 0; k < n_; ++k) {  // gaps of the corrected state
    double g = -offset_;
    for (int d = 0; d < 3; ++d) g += (c_.nodes[k].x[d] + qp[c_.nodes[k].dof + d]) * nv[d];
    gap_[k] = g;
  }
}

}  // namespace morse::sim::detail
