// Tests of the element library (fe/element.hpp): shape functions, quadrature, geometry, stiffness
// and mass of every element type. Each rank runs the same serial checks with fixed seeds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/fe/element.hpp"

namespace {

using morse::fe::ElementType;
namespace fe = morse::fe;
namespace mesh = morse::mesh;

using Vec = std::vector<double>;
using Mat3 = std::array<double, 9>;

constexpr ElementType kAllTypes[] = {ElementType::Tet4,    ElementType::Tet10, ElementType::Wedge6,
                                     ElementType::Wedge15, ElementType::Hex8,  ElementType::Hex20};

enum class Shape { Tet, Wedge, Hex };

Shape shape_of(ElementType t) {
  const int nv = mesh::vertices_per_element(t);
  return nv == 4 ? Shape::Tet : nv == 6 ? Shape::Wedge : Shape::Hex;
}

double reference_volume(ElementType t) {
  switch (shape_of(t)) {
    case Shape::Tet:
      return 1.0 / 6.0;
    case Shape::Wedge:
      return 1.0;
    case Shape::Hex:
      return 8.0;
  }
  return 0.0;
}

// Area of the cross-section of the reference cell at fixed zeta (prisms only).
double reference_section_area(ElementType t) { return shape_of(t) == Shape::Wedge ? 0.5 : 4.0; }

double factorial(int n) { return n <= 1 ? 1.0 : n * factorial(n - 1); }
double line_integral(int c) { return c % 2 ? 0.0 : 2.0 / (c + 1); }  // int_{-1}^{1} z^c

// Closed-form integral of x^a y^b z^c over the reference cell.
double monomial_integral(ElementType t, int a, int b, int c) {
  switch (shape_of(t)) {
    case Shape::Tet:
      return factorial(a) * factorial(b) * factorial(c) / factorial(a + b + c + 3);
    case Shape::Wedge:
      return factorial(a) * factorial(b) / factorial(a + b + 2) * line_integral(c);
    case Shape::Hex:
      return line_integral(a) * line_integral(b) * line_integral(c);
  }
  return 0.0;
}

// Polynomial exactness claimed for a rule: total degree for tets; (triangle degree, line degree)
// for wedges; degree per variable for hexes (stored in `line`).
struct Exactness {
  int simplex;
  int line;
};

Exactness stiffness_exactness(ElementType t) {
  switch (t) {
    case ElementType::Tet4:
      return {1, 0};
    case ElementType::Tet10:
      return {2, 0};
    case ElementType::Wedge6:
      return {2, 3};
    case ElementType::Wedge15:
      return {4, 5};
    case ElementType::Hex8:
      return {0, 3};
    case ElementType::Hex20:
      return {0, 5};
  }
  return {};
}

Exactness mass_exactness(ElementType t) {
  switch (t) {
    case ElementType::Tet4:
      return {2, 0};
    case ElementType::Tet10:
      return {5, 0};  // N^T N needs 4
    case ElementType::Wedge6:
      return {2, 3};
    case ElementType::Wedge15:
      return {4, 5};
    case ElementType::Hex8:
      return {0, 3};
    case ElementType::Hex20:
      return {0, 5};
  }
  return {};
}

bool within(ElementType t, Exactness e, int a, int b, int c) {
  switch (shape_of(t)) {
    case Shape::Tet:
      return a + b + c <= e.simplex;
    case Shape::Wedge:
      return a + b <= e.simplex && c <= e.line;
    case Shape::Hex:
      return a <= e.line && b <= e.line && c <= e.line;
  }
  return false;
}

bool inside_reference(ElementType t, const double* x, double tol) {
  switch (shape_of(t)) {
    case Shape::Tet:
      return x[0] >= -tol && x[1] >= -tol && x[2] >= -tol && x[0] + x[1] + x[2] <= 1 + tol;
    case Shape::Wedge:
      return x[0] >= -tol && x[1] >= -tol && x[0] + x[1] <= 1 + tol && std::abs(x[2]) <= 1 + tol;
    case Shape::Hex:
      return std::abs(x[0]) <= 1 + tol && std::abs(x[1]) <= 1 + tol && std::abs(x[2]) <= 1 + tol;
  }
  return false;
}

std::array<double, 3> random_reference_point(ElementType t, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0), s(-1.0, 1.0);
  for (;;) {
    std::array<double, 3> x{};
    switch (shape_of(t)) {
      case Shape::Tet:
        x = {u(rng), u(rng), u(rng)};
        break;
      case Shape::Wedge:
        x = {u(rng), u(rng), s(rng)};
        break;
      case Shape::Hex:
        x = {s(rng), s(rng), s(rng)};
        break;
    }
    if (inside_reference(t, x.data(), 0.0)) return x;
  }
}

// --- high-order reference quadrature, independent of the library's rules ----------------------

