#include "morse/mesh/stator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <unordered_map>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/options.hpp"

namespace morse::mesh {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Size presets: vanes and target edge length.
constexpr int kDefaultVanes = 14;
constexpr double kDefaultH = 0.0175;
constexpr int kCoarseVanes = 8;
constexpr double kCoarseH = 0.075;

constexpr std::int64_t kMaxElements = 10000000;
constexpr int kMaxLattice = 30000;  // doubled lattice indices must fit in 16 bits

// Hex20 in lattice terms: corner offsets in Gmsh order (xi, eta, zeta) and the vertex pairs of
// the mid-edge nodes 8..19 (fe/element.hpp).
constexpr int kCorner[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
constexpr int kEdge[12][2] = {{0, 1}, {0, 3}, {0, 4}, {1, 2}, {1, 5}, {2, 3},
                              {2, 6}, {3, 7}, {4, 5}, {4, 7}, {5, 6}, {6, 7}};

/// Number of cells of size about h on a length (at least 1).
int cells_for(double length, double h) { return std::max(1, static_cast<int>(std::ceil(length / h - 1e-9))); }

/// A piecewise uniform 1D lattice: breakpoints b[0] < b[1] < ... with cells[s] cells in segment
/// s. Positions are evaluated on the doubled lattice (index 2i = vertex i, odd = mid-edge).
struct Axis {
  std::vector<double> b;
  std::vector<int> cells;

  int n() const {
    int s = 0;
    for (int c : cells) s += c;
    return s;
  }
  /// Position of doubled index k in [0, 2n]. Breakpoints are returned exactly.
  double at(int k) const {
    int k0 = 0;
    for (std::size_t s = 0; s < cells.size(); ++s) {
      const int k1 = k0 + 2 * cells[s];
      if (k < k1) return b[s] + (b[s + 1] - b[s]) * (k - k0) / (2.0 * cells[s]);
      k0 = k1;
    }
    return b.back();
  }
};

/// Angular lattice of a ring of radius r_joint on which N vanes of half-thickness a end: per
/// pitch, n_t cells across the vane (uniform in the tangential offset s, angle asin(s / r)) and
/// n_gap uniform cells between the vanes. Pitch p starts at 2 pi p / N - asin(a / r).
struct Ring {
  int n_vanes = 0, n_t = 0, n_gap = 0;
  double r_joint = 0, a = 0;

  int per_pitch() const { return n_t + n_gap; }
  int n() const { return n_vanes * per_pitch(); }
  /// Wraps a doubled angular index into [0, 2n).
  int wrap(int j) const {
    const int m = 2 * n();
    return ((j % m) + m) % m;
  }
  double angle(int j) const {
    j = wrap(j);
    const int p = j / (2 * per_pitch()), loc = j % (2 * per_pitch());
    const double phi = 2 * kPi * p / n_vanes;
    if (loc <= 2 * n_t) return phi + std::asin((-a + 2 * a * loc / (2.0 * n_t)) / r_joint);
    const double alpha = std::asin(a / r_joint);
    return phi + alpha + (2 * kPi / n_vanes - 2 * alpha) * (loc - 2 * n_t) / (2.0 * n_gap);
  }
};

enum Block : int { kHub = 0, kCasing = 1, kVane0 = 2 };

std::uint64_t make_key(int block, int i, int j, int k) {
  return (static_cast<std::uint64_t>(block) << 48) | (static_cast<std::uint64_t>(i) << 32) |
         (static_cast<std::uint64_t>(j) << 16) | static_cast<std::uint64_t>(k);
}

struct LatticePoint {
  int block, i, j, k;
};

LatticePoint decode(std::uint64_t key) {
  return {static_cast<int>(key >> 48), static_cast<int>((key >> 32) & 0xffff), static_cast<int>((key >> 16) & 0xffff),
          static_cast<int>(key & 0xffff)};
}

std::string check_spec(const StatorSpec& s, StatorLayout* out) {
  if (s.size != "default" && s.size != "coarse")
    return cat("-stator_size ", s.size, ": unknown size (default, coarse)");
  const bool coarse = s.size == "coarse";
  StatorLayout l;
  l.n_vanes = s.n_vanes > 0 ? s.n_vanes : coarse ? kCoarseVanes : kDefaultVanes;
  l.h = s.h > 0 ? s.h : coarse ? kCoarseH : kDefaultH;
  l.n_thick = s.n_thick > 0 ? s.n_thick : 1;
  if (s.n_vanes < 0 || l.n_vanes < 3)
    return cat("-stator_n_vanes ", s.n_vanes, ": need at least 3 vanes (0 = size default)");
  if (!(std::isfinite(s.h) && s.h >= 0) || l.h < 1e-4 || l.h > 0.1)
    return cat("-stator_h ", s.h, ": must be in [0.0001, 0.1] m (0 = size default)");
  if (s.n_thick < 0 || l.n_thick > 8)
    return cat("-stator_n_thick ", s.n_thick, ": must be in [1, 8] (0 = size default)");
  const double lengths[] = {
      s.hub_bore_radius,  s.hub_outer_radius, s.casing_inner_radius, s.casing_outer_radius, s.flange_outer_radius,
      s.flange_thickness, s.length,           s.vane_thickness};
  for (double v : lengths)
    if (!(std::isfinite(v) && v > 0)) return cat("stator: every dimension must be positive");
  if (!(s.vane_thickness < 0.1 * s.hub_outer_radius))
    return cat("-stator_vane_thickness ", s.vane_thickness, ": must be positive and below ", 0.1 * s.hub_outer_radius,
               " m");
  if (!(s.hub_bore_radius < s.hub_outer_radius && s.hub_outer_radius < s.casing_inner_radius &&
        s.casing_inner_radius < s.casing_outer_radius && s.casing_outer_radius < s.flange_outer_radius))
    return "stator: radii must increase: hub bore < hub outer < casing inner < casing outer < "
           "flange outer";
  if (!(2 * s.flange_thickness < s.length)) return "stator: the two flanges must be thinner than the length";
  const double a = 0.5 * s.vane_thickness;
  const double gap_hub = (2 * kPi / l.n_vanes - 2 * std::asin(a / s.hub_outer_radius)) * s.hub_outer_radius;
  if (!(gap_hub >= s.vane_thickness))
    return cat("-stator_n_vanes ", l.n_vanes, ": the vanes (", s.vane_thickness,
               " m thick) leave no room between them at the hub");
  const double gap_casing = (2 * kPi / l.n_vanes - 2 * std::asin(a / s.casing_inner_radius)) * s.casing_inner_radius;
  l.n_hub_gap = cells_for(gap_hub, l.h);
  l.n_casing_gap = cells_for(gap_casing, l.h);
  l.n_vane_span = cells_for(s.casing_inner_radius - s.hub_outer_radius, l.h);
  l.n_vane_chord = cells_for(s.length - 2 * s.flange_thickness, l.h);
  l.n_flange = cells_for(s.flange_outer_radius - s.casing_outer_radius, l.h);
  // Lattice and size limits (doubled indices must fit the 16-bit key fields).
  const std::int64_t nz = l.n_vane_chord + 2 * l.n_thick;
  const std::int64_t jh = static_cast<std::int64_t>(l.n_vanes) * (l.n_thick + l.n_hub_gap);
  const std::int64_t jc = static_cast<std::int64_t>(l.n_vanes) * (l.n_thick + l.n_casing_gap);
  const std::int64_t ne = jh * l.n_thick * nz + jc * l.n_thick * nz + jc * l.n_flange * 2 * l.n_thick +
                          static_cast<std::int64_t>(l.n_vanes) * l.n_vane_span * l.n_thick * l.n_vane_chord;
  if (nz > kMaxLattice || jh > kMaxLattice || jc > kMaxLattice || l.n_vane_span > kMaxLattice || ne > kMaxElements ||
      l.n_vanes > kMaxLattice)
    return cat("stator: -stator_h ", l.h, " with ", l.n_vanes, " vanes gives ", ne, " elements, more than the ",
               kMaxElements, " allowed");
  *out = l;
  return "";
}

/// Builds the mesh block by block; nodes are created on first use from their canonical lattice
/// point, so the nodes shared by two blocks (vane ends) are computed once.
class Builder {
 public:
  Builder(const StatorSpec& s, const StatorLayout& l) : s_(s), l_(l) {
    a_ = 0.5 * s.vane_thickness;
    z_.b = {0.0, s.flange_thickness, s.length - s.flange_thickness, s.length};
    z_.cells = {l.n_thick, l.n_vane_chord, l.n_thick};
    hub_r_.b = {s.hub_bore_radius, s.hub_outer_radius};
    hub_r_.cells = {l.n_thick};
    casing_r_.b = {s.casing_inner_radius, s.casing_outer_radius, s.flange_outer_radius};
    casing_r_.cells = {l.n_thick, l.n_flange};
    hub_ = Ring{l.n_vanes, l.n_thick, l.n_hub_gap, s.hub_outer_radius, a_};
    casing_ = Ring{l.n_vanes, l.n_thick, l.n_casing_gap, s.casing_inner_radius, a_};
  }

  Mesh build() {
    m_.materials = {s_.material};
    m_.units = "SI";
    const int nz = z_.n();
    // Hub: cells (r, theta, z).
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < hub_.n(); ++j)
        for (int i = 0; i < hub_r_.n(); ++i) add_hex(kHub, i, j, k, "hub");
    // Casing shell, then the flange lips at both ends.
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < casing_.n(); ++j)
        for (int i = 0; i < casing_r_.n(); ++i) {
          const bool shell = i < l_.n_thick;
          const bool flange_z = k < l_.n_thick || k >= nz - l_.n_thick;
          if (shell || flange_z) add_hex(kCasing, i, j, k, shell ? "casing" : "flanges");
        }
    // Vanes: cells (x, s, z) over z in [t_f, L - t_f].
    for (int p = 0; p < l_.n_vanes; ++p)
      for (int k = l_.n_thick; k < nz - l_.n_thick; ++k)
        for (int j = 0; j < l_.n_thick; ++j)
          for (int i = 0; i < l_.n_vane_span; ++i) add_hex(kVane0 + p, i, j, k, "vanes");
    make_sets();
    m_.source =
        cat("stator ", s_.size, ": ", l_.n_vanes, " vanes ", s_.vane_thickness, " m thick, hub r ", s_.hub_bore_radius,
            "-", s_.hub_outer_radius, ", casing r ", s_.casing_inner_radius, "-", s_.casing_outer_radius,
            ", flanges to r ", s_.flange_outer_radius, " x ", s_.flange_thickness, ", length ", s_.length, ", h ", l_.h,
            ", ", l_.n_thick, " element(s) through the walls, hex20, ", s_.material.name);
    m_.normalize_sets();
    return std::move(m_);
  }

