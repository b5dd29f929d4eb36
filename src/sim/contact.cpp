// Forward-increment Lagrange-multiplier contact for central differences (see contact.hpp).
//
// With the predictor q* (eq. 41) and P = (M~/h^2 + C~/2h)^-1, a force f_c on the contact DOFs
// moves the state by P f_c (eq. 42). For the active nodes A, each carrying lambda_k along its
// force direction d_k = n - mu t_k (t_k: unit sliding direction of the predictor), the corrected
// gap of node c is  g*_c + sum_k n^T P_ck d_k lambda_k, and W lambda = -g*_A makes every gap of A
// zero. Nodes with lambda < 0 (adhesion) leave A, one at a time (the most negative first), and
// the system is solved again; a node that the correction itself pushes into the obstacle joins A
// (the deepest first), until neither kind of node is left.
#include "sim/contact.hpp"

#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>

#include "morse/core/error.hpp"

namespace morse::sim {

std::vector<ContactNode> contact_nodes(const nlrom::StoredModel& sm, const std::string& set) {
  const auto pos = sm.boundary_translations(set);
  const auto& rows = sm.sets.at(set);
  std::vector<ContactNode> out;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ContactNode n;
    n.dof = pos[i];
    for (int d = 0; d < 3; ++d) n.x[d] = sm.coords[3 * rows[i] + d];
    out.push_back(n);
  }
  return out;
}

std::vector<double> contact_normals(const ContactSettings& c) {
  const std::size_t n = c.nodes.size();
  std::vector<double> normal(3 * n, 0.0);
  if (c.obstacle == Obstacle::Plane) {
    const double* nv = c.plane.normal;
    const double nn = std::sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
    MORSE_CHECK(nn > 0 && std::abs(nn - 1.0) < 1e-12, "contact: the plane normal must be a unit vector (norm ", nn,
                ")");
    for (std::size_t k = 0; k < n; ++k)
      for (int d = 0; d < 3; ++d) normal[3 * k + d] = nv[d];
  } else {
    for (std::size_t k = 0; k < n; ++k) {
      const double* x = c.nodes[k].x;
      const double rho = std::hypot(x[0], x[1]);
      MORSE_CHECK(rho > 0, "contact: casing contact node ", k, " lies on the rotation axis");
      normal[3 * k] = -x[0] / rho, normal[3 * k + 1] = -x[1] / rho;  // -e_r
    }
  }
  return normal;
}

}  // namespace morse::sim

