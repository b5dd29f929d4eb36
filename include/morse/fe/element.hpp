// morse/fe/element.hpp: isoparametric solid elements (shape functions, quadrature, element
// stiffness and consistent mass for linear isotropic elasticity).
//
// Node ordering: morse's (= Gmsh's), whose reference cells and mid-edge nodes are given in
// mesh/cells.hpp (mesh::mid_edges()).
// Element DOFs are node-major: (u_x, u_y, u_z) of node 0, then node 1, ... Matrices are dense,
// row-major, size (3n)x(3n).
#pragma once

#include <array>
#include <utility>
#include <vector>

#include "morse/mesh/cells.hpp"
#include "morse/mesh/mesh.hpp"

namespace morse::fe {

using mesh::ElementType;

using mesh::kMaxNodes;
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
