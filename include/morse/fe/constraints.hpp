// morse/fe/constraints.hpp: elimination of rigid elements (RBE2), interpolation elements (RBE3)
// and linear multi-point constraints (MPC) from a mesh model, by a transformation u = T u_bar
// (docs/theory.md §1.4).
//
// Every record becomes equations "dependent DOF = linear combination of other DOFs":
//   rigid          u_d = u_R + theta_R x (x_d - x_R) for the element's components of every
//                  dependent node (and theta_d = theta_R for a dependent point);
//   interpolation  the reference point's motion is the weighted least-squares rigid fit of its
//                  nodes' translations, (u_R, theta_R) = G u_nodes. The reference point is made
//                  independent (so that it can be a superelement's boundary, carry a mass or a
//                  load): as Nastran's UM option, as many node DOFs as the reference has
//                  components become dependent instead, chosen by complete pivoting on G, and
//                  u_S = G_S^-1 (u_R - G_N u_N). The constrained motions are the same set.
//                  When its nodes' free DOFs cannot carry the reference (overlapping elements
//                  that already made them dependent), the reference stays dependent (Nastran's
//                  default) and is no DOF of the model (notice).
//   linear         a_1 u_1 + sum a_k u_k = 0: u_1 = -sum (a_k / a_1) u_k.
// Chains (a dependent DOF in another equation) are substituted; a cycle is an error. The model's
// DOFs are then the nodes' free translations that are not dependent, rank by rank as before,
// followed on rank 0 by the points' independent DOFs (point id, component 1..6). A point DOF
// that no equation uses has no stiffness; it is left out (Nastran's AUTOSPC), with a notice.
// K_bar = T^T K T and M_bar = T^T M T (symmetrized), plus the points' lumped masses. Both stay
// distributed; the constraints themselves (a few thousand terms) are replicated on every rank.
#pragma once

#include <petscmat.h>
#include <petscvec.h>

#include <string>
#include <vector>

#include "morse/core/handle.hpp"
#include "morse/fe/model.hpp"

namespace morse::fe {

/// Eliminates the constraints of md's mesh (md->mesh->mesh.constraints, not empty) from md: md's
/// DOF layout, K and M become the reduced ones and md->constraints holds T and the former layout.
/// clamp_sets are the sets number_dofs clamped (their points' DOFs are clamped too). Throws
/// (collectively), naming the element (file:line and card), node and component, for: a dependent
/// DOF that is also clamped or dependent in another element, a circular dependency, an
/// independent or reference node that is not a six-DOF point, rotations of a solid node, an
/// interpolation element whose nodes and weights leave the reference's motion undetermined
/// (collinear nodes, zero weights), a linear constraint whose first coefficient is 0. With
/// keep_node_stiffness, md->constraints->K_nodes keeps the stiffness on the nodes' layout, which only
/// the nonlinear forces need (fe::Svk through T); without, it is released (one matrix less). Collective.
void eliminate_constraints(Model* md, const std::vector<std::string>& clamp_sets, bool keep_node_stiffness = true);

/// u = T u_bar: the free translations of the mesh's nodes (md.constraints->full) from a vector of
/// the model's DOFs. Without constraints, a copy of u_bar. Collective.
UVec expand(const Model& md, Vec u_bar);

/// The columns of X (MPIDENSE, rows as node_layout(md): nodal fields such as a fom file's
/// snapshots) on the model's DOFs, by least squares: Y = argmin ||T Y - X|| (the normal equations,
/// a Cholesky factor of T^T T). A field that satisfies the constraints (X = T Y) gives its model
/// coordinates exactly, the six-DOF points' rotations included. Without constraints, a copy of X.
/// Collective.
UMat restrict_columns(const Model& md, Mat X);
/// The same for one nodal field x (a vector of node_layout(md)): a vector of the model's DOFs.
UVec restrict_vector(const Model& md, Vec x);

/// The layout of the nodes' free translations: md.constraints->full, or md.dofs. Not collective.
const DofLayout& node_layout(const Model& md);

/// For each owned row of md.dofs: 6 p + c - 1 if it is component c of six-DOF point p
/// (p indexing md.mesh->mesh.constraints.point_ids), else -1. Empty without points. The points'
/// rows are rank 0's, so other ranks get only -1. Not collective.
std::vector<std::int64_t> point_dof_slots(const Model& md);

}  // namespace morse::fe
