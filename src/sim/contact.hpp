// Private to src/sim: the Lagrange-multiplier contact correction of central differences (see
// morse/sim/sim.hpp, ContactSettings).
#pragma once

#include <vector>

#include "morse/sim/sim.hpp"

namespace morse::sim::detail {

class ContactSolver {
 public:
  /// P = (M~/h^2 + C~/2h)^-1 (r x r, row-major), the operator of eq. 42.
  ContactSolver(const ContactSettings& c, const std::vector<double>& P, std::size_t r);
  /// Corrects the predictor qp in place (qm = q_{n-1}, for the sliding velocity, h the step) and
  /// records the forces and gaps of the new state.
  void correct(double* qp, const double* qm, double h);
  const double* normal() const { return lam_.data(); }
  const double* friction() const { return fric_.data(); }
  const double* gap() const { return gap_.data(); }
  int active() const { return active_; }

 private:
  const ContactSettings& c_;
  std::size_t r_, n_;
  std::vector<double> Pc_;    // r x 3n: the columns of P at the contact DOFs
  double offset_ = 0.0;       // point . normal
  std::vector<double> lam_, fric_, gap_, dir_, W_, rhs_;
  std::vector<int> act_;
  int active_ = 0;
};

}  // namespace morse::sim::detail
