// The rotor-37-like blade generator. Geometry and meshing are described in
// include/morse/mesh/blade.hpp and docs/blade.md.
#include "morse/mesh/blade.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/options.hpp"

namespace morse::mesh {

namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kDeg = kPi / 180.0;

// --- published rotor 37 sections (hub to tip), see docs/blade.md
constexpr int kNumSections = 6;
constexpr double kSectionRadius[kNumSections] = {0.1826, 0.1958, 0.2091, 0.2223, 0.2355, 0.2486};
constexpr double kChord[kNumSections] = {0.05560, 0.05572, 0.05584, 0.05596, 0.05608, 0.05620};
constexpr double kStaggerDeg[kNumSections] = {39.8, 43.8, 47.8, 51.7, 55.8, 60.3};
constexpr double kThicknessRatio[kNumSections] = {0.082, 0.070, 0.060, 0.050, 0.041, 0.032};
// Camber (turning of the camber line) is not published with the sections: chosen values.
constexpr double kCamberDeg[kNumSections] = {40.0, 26.0, 14.0, 7.0, 4.0, 3.0};

constexpr double kHubRadius = 0.178;
constexpr double kTipRadius = 0.252;

/// Edge roundness rho in (0, 1]: the half thickness is (T/2) sqrt(w ((1 - rho) w^2 + rho)),
/// w = 4u(1-u); the edges are round with radius rho T^2 / (2 L) (L: camber-line length).
constexpr double kEdgeRoundness = 0.1;

/// Chord-wise grid stretching: u(phi) = (phi + ((1 - 2 phi)^5 - 1) / 10) / 0.8.
double chord_fraction(double phi) {
  const double a = 1.0 - 2.0 * phi;
  const double a2 = a * a;
  return (phi + (a2 * a2 * a - 1.0) / 10.0) / 0.8;
}
double chord_fraction_derivative(double phi) {
  const double a = 1.0 - 2.0 * phi;
  const double a2 = a * a;
  return (1.0 - a2 * a2) / 0.8;
}

/// Monotone piecewise-cubic Hermite interpolation (Fritsch-Butland slopes at the interior
/// points, secant slopes at the ends) in the section radii, extended linearly beyond them.
class Pchip {
 public:
  explicit Pchip(const double* y) {
    std::copy(y, y + kNumSections, y_.begin());
    double h[kNumSections - 1], delta[kNumSections - 1];
    for (int k = 0; k + 1 < kNumSections; ++k) {
      h[k] = kSectionRadius[k + 1] - kSectionRadius[k];
      delta[k] = (y_[k + 1] - y_[k]) / h[k];
    }
    d_[0] = delta[0];
    d_[kNumSections - 1] = delta[kNumSections - 2];
    for (int k = 1; k + 1 < kNumSections; ++k) {
      if (delta[k - 1] * delta[k] <= 0) {
        d_[k] = 0.0;
      } else {
        const double w1 = 2.0 * h[k] + h[k - 1], w2 = h[k] + 2.0 * h[k - 1];
        d_[k] = (w1 + w2) / (w1 / delta[k - 1] + w2 / delta[k]);
      }
    }
  }

  double operator()(double r) const {
    if (r <= kSectionRadius[0]) return y_[0] + d_[0] * (r - kSectionRadius[0]);
    if (r >= kSectionRadius[kNumSections - 1])
      return y_[kNumSections - 1] + d_[kNumSections - 1] * (r - kSectionRadius[kNumSections - 1]);
    int k = 0;
    while (r > kSectionRadius[k + 1]) ++k;
    const double h = kSectionRadius[k + 1] - kSectionRadius[k];
    const double s = (r - kSectionRadius[k]) / h;
    const double s2 = s * s, s3 = s2 * s;
    return (2 * s3 - 3 * s2 + 1) * y_[k] + (s3 - 2 * s2 + s) * h * d_[k] + (-2 * s3 + 3 * s2) * y_[k + 1] +
           (s3 - s2) * h * d_[k + 1];
  }

