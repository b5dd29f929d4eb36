// morse/mesh/constraints.hpp: rigid elements, interpolation elements and linear multi-point
// constraints as a deck gives them (Nastran RBE2, RBE3, MPC; Abaqus *RIGID BODY, *COUPLING,
// *EQUATION), and the six-DOF points they connect.
//
// The records keep the deck's external node ids, so they survive the removal of unused nodes and
// the distribution of the mesh unchanged: every rank holds all of them (they are few). A point is
// a node that no solid element uses but a constraint does (a spider's centre, a bearing's
// reference node): it has six DOFs, three translations and three rotations, and no stiffness of
// its own. fe::eliminate_constraints (fe/constraints.hpp) turns the records into u = T u_bar.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace morse::mesh {

/// Components as a bit mask: bit c-1 for component c (1..3 the translations x, y, z, 4..6 the
/// rotations about x, y, z).
using ComponentMask = std::uint8_t;

/// A rigid element (Nastran RBE2, Abaqus *RIGID BODY or *COUPLING with *KINEMATIC): the
/// `components` of every dependent node follow the rigid motion of the independent node,
/// u_d = u_R + theta_R x (x_d - x_R), theta_d = theta_R. The independent node must be a point.
struct RigidElement {
  std::int64_t id = 0;
  std::string where;  ///< "file:line: CARD id" for messages
  std::int64_t reference = 0;
  ComponentMask components = 0;  ///< of the dependent nodes
  std::vector<std::int64_t> dependent;
};

/// An interpolation element (Nastran RBE3, Abaqus *COUPLING with *DISTRIBUTING): the motion of
/// the reference point is the weighted least-squares rigid fit of the nodes' motions,
/// min over (u_R, theta_R) of sum_i w_i sum_{c in C_i} (u_i,c - (u_R + theta_R x (x_i - x_R))_c)^2,
/// for its `ref_components`. Forces on the reference point are spread to the nodes by the
/// transpose (the lever rule).
struct InterpolationElement {
  std::int64_t id = 0;
  std::string where;
  std::int64_t reference = 0;
  ComponentMask ref_components = 0;
  std::vector<std::int64_t> nodes;
  std::vector<double> weights;                 ///< per node, > 0
  std::vector<ComponentMask> node_components;  ///< per node, translations (1..3)
};

/// One term of a linear constraint: coefficient times component (1..6) of node `node`.
struct Term {
  std::int64_t node = 0;
  int component = 0;
  double coefficient = 0;
};

/// A linear multi-point constraint sum_k a_k u_k = 0 (Nastran MPC, Abaqus *EQUATION); the first
/// term's DOF is the dependent one (a_1 != 0).
struct LinearConstraint {
  std::int64_t id = 0;
  std::string where;
  std::vector<Term> terms;
};

/// Everything a deck constrains, and the points it adds.
struct Constraints {
  std::vector<RigidElement> rigid;
  std::vector<InterpolationElement> interpolation;
  std::vector<LinearConstraint> linear;

  /// The six-DOF points (nodes no solid uses), ascending ids, with their coordinates (3 each)
  /// and lumped masses (on the translations; 0 if none). Filled by mesh::distribute.
  std::vector<std::int64_t> point_ids;
  std::vector<double> point_coords;
  std::vector<double> point_mass;
  /// The DOFs the deck fixes (*BOUNDARY, SPC) on each point, bits 0-5 for components 1-6.
  std::vector<std::uint8_t> point_fixed;
  /// Rigid masses on points (Nastran CONM2 with offsets or inertias): point id and its 6 x 6 mass
  /// matrix about the point in the basic system (36 values, row-major, DOFs x y z rx ry rz).
  std::vector<std::int64_t> mass_ids;
  std::vector<double> mass_matrices;
  /// The points of each node set (ids, ascending): a set may hold solid nodes and points.
  std::map<std::string, std::vector<std::int64_t>> point_sets;

  bool empty() const { return rigid.empty() && interpolation.empty() && linear.empty(); }
  /// Every node id a record names (references, dependents, nodes, terms), ascending, unique.
  std::vector<std::int64_t> referenced_ids() const;
  /// Index of point `id` in point_ids, or -1.
  std::int64_t point_index(std::int64_t id) const;
  /// "2 rigid elements, 1 interpolation element, 4 linear constraints, 3 points".
  std::string summary() const;
};

/// The 6 x 6 mass matrix about a point of a rigid body of mass m whose centre of gravity is at
/// offset d from the point and whose inertia tensor about the centre of gravity is J (3 x 3,
/// row-major): [[m I, -m [d]x], [m [d]x, J + m (|d|^2 I - d d^T)]], for the DOFs (u, theta) of
/// the point (the body moves as u + theta x r). Row-major, 36 values.
std::vector<double> rigid_mass_matrix(double m, const double d[3], const double J[9]);

/// Parses a component string of digits 1-6 ("123456", "123"); false if it is empty, has another
/// character or repeats a digit.
bool parse_component_mask(const std::string& s, ComponentMask* mask);
/// The digits of a mask ("123456").
std::string component_digits(ComponentMask mask);

}  // namespace morse::mesh
