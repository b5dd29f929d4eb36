#include "morse/mesh/cells.hpp"

#include <array>

#include "morse/core/error.hpp"

namespace morse::mesh {

namespace {

using EdgeList = std::vector<std::pair<int, int>>;

// Mid-edge tables per type, linear types empty.
struct OrderTables {
  EdgeList tet10, wedge15, hex20;
};

const OrderTables& tables(NodeOrder o) {
  static const OrderTables gmsh{
      {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {2, 3}, {1, 3}},
      {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 4}, {2, 5}, {3, 4}, {3, 5}, {4, 5}},
      {{0, 1}, {0, 3}, {0, 4}, {1, 2}, {1, 5}, {2, 3}, {2, 6}, {3, 7}, {4, 5}, {4, 7}, {5, 6}, {6, 7}}};
  static const OrderTables abaqus{
      {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}},
      {{0, 1}, {1, 2}, {2, 0}, {3, 4}, {4, 5}, {5, 3}, {0, 3}, {1, 4}, {2, 5}},
      {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6}, {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}}};
  // Nastran's midside grids: CTETRA G5..G10, CPENTA G7..G15, CHEXA G9..G20.
  static const OrderTables nastran{
      {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}},
      {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 4}, {2, 5}, {3, 4}, {4, 5}, {5, 3}},
      {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {0, 4}, {1, 5}, {2, 6}, {3, 7}, {4, 5}, {5, 6}, {6, 7}, {7, 4}}};
  static const OrderTables vtk{
      {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {1, 3}, {2, 3}},
      {{0, 1}, {1, 2}, {0, 2}, {3, 4}, {4, 5}, {3, 5}, {0, 3}, {1, 4}, {2, 5}},
      {{0, 1}, {1, 2}, {2, 3}, {0, 3}, {4, 5}, {5, 6}, {6, 7}, {4, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}}};
  switch (o) {
    case NodeOrder::Abaqus:
      return abaqus;
    case NodeOrder::Nastran:
      return nastran;
    case NodeOrder::Vtk:
      return vtk;
    default:
      return gmsh;
  }
}

}  // namespace

const std::vector<std::pair<int, int>>& mid_edges(ElementType t, NodeOrder o) {
  static const EdgeList kNone;
  const OrderTables& tab = tables(o);
  switch (t) {
    case ElementType::Tet10:
      return tab.tet10;
    case ElementType::Wedge15:
      return tab.wedge15;
    case ElementType::Hex20:
      return tab.hex20;
    default:
      return kNone;
  }
}

std::vector<int> foreign_to_morse(ElementType t, const std::vector<std::pair<int, int>>& foreign) {
  const int nv = vertices_per_element(t), n = nodes_per_element(t);
  const auto& ours = mid_edges(t);
  MORSE_CHECK(static_cast<int>(ours.size()) == n - nv && static_cast<int>(foreign.size()) == n - nv,
              "node ordering: mid-edge table size mismatch for ", element_name(t));
  std::vector<int> perm(n, -1);
  for (int i = 0; i < nv; ++i) perm[i] = i;  // vertex orderings coincide
  std::vector<bool> used(n - nv, false);
  for (int i = 0; i < n - nv; ++i) {
    auto [a, b] = foreign[i];
    for (int j = 0; j < n - nv; ++j)
      if (!used[j] && ((ours[j].first == a && ours[j].second == b) || (ours[j].first == b && ours[j].second == a))) {
        perm[nv + i] = nv + j;
        used[j] = true;
        break;
      }
    MORSE_CHECK(perm[nv + i] >= 0, "node ordering: no ", element_name(t), " node on edge (", a, ",", b, ")");
  }
  return perm;
}

std::vector<int> foreign_to_morse(ElementType t, NodeOrder o) { return foreign_to_morse(t, mid_edges(t, o)); }

const double* centroid(ElementType linear) {
  static const double kTet[3] = {0.25, 0.25, 0.25};
  static const double kWedge[3] = {1.0 / 3, 1.0 / 3, 0.0};
  static const double kHex[3] = {0.0, 0.0, 0.0};
  return linear == ElementType::Tet4 ? kTet : linear == ElementType::Wedge6 ? kWedge : kHex;
}

double corner_jacobian(ElementType linear, const double* xyz) {
  MORSE_CHECK(!is_quadratic(linear), "corner_jacobian: ", element_name(linear), " is not a linear cell");
  // Shape-function derivatives at the centroid, evaluated as fe's shape functions evaluate them
  // (same expressions, so the determinant is bitwise fe::jacobian_determinant's).
  const double* x = centroid(linear);
  const int n = vertices_per_element(linear);
  double dN[3 * 8];
  if (n == 4) {
    static constexpr double kD[12] = {-1, -1, -1, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    std::copy(kD, kD + 12, dN);
  } else if (n == 6) {
    const double L[3] = {1.0 - x[0] - x[1], x[0], x[1]}, dx[3] = {-1.0, 1.0, 0.0}, dy[3] = {-1.0, 0.0, 1.0};
    const double Z[2] = {0.5 * (1.0 - x[2]), 0.5 * (1.0 + x[2])};
    const double dZ[2] = {-0.5, 0.5};
    for (int i = 0; i < 6; ++i) {
      const int t = i % 3, l = i / 3;
      dN[3 * i + 0] = dx[t] * Z[l];
      dN[3 * i + 1] = dy[t] * Z[l];
      dN[3 * i + 2] = L[t] * dZ[l];
    }
  } else {
    static constexpr double kS[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                        {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    for (int i = 0; i < 8; ++i) {
      const double* s = kS[i];
      const double f0 = 1.0 + s[0] * x[0], f1 = 1.0 + s[1] * x[1], f2 = 1.0 + s[2] * x[2];
      dN[3 * i + 0] = 0.125 * s[0] * f1 * f2;
      dN[3 * i + 1] = 0.125 * f0 * s[1] * f2;
      dN[3 * i + 2] = 0.125 * f0 * f1 * s[2];
    }
  }
  double J[9];
  jacobian(n, dN, xyz, J);
  return det3(J);
}

}  // namespace morse::mesh