namespace morse::sim::detail {

ContactSolver::ContactSolver(const ContactSettings& c, const std::vector<double>& P, std::size_t r, double t_final)
    : c_(c), r_(r), n_(c.nodes.size()) {
  MORSE_CHECK(c.mu >= 0 && std::isfinite(c.mu), "contact: the friction coefficient must be >= 0 (got ", c.mu, ")");
  for (const auto& node : c.nodes)
    MORSE_CHECK(node.dof + 3 <= r, "contact: node DOF ", node.dof, " is outside the reduced coordinates (r = ", r, ")");
  normal_ = contact_normals(c);
  slide_.assign(3 * n_, 0.0);
  omega_rho_.assign(3 * n_, 0.0);
  theta0_.assign(n_, 0.0);
  if (c.obstacle == Obstacle::Casing) {
    const auto& cs = c.casing;
    MORSE_CHECK(cs.clearance > 0 && cs.bump_height >= 0 && cs.lobes > 0 && cs.width > 0 && cs.alpha >= 0,
                "contact: the casing needs clearance > 0, bump height >= 0, lobes > 0, width > 0, alpha >= 0");
    alpha_ = cs.alpha > 0 ? cs.alpha : std::log(100.0) / (0.2 * t_final);
    const double sgn = cs.omega >= 0 ? 1.0 : -1.0;
    for (std::size_t k = 0; k < n_; ++k) {
      const double* x = c.nodes[k].x;
      const double rho = std::hypot(x[0], x[1]);
      slide_[3 * k] = -sgn * x[1] / rho, slide_[3 * k + 1] = sgn * x[0] / rho;        // sign(omega) e_theta
      omega_rho_[3 * k] = -cs.omega * x[1], omega_rho_[3 * k + 1] = cs.omega * x[0];  // omega e_z x x_k
      theta0_[k] = std::atan2(x[1], x[0]) + cs.phase;  // the lobes' angle at t = 0 folded in
    }
  }
  set_compliance(P);
  lam_.assign(n_, 0.0);
  fric_.assign(3 * n_, 0.0);
  gap_.assign(n_, 0.0);
  dir_.assign(3 * n_, 0.0);
  in_set_.assign(n_, 0);
  set_.reserve(n_ + 1);
  piv_.assign(n_ + 1, 0);
  W_.reserve(n_ * n_);
  rhs_.reserve(n_);
}

void ContactSolver::set_compliance(const std::vector<double>& P) {
  Pc_.assign(r_ * 3 * n_, 0.0);
  for (std::size_t i = 0; i < r_; ++i)
    for (std::size_t k = 0; k < n_; ++k)
      for (int d = 0; d < 3; ++d) Pc_[i * 3 * n_ + 3 * k + d] = P[i * r_ + c_.nodes[k].dof + d];
}

double ContactSolver::gap_of(std::size_t k, const double* q, double t) const {
  const auto& node = c_.nodes[k];
  const double* nv = &normal_[3 * k];
  double g = 0.0;
  if (c_.obstacle == Obstacle::Plane) {
    for (int d = 0; d < 3; ++d) g += (node.x[d] + q[node.dof + d] - c_.plane.point[d]) * nv[d];
    return g;
  }
  const auto& cs = c_.casing;
  const double period = 2.0 * M_PI / cs.lobes;
  double theta = std::fmod(theta0_[k] + cs.omega * t, period);
  if (theta < 0) theta += period;
  const double z = (theta - 0.5 * period) / cs.width;
  const double f = cs.bump_height * std::exp(-z * z);
  g = cs.clearance - (cs.grown ? 1.0 : 1.0 - std::exp(-alpha_ * t)) * f;
  for (int d = 0; d < 3; ++d) g += q[node.dof + d] * nv[d];  // - u_r
  return g;
}

void ContactSolver::correct(double* qp, const double* qm, double h, double t) {
  std::fill(lam_.begin(), lam_.end(), 0.0);
  std::fill(fric_.begin(), fric_.end(), 0.0);
  auto& A = set_;  // active nodes (member storage: no allocation per step)
  A.clear();
  std::fill(in_set_.begin(), in_set_.end(), 0);
  for (std::size_t k = 0; k < n_; ++k) {
    const auto& node = c_.nodes[k];
    const double* nv = &normal_[3 * k];
    gap_[k] = gap_of(k, qp, t);
    double tv[3] = {slide_[3 * k], slide_[3 * k + 1], slide_[3 * k + 2]};
    const bool relative = c_.obstacle == Obstacle::Plane || c_.sliding == Sliding::Relative;
    if (relative) {  // sliding direction: the tangential predicted velocity relative to the obstacle
      double vn = 0.0;
      for (int d = 0; d < 3; ++d) {
        tv[d] = (qp[node.dof + d] - qm[node.dof + d]) / (2.0 * h);
        if (c_.obstacle == Obstacle::Casing) tv[d] += omega_rho_[3 * k + d];  // + omega e_z x x_k
        vn += tv[d] * nv[d];
      }
      double tn = 0.0;
      for (int d = 0; d < 3; ++d) {
        tv[d] -= vn * nv[d];
        tn += tv[d] * tv[d];
      }
      tn = std::sqrt(tn);
      for (int d = 0; d < 3; ++d) tv[d] = tn > 0.0 ? tv[d] / tn : 0.0;
    }
    for (int d = 0; d < 3; ++d) dir_[3 * k + d] = nv[d] - c_.mu * tv[d];
    if (gap_[k] < 0.0) A.push_back(k), in_set_[k] = 1;
  }
  // Active-set iteration: drop the most adhesive node (lambda < 0), or add the node that the
  // correction pushes deepest into the obstacle, until neither exists.
  double gscale = 0.0;
  for (double g : gap_) gscale = std::max(gscale, std::abs(g));
  const double tol = 1e-12 * gscale;
  auto coupling = [&](std::size_t a, std::size_t b) {  // n_a^T P(dof_a, dof_b) d_b
    const auto& ca = c_.nodes[a];
    const double* nv = &normal_[3 * a];
    double w = 0.0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) w += nv[i] * Pc_[(ca.dof + i) * 3 * n_ + 3 * b + j] * dir_[3 * b + j];
    return w;
  };
  bool settled = A.empty();
  for (std::size_t iter = 0; iter < 4 * n_ + 4 && !settled; ++iter) {
    const std::size_t na = A.size();
    if (na == 0) {
      settled = true;
      break;
    }
    W_.assign(na * na, 0.0);
    rhs_.assign(na, 0.0);
    for (std::size_t a = 0; a < na; ++a) {
      rhs_[a] = -gap_[A[a]];
      for (std::size_t b = 0; b < na; ++b) W_[b * na + a] = coupling(A[a], A[b]);  // column-major
    }
    PetscBLASInt nn = static_cast<PetscBLASInt>(na), one = 1, info = 0;
    LAPACKgesv_(&nn, &one, W_.data(), &nn, piv_.data(), rhs_.data(), &nn, &info);
    MORSE_CHECK(info == 0, "contact: singular contact compliance (LAPACK gesv info ", info, ")");
    std::size_t worst = na;
    for (std::size_t a = 0; a < na; ++a)
      if (rhs_[a] < 0.0 && (worst == na || rhs_[a] < rhs_[worst])) worst = a;
    if (worst != na) {
      in_set_[A[worst]] = 0;
      A.erase(A.begin() + static_cast<std::ptrdiff_t>(worst));
      continue;
    }
    // Gaps of the inactive nodes after this correction.
    std::size_t add = n_;
    double deepest = -tol;
    for (std::size_t k = 0; k < n_; ++k) {
      if (in_set_[k]) continue;
      double g = gap_[k];
      for (std::size_t a = 0; a < na; ++a) g += coupling(k, A[a]) * rhs_[a];
      if (g < deepest) deepest = g, add = k;
    }
    if (add == n_) {
      for (std::size_t a = 0; a < na; ++a) lam_[A[a]] = rhs_[a];
      settled = true;
      break;
    }
    A.push_back(add);
    in_set_[add] = 1;
  }
  MORSE_CHECK(settled, "contact: the active set did not settle in ", 4 * n_ + 4, " iterations at t = ", t,
              " (cycling between contact states); reduce -sim_dt");
  active_ = 0;
  for (std::size_t k = 0; k < n_; ++k) {
    if (lam_[k] == 0.0) continue;
    ++active_;
    for (int d = 0; d < 3; ++d) fric_[3 * k + d] = lam_[k] * (dir_[3 * k + d] - normal_[3 * k + d]);
    for (std::size_t i = 0; i < r_; ++i) {
      const double* pc = &Pc_[i * 3 * n_ + 3 * k];
      qp[i] += lam_[k] * (pc[0] * dir_[3 * k] + pc[1] * dir_[3 * k + 1] + pc[2] * dir_[3 * k + 2]);
    }
  }
  for (std::size_t k = 0; k < n_; ++k) gap_[k] = gap_of(k, qp, t);  // of the corrected state
}

}  // namespace morse::sim::detail

namespace morse::sim {

double divergence_radius(const ContactSettings& c) {
  double r = 0.0;
  for (const auto& n : c.nodes) r = std::max(r, std::hypot(n.x[0], n.x[1]));
  return r;
}

}  // namespace morse::sim
