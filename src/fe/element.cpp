// Isoparametric solid elements: shape functions, quadrature, element stiffness and mass.
//
// Shape functions and their reference derivatives at the stiffness and mass quadrature points
// are tabulated once per type, so the per-element kernels only build Jacobians and accumulate;
// they use stack buffers of kMaxNodes / kMaxDofs and never allocate.
#include "morse/fe/element.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "morse/core/error.hpp"

namespace morse::fe {

namespace {

using Point = std::array<double, 3>;

// Largest stiffness rule (Hex20, 3x3x3); sizes the stack buffers of element_stiffness().
constexpr int kMaxStiffnessPoints = 27;

int type_index(ElementType t) {
  const int i = static_cast<int>(t);
  MORSE_CHECK(i >= 0 && i < mesh::kNumElementTypes, "fe: invalid element type code ", i);
  return i;
}

// ------------------------------------------------------------------------------------------------
// Quadrature rules

struct Rule1D {
  std::vector<double> x, w;
};

Rule1D gauss_legendre(int n) {
  switch (n) {
    case 2: {
      const double a = 1.0 / std::sqrt(3.0);
      return {{-a, a}, {1.0, 1.0}};
    }
    case 3: {
      const double a = std::sqrt(0.6);
      return {{-a, 0.0, a}, {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0}};
    }
    default:
      throw Error(cat("fe: no Gauss-Legendre rule with ", n, " points"));
  }
}

QuadratureRule hex_gauss(int n) {
  const Rule1D g = gauss_legendre(n);
  QuadratureRule r;
  // zeta slowest, xi fastest; the order only matters for reproducibility.
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        r.points.push_back({g.x[i], g.x[j], g.x[k]});
        r.weights.push_back(g.w[i] * g.w[j] * g.w[k]);
      }
  return r;
}

// Triangle rules on (0,0) (1,0) (0,1); weights sum to 1/2.
struct TriangleRule {
  std::vector<std::array<double, 2>> x;
  std::vector<double> w;
};

// Orbit of the barycentric point (a, a, 1-2a): three points.
void add_triangle_orbit(TriangleRule* r, double a, double w) {
  const double b = 1.0 - 2.0 * a;
  for (const auto& p : {std::array<double, 2>{a, a}, {b, a}, {a, b}}) {
    r->x.push_back(p);
    r->w.push_back(w);
  }
}

// Interior 3-point rule, degree 2.
TriangleRule triangle_degree2() {
  TriangleRule r;
  add_triangle_orbit(&r, 1.0 / 6.0, 1.0 / 6.0);
  return r;
}

// 6-point rule of degree 4 (Dunavant), positive weights. The constants solve the moment
// equations to double precision.
TriangleRule triangle_degree4() {
  TriangleRule r;
  add_triangle_orbit(&r, 0.44594849091596495, 0.11169079483900564);
  add_triangle_orbit(&r, 0.09157621350977084, 0.05497587182766101);
  return r;
}

QuadratureRule wedge_rule(const TriangleRule& tri, int n_line) {
  const Rule1D g = gauss_legendre(n_line);
  QuadratureRule r;
  for (int k = 0; k < n_line; ++k)
    for (size_t i = 0; i < tri.w.size(); ++i) {
      r.points.push_back({tri.x[i][0], tri.x[i][1], g.x[k]});
      r.weights.push_back(tri.w[i] * g.w[k]);
    }
  return r;
}

// Tet points are given by barycentric coordinates (L0, L1, L2, L3); (x, y, z) = (L1, L2, L3).
void add_tet_point(QuadratureRule* r, double l1, double l2, double l3, double w) {
  r->points.push_back({l1, l2, l3});
  r->weights.push_back(w);
}

// Orbit of (b, a, a, a): four points.
void add_tet_orbit4(QuadratureRule* r, double a, double w) {
  const double b = 1.0 - 3.0 * a;
  add_tet_point(r, a, a, a, w);
  add_tet_point(r, b, a, a, w);
  add_tet_point(r, a, b, a, w);
  add_tet_point(r, a, a, b, w);
}

// Orbit of (a, a, b, b) with b = 1/2 - a: six points.
void add_tet_orbit6(QuadratureRule* r, double a, double w) {
  const double b = 0.5 - a;
  add_tet_point(r, a, b, b, w);  // L0 = a
  add_tet_point(r, b, a, b, w);
  add_tet_point(r, b, b, a, w);
  add_tet_point(r, b, a, a, w);  // L0 = b
  add_tet_point(r, a, b, a, w);
  add_tet_point(r, a, a, b, w);
}

QuadratureRule tet_degree1() {
  QuadratureRule r;
  add_tet_point(&r, 0.25, 0.25, 0.25, 1.0 / 6.0);
  return r;
}

QuadratureRule tet_degree2() {
  QuadratureRule r;
  add_tet_orbit4(&r, (5.0 - std::sqrt(5.0)) / 20.0, 1.0 / 24.0);
  return r;
}

// Classical symmetric 14-point rule of degree 5, positive weights. The constants solve
// the moment equations to double precision.
QuadratureRule tet_degree5() {
  QuadratureRule r;
  add_tet_orbit4(&r, 0.09273525031089126, 0.01224884051939367);
  add_tet_orbit4(&r, 0.3108859192633009, 0.018781320953002723);
  add_tet_orbit6(&r, 0.045503704125649365, 0.007091003462846842);
  return r;
}

// ------------------------------------------------------------------------------------------------
// Shape functions. Each writes N[n] and dN[n][3] (both required).

void shape_tet4(const double* x, double* N, double* dN) {
  N[0] = 1.0 - x[0] - x[1] - x[2];
  N[1] = x[0];
  N[2] = x[1];
  N[3] = x[2];
  static constexpr double kD[12] = {-1, -1, -1, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::copy(kD, kD + 12, dN);
}

void shape_tet10(const double* x, double* N, double* dN) {
  double L[4], dL[12];
  shape_tet4(x, L, dL);
  for (int i = 0; i < 4; ++i) {
    N[i] = L[i] * (2.0 * L[i] - 1.0);
    for (int d = 0; d < 3; ++d) dN[3 * i + d] = (4.0 * L[i] - 1.0) * dL[3 * i + d];
  }
  const auto& edges = mesh::mid_edges(ElementType::Tet10);
  for (int k = 0; k < 6; ++k) {
    const int p = edges[k].first, q = edges[k].second, m = 4 + k;
    N[m] = 4.0 * L[p] * L[q];
    for (int d = 0; d < 3; ++d) dN[3 * m + d] = 4.0 * (dL[3 * p + d] * L[q] + L[p] * dL[3 * q + d]);
  }
}

// Linear triangle functions of (xi, eta) and their (xi, eta) derivatives, used by the wedges.
struct Tri {
  double L[3];
  double dx[3], dy[3];
};

Tri triangle_functions(const double* x) {
  return {{1.0 - x[0] - x[1], x[0], x[1]}, {-1.0, 1.0, 0.0}, {-1.0, 0.0, 1.0}};
}

void shape_wedge6(const double* x, double* N, double* dN) {
  const Tri T = triangle_functions(x);
  const double Z[2] = {0.5 * (1.0 - x[2]), 0.5 * (1.0 + x[2])};
  const double dZ[2] = {-0.5, 0.5};
  for (int i = 0; i < 6; ++i) {
    const int t = i % 3, l = i / 3;
    N[i] = T.L[t] * Z[l];
    dN[3 * i + 0] = T.dx[t] * Z[l];
    dN[3 * i + 1] = T.dy[t] * Z[l];
    dN[3 * i + 2] = T.L[t] * dZ[l];
  }
}

void shape_wedge15(const double* x, double* N, double* dN) {
  const Tri T = triangle_functions(x);
  const double z = x[2];
  for (int i = 0; i < 6; ++i) {
    const int t = i % 3;
    const double s = i < 3 ? -1.0 : 1.0, L = T.L[t];
    // N = L (1 + s z) (2L + s z - 2) / 2
    N[i] = 0.5 * L * (1.0 + s * z) * (2.0 * L + s * z - 2.0);
    const double dNdL = 0.5 * (1.0 + s * z) * (4.0 * L + s * z - 2.0);
    dN[3 * i + 0] = dNdL * T.dx[t];
    dN[3 * i + 1] = dNdL * T.dy[t];
    dN[3 * i + 2] = 0.5 * L * s * (2.0 * L + 2.0 * s * z - 1.0);
  }
  const auto& edges = mesh::mid_edges(ElementType::Wedge15);
  for (int k = 0; k < 9; ++k) {
    const int p = edges[k].first, q = edges[k].second, m = 6 + k;
    if (q == p + 3) {  // edge along zeta
      const int t = p;
      N[m] = T.L[t] * (1.0 - z * z);
      dN[3 * m + 0] = T.dx[t] * (1.0 - z * z);
      dN[3 * m + 1] = T.dy[t] * (1.0 - z * z);
      dN[3 * m + 2] = -2.0 * z * T.L[t];
    } else {  // triangle edge on the face zeta = s
      const int a = p % 3, b = q % 3;
      const double s = p < 3 ? -1.0 : 1.0, f = 2.0 * (1.0 + s * z);
      N[m] = f * T.L[a] * T.L[b];
      dN[3 * m + 0] = f * (T.dx[a] * T.L[b] + T.L[a] * T.dx[b]);
      dN[3 * m + 1] = f * (T.dy[a] * T.L[b] + T.L[a] * T.dy[b]);
      dN[3 * m + 2] = 2.0 * s * T.L[a] * T.L[b];
    }
  }
}

void shape_hex8(const double* x, double* N, double* dN) {
  const auto& ref = reference_nodes(ElementType::Hex8);
  for (int i = 0; i < 8; ++i) {
    const double* s = ref[i].data();
    const double f0 = 1.0 + s[0] * x[0], f1 = 1.0 + s[1] * x[1], f2 = 1.0 + s[2] * x[2];
    N[i] = 0.125 * f0 * f1 * f2;
    dN[3 * i + 0] = 0.125 * s[0] * f1 * f2;
    dN[3 * i + 1] = 0.125 * f0 * s[1] * f2;
    dN[3 * i + 2] = 0.125 * f0 * f1 * s[2];
  }
}

void shape_hex20(const double* x, double* N, double* dN) {
  const auto& ref = reference_nodes(ElementType::Hex20);
  for (int i = 0; i < 20; ++i) {
    const double* s = ref[i].data();
    if (i < 8) {
      // N = f0 f1 f2 (s.x - 2) / 8 with f = 1 + s x
      const double f[3] = {1.0 + s[0] * x[0], 1.0 + s[1] * x[1], 1.0 + s[2] * x[2]};
      const double e = s[0] * x[0] + s[1] * x[1] + s[2] * x[2] - 2.0;
      N[i] = 0.125 * f[0] * f[1] * f[2] * e;
      dN[3 * i + 0] = 0.125 * s[0] * f[1] * f[2] * (e + f[0]);
      dN[3 * i + 1] = 0.125 * s[1] * f[0] * f[2] * (e + f[1]);
      dN[3 * i + 2] = 0.125 * s[2] * f[0] * f[1] * (e + f[2]);
    } else {
      // Along the edge axis (s = 0) the factor is 1 - x^2, across it 1 + s x.
      double f[3], df[3];
      for (int d = 0; d < 3; ++d) {
        if (s[d] == 0.0) {
          f[d] = 1.0 - x[d] * x[d];
          df[d] = -2.0 * x[d];
        } else {
          f[d] = 1.0 + s[d] * x[d];
          df[d] = s[d];
        }
      }
      N[i] = 0.25 * f[0] * f[1] * f[2];
      dN[3 * i + 0] = 0.25 * df[0] * f[1] * f[2];
      dN[3 * i + 1] = 0.25 * f[0] * df[1] * f[2];
      dN[3 * i + 2] = 0.25 * f[0] * f[1] * df[2];
    }
  }
}

void eval_shape(ElementType t, const double* xi, double* N, double* dN) {
  switch (t) {
    case ElementType::Tet4:
      return shape_tet4(xi, N, dN);
    case ElementType::Tet10:
      return shape_tet10(xi, N, dN);
    case ElementType::Wedge6:
      return shape_wedge6(xi, N, dN);
    case ElementType::Wedge15:
      return shape_wedge15(xi, N, dN);
    case ElementType::Hex8:
      return shape_hex8(xi, N, dN);
    case ElementType::Hex20:
      return shape_hex20(xi, N, dN);
  }
  type_index(t);  // throws
}

// ------------------------------------------------------------------------------------------------
// Tabulated shape data per type

struct Tabulated {
  int nq = 0;
  const double* w = nullptr;
  std::vector<double> N;   // nq x n
  std::vector<double> dN;  // nq x n x 3
};

struct TypeData {
  int n = 0;
  Tabulated stiff, mass, nodes;  // nodes: weights unused
};

Tabulated tabulate(ElementType t, const std::vector<Point>& pts, const double* w) {
  const int n = mesh::nodes_per_element(t);
  Tabulated tab;
  tab.nq = static_cast<int>(pts.size());
  tab.w = w;
  tab.N.resize(static_cast<size_t>(tab.nq) * n);
  tab.dN.resize(static_cast<size_t>(tab.nq) * n * 3);
  for (int q = 0; q < tab.nq; ++q) eval_shape(t, pts[q].data(), &tab.N[q * n], &tab.dN[q * n * 3]);
  return tab;
}

const TypeData& type_data(ElementType t) {
  static const std::array<TypeData, mesh::kNumElementTypes> data = [] {
    std::array<TypeData, mesh::kNumElementTypes> d;
    for (int i = 0; i < mesh::kNumElementTypes; ++i) {
      const auto et = static_cast<ElementType>(i);
      const QuadratureRule& ks = stiffness_rule(et);
      const QuadratureRule& ms = mass_rule(et);
      d[i].n = mesh::nodes_per_element(et);
      MORSE_CHECK(static_cast<int>(ks.points.size()) <= kMaxStiffnessPoints,
                  "fe: stiffness rule larger than kMaxStiffnessPoints");
      d[i].stiff = tabulate(et, ks.points, ks.weights.data());
      d[i].mass = tabulate(et, ms.points, ms.weights.data());
      d[i].nodes = tabulate(et, reference_nodes(et), nullptr);
    }
    return d;
  }();
  return data[type_index(t)];
}

// ------------------------------------------------------------------------------------------------
// Geometry kernels

using mesh::det3;
using mesh::jacobian;

// Inverse of J given its (non-zero) determinant.
void inverse3(const double* J, double det, double* Ji) {
  const double r = 1.0 / det;
  Ji[0] = r * (J[4] * J[8] - J[5] * J[7]);
  Ji[1] = r * (J[2] * J[7] - J[1] * J[8]);
  Ji[2] = r * (J[1] * J[5] - J[2] * J[4]);
  Ji[3] = r * (J[5] * J[6] - J[3] * J[8]);
  Ji[4] = r * (J[0] * J[8] - J[2] * J[6]);
  Ji[5] = r * (J[2] * J[3] - J[0] * J[5]);
  Ji[6] = r * (J[3] * J[7] - J[4] * J[6]);
  Ji[7] = r * (J[1] * J[6] - J[0] * J[7]);
  Ji[8] = r * (J[0] * J[4] - J[1] * J[3]);
}

// Physical gradients g[a][k] = dN_a/dx_k = sum_j dN_a/dxi_j (J^-1)_jk. Returns det J; g is left
// untouched when det J == 0.
double physical_gradients(int n, const double* dN, const double* xyz, double* g) {
  double J[9], Ji[9];
  jacobian(n, dN, xyz, J);
  const double det = det3(J);
  if (det == 0.0) return det;
  inverse3(J, det, Ji);
  for (int a = 0; a < n; ++a) {
    const double* d = dN + 3 * a;
    for (int k = 0; k < 3; ++k) g[3 * a + k] = d[0] * Ji[k] + d[1] * Ji[3 + k] + d[2] * Ji[6 + k];
  }
  return det;
}

void check_material(double E, double nu) {
  MORSE_CHECK(std::isfinite(E) && E > 0.0, "fe: Young's modulus must be positive (got ", E, ")");
  MORSE_CHECK(nu > -1.0 && nu < 0.5, "fe: Poisson's ratio must lie in (-1, 0.5) (got ", nu, ")");
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// Public API

const QuadratureRule& stiffness_rule(ElementType t) {
  static const std::array<QuadratureRule, mesh::kNumElementTypes> rules = {
      tet_degree1(),                      // Tet4: B constant
      tet_degree2(),                      // Tet10: B linear
      wedge_rule(triangle_degree2(), 2),  // Wedge6
      wedge_rule(triangle_degree4(), 3),  // Wedge15
      hex_gauss(2),                       // Hex8
      hex_gauss(3),                       // Hex20: full integration
  };
  return rules[type_index(t)];
}

const QuadratureRule& mass_rule(ElementType t) {
  static const std::array<QuadratureRule, mesh::kNumElementTypes> rules = {
      tet_degree2(),                      // Tet4: N^T N quadratic
      tet_degree5(),                      // Tet10: N^T N quartic
      wedge_rule(triangle_degree2(), 2),  // Wedge6
      wedge_rule(triangle_degree4(), 3),  // Wedge15
      hex_gauss(2),                       // Hex8
      hex_gauss(3),                       // Hex20
  };
  return rules[type_index(t)];
}

const std::vector<std::array<double, 3>>& reference_nodes(ElementType t) {
  static const std::array<std::vector<Point>, mesh::kNumElementTypes> nodes = [] {
    const std::vector<Point> tet = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const std::vector<Point> wedge = {{0, 0, -1}, {1, 0, -1}, {0, 1, -1}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
    const std::vector<Point> hex = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                    {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    std::array<std::vector<Point>, mesh::kNumElementTypes> r;
    for (int i = 0; i < mesh::kNumElementTypes; ++i) {
      const auto et = static_cast<ElementType>(i);
      const int nv = mesh::vertices_per_element(et);
      r[i] = nv == 4 ? tet : nv == 6 ? wedge : hex;
      // Mid-edge nodes sit at the middle of their (straight) reference edge.
      for (const auto& [p, q] : mesh::mid_edges(et)) {
        Point m;
        for (int d = 0; d < 3; ++d) m[d] = 0.5 * (r[i][p][d] + r[i][q][d]);
        r[i].push_back(m);
      }
    }
    return r;
  }();
  return nodes[type_index(t)];
}

void shape_functions(ElementType t, const double xi[3], double* N, double* dN) {
  double n_buf[kMaxNodes], dn_buf[3 * kMaxNodes];
  eval_shape(t, xi, n_buf, dn_buf);
  const int n = mesh::nodes_per_element(t);
  if (N) std::copy(n_buf, n_buf + n, N);
  if (dN) std::copy(dn_buf, dn_buf + 3 * n, dN);
}

double jacobian_determinant(ElementType t, const double* xyz, const double xi[3]) {
  double N[kMaxNodes], dN[3 * kMaxNodes], J[9];
  eval_shape(t, xi, N, dN);
  jacobian(mesh::nodes_per_element(t), dN, xyz, J);
  return det3(J);
}

double min_jacobian(ElementType t, const double* xyz) {
  const TypeData& d = type_data(t);
  double J[9];
  double m = std::numeric_limits<double>::infinity();
  for (const Tabulated* tab : {&d.nodes, &d.stiff})
    for (int q = 0; q < tab->nq; ++q) {
      jacobian(d.n, &tab->dN[3 * d.n * q], xyz, J);
      m = std::min(m, det3(J));
    }
  return m;
}

double element_volume(ElementType t, const double* xyz) {
  const TypeData& d = type_data(t);
  double J[9], v = 0.0;
  for (int q = 0; q < d.mass.nq; ++q) {
    jacobian(d.n, &d.mass.dN[3 * d.n * q], xyz, J);
    v += d.mass.w[q] * det3(J);
  }
  return v;
}

std::array<double, 36> isotropic_elasticity(double E, double nu) {
  check_material(E, nu);
  const double lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  const double mu = E / (2.0 * (1.0 + nu));
  std::array<double, 36> D{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) D[6 * i + j] = lam;
    D[6 * i + i] = lam + 2.0 * mu;
    D[6 * (i + 3) + (i + 3)] = mu;
  }
  return D;
}

double element_stiffness(ElementType t, const double* xyz, double E, double nu, double* Ke) {
  check_material(E, nu);
  const double lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  const double mu = E / (2.0 * (1.0 + nu));
  const TypeData& d = type_data(t);
  const int n = d.n, nd = 3 * n;

  // Physical gradients at the valid quadrature points, plain (G) and weighted by w det J (Gw).
  double G[kMaxStiffnessPoints * 3 * kMaxNodes], Gw[kMaxStiffnessPoints * 3 * kMaxNodes];
  double min_det = std::numeric_limits<double>::infinity();
  int nq = 0;
  for (int q = 0; q < d.stiff.nq; ++q) {
    double* g = G + nq * nd;
    const double det = physical_gradients(n, &d.stiff.dN[3 * n * q], xyz, g);
    min_det = std::min(min_det, det);
    if (!(det > 0.0)) continue;  // inverted: Ke is meaningless anyway, just keep it finite
    const double f = d.stiff.w[q] * det;
    for (int k = 0; k < nd; ++k) Gw[nq * nd + k] = f * g[k];
    ++nq;
  }

  // For isotropic D, block (a, b) of B^T D B only needs S_ab = int g_a g_b^T dV:
  //   K_ab = lam S_ab + mu (S_ab^T + tr(S_ab) I).
  // S is accumulated into Ke for the blocks b >= a with axpy inner loops (they vectorize).
  std::fill(Ke, Ke + nd * nd, 0.0);
  for (int r = 0; r < nd; ++r) {
    const int c0 = r - r % 3;
    double* row = Ke + r * nd;
    for (int q = 0; q < nq; ++q) {
      const double s = Gw[q * nd + r];
      const double* gq = G + q * nd;
      for (int c = c0; c < nd; ++c) row[c] += s * gq[c];
    }
  }
  for (int a = 0; a < n; ++a)
    for (int b = a; b < n; ++b) {
      double* blk = Ke + 3 * a * nd + 3 * b;
      double S[9];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) S[3 * i + j] = blk[i * nd + j];
      const double tr = S[0] + S[4] + S[8];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) blk[i * nd + j] = lam * S[3 * i + j] + mu * (S[3 * j + i] + (i == j ? tr : 0.0));
    }
  for (int r = 0; r < nd; ++r)
    for (int c = r + 1; c < nd; ++c) Ke[c * nd + r] = Ke[r * nd + c];
  return min_det;
}

double stiffness_gradients(ElementType t, const double* xyz, double* g, double* wdet) {
  const TypeData& d = type_data(t);
  const int n = d.n;
  double min_det = std::numeric_limits<double>::infinity();
  for (int q = 0; q < d.stiff.nq; ++q) {
    const double det = physical_gradients(n, &d.stiff.dN[3 * n * q], xyz, g + 3 * n * q);
    min_det = std::min(min_det, det);
    wdet[q] = d.stiff.w[q] * det;
  }
  return min_det;
}

double element_mass(ElementType t, const double* xyz, double rho, double* Me) {
  const TypeData& d = type_data(t);
  const int n = d.n, nd = 3 * n;
  double m[kMaxNodes * kMaxNodes] = {};
  double J[9];
  double min_det = std::numeric_limits<double>::infinity();
  for (int q = 0; q < d.mass.nq; ++q) {
    jacobian(n, &d.mass.dN[3 * n * q], xyz, J);
    const double det = det3(J);
    min_det = std::min(min_det, det);
    const double f = rho * d.mass.w[q] * det;
    const double* N = &d.mass.N[n * q];
    for (int a = 0; a < n; ++a) {
      const double fa = f * N[a];
      for (int b = a; b < n; ++b) m[a * n + b] += fa * N[b];
    }
  }
  std::fill(Me, Me + nd * nd, 0.0);
  for (int a = 0; a < n; ++a)
    for (int b = a; b < n; ++b)
      for (int i = 0; i < 3; ++i) {
        Me[(3 * a + i) * nd + 3 * b + i] = m[a * n + b];
        Me[(3 * b + i) * nd + 3 * a + i] = m[a * n + b];
      }
  return min_det;
}

double shape_gradients(ElementType t, const double* xyz, const double xi[3], double* g) {
  double N[kMaxNodes], dN[3 * kMaxNodes];
  eval_shape(t, xi, N, dN);
  return physical_gradients(mesh::nodes_per_element(t), dN, xyz, g);
}

double strain_displacement(ElementType t, const double* xyz, const double xi[3], double* B) {
  const int n = mesh::nodes_per_element(t), nd = 3 * n;
  double g[3 * kMaxNodes];
  std::fill(B, B + 6 * nd, 0.0);
  const double det = shape_gradients(t, xyz, xi, g);
  if (det == 0.0) return det;
  for (int a = 0; a < n; ++a) {
    const double gx = g[3 * a], gy = g[3 * a + 1], gz = g[3 * a + 2];
    double* c = B + 3 * a;
    c[0 * nd + 0] = gx;  // exx
    c[1 * nd + 1] = gy;  // eyy
    c[2 * nd + 2] = gz;  // ezz
    c[3 * nd + 1] = gz;  // gamma_yz
    c[3 * nd + 2] = gy;
    c[4 * nd + 0] = gz;  // gamma_xz
    c[4 * nd + 2] = gx;
    c[5 * nd + 0] = gy;  // gamma_xy
    c[5 * nd + 1] = gx;
  }
  return det;
}

}  // namespace morse::fe