fe::QuadratureRule gauss_legendre(int n) {
  fe::QuadratureRule r;
  for (int i = 0; i < n; ++i) {
    double x = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 0.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    r.points.push_back({x, 0.0, 0.0});
    r.weights.push_back(2.0 / ((1.0 - x * x) * dp * dp));
  }
  return r;
}

// Collapsed (Duffy) tensor Gauss rules; 8 points per direction is far beyond what any element
// integrand here needs.
fe::QuadratureRule reference_rule(ElementType t) {
  const fe::QuadratureRule g = gauss_legendre(8);
  const int n = static_cast<int>(g.weights.size());
  fe::QuadratureRule r;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const double a = g.points[i][0], b = g.points[j][0], c = g.points[k][0];
        const double w = g.weights[i] * g.weights[j] * g.weights[k];
        const double u = 0.5 * (1 + a), v = 0.5 * (1 + b), s = 0.5 * (1 + c);
        switch (shape_of(t)) {
          case Shape::Hex:
            r.points.push_back({a, b, c});
            r.weights.push_back(w);
            break;
          case Shape::Wedge:
            r.points.push_back({u, v * (1 - u), c});
            r.weights.push_back(w * 0.25 * (1 - u));
            break;
          case Shape::Tet:
            r.points.push_back({u, v * (1 - u), s * (1 - u) * (1 - v)});
            r.weights.push_back(w * 0.125 * (1 - u) * (1 - u) * (1 - v));
            break;
        }
      }
  return r;
}

// --- element geometries ------------------------------------------------------------------------

int num_nodes(ElementType t) { return mesh::nodes_per_element(t); }
int num_dofs(ElementType t) { return 3 * num_nodes(t); }

double det3(const Mat3& A) {
  return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) + A[2] * (A[3] * A[7] - A[4] * A[6]);
}

// Reference nodes mapped by x = A xi + c.
Vec affine_nodes(ElementType t, const Mat3& A, const std::array<double, 3>& c) {
  Vec x;
  for (const auto& p : fe::reference_nodes(t))
    for (int i = 0; i < 3; ++i) x.push_back(A[3 * i] * p[0] + A[3 * i + 1] * p[1] + A[3 * i + 2] * p[2] + c[i]);
  return x;
}

const Mat3 kShear = {1.3, 0.2, -0.1, 0.1, 0.8, 0.25, -0.15, 0.1, 1.1};

// Valid but distorted element: an affine image with randomly moved vertices; mid-edge nodes are
// moved off their edge midpoints (curved edges), so even tets are non-affine when quadratic.
Vec distorted_nodes(ElementType t, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double size = shape_of(t) == Shape::Hex ? 2.0 : 1.0;
  Vec x = affine_nodes(t, kShear, {0.3, -0.2, 0.5});
  const int nv = mesh::vertices_per_element(t);
  for (int k = 0; k < 3 * nv; ++k) x[k] += 0.12 * size * u(rng);
  const auto& edges = mesh::mid_edges(t);
  for (size_t e = 0; e < edges.size(); ++e)
    for (int i = 0; i < 3; ++i)
      x[3 * (nv + e) + i] = 0.5 * (x[3 * edges[e].first + i] + x[3 * edges[e].second + i]) + 0.04 * size * u(rng);
  return x;
}

// Prism-type element (wedge or hex) with straight edges whose cross-section scales linearly
// along zeta: (sx(z) X + tx z, sy(z) Y + ty z, h (z + 1) / 2), sx = a0 + a1 z, sy = b0 + b1 z.
// The map is not affine when a1 or b1 != 0; the volume is A_ref h/2 (2 a0 b0 + 2/3 a1 b1).
struct Frustum {
  double a0, a1, b0, b1, h, tx, ty;
};

Vec frustum_nodes(ElementType t, const Frustum& f) {
  Vec x;
  for (const auto& p : fe::reference_nodes(t)) {
    const double z = p[2];
    x.push_back((f.a0 + f.a1 * z) * p[0] + f.tx * z);
    x.push_back((f.b0 + f.b1 * z) * p[1] + f.ty * z);
    x.push_back(f.h * (z + 1) / 2);
  }
  return x;
}

double frustum_volume(ElementType t, const Frustum& f) {
  return reference_section_area(t) * f.h / 2 * (2 * f.a0 * f.b0 + 2.0 / 3.0 * f.a1 * f.b1);
}

// --- linear algebra helpers --------------------------------------------------------------------

