#include "morse/mesh/constraints.hpp"

#include <algorithm>

#include "morse/core/error.hpp"

namespace morse::mesh {

std::vector<std::int64_t> Constraints::referenced_ids() const {
  std::vector<std::int64_t> ids;
  for (const auto& r : rigid) {
    ids.push_back(r.reference);
    ids.insert(ids.end(), r.dependent.begin(), r.dependent.end());
  }
  for (const auto& r : interpolation) {
    ids.push_back(r.reference);
    ids.insert(ids.end(), r.nodes.begin(), r.nodes.end());
  }
  for (const auto& r : linear)
    for (const auto& t : r.terms) ids.push_back(t.node);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

std::int64_t Constraints::point_index(std::int64_t id) const {
  auto it = std::lower_bound(point_ids.begin(), point_ids.end(), id);
  return it != point_ids.end() && *it == id ? it - point_ids.begin() : -1;
}

std::string Constraints::summary() const {
  auto n = [](std::size_t k, const char* what) { return cat(k, " ", what, k == 1 ? "" : "s"); };
  return cat(n(rigid.size(), "rigid element"), ", ", n(interpolation.size(), "interpolation element"), ", ",
             n(linear.size(), "linear constraint"), ", ", n(point_ids.size(), "six-DOF point"));
}

std::vector<double> rigid_mass_matrix(double m, const double d[3], const double J[9]) {
  std::vector<double> M(36, 0.0);
  const double S[3][3] = {{0, -d[2], d[1]}, {d[2], 0, -d[0]}, {-d[1], d[0], 0}};  // [d]x
  const double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  for (int i = 0; i < 3; ++i) {
    M[6 * i + i] = m;
    for (int j = 0; j < 3; ++j) {
      M[6 * i + 3 + j] = -m * S[i][j];
      M[6 * (3 + i) + j] = m * S[i][j];
      M[6 * (3 + i) + 3 + j] = J[3 * i + j] + m * ((i == j ? dd : 0.0) - d[i] * d[j]);
    }
  }
  return M;
}

bool parse_component_mask(const std::string& s, ComponentMask* mask) {
  ComponentMask m = 0;
  for (char c : s) {
    if (c < '1' || c > '6') return false;
    const auto bit = static_cast<ComponentMask>(1u << (c - '1'));
    if (m & bit) return false;
    m |= bit;
  }
  if (!m) return false;
  *mask = m;
  return true;
}

std::string component_digits(ComponentMask mask) {
  std::string s;
  for (int c = 0; c < 6; ++c)
    if (mask & (1u << c)) s += static_cast<char>('1' + c);
  return s;
}

}  // namespace morse::mesh