 private:
  /// The canonical key of a lattice point: vane end points are the hub / casing points.
  std::uint64_t canonical(int block, int i, int j, int k) const {
    if (block == kHub) return make_key(kHub, i, hub_.wrap(j), k);
    if (block == kCasing) return make_key(kCasing, i, casing_.wrap(j), k);
    const int p = block - kVane0;
    if (i == 0) return make_key(kHub, 2 * hub_r_.n(), hub_.wrap(2 * p * hub_.per_pitch() + j), k);
    if (i == 2 * l_.n_vane_span) return make_key(kCasing, 0, casing_.wrap(2 * p * casing_.per_pitch() + j), k);
    return make_key(block, i, j, k);
  }

  void position(std::uint64_t key, double x[3]) const {
    const LatticePoint q = decode(key);
    x[2] = z_.at(q.k);
    if (q.block == kHub || q.block == kCasing) {
      const double r = q.block == kHub ? hub_r_.at(q.i) : casing_r_.at(q.i);
      const double t = q.block == kHub ? hub_.angle(q.j) : casing_.angle(q.j);
      x[0] = r * std::cos(t);
      x[1] = r * std::sin(t);
      return;
    }
    // Vane frame: x radial along the vane's mid-plane, s across it.
    const double phi = 2 * kPi * (q.block - kVane0) / l_.n_vanes;
    const double sv = -a_ + 2 * a_ * q.j / (2.0 * l_.n_thick);
    const double x0 = std::sqrt(s_.hub_outer_radius * s_.hub_outer_radius - sv * sv);
    const double x1 = std::sqrt(s_.casing_inner_radius * s_.casing_inner_radius - sv * sv);
    const double xv = x0 + (x1 - x0) * q.i / (2.0 * l_.n_vane_span);
    x[0] = xv * std::cos(phi) - sv * std::sin(phi);
    x[1] = xv * std::sin(phi) + sv * std::cos(phi);
  }