// Eigenvalues (ascending) of a symmetric row-major matrix by cyclic Jacobi rotations. LAPACK is
// not on the test link line, and n <= 60 makes Jacobi cheap and accurate to roundoff.
Vec symmetric_eigenvalues(Vec A, int n) {
  auto at = [&](int r, int c) -> double& { return A[r * n + c]; };
  for (int sweep = 0; sweep < 100; ++sweep) {
    double off = 0.0, diag = 0.0;
    for (int r = 0; r < n; ++r) {
      diag += at(r, r) * at(r, r);
      for (int c = r + 1; c < n; ++c) off += at(r, c) * at(r, c);
    }
    if (off <= 1e-34 * diag) break;
    for (int p = 0; p < n; ++p)
      for (int q = p + 1; q < n; ++q) {
        const double apq = at(p, q);
        if (apq == 0.0) continue;
        const double theta = (at(q, q) - at(p, p)) / (2.0 * apq);
        const double tn = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(tn * tn + 1.0), s = tn * c;
        for (int k = 0; k < n; ++k) {  // columns p, q
          const double akp = at(k, p), akq = at(k, q);
          at(k, p) = c * akp - s * akq;
          at(k, q) = s * akp + c * akq;
        }
        for (int k = 0; k < n; ++k) {  // rows p, q
          const double apk = at(p, k), aqk = at(q, k);
          at(p, k) = c * apk - s * aqk;
          at(q, k) = s * apk + c * aqk;
        }
      }
  }
  Vec w(n);
  for (int i = 0; i < n; ++i) w[i] = at(i, i);
  std::sort(w.begin(), w.end());
  return w;
}

Vec matvec(const Vec& A, const Vec& x) {
  const size_t n = x.size();
  Vec y(n, 0.0);
  for (size_t r = 0; r < n; ++r)
    for (size_t c = 0; c < n; ++c) y[r] += A[r * n + c] * x[c];
  return y;
}

