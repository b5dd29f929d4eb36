// morse/eval/indicator.hpp: the performance indicator of seed 003 (eq. 43–51), comparing a
// full-order response u_FOM(t) with a reduced one u_ROM(t) = Phi q(t):
//
//   e1 = (x1^T x2)^2 / ((x1^T x1)(x2^T x2)),  x = u(t_max)        covariance (eq. 44)
//   e2 = max(0, 1 - ||E_FOM - E_ROM|| / ||E_FOM||)                 energy, eq. 46 (eq. 45, 47)
//   e3 = max(0, 1 - sqrt(mean_i ((o_i^FOM - o_i^ROM) / o_i^FOM)^2)), o_i = max_t u_i - min_t u_i
//        over the 3 N_tip tip DOFs                                  peak-to-peak (eq. 48–49)
//   e4 = max(0, 1 - ||u_tip^FOM - u_tip^ROM|| / ||u_tip^FOM||)     tip displacement (eq. 50–51)
//   I  = sum w_i e_i  (eq. 43; w_i = 1/4 by default)
//
// Norms over time are discrete sums over the common time samples. Pure functions of arrays:
// eval/compare.hpp (compare_runs) reads the files and aligns the time samples.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace morse::eval {

double covariance(const std::vector<double>& x1, const std::vector<double>& x2);
double energy_criterion(const std::vector<double>& e_fom, const std::vector<double>& e_rom);
/// u_* are (n_t x n) row-major histories of the n tip DOFs. DOFs whose FOM peak-to-peak is zero
/// (e.g. clamped) are skipped; if all are, the criterion is 1 when the ROM's are zero too.
double peak_to_peak_criterion(const std::vector<double>& u_fom, const std::vector<double>& u_rom, std::size_t n);
double displacement_criterion(const std::vector<double>& u_fom, const std::vector<double>& u_rom);

struct Indicator {
  std::array<double, 4> e{};
  std::array<double, 4> w{0.25, 0.25, 0.25, 0.25};
  double I() const { return w[0] * e[0] + w[1] * e[1] + w[2] * e[2] + w[3] * e[3]; }
};

/// Linear interpolation of samples (t, y[t][n]) at times `at` (clamped at the ends).
std::vector<double> interpolate(const std::vector<double>& t, const std::vector<double>& y, std::size_t n,
                                const std::vector<double>& at);

/// Writes /compare into a `morse simulate` file (docs/hdf5-schema.md): e, weights, I, t_max and
/// the time of the snapshot used, with the fom file and the tip set as attributes (an existing
/// /compare is replaced). Atomic: a copy of `file` is modified, then renamed over it. Serial (one
/// rank); throws naming the file if it cannot be written.
void write_compare(const std::string& file, const Indicator& ind, double tmax, double tsnap, const std::string& fom,
                   const std::string& tip);

}  // namespace morse::eval