  std::int64_t node(int block, int i, int j, int k) {
    const std::uint64_t key = canonical(block, i, j, k);
    auto [it, added] = index_.emplace(key, m_.num_nodes());
    if (added) {
      double x[3];
      position(key, x);
      m_.add_node(m_.num_nodes() + 1, x[0], x[1], x[2]);
      keys_.push_back(key);
    }
    return it->second;
  }

  void add_hex(int block, int i, int j, int k, const char* set) {
    int c[8][3];
    std::int64_t conn[20];
    for (int v = 0; v < 8; ++v) {
      c[v][0] = 2 * (i + kCorner[v][0]);
      c[v][1] = 2 * (j + kCorner[v][1]);
      c[v][2] = 2 * (k + kCorner[v][2]);
      conn[v] = node(block, c[v][0], c[v][1], c[v][2]);
    }
    for (int e = 0; e < 12; ++e) {
      const int* p = c[kEdge[e][0]];
      const int* q = c[kEdge[e][1]];
      conn[8 + e] = node(block, (p[0] + q[0]) / 2, (p[1] + q[1]) / 2, (p[2] + q[2]) / 2);
    }
    const std::int64_t e = m_.add_element(m_.num_elements() + 1, ElementType::Hex20, conn, 0);
    m_.elem_sets[set].push_back(e);
  }