 private:
  std::array<double, kNumSections> y_{};
  std::array<double, kNumSections> d_{};
};

/// A blade section: a circular-arc camber line of chord c and turning theta, carrying the
/// thickness distribution; placed so that its area centroid lies on the stacking line.
class Section {
 public:
  Section(double chord, double stagger, double thickness, double turning)
      : c_(chord), thick_(thickness), theta_(turning) {
    arc_radius_ = c_ / (2.0 * std::sin(0.5 * theta_));
    arc_len_ = theta_ * arc_radius_;
    cos_half_ = std::cos(0.5 * theta_);
    cos_g_ = std::cos(stagger);
    sin_g_ = std::sin(stagger);
    // Area centroid: composite 3-point Gauss-Legendre rule in phi (the integrand is smooth in
    // phi; it has a square-root behaviour in u at the edges).
    static const double gx[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
    static const double gw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    constexpr int kIntervals = 200;
    double area = 0, mx = 0, my = 0;
    for (int i = 0; i < kIntervals; ++i)
      for (int q = 0; q < 3; ++q) {
        const double phi = (i + 0.5 + 0.5 * gx[q]) / kIntervals;
        const double w = 0.5 * gw[q] / kIntervals * chord_fraction_derivative(phi);
        const double u = chord_fraction(phi);
        const double h = half_thickness(u);
        double cx, cy, nx, ny;
        camber(u, &cx, &cy, &nx, &ny);
        const double moment = (2.0 / 3.0) * theta_ * h * h;
        area += w * 2.0 * arc_len_ * h;
        mx += w * h * (2.0 * arc_len_ * cx + moment * nx);
        my += w * h * (2.0 * arc_len_ * cy + moment * ny);
      }
    xc_ = mx / area;
    yc_ = my / area;
  }

  /// Half thickness at the camber-line fraction u.
  double half_thickness(double u) const {
    const double w = 4.0 * u * (1.0 - u);
    return 0.5 * thick_ * std::sqrt(w * ((1.0 - kEdgeRoundness) * w * w + kEdgeRoundness));
  }

  /// Point of the camber line at arc-length fraction u (chord from (0,0) to (c,0)) and the unit
  /// normal towards the convex side.
  void camber(double u, double* x, double* y, double* nx, double* ny) const {
    const double a = theta_ * (u - 0.5);
    const double sa = std::sin(a), ca = std::cos(a);
    *x = 0.5 * c_ + arc_radius_ * sa;
    *y = arc_radius_ * (ca - cos_half_);
    *nx = sa;
    *ny = ca;
  }

  /// Section point at grid parameters (phi in [0,1] from LE to TE, t in [-1,1] from the
  /// concave to the convex side): (axial z, circumferential arc length s).
  void point(double phi, double t, double* z, double* s) const {
    const double u = chord_fraction(phi);
    double x, y, nx, ny;
    camber(u, &x, &y, &nx, &ny);
    const double h = half_thickness(u);
    place(x + t * h * nx, y + t * h * ny, z, s);
  }

  /// Rotates section coordinates (chord along x) by the stagger, centroid to the origin.
  void place(double x, double y, double* z, double* s) const {
    x -= xc_;
    y -= yc_;
    *z = x * cos_g_ - y * sin_g_;
    *s = x * sin_g_ + y * cos_g_;
  }

 private:
  double c_, thick_, theta_;
  double arc_radius_ = 0, arc_len_ = 0, cos_half_ = 0, cos_g_ = 1, sin_g_ = 0;
  double xc_ = 0, yc_ = 0;
};

/// Interpolated section parameters along the span.
class Blade {
 public:
  explicit Blade(double thickness_scale)
      : scale_(thickness_scale), chord_(kChord), stagger_(kStaggerDeg), ratio_(kThicknessRatio), camber_(kCamberDeg) {}

  Section at(double r) const {
    const double c = chord_(r);
    return Section(c, stagger_(r) * kDeg, scale_ * ratio_(r) * c, camber_(r) * kDeg);
  }

