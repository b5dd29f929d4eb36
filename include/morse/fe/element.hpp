// morse/fe/element.hpp: isoparametric solid elements (shape functions, quadrature, element
// stiffness and consistent mass for linear isotropic elasticity).
//
// Node ordering (morse = Gmsh convention). Reference cells:
//   tet:   vertices (0,0,0) (1,0,0) (0,1,0) (0,0,1)
//   wedge: vertices (0,0,-1) (1,0,-1) (0,1,-1) (0,0,1) (1,0,1) (0,1,1)   [triangle x line]
//   hex:   vertices (-1,-1,-1) (1,-1,-1) (1,1,-1) (-1,1,-1) then the same at zeta=+1
// Mid-edge nodes of quadratic types, given by the vertex pair of their edge (see mid_edges()):
//   tet10:   4:(0,1) 5:(1,2) 6:(0,2) 7:(0,3) 8:(2,3) 9:(1,3)
//   wedge15: 6:(0,1) 7:(0,2) 8:(0,3) 9:(1,2) 10:(1,4) 11:(2,5) 12:(3,4) 13:(3,5) 14:(4,5)
//   hex20:   8:(0,1) 9:(0,3) 10:(0,4) 11:(1,2) 12:(1,5) 13:(2,3) 14:(2,6) 15:(3,7)
//            16:(4,5) 17:(4,7) 18:(5,6) 19:(6,7)
// Element DOFs are node-major: (u_x, u_y, u_z) of node 0, then node 1, ... Matrices are dense,
// row-major, size (3n)x(3n).
#pragma once

#include <array>
#include <utility>
#include <vector>

#include "morse/mesh/mesh.hpp"

namespace morse::fe {

using mesh::ElementType;

constexpr int kMaxNodes = 20;
constexpr int kMaxDofs = 3 * kMaxNodes;

/// A quadrature rule on the reference cell. Weights sum to the reference cell volume
/// (1/6 tet, 1 wedge, 8 hex).
struct QuadratureRule {
  std::vector<std::array<double, 3>> points;
  std::vector<double> weights;
};

/// Rule used for the stiffness matrix: exact for the B^T D B integrand on affine/undistorted
/// elements and rank-sufficient (no spurious zero-energy modes) for every type.
const QuadratureRule& stiffness_rule(ElementType t);
/// Rule used for the consistent mass matrix: exact for N^T N on affine/undistorted elements.
const QuadratureRule& mass_rule(ElementType t);

/// Reference coordinates of the nodes (n x 3, in morse ordering).
const std::vector<std::array<double, 3>>& reference_nodes(ElementType t);
/// Vertex pairs of the mid-edge nodes, in order (empty for linear types). Entry k belongs to node
/// vertices_per_element(t) + k.
const std::vector<std::pair<int, int>>& mid_edges(ElementType t);

/// Node permutation from another node ordering of type t (vertices in the same order, mid-edge
/// nodes given by their vertex pairs, entry k belonging to node vertices + k): returns, for each
/// node position i of the other ordering, the morse node index. Throws morse::Error if the two
/// tables do not name the same edges.
std::vector<int> foreign_to_morse(ElementType t, const std::vector<std::pair<int, int>>& foreign_mid_edges);

/// Shape functions N (n) and derivatives dN (n x 3, row-major, d/dxi, d/deta, d/dzeta) at xi.
/// dN may be null.
void shape_functions(ElementType t, const double xi[3], double* N, double* dN);

/// Jacobian determinant at xi for node coordinates xyz (n x 3 row-major).
double jacobian_determinant(ElementType t, const double* xyz, const double xi[3]);

/// Smallest Jacobian determinant over the nodes and the stiffness quadrature points. A value <= 0
/// means the element is inverted or degenerate.
double min_jacobian(ElementType t, const double* xyz);

/// Element volume (integral of 1) with the mass rule.
double element_volume(ElementType t, const double* xyz);

/// Element stiffness Ke ((3n)^2, row-major) of linear isotropic elasticity. Returns the smallest
/// Jacobian determinant met at the quadrature points (<= 0: inverted element; Ke is then
/// meaningless).
double element_stiffness(ElementType t, const double* xyz, double E, double nu, double* Ke);

/// Consistent mass Me ((3n)^2, row-major). Returns the smallest Jacobian determinant met.
double element_mass(ElementType t, const double* xyz, double rho, double* Me);

/// Isotropic elasticity matrix (6x6, Voigt order xx yy zz yz xz xy with engineering shear).
std::array<double, 36> isotropic_elasticity(double E, double nu);

/// Physical shape-function gradients at the points of stiffness_rule(t): g (nq x n x 3,
/// row-major: dN_a/dx_k of node a at point q at g[3 (n q + a) + k]) and the weights w_q det J_q
/// (nq). Returns the smallest det J (<= 0: inverted element; the outputs are then meaningless).
/// Used by the geometrically nonlinear kernels (fe/nonlinear.hpp), so that they integrate with
/// exactly the linear stiffness quadrature.
double stiffness_gradients(ElementType t, const double* xyz, double* g, double* wdet);

/// Physical shape-function gradients at xi: g (n x 3, row-major, dN_a/dx_k at g[3a + k]).
/// Returns det J (<= 0: inverted or degenerate element; g is then meaningless).
double shape_gradients(ElementType t, const double* xyz, const double xi[3], double* g);

/// Strain-displacement evaluation: given xyz and xi, fills B (6 x 3n, row-major) and returns
/// det J. Used for stress recovery and patch tests.
double strain_displacement(ElementType t, const double* xyz, const double xi[3], double* B);

}  // namespace morse::fe
