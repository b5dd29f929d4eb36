// The performance indicator of seed 003 (see morse/eval/indicator.hpp).
#include "morse/eval/indicator.hpp"

#include <algorithm>
#include <cmath>

#include "morse/core/error.hpp"

namespace morse::eval {

double covariance(const std::vector<double>& x1, const std::vector<double>& x2) {
  MORSE_CHECK(x1.size() == x2.size(), "covariance: fields of ", x1.size(), " and ", x2.size(), " values");
  double a = 0, b = 0, c = 0;
  for (std::size_t i = 0; i < x1.size(); ++i) a += x1[i] * x2[i], b += x1[i] * x1[i], c += x2[i] * x2[i];
  if (b == 0 || c == 0) return b == c ? 1.0 : 0.0;
  return a * a / (b * c);
}

namespace {
double relative_criterion(const std::vector<double>& ref, const std::vector<double>& x) {
  MORSE_CHECK(ref.size() == x.size(), "indicator: histories of ", ref.size(), " and ", x.size(), " values");
  double d = 0, n = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) d += (ref[i] - x[i]) * (ref[i] - x[i]), n += ref[i] * ref[i];
  if (n == 0) return d == 0 ? 1.0 : 0.0;
  return std::max(0.0, 1.0 - std::sqrt(d) / std::sqrt(n));
}
}  // namespace

double energy_criterion(const std::vector<double>& e_fom, const std::vector<double>& e_rom) {
  return relative_criterion(e_fom, e_rom);
}

double displacement_criterion(const std::vector<double>& u_fom, const std::vector<double>& u_rom) {
  return relative_criterion(u_fom, u_rom);
}

double peak_to_peak_criterion(const std::vector<double>& u_fom, const std::vector<double>& u_rom, std::size_t n) {
  MORSE_CHECK(n > 0 && u_fom.size() == u_rom.size() && u_fom.size() % n == 0, "peak-to-peak criterion: histories of ",
              u_fom.size(), " and ", u_rom.size(), " values for ", n, " DOFs");
  const std::size_t nt = u_fom.size() / n;
  double s = 0;
  std::size_t used = 0;
  bool rom_moves = false;
  for (std::size_t i = 0; i < n; ++i) {
    double fmin = 1e300, fmax = -1e300, rmin = 1e300, rmax = -1e300;
    for (std::size_t t = 0; t < nt; ++t) {
      fmin = std::min(fmin, u_fom[t * n + i]), fmax = std::max(fmax, u_fom[t * n + i]);
      rmin = std::min(rmin, u_rom[t * n + i]), rmax = std::max(rmax, u_rom[t * n + i]);
    }
    const double of = fmax - fmin, orr = rmax - rmin;
    if (of == 0) {
      rom_moves = rom_moves || orr != 0;
      continue;
    }
    s += ((of - orr) / of) * ((of - orr) / of);
    ++used;
  }
  if (used == 0) return rom_moves ? 0.0 : 1.0;
  return std::max(0.0, 1.0 - std::sqrt(s / static_cast<double>(used)));
}

std::vector<double> interpolate(const std::vector<double>& t, const std::vector<double>& y, std::size_t n,
                                const std::vector<double>& at) {
  MORSE_CHECK(!t.empty() && y.size() == t.size() * n, "interpolate: ", t.size(), " times for ", y.size(), " values");
  std::vector<double> out(at.size() * n);
  for (std::size_t k = 0; k < at.size(); ++k) {
    const double x = at[k];
    std::size_t j = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), x) - t.begin());
    if (j == 0) {
      std::copy(y.begin(), y.begin() + n, out.begin() + k * n);
      continue;
    }
    if (j >= t.size()) {
      std::copy(y.end() - n, y.end(), out.begin() + k * n);
      continue;
    }
    const double a = (x - t[j - 1]) / (t[j] - t[j - 1]);
    for (std::size_t i = 0; i < n; ++i) out[k * n + i] = (1 - a) * y[(j - 1) * n + i] + a * y[j * n + i];
  }
  return out;
}

}  // namespace morse::eval