 private:
  double scale_;
  Pchip chord_, stagger_, ratio_, camber_;
};

struct Sizes {
  int n_chord, n_thick, n_span;
};

Sizes resolve_sizes(const BladeSpec& spec) {
  Sizes s{};
  if (spec.size == "default") {
    s = {40, 4, 22};
  } else if (spec.size == "coarse") {
    s = {16, 2, 7};
  } else {
    throw Error(cat("blade generator: unknown size '", spec.size, "' (default or coarse)"));
  }
  if (spec.n_chord > 0) s.n_chord = spec.n_chord;
  if (spec.n_thick > 0) s.n_thick = spec.n_thick;
  if (spec.n_span > 0) s.n_span = spec.n_span;
  return s;
}

/// Radii of the section layers: the hub, the six published sections and the tip are layers;
/// the n_span cells are shared among the seven intervals in proportion to their length (at
/// least one each, largest remainders first), uniformly within an interval.
std::vector<double> layer_radii(int n_span) {
  std::array<double, kNumSections + 2> b{};
  b[0] = kHubRadius;
  for (int k = 0; k < kNumSections; ++k) b[k + 1] = kSectionRadius[k];
  b[kNumSections + 1] = kTipRadius;
  constexpr int kIntervals = kNumSections + 1;
  const double total = kTipRadius - kHubRadius;
  std::array<int, kIntervals> cells{};
  std::array<double, kIntervals> frac{};
  int used = 0;
  for (int i = 0; i < kIntervals; ++i) {
    const double ideal = n_span * (b[i + 1] - b[i]) / total;
    cells[i] = std::max(1, static_cast<int>(std::floor(ideal)));
    frac[i] = ideal - cells[i];
    used += cells[i];
  }
  while (used < n_span) {
    int best = 0;
    for (int i = 1; i < kIntervals; ++i)
      if (frac[i] > frac[best]) best = i;
    ++cells[best];
    frac[best] -= 1.0;
    ++used;
  }
  while (used > n_span) {  // only if several intervals were raised to one cell
    int best = -1;
    for (int i = 0; i < kIntervals; ++i)
      if (cells[i] > 1 && (best < 0 || frac[i] < frac[best])) best = i;
    --cells[best];
    frac[best] += 1.0;
    --used;
  }
  std::vector<double> r;
  r.push_back(b[0]);
  for (int i = 0; i < kIntervals; ++i)
    for (int j = 1; j <= cells[i]; ++j) r.push_back(j == cells[i] ? b[i + 1] : b[i] + (b[i + 1] - b[i]) * j / cells[i]);
  return r;
}

}  // namespace

Mesh generate_blade(const BladeSpec& spec) {
  const Sizes sz = resolve_sizes(spec);
  MORSE_CHECK(sz.n_chord >= kMinBladeChordCells && sz.n_chord <= kMaxBladeCells,
              "blade generator: n_chord = ", sz.n_chord, " must be in [", kMinBladeChordCells, ", ", kMaxBladeCells,
              "]");
  MORSE_CHECK(sz.n_thick >= 1 && sz.n_thick <= kMaxBladeCells, "blade generator: n_thick = ", sz.n_thick,
              " must be in [1, ", kMaxBladeCells, "]");
  MORSE_CHECK(sz.n_span >= kMinBladeSpanCells && sz.n_span <= kMaxBladeCells, "blade generator: n_span = ", sz.n_span,
              " must be in [", kMinBladeSpanCells, ", ", kMaxBladeCells, "]");
  MORSE_CHECK(std::isfinite(spec.thickness_scale) && spec.thickness_scale > 0 &&
                  spec.thickness_scale <= kMaxBladeThicknessScale,
              "blade generator: thickness_scale = ", spec.thickness_scale, " must be in (0, ", kMaxBladeThicknessScale,
              "]");
  const std::int64_t nc = sz.n_chord, nt = sz.n_thick, ns = sz.n_span;
  // Quadratic grid: (K, I, J) = span, chord, thickness positions, 0..2n.
  const std::int64_t NK = 2 * ns + 1, NI = 2 * nc + 1, NJ = 2 * nt + 1;
  MORSE_CHECK(NK * NI * NJ < (std::int64_t{1} << 27), "blade generator: ", nc, " x ", nt, " x ", ns,
              " cells are too many");

  const Blade blade(spec.thickness_scale);
  const std::vector<double> rk = layer_radii(static_cast<int>(ns));

  Mesh m;
  m.units = "SI";
  m.source = cat("morse blade generator (", spec.size, ": n_chord=", nc, " n_thick=", nt, " n_span=", ns,
                 ", thickness_scale=", spec.thickness_scale, ")");
  m.materials.push_back(Material{"maraging steel", 1.8e11, 0.3, 8000.0});

  // Which quadratic grid positions carry a node. The LE (I = 0) and TE (I = 2nc) columns
  // collapse into one node each, stored at J = nt. In a section layer (K even): every vertex,
  // edge midpoint and quad centre (= midpoint of its diagonal); in the columns next to the
  // edges (I = 1, 2nc-1) only the midpoints of the fan edges (J even). Between layers (K odd):
  // the midpoints of the span-wise edges, i.e. the vertex positions.
  auto exists = [&](std::int64_t K, std::int64_t I, std::int64_t J) {
    if (I == 0 || I == NI - 1) return J == nt;
    if (K % 2 == 1) return I % 2 == 0 && J % 2 == 0;
    if (I == 1 || I == NI - 2) return J % 2 == 0;
    return true;
  };
  std::vector<std::int64_t> index(static_cast<std::size_t>(NK * NI * NJ), -1);
  auto at = [&](std::int64_t K, std::int64_t I, std::int64_t J) -> std::int64_t& {
    if (I == 0 || I == NI - 1) J = nt;
    return index[static_cast<std::size_t>((K * NI + I) * NJ + J)];
  };

  // --- nodes, layer by layer (span), LE to TE, concave to convex side
  auto wrap = [&](double r, double z, double s) {
    const double a = s / r;
    m.add_node(m.num_nodes() + 1, r * std::cos(a), r * std::sin(a), z);
  };
  for (std::int64_t K = 0; K < NK; ++K) {
    const double r = K % 2 == 0 ? rk[K / 2] : 0.5 * (rk[K / 2] + rk[K / 2 + 1]);
    const Section sec = blade.at(r);
    auto grid_point = [&](std::int64_t I, std::int64_t J, double* z, double* s) {
      sec.point(static_cast<double>(I) / (NI - 1), -1.0 + static_cast<double>(J) / nt, z, s);
    };
    for (std::int64_t I = 0; I < NI; ++I)
      for (std::int64_t J = 0; J < NJ; ++J) {
        if (!exists(K, I, J)) continue;
        double z, s;
        if ((I == 1 || I == NI - 2) && K % 2 == 0 && J != 0 && J != NJ - 1) {
          // Interior edges of the edge fans: straight (a curved fan edge would be tangent to
          // its neighbours at the edge point, making the element degenerate there).
          double z0, s0, z1, s1;
          grid_point(I == 1 ? 0 : NI - 1, nt, &z0, &s0);
          grid_point(I == 1 ? 2 : NI - 3, J, &z1, &s1);
          z = 0.5 * (z0 + z1);
          s = 0.5 * (s0 + s1);
        } else {
          grid_point(I, J, &z, &s);
        }
        at(K, I, J) = m.num_nodes();
        wrap(r, z, s);
      }
  }

  // --- section triangles (vertex grid positions in quadratic indices), clockwise in (phi, t)
  // so that the wedges extruded towards the tip have a positive Jacobian.
  std::vector<std::array<std::int64_t, 6>> tris;  // (I, J) of three vertices
  auto add_tri = [&](std::int64_t i0, std::int64_t j0, std::int64_t i1, std::int64_t j1, std::int64_t i2,
                     std::int64_t j2) {
    // Orientation in (phi, t); the edge points sit at t = 0 (J = nt).
    auto jj = [&](std::int64_t i, std::int64_t j) { return (i == 0 || i == NI - 1) ? nt : j; };
    const double a0 = static_cast<double>(i1 - i0), a1 = static_cast<double>(jj(i1, j1) - jj(i0, j0));
    const double b0 = static_cast<double>(i2 - i0), b1 = static_cast<double>(jj(i2, j2) - jj(i0, j0));
    if (a0 * b1 - a1 * b0 > 0)
      tris.push_back({i0, j0, i2, j2, i1, j1});
    else
      tris.push_back({i0, j0, i1, j1, i2, j2});
  };
  for (std::int64_t i = 0; i < nc; ++i)
    for (std::int64_t j = 0; j < nt; ++j) {
      const std::int64_t I0 = 2 * i, I1 = 2 * i + 2, J0 = 2 * j, J1 = 2 * j + 2;
      if (i == 0) {
        add_tri(0, nt, I1, J0, I1, J1);
      } else if (i == nc - 1) {
        add_tri(I0, J0, NI - 1, nt, I0, J1);
      } else if (2 * j < nt) {  // concave half: diagonal (I0,J1)-(I1,J0)
        add_tri(I0, J0, I1, J0, I0, J1);
        add_tri(I1, J0, I1, J1, I0, J1);
      } else {  // convex half: diagonal (I0,J0)-(I1,J1)
        add_tri(I0, J0, I1, J0, I1, J1);
        add_tri(I0, J0, I1, J1, I0, J1);
      }
    }

  // --- wedges: each triangle of layer k extruded to layer k+1 (morse/Gmsh wedge15 ordering)
  const std::size_t ne = tris.size() * static_cast<std::size_t>(ns);
  m.elem_types.reserve(ne);
  m.elem_ids.reserve(ne);
  m.elem_material.reserve(ne);
  m.elem_offsets.reserve(ne + 1);
  m.elem_nodes.reserve(15 * ne);
  for (std::int64_t k = 0; k < ns; ++k) {
    const std::int64_t Kb = 2 * k, Km = 2 * k + 1, Kt = 2 * k + 2;
    for (const auto& t : tris) {
      const std::int64_t I[3] = {t[0], t[2], t[4]}, J[3] = {t[1], t[3], t[5]};
      auto mid = [&](std::int64_t K, int a, int b) { return at(K, (I[a] + I[b]) / 2, (J[a] + J[b]) / 2); };
      // Midpoints of the edge-fan edges take the J of the non-edge vertex.
      auto fan_mid = [&](std::int64_t K, int a, int b) {
        const bool ea = I[a] == 0 || I[a] == NI - 1, eb = I[b] == 0 || I[b] == NI - 1;
        if (!ea && !eb) return mid(K, a, b);
        const int o = ea ? b : a;
        return at(K, (I[a] + I[b]) / 2, J[o]);
      };
      const std::int64_t conn[15] = {
          at(Kb, I[0], J[0]), at(Kb, I[1], J[1]), at(Kb, I[2], J[2]),  // bottom vertices
          at(Kt, I[0], J[0]), at(Kt, I[1], J[1]), at(Kt, I[2], J[2]),  // top vertices
          fan_mid(Kb, 0, 1),  fan_mid(Kb, 0, 2),  at(Km, I[0], J[0]),  // 6 (0,1) 7 (0,2) 8 (0,3)
          fan_mid(Kb, 1, 2),  at(Km, I[1], J[1]), at(Km, I[2], J[2]),  // 9 (1,2) 10 (1,4) 11 (2,5)
          fan_mid(Kt, 0, 1),  fan_mid(Kt, 0, 2),  fan_mid(Kt, 1, 2)};  // 12 (3,4) 13 (3,5) 14 (4,5)
      for (std::int64_t v : conn) MORSE_CHECK(v >= 0, "blade generator: internal error (missing grid node)");
      m.add_element(m.num_elements() + 1, ElementType::Wedge15, conn, 0);
    }
  }

  // --- sets
  auto& root = m.node_sets["root"];
  for (std::int64_t I = 0; I < NI; ++I)
    for (std::int64_t J = 0; J < NJ; ++J)
      if (exists(0, I, J)) root.push_back(at(0, I, J));
  // Tip: 8 nodes of the tip camber line (t = 0) nearest to equal chord fractions, LE to TE.
  {
    std::vector<std::int64_t> stations;  // I with a node at t = 0
    for (std::int64_t I = 0; I < NI; ++I)
      if (exists(NK - 1, I, nt)) stations.push_back(I);
    auto& tip = m.node_sets["tip"];
    std::int64_t prev = -1;
    for (int k = 0; k < kBladeTipNodes; ++k) {
      const double target = static_cast<double>(k) / (kBladeTipNodes - 1);
      std::int64_t best = -1;
      double best_d = 0;
      for (std::int64_t I : stations) {
        const double d = std::abs(chord_fraction(static_cast<double>(I) / (NI - 1)) - target);
        if (best < 0 || d < best_d) best = I, best_d = d;
      }
      MORSE_CHECK(best > prev, "blade generator: n_chord = ", nc, " is too small to place the tip nodes");
      prev = best;
      tip.push_back(at(NK - 1, best, nt));
    }
    m.node_sets["LE"] = {at(NK - 1, 0, nt)};
    m.node_sets["TE"] = {at(NK - 1, NI - 1, nt)};
  }
  auto& all = m.elem_sets["blade"];
  all.resize(static_cast<std::size_t>(m.num_elements()));
  for (std::int64_t e = 0; e < m.num_elements(); ++e) all[e] = e;
  m.normalize_sets();
  return m;
}

PetscErrorCode blade_spec_from_options(MPI_Comm comm, BladeSpec* spec) {
  char size[64];
  PetscInt n_chord = spec->n_chord, n_thick = spec->n_thick, n_span = spec->n_span;
  PetscReal scale = spec->thickness_scale;
  PetscFunctionBeginUser;
  PetscCall(PetscStrncpy(size, spec->size.c_str(), sizeof size));
  PetscOptionsBegin(comm, nullptr, "Blade generator options (morse mesh blade)", "");
  PetscCall(MorseOptionsString("-blade_size",
                               "Mesh size: default (40x4x22 cells, ~20k nodes) or coarse (16x2x7 "
                               "cells, ~1.6k nodes)",
                               "", size, size, sizeof size, nullptr));
  PetscCall(MorseOptionsBoundedInt("-blade_n_chord", "Cells along the chord (0 = from -blade_size: 40 / 16)", "",
                                   n_chord, &n_chord, nullptr, 0));
  PetscCall(MorseOptionsBoundedInt("-blade_n_thick", "Cells across the thickness (0 = from -blade_size: 4 / 2)", "",
                                   n_thick, &n_thick, nullptr, 0));
  PetscCall(MorseOptionsBoundedInt("-blade_n_span", "Cells along the span, >= 7 (0 = from -blade_size: 22 / 7)", "",
                                   n_span, &n_span, nullptr, 0));
  PetscCall(MorseOptionsReal("-blade_thickness_scale",
                             "Factor on the published thickness-to-chord ratios (calibrated "
                             "default)",
                             "", scale, &scale, nullptr));
  PetscOptionsEnd();
  PetscCheck(std::strcmp(size, "default") == 0 || std::strcmp(size, "coarse") == 0, comm, PETSC_ERR_ARG_OUTOFRANGE,
             "-blade_size %s: unknown size (default or coarse)", size);
  PetscCheck(n_chord == 0 || (n_chord >= kMinBladeChordCells && n_chord <= kMaxBladeCells), comm,
             PETSC_ERR_ARG_OUTOFRANGE, "-blade_n_chord %d: must be 0 or in [%d, %d]", (int)n_chord, kMinBladeChordCells,
             kMaxBladeCells);
  PetscCheck(n_thick == 0 || n_thick <= kMaxBladeCells, comm, PETSC_ERR_ARG_OUTOFRANGE,
             "-blade_n_thick %d: must be 0 or in [1, %d]", (int)n_thick, kMaxBladeCells);
  PetscCheck(n_span == 0 || (n_span >= kMinBladeSpanCells && n_span <= kMaxBladeCells), comm, PETSC_ERR_ARG_OUTOFRANGE,
             "-blade_n_span %d: must be 0 or in [%d, %d]", (int)n_span, kMinBladeSpanCells, kMaxBladeCells);
  PetscCheck(std::isfinite(scale) && scale > 0 && scale <= kMaxBladeThicknessScale, comm, PETSC_ERR_ARG_OUTOFRANGE,
             "-blade_thickness_scale %.6g: must be in (0, %.6g]", (double)scale, kMaxBladeThicknessScale);
  spec->size = size;
  spec->n_chord = static_cast<int>(n_chord);
  spec->n_thick = static_cast<int>(n_thick);
  spec->n_span = static_cast<int>(n_span);
  spec->thickness_scale = scale;
  PetscFunctionReturn(PETSC_SUCCESS);
}

}  // namespace morse::mesh