double max_abs(const Vec& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

double max_abs_diff(const Vec& a, const Vec& b) {
  double m = 0.0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

Vec stiffness(ElementType t, const Vec& xyz, double E, double nu, double* min_det = nullptr) {
  Vec K(num_dofs(t) * num_dofs(t));
  const double d = fe::element_stiffness(t, xyz.data(), E, nu, K.data());
  if (min_det) *min_det = d;
  return K;
}

Vec mass(ElementType t, const Vec& xyz, double rho, double* min_det = nullptr) {
  Vec M(num_dofs(t) * num_dofs(t));
  const double d = fe::element_mass(t, xyz.data(), rho, M.data());
  if (min_det) *min_det = d;
  return M;
}

// int B^T D B dV with an arbitrary rule, through strain_displacement() and isotropic_elasticity().
Vec integrate_btdb(ElementType t, const Vec& xyz, double E, double nu, const fe::QuadratureRule& rule) {
  const int nd = num_dofs(t);
  const auto D = fe::isotropic_elasticity(E, nu);
  Vec K(nd * nd, 0.0), B(6 * nd), DB(6 * nd);
  for (size_t q = 0; q < rule.weights.size(); ++q) {
    const double det = fe::strain_displacement(t, xyz.data(), rule.points[q].data(), B.data());
    std::fill(DB.begin(), DB.end(), 0.0);
    for (int i = 0; i < 6; ++i)
      for (int k = 0; k < 6; ++k)
        for (int c = 0; c < nd; ++c) DB[i * nd + c] += D[6 * i + k] * B[k * nd + c];
    for (int r = 0; r < nd; ++r)
      for (int c = 0; c < nd; ++c) {
        double s = 0.0;
        for (int i = 0; i < 6; ++i) s += B[i * nd + r] * DB[i * nd + c];
        K[r * nd + c] += rule.weights[q] * det * s;
      }
  }
  return K;
}

// rho int N^T N dV (expanded to 3 DOFs per node) with an arbitrary rule.
Vec integrate_ntn(ElementType t, const Vec& xyz, double rho, const fe::QuadratureRule& rule) {
  const int n = num_nodes(t), nd = 3 * n;
  Vec M(nd * nd, 0.0), N(n);
  for (size_t q = 0; q < rule.weights.size(); ++q) {
    fe::shape_functions(t, rule.points[q].data(), N.data(), nullptr);
    const double f = rho * rule.weights[q] * fe::jacobian_determinant(t, xyz.data(), rule.points[q].data());
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        for (int i = 0; i < 3; ++i) M[(3 * a + i) * nd + 3 * b + i] += f * N[a] * N[b];
  }
  return M;
}

// Displacement u = A x + c at the nodes.
Vec linear_field(const Vec& xyz, const Mat3& A, const std::array<double, 3>& c) {
  Vec u(xyz.size());
  for (size_t a = 0; a < xyz.size() / 3; ++a)
    for (int i = 0; i < 3; ++i)
      u[3 * a + i] = A[3 * i] * xyz[3 * a] + A[3 * i + 1] * xyz[3 * a + 1] + A[3 * i + 2] * xyz[3 * a + 2] + c[i];
  return u;
}

std::array<double, 6> voigt_strain(const Mat3& A) { return {A[0], A[4], A[8], A[5] + A[7], A[2] + A[6], A[1] + A[3]}; }

// Six rigid body modes: translations and infinitesimal rotations.
std::vector<Vec> rigid_modes(const Vec& xyz) {
  std::vector<Vec> modes;
  for (int d = 0; d < 3; ++d) {
    Mat3 zero{};
    std::array<double, 3> c{};
    c[d] = 1.0;
    modes.push_back(linear_field(xyz, zero, c));
  }
  const Mat3 rot[3] = {{0, 0, 0, 0, 0, -1, 0, 1, 0}, {0, 0, 1, 0, 0, 0, -1, 0, 0}, {0, -1, 0, 1, 0, 0, 0, 0, 0}};
  for (const Mat3& R : rot) modes.push_back(linear_field(xyz, R, {0, 0, 0}));
  return modes;
}

constexpr double kE = 210e9, kNu = 0.3, kRho = 7850.0;

class ElementTest : public ::testing::TestWithParam<ElementType> {};

std::string type_name(const ::testing::TestParamInfo<ElementType>& info) { return mesh::element_name(info.param); }

// --- shape functions ---------------------------------------------------------------------------

TEST_P(ElementTest, NodeTables) {
  const ElementType t = GetParam();
  const int n = num_nodes(t), nv = mesh::vertices_per_element(t);
  const auto& ref = fe::reference_nodes(t);
  const auto& edges = mesh::mid_edges(t);
  ASSERT_EQ(static_cast<int>(ref.size()), n);
  ASSERT_EQ(static_cast<int>(edges.size()), n - nv);
  for (size_t k = 0; k < edges.size(); ++k) {
    const auto [p, q] = edges[k];
    ASSERT_TRUE(p >= 0 && p < nv && q >= 0 && q < nv && p != q);
    for (int d = 0; d < 3; ++d) EXPECT_DOUBLE_EQ(ref[nv + k][d], 0.5 * (ref[p][d] + ref[q][d])) << "node " << nv + k;
  }
  for (int a = 0; a < n; ++a) EXPECT_TRUE(inside_reference(t, ref[a].data(), 0.0));
}

// The mid-edge tables are the Gmsh convention documented in mesh/cells.hpp; everything else (reference
// nodes, shape functions) is derived from them, so pin them literally.
TEST(Element, MidEdgeTablesAreGmsh) {
  using Edges = std::vector<std::pair<int, int>>;
  EXPECT_TRUE(mesh::mid_edges(ElementType::Tet4).empty());
  EXPECT_TRUE(mesh::mid_edges(ElementType::Wedge6).empty());
  EXPECT_TRUE(mesh::mid_edges(ElementType::Hex8).empty());
  EXPECT_EQ(mesh::mid_edges(ElementType::Tet10), (Edges{{0, 1}, {1, 2}, {0, 2}, {0, 3}, {2, 3}, {1, 3}}));
  EXPECT_EQ(mesh::mid_edges(ElementType::Wedge15),
            (Edges{{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 4}, {2, 5}, {3, 4}, {3, 5}, {4, 5}}));
  EXPECT_EQ(mesh::mid_edges(ElementType::Hex20),
            (Edges{{0, 1}, {0, 3}, {0, 4}, {1, 2}, {1, 5}, {2, 3}, {2, 6}, {3, 7}, {4, 5}, {4, 7}, {5, 6}, {6, 7}}));
  const std::vector<std::array<double, 3>> hex = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                                  {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
  const std::vector<std::array<double, 3>> wedge = {{0, 0, -1}, {1, 0, -1}, {0, 1, -1},
                                                    {0, 0, 1},  {1, 0, 1},  {0, 1, 1}};
  const std::vector<std::array<double, 3>> tet = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  EXPECT_EQ(fe::reference_nodes(ElementType::Hex8), hex);
  EXPECT_EQ(fe::reference_nodes(ElementType::Wedge6), wedge);
  EXPECT_EQ(fe::reference_nodes(ElementType::Tet4), tet);
}

TEST_P(ElementTest, KroneckerAtNodes) {
  const ElementType t = GetParam();
  const int n = num_nodes(t);
  const auto& ref = fe::reference_nodes(t);
  Vec N(n);
  for (int j = 0; j < n; ++j) {
    fe::shape_functions(t, ref[j].data(), N.data(), nullptr);
    for (int i = 0; i < n; ++i) EXPECT_NEAR(N[i], i == j ? 1.0 : 0.0, 1e-14) << i << " at " << j;
  }
}

TEST_P(ElementTest, PartitionOfUnity) {
  const ElementType t = GetParam();
  const int n = num_nodes(t);
  std::mt19937_64 rng(42);
  Vec N(n), dN(3 * n);
  for (int s = 0; s < 50; ++s) {
    const auto x = random_reference_point(t, rng);
    fe::shape_functions(t, x.data(), N.data(), dN.data());
    double sum = 0.0, dsum[3] = {0, 0, 0};
    for (int a = 0; a < n; ++a) {
      sum += N[a];
      for (int d = 0; d < 3; ++d) dsum[d] += dN[3 * a + d];
    }
    EXPECT_NEAR(sum, 1.0, 1e-14);
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(dsum[d], 0.0, 1e-13);
  }
}

// Isoparametric completeness: sum_a N_a x_a = x for the reference coordinates themselves.
TEST_P(ElementTest, ReproducesLinearFields) {
  const ElementType t = GetParam();
  const int n = num_nodes(t);
  const auto& ref = fe::reference_nodes(t);
  std::mt19937_64 rng(7);
  Vec N(n), dN(3 * n);
  for (int s = 0; s < 20; ++s) {
    const auto x = random_reference_point(t, rng);
    fe::shape_functions(t, x.data(), N.data(), dN.data());
    for (int d = 0; d < 3; ++d) {
      double v = 0.0, g[3] = {0, 0, 0};
      for (int a = 0; a < n; ++a) {
        v += N[a] * ref[a][d];
        for (int k = 0; k < 3; ++k) g[k] += dN[3 * a + k] * ref[a][d];
      }
      EXPECT_NEAR(v, x[d], 1e-14);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(g[k], k == d ? 1.0 : 0.0, 1e-13);
    }
  }
}

TEST_P(ElementTest, DerivativesMatchFiniteDifferences) {
  const ElementType t = GetParam();
  const int n = num_nodes(t);
  std::mt19937_64 rng(1234);
  Vec N(n), dN(3 * n), Np(n), Nm(n);
  const double h = 1e-5;
  for (int s = 0; s < 20; ++s) {
    const auto x = random_reference_point(t, rng);
    fe::shape_functions(t, x.data(), N.data(), dN.data());
    for (int d = 0; d < 3; ++d) {
      auto xp = x, xm = x;
      xp[d] += h;
      xm[d] -= h;
      // Shape functions are polynomials, so evaluating slightly outside the cell is fine.
      fe::shape_functions(t, xp.data(), Np.data(), nullptr);
      fe::shape_functions(t, xm.data(), Nm.data(), nullptr);
      for (int a = 0; a < n; ++a)
        EXPECT_NEAR(dN[3 * a + d], (Np[a] - Nm[a]) / (2 * h), 1e-9) << "node " << a << " dir " << d;
    }
  }
}

// --- quadrature --------------------------------------------------------------------------------

void check_rule_basics(ElementType t, const fe::QuadratureRule& r) {
  ASSERT_EQ(r.points.size(), r.weights.size());
  ASSERT_FALSE(r.points.empty());
  double sum = 0.0;
  for (size_t q = 0; q < r.weights.size(); ++q) {
    EXPECT_GT(r.weights[q], 0.0);
    EXPECT_TRUE(inside_reference(t, r.points[q].data(), 1e-15)) << "point " << q;
    sum += r.weights[q];
  }
  EXPECT_NEAR(sum, reference_volume(t), 1e-14);
}

void check_rule_exactness(ElementType t, const fe::QuadratureRule& r, Exactness e) {
  int checked = 0;
  for (int a = 0; a <= 6; ++a)
    for (int b = 0; b <= 6; ++b)
      for (int c = 0; c <= 6; ++c) {
        if (!within(t, e, a, b, c)) continue;
        double s = 0.0;
        for (size_t q = 0; q < r.weights.size(); ++q) {
          const auto& p = r.points[q];
          s += r.weights[q] * std::pow(p[0], a) * std::pow(p[1], b) * std::pow(p[2], c);
        }
        EXPECT_NEAR(s, monomial_integral(t, a, b, c), 1e-15 * reference_volume(t) * 10)
            << "x^" << a << " y^" << b << " z^" << c;
        ++checked;
      }
  EXPECT_GT(checked, 0);
}

TEST_P(ElementTest, StiffnessRule) {
  const ElementType t = GetParam();
  check_rule_basics(t, fe::stiffness_rule(t));
  check_rule_exactness(t, fe::stiffness_rule(t), stiffness_exactness(t));
}

TEST_P(ElementTest, MassRule) {
  const ElementType t = GetParam();
  check_rule_basics(t, fe::mass_rule(t));
  check_rule_exactness(t, fe::mass_rule(t), mass_exactness(t));
}

// The mass rule must integrate N^T N exactly on an affine element; compare with a high-order rule.
TEST_P(ElementTest, MassExactOnAffineElement) {
  const ElementType t = GetParam();
  const Vec xyz = affine_nodes(t, kShear, {1.0, 2.0, 3.0});
  const Vec M = mass(t, xyz, kRho);
  const Vec Mref = integrate_ntn(t, xyz, kRho, reference_rule(t));
  EXPECT_LT(max_abs_diff(M, Mref), 1e-13 * max_abs(Mref));
}

// The stiffness rule must integrate B^T D B exactly on an affine element.
TEST_P(ElementTest, StiffnessExactOnAffineElement) {
  const ElementType t = GetParam();
  const Vec xyz = affine_nodes(t, kShear, {1.0, 2.0, 3.0});
  const Vec K = stiffness(t, xyz, kE, kNu);
  const Vec Kref = integrate_btdb(t, xyz, kE, kNu, reference_rule(t));
  EXPECT_LT(max_abs_diff(K, Kref), 1e-12 * max_abs(Kref));
}

// --- geometry ----------------------------------------------------------------------------------

TEST_P(ElementTest, AffineVolumeAndJacobian) {
  const ElementType t = GetParam();
  const Vec xyz = affine_nodes(t, kShear, {-1.0, 0.5, 2.0});
  const double detA = det3(kShear);
  EXPECT_NEAR(fe::element_volume(t, xyz.data()), detA * reference_volume(t), 1e-14 * detA);
  EXPECT_NEAR(fe::min_jacobian(t, xyz.data()), detA, 1e-14 * detA);
  std::mt19937_64 rng(3);
  for (int s = 0; s < 10; ++s) {
    const auto x = random_reference_point(t, rng);
    EXPECT_NEAR(fe::jacobian_determinant(t, xyz.data(), x.data()), detA, 1e-14 * detA);
  }
}

// Tet10 with mid-edge nodes slid along their straight edges: the map is no longer affine but the
// image is still the same tetrahedron, and det J (cubic) is integrated exactly by the mass rule.
TEST(Element, Tet10SlidMidNodesVolume) {
  const ElementType t = ElementType::Tet10;
  Vec xyz = affine_nodes(t, kShear, {0.5, 0.5, 0.5});
  const double alpha[6] = {0.42, 0.55, 0.6, 0.45, 0.4, 0.58};
  const auto& edges = mesh::mid_edges(t);
  for (int e = 0; e < 6; ++e)
    for (int i = 0; i < 3; ++i)
      xyz[3 * (4 + e) + i] = (1 - alpha[e]) * xyz[3 * edges[e].first + i] + alpha[e] * xyz[3 * edges[e].second + i];
  const double v = det3(kShear) / 6.0;
  ASSERT_GT(fe::min_jacobian(t, xyz.data()), 0.0);
  // Really non-affine: det J varies.
  EXPECT_GT(std::abs(fe::jacobian_determinant(t, xyz.data(), fe::reference_nodes(t)[0].data()) - det3(kShear)), 1e-3);
  EXPECT_NEAR(fe::element_volume(t, xyz.data()), v, 1e-14 * v);
}

TEST_P(ElementTest, NonAffineVolume) {
  const ElementType t = GetParam();
  if (shape_of(t) == Shape::Tet) GTEST_SKIP() << "straight-edged tets: see AffineVolumeAndJacobian";
  const Frustum shapes[] = {
      {1.0, -0.4, 1.0, -0.4, 2.0, 0.0, 0.0},  // right frustum
      {1.5, 0.5, 0.7, -0.2, 1.3, 0.4, -0.3},  // oblique, anisotropic taper
      {2.0, 0.8, 1.0, 0.0, 0.5, 0.0, 0.0},    // trapezoidal prism
  };
  for (const Frustum& f : shapes) {
    const Vec xyz = frustum_nodes(t, f);
    const double v = frustum_volume(t, f);
    ASSERT_GT(fe::min_jacobian(t, xyz.data()), 0.0);
    EXPECT_NEAR(fe::element_volume(t, xyz.data()), v, 1e-14 * v);
    // Consistent mass carries the total mass rho V in each direction.
    const Vec M = mass(t, xyz, kRho);
    const int nd = num_dofs(t);
    for (int i = 0; i < 3; ++i) {
      double m = 0.0;
      for (int a = 0; a < nd / 3; ++a)
        for (int b = 0; b < nd / 3; ++b) m += M[(3 * a + i) * nd + 3 * b + i];
      EXPECT_NEAR(m, kRho * v, 1e-13 * kRho * v);
    }
  }
}

// A pyramid frustum with straight edges: the classical volume formula h/3 (A0 + A1 + sqrt(A0 A1)).
TEST(Element, HexFrustumVolumeFormula) {
  const Frustum f{1.0, -0.5, 1.0, -0.5, 3.0, 0.2, 0.1};
  const double A0 = 4 * 1.5 * 1.5, A1 = 4 * 0.5 * 0.5;
  const double v = f.h / 3 * (A0 + A1 + std::sqrt(A0 * A1));
  for (ElementType t : {ElementType::Hex8, ElementType::Hex20}) {
    const Vec xyz = frustum_nodes(t, f);
    EXPECT_NEAR(fe::element_volume(t, xyz.data()), v, 1e-14 * v) << mesh::element_name(t);
  }
}

TEST_P(ElementTest, InvertedElement) {
  const ElementType t = GetParam();
  const int nv = mesh::vertices_per_element(t);
  const Vec good = distorted_nodes(t, 11);
  ASSERT_GT(fe::min_jacobian(t, good.data()), 0.0);

  // Swap vertices 0 and 1 and rebuild the mid-edge nodes on the new edges.
  Vec bad = good;
  for (int i = 0; i < 3; ++i) std::swap(bad[i], bad[3 + i]);
  const auto& edges = mesh::mid_edges(t);
  for (size_t e = 0; e < edges.size(); ++e)
    for (int i = 0; i < 3; ++i)
      bad[3 * (nv + e) + i] = 0.5 * (bad[3 * edges[e].first + i] + bad[3 * edges[e].second + i]);
  EXPECT_LE(fe::min_jacobian(t, bad.data()), 0.0);

  // A mirror image is inverted everywhere.
  Vec mirror = good;
  for (size_t a = 0; a < mirror.size(); a += 3) mirror[a] = -mirror[a];
  EXPECT_LT(fe::min_jacobian(t, mirror.data()), 0.0);
  double dk = 1.0, dm = 1.0;
  const Vec K = stiffness(t, mirror, kE, kNu, &dk);
  mass(t, mirror, kRho, &dm);
  EXPECT_LT(dk, 0.0);
  EXPECT_LT(dm, 0.0);
  for (double k : K) EXPECT_TRUE(std::isfinite(k));
}

// mesh::corner_jacobian (the orientation test of the Nastran reader, which does not depend on fe)
// is bitwise fe's Jacobian determinant at the centroid of the linear cell, on distorted, inverted
// and mirrored cells.
TEST_P(ElementTest, CornerJacobianIsFeJacobianAtCentroid) {
  const ElementType t = GetParam();
  if (mesh::is_quadratic(t)) return;
  const int nv = mesh::vertices_per_element(t);
  for (unsigned seed : {3u, 11u, 29u}) {
    Vec x = distorted_nodes(t, seed);
    for (int pass = 0; pass < 3; ++pass) {
      if (pass == 1)
        for (int i = 0; i < 3; ++i) std::swap(x[i], x[3 + i]);
      if (pass == 2)
        for (int a = 0; a < nv; ++a) x[3 * a] = -x[3 * a];
      EXPECT_EQ(mesh::corner_jacobian(t, x.data()), fe::jacobian_determinant(t, x.data(), mesh::centroid(t)))
          << mesh::element_name(t) << " seed " << seed << " pass " << pass;
    }
  }
}

// --- stiffness ---------------------------------------------------------------------------------

TEST(Element, IsotropicElasticity) {
  const double E = 100.0, nu = 0.25;
  const auto D = fe::isotropic_elasticity(E, nu);
  const double c = E / ((1 + nu) * (1 - 2 * nu)), G = E / (2 * (1 + nu));
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      double expect = 0.0;
      if (i < 3 && j < 3) expect = i == j ? c * (1 - nu) : c * nu;
      if (i >= 3 && i == j) expect = G;
      EXPECT_NEAR(D[6 * i + j], expect, 1e-13 * E) << i << "," << j;
    }
  EXPECT_THROW(fe::isotropic_elasticity(E, 0.5), morse::Error);
  EXPECT_THROW(fe::isotropic_elasticity(-1.0, 0.3), morse::Error);
}

// The index-form assembly in element_stiffness() must equal B^T D B at the same points.
TEST_P(ElementTest, StiffnessEqualsBtDB) {
  const ElementType t = GetParam();
  const Vec xyz = distorted_nodes(t, 5);
  const Vec K = stiffness(t, xyz, kE, kNu);
  const Vec Kb = integrate_btdb(t, xyz, kE, kNu, fe::stiffness_rule(t));
  EXPECT_LT(max_abs_diff(K, Kb), 1e-13 * max_abs(Kb));
  const int nd = num_dofs(t);
  for (int r = 0; r < nd; ++r)
    for (int c = 0; c < r; ++c) EXPECT_EQ(K[r * nd + c], K[c * nd + r]);
}

void check_rigid_body_modes(ElementType t, const Vec& xyz) {
  const int nd = num_dofs(t);
  double min_det = 0.0;
  const Vec K = stiffness(t, xyz, kE, kNu, &min_det);
  EXPECT_GT(min_det, 0.0);
  const Vec ev = symmetric_eigenvalues(K, nd);
  const double top = ev.back();
  ASSERT_GT(top, 0.0);
  int zeros = 0;
  for (double l : ev) zeros += std::abs(l) < 1e-10 * top;
  EXPECT_EQ(zeros, 6);
  EXPECT_GT(ev[6] / top, 1e-8) << "spurious zero-energy mode";
  EXPECT_GT(ev[0], -1e-10 * top);
  for (const Vec& r : rigid_modes(xyz)) EXPECT_LT(max_abs(matvec(K, r)), 1e-12 * top * max_abs(r));
}

TEST_P(ElementTest, RigidBodyModesRegular) {
  const ElementType t = GetParam();
  const Mat3 I = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  check_rigid_body_modes(t, affine_nodes(t, I, {0, 0, 0}));
}

TEST_P(ElementTest, RigidBodyModesDistorted) {
  const ElementType t = GetParam();
  for (unsigned seed : {1u, 2u, 3u}) {
    const Vec xyz = distorted_nodes(t, seed);
    ASSERT_GT(fe::min_jacobian(t, xyz.data()), 0.0);
    check_rigid_body_modes(t, xyz);
  }
}

// Element patch test: a linear displacement field gives the exact constant strain everywhere,
// and Ke u equals the nodal forces of the corresponding constant stress.
TEST_P(ElementTest, PatchTest) {
  const ElementType t = GetParam();
  const int nd = num_dofs(t);
  const Vec xyz = distorted_nodes(t, 9);
  ASSERT_GT(fe::min_jacobian(t, xyz.data()), 0.0);
  const Mat3 A = {1.0e-3, -2.0e-4, 3.0e-4, 5.0e-4, -7.0e-4, 1.0e-4, -4.0e-4, 6.0e-4, 2.0e-3};
  const Vec u = linear_field(xyz, A, {0.01, -0.02, 0.03});
  const auto eps = voigt_strain(A);
  const auto D = fe::isotropic_elasticity(kE, kNu);
  std::array<double, 6> sigma{};
  for (int i = 0; i < 6; ++i)
    for (int k = 0; k < 6; ++k) sigma[i] += D[6 * i + k] * eps[k];

  // Strain at random points.
  Vec B(6 * nd);
  std::mt19937_64 rng(99);
  const double eps_norm =
      *std::max_element(eps.begin(), eps.end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
  for (int s = 0; s < 10; ++s) {
    const auto x = random_reference_point(t, rng);
    ASSERT_GT(fe::strain_displacement(t, xyz.data(), x.data(), B.data()), 0.0);
    for (int i = 0; i < 6; ++i) {
      double e = 0.0;
      for (int c = 0; c < nd; ++c) e += B[i * nd + c] * u[c];
      EXPECT_NEAR(e, eps[i], 1e-12 * std::abs(eps_norm)) << "component " << i;
    }
  }

  // Nodal forces of the constant stress, with the stiffness rule.
  const auto& rule = fe::stiffness_rule(t);
  Vec f(nd, 0.0);
  double vol = 0.0;
  for (size_t q = 0; q < rule.weights.size(); ++q) {
    const double det = fe::strain_displacement(t, xyz.data(), rule.points[q].data(), B.data());
    vol += rule.weights[q] * det;
    for (int c = 0; c < nd; ++c)
      for (int i = 0; i < 6; ++i) f[c] += rule.weights[q] * det * B[i * nd + c] * sigma[i];
  }
  const Vec K = stiffness(t, xyz, kE, kNu);
  const Vec Ku = matvec(K, u);
  EXPECT_LT(max_abs_diff(Ku, f), 1e-12 * max_abs(f));
  // Self-equilibrated forces.
  for (int i = 0; i < 3; ++i) {
    double s = 0.0;
    for (int a = 0; a < nd / 3; ++a) s += Ku[3 * a + i];
    EXPECT_NEAR(s, 0.0, 1e-12 * max_abs(f));
  }
  // Strain energy u^T K u = V eps . D eps.
  double uku = 0.0, ede = 0.0;
  for (int c = 0; c < nd; ++c) uku += u[c] * Ku[c];
  for (int i = 0; i < 6; ++i) ede += eps[i] * sigma[i];
  EXPECT_NEAR(uku, vol * ede, 1e-12 * vol * ede);
}

// --- mass --------------------------------------------------------------------------------------

TEST_P(ElementTest, MassTotalAndStructure) {
  const ElementType t = GetParam();
  const int n = num_nodes(t), nd = 3 * n;
  const Vec xyz = distorted_nodes(t, 21);
  double min_det = 0.0;
  const Vec M = mass(t, xyz, kRho, &min_det);
  EXPECT_GT(min_det, 0.0);
  const double v = fe::element_volume(t, xyz.data());
  double mx = 0.0;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) mx += M[3 * a * nd + 3 * b];
  EXPECT_NEAR(mx, kRho * v, 1e-13 * kRho * v);
  // Same scalar mass in each direction, no coupling between directions, symmetric.
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const double m = M[(3 * a + i) * nd + 3 * b + j];
          EXPECT_EQ(m, i == j ? M[3 * a * nd + 3 * b] : 0.0);
          EXPECT_EQ(m, M[(3 * b + j) * nd + 3 * a + i]);
        }
  // Consistent mass is positive definite.
  const Vec ev = symmetric_eigenvalues(M, nd);
  EXPECT_GT(ev.front(), 1e-8 * ev.back());
}

TEST(Element, Tet4ConsistentMassClosedForm) {
  const Vec xyz = affine_nodes(ElementType::Tet4, kShear, {0, 0, 0});
  const double v = det3(kShear) / 6.0;
  const Vec M = mass(ElementType::Tet4, xyz, kRho);
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) EXPECT_NEAR(M[3 * a * 12 + 3 * b], kRho * v / 20 * (a == b ? 2 : 1), 1e-13 * kRho * v);
}

INSTANTIATE_TEST_SUITE_P(AllTypes, ElementTest, ::testing::ValuesIn(kAllTypes), type_name);

}  // namespace