  /// Node of the ring block at doubled (i, k) whose angle is nearest to target (lowest index on
  /// ties). Only existing nodes are considered.
  std::int64_t nearest_on_ring(int block, int i, int k, double target) const {
    const Ring& ring = block == kHub ? hub_ : casing_;
    std::int64_t best = -1;
    double best_d = 0;
    for (int j = 0; j < 2 * ring.n(); ++j) {
      auto it = index_.find(make_key(block, i, j, k));
      if (it == index_.end()) continue;
      double d = std::fabs(std::remainder(ring.angle(j) - target, 2 * kPi));
      if (best < 0 || d < best_d || (d == best_d && it->second < best)) {
        best = it->second;
        best_d = d;
      }
    }
    MORSE_CHECK(best >= 0, "stator: no node found for an interface location");
    return best;
  }

  void make_sets() {
    const int nz = z_.n();
    auto& mount = m_.node_sets["mount"];
    for (std::size_t n = 0; n < keys_.size(); ++n) {
      const LatticePoint q = decode(keys_[n]);
      if (q.block == kCasing && q.k == 2 * nz) mount.push_back(static_cast<std::int64_t>(n));
    }
    auto& iface = m_.node_sets["interface"];
    int b = 0;
    for (int k : {2 * l_.n_thick, 2 * (nz - l_.n_thick)})
      for (int a = 0; a < 5; ++a) {
        const std::int64_t n = nearest_on_ring(kHub, 0, k, 2 * kPi * a / 5);
        m_.node_sets[cat("bearing", ++b)] = {n};
        iface.push_back(n);
      }
    const double lugs[3] = {90, 210, 330};
    for (int a = 0; a < 3; ++a) {
      const std::int64_t n = nearest_on_ring(kCasing, 2 * casing_r_.n(), l_.n_thick, lugs[a] * kPi / 180);
      m_.node_sets[cat("suspension", a + 1)] = {n};
      iface.push_back(n);
    }
  }

