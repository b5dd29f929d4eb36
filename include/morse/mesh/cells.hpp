// morse/mesh/cells.hpp: the node orderings of the cells in one place (morse's own, which is
// Gmsh's, and those of Abaqus, Nastran and XDMF/VTK), and the size of the largest cell.
//
// Every ordering lists the vertices as morse does; the orderings differ in their mid-edge nodes
// only, each of which is named by the vertex pair of its edge. morse (= Gmsh) reference cells:
//   tet:   vertices (0,0,0) (1,0,0) (0,1,0) (0,0,1)
//   wedge: vertices (0,0,-1) (1,0,-1) (0,1,-1) (0,0,1) (1,0,1) (0,1,1)   [triangle x line]
//   hex:   vertices (-1,-1,-1) (1,-1,-1) (1,1,-1) (-1,1,-1) then the same at zeta=+1
// and their mid-edge nodes:
//   tet10:   4:(0,1) 5:(1,2) 6:(0,2) 7:(0,3) 8:(2,3) 9:(1,3)
//   wedge15: 6:(0,1) 7:(0,2) 8:(0,3) 9:(1,2) 10:(1,4) 11:(2,5) 12:(3,4) 13:(3,5) 14:(4,5)
//   hex20:   8:(0,1) 9:(0,3) 10:(0,4) 11:(1,2) 12:(1,5) 13:(2,3) 14:(2,6) 15:(3,7)
//            16:(4,5) 17:(4,7) 18:(5,6) 19:(6,7)
// Nothing here is collective.
#pragma once

#include <utility>
#include <vector>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Nodes of the largest cell (hex20).
constexpr int kMaxNodes = 20;

/// The node orderings morse reads or writes. morse's own ordering is Gmsh's; XDMF uses VTK's.
enum class NodeOrder { Gmsh, Abaqus, Nastran, Vtk };

/// Vertex pairs of the mid-edge nodes of type t in ordering o, in order (empty for linear types):
/// entry k belongs to node vertices_per_element(t) + k.
const std::vector<std::pair<int, int>>& mid_edges(ElementType t, NodeOrder o = NodeOrder::Gmsh);

/// Node permutation from another node ordering of type t (vertices in the same order, mid-edge
/// nodes given by their vertex pairs, entry k belonging to node vertices + k): returns, for each
/// node position i of the other ordering, the morse node index. Throws morse::Error if the two
/// tables do not name the same edges.
std::vector<int> foreign_to_morse(ElementType t, const std::vector<std::pair<int, int>>& foreign_mid_edges);

/// foreign_to_morse(t, mid_edges(t, o)): for each node position i of ordering o, the morse node index.
std::vector<int> foreign_to_morse(ElementType t, NodeOrder o);

/// Reference coordinates of the centroid of a linear cell (Tet4, Wedge6 or Hex8).
const double* centroid(ElementType linear);

/// Jacobian determinant of the linear cell `linear` (Tet4, Wedge6 or Hex8) with vertex
/// coordinates xyz (vertices x 3, row-major) at its centroid: negative for a cell whose vertices
/// are listed in the mirrored order. The same number, bitwise, as fe::jacobian_determinant(linear,
/// xyz, centroid(linear)).
double corner_jacobian(ElementType linear, const double* xyz);

/// The Jacobian J[3i + j] = d x_i / d xi_j (3 x 3, row-major) of a cell of n nodes with
/// coordinates xyz (n x 3) at a point where its shape-function derivatives are dN (n x 3):
/// J = sum_a xyz_a dN_a^T. Not collective.
inline void jacobian(int n, const double* dN, const double* xyz, double* J) {
  for (int k = 0; k < 9; ++k) J[k] = 0.0;
  for (int a = 0; a < n; ++a) {
    const double* g = dN + 3 * a;
    const double* p = xyz + 3 * a;
    for (int i = 0; i < 3; ++i) {
      J[3 * i + 0] += p[i] * g[0];
      J[3 * i + 1] += p[i] * g[1];
      J[3 * i + 2] += p[i] * g[2];
    }
  }
}

/// Determinant of a 3 x 3 row-major matrix. Not collective.
inline double det3(const double* J) {
  return J[0] * (J[4] * J[8] - J[5] * J[7]) - J[1] * (J[3] * J[8] - J[5] * J[6]) + J[2] * (J[3] * J[7] - J[4] * J[6]);
}

}  // namespace morse::mesh