  const StatorSpec& s_;
  const StatorLayout& l_;
  double a_ = 0;
  Axis z_, hub_r_, casing_r_;
  Ring hub_, casing_;
  Mesh m_;
  std::unordered_map<std::uint64_t, std::int64_t> index_;
  std::vector<std::uint64_t> keys_;  // canonical key of each node
};

/// Integral of sqrt(r^2 - s^2) ds over [-a, a].
double chord_area(double r, double a) { return a * std::sqrt(r * r - a * a) + r * r * std::asin(a / r); }

}  // namespace

StatorLayout resolve_stator_spec(const StatorSpec& spec) {
  StatorLayout l;
  const std::string err = check_spec(spec, &l);
  MORSE_CHECK(err.empty(), err);
  return l;
}

double stator_volume(const StatorSpec& s) {
  const StatorLayout l = resolve_stator_spec(s);
  const double a = 0.5 * s.vane_thickness;
  auto annulus = [](double r0, double r1) { return kPi * (r1 * r1 - r0 * r0); };
  const double hub = annulus(s.hub_bore_radius, s.hub_outer_radius) * s.length;
  const double casing = annulus(s.casing_inner_radius, s.casing_outer_radius) * s.length;
  const double flanges = 2 * annulus(s.casing_outer_radius, s.flange_outer_radius) * s.flange_thickness;
  const double vane =
      (chord_area(s.casing_inner_radius, a) - chord_area(s.hub_outer_radius, a)) * (s.length - 2 * s.flange_thickness);
  return hub + casing + flanges + l.n_vanes * vane;
}

Mesh generate_stator(const StatorSpec& spec) {
  const StatorLayout layout = resolve_stator_spec(spec);
  return Builder(spec, layout).build();
}

PetscErrorCode stator_spec_from_options(MPI_Comm comm, StatorSpec* spec) {
  char size[64];
  std::snprintf(size, sizeof size, "%s", spec->size.c_str());
  PetscInt n_vanes = spec->n_vanes, n_thick = spec->n_thick;
  PetscReal h = spec->h, vane_thickness = spec->vane_thickness;
  PetscOptionsBegin(comm, nullptr, "morse mesh stator options", "");
  PetscCall(MorseOptionsString("-stator_size", "Mesh size preset: default (100-200k DOFs) or coarse (~10k DOFs)", "",
                               size, size, sizeof size, nullptr));
  PetscCall(
      MorseOptionsInt("-stator_n_vanes", "Number of radial vanes (0 = 14, coarse: 8)", "", n_vanes, &n_vanes, nullptr));
  PetscCall(MorseOptionsReal("-stator_h", "Target element edge length along the walls [m] (0 = from the size)", "", h,
                             &h, nullptr));
  PetscCall(MorseOptionsInt("-stator_n_thick", "Elements through each wall thickness (0 = 1)", "", n_thick, &n_thick,
                            nullptr));
  PetscCall(
      MorseOptionsReal("-stator_vane_thickness", "Vane thickness [m]", "", vane_thickness, &vane_thickness, nullptr));
  PetscOptionsEnd();
  PetscCheck(n_vanes >= 0 && n_vanes <= kMaxLattice, comm, PETSC_ERR_ARG_OUTOFRANGE,
             "-stator_n_vanes %" PetscInt_FMT ": need at least 3 vanes (0 = size default)", n_vanes);
  PetscCheck(n_thick >= 0 && n_thick <= 8, comm, PETSC_ERR_ARG_OUTOFRANGE,
             "-stator_n_thick %" PetscInt_FMT ": must be in [1, 8] (0 = size default)", n_thick);
  StatorSpec s = *spec;
  s.size = size;
  s.n_vanes = static_cast<int>(n_vanes);
  s.n_thick = static_cast<int>(n_thick);
  s.h = h;
  s.vane_thickness = vane_thickness;
  StatorLayout layout;
  const std::string err = check_spec(s, &layout);
  PetscCheck(err.empty(), comm, PETSC_ERR_ARG_OUTOFRANGE, "%s", err.c_str());
  *spec = s;
  return PETSC_SUCCESS;
}

}  // namespace morse::mesh
