// morse/mesh/abaqus.hpp: reader of Abaqus / CalculiX input decks (.inp).
//
// Reads the model-data part of a deck into a serial Mesh. Supported keywords (names and parameter
// names are case-insensitive, spaces in keyword lines are ignored):
//
//   *NODE [, NSET=name]                     label, x, y, z
//   *ELEMENT, TYPE=t [, ELSET=name]         label, n1, n2, ...  (continues on the following lines
//                                           until all nodes are read; a trailing comma is optional)
//        t = C3D4, C3D10, C3D6, C3D15, C3D8, C3D20, C3D20R (read as C3D20)
//   *NSET, NSET=name [, GENERATE]           node labels or names of node sets (GENERATE:
//                                           start, end[, step])
//   *ELSET, ELSET=name [, GENERATE]         the same for elements and element sets
//   *INCLUDE, INPUT=file                    file relative to the including file's directory;
//                                           nesting allowed. INPUT= on *NODE, *ELEMENT, *NSET and
//                                           *ELSET reads that keyword's data lines from a file.
//   *BOUNDARY                               node label or node set, first DOF[, last DOF[, value]]
//                                           or node/set, ENCASTRE|PINNED|XSYMM|...: DOFs 1..3 set
//                                           bits of Mesh::fixed_dofs; rotational DOFs (4..6) are
//                                           ignored (with a notice, also on a reference node); a
//                                           nonzero prescribed value is an error. A *BOUNDARY
//                                           inside a *STEP is applied like the others.
//   *MATERIAL, NAME=name
//   *ELASTIC [, TYPE=ISO]                   E, nu[, temperature]: first line used
//   *DENSITY                                rho[, temperature]: first line used
//   *SOLID SECTION, ELSET=name, MATERIAL=name
//
// Constraints, into Mesh::constraints (mesh/constraints.hpp, by node label):
//
//   *EQUATION [, INPUT=file]                N (the number of terms), then N terms 'node or node
//                                           set, DOF (1..6), coefficient', one to four per line,
//                                           on as many lines as needed; repeat for more equations.
//                                           One LinearConstraint per equation, the first term's DOF
//                                           dependent. A node-set term gives one equation per node:
//                                           all sets of an equation must have as many nodes and are
//                                           matched in ascending label order; a node given by its
//                                           number is in every one of them.
//   *RIGID BODY, REF NODE=n, NSET=s | TIE NSET=s | PIN NSET=s | ELSET=e [, ISOTHERMAL=...]
//                                           (no data lines) one RigidElement with reference n and
//                                           components 123456 for the nodes of NSET, TIE NSET and
//                                           the elements of ELSET, one with components 123 for PIN
//                                           NSET.
//   *COUPLING, REF NODE=n, SURFACE=name [, CONSTRAINT NAME=c]
//                                           (no data lines) followed directly by
//   *KINEMATIC                              [first DOF[, last DOF] lines]: a RigidElement over the
//                                           surface's nodes, components the DOFs listed (all six
//                                           without data lines), or by
//   *DISTRIBUTING [, WEIGHTING METHOD=UNIFORM] [, COUPLING=CONTINUUM]
//                                           [first DOF[, last DOF] lines]: an InterpolationElement
//                                           over the surface's nodes (their translations), with
//                                           the surface's weights, reference components the DOFs
//                                           listed (all six without data lines).
//   *SURFACE, NAME=name, TYPE=NODE          node or node set[, weight] (a weight of 0 or none is
//                                           1). Other surfaces (TYPE=ELEMENT, the default, ...) are
//                                           skipped with a notice; a *COUPLING on one is an error.
//
// REF NODE is a node label or a node set of exactly one node. A reference node is usually a *NODE
// that no element uses: it becomes a six-DOF point (mesh::distribute). Records keep the order of
// the deck; ids count the records of each kind from 1; `where` is "file:line: *EQUATION",
// "file:line: *RIGID BODY" (" (PIN NSET)" for the pinned nodes), "file:line: *COUPLING c".
//
// Every other keyword (*HEADING, *STEP, *FREQUENCY, *NODE PRINT, *EL FILE, ...) is skipped with
// its data lines; one notice per distinct keyword is printed to stderr when verbose. Lines starting
// with "**" are comments; blank lines are ignored. Keyword lines do not continue onto the next
// line (CalculiX convention: "*FREQUENCY, ...," is followed by a data line).
//
// Node and element labels may be arbitrary (non-contiguous) positive integers; the Mesh keeps
// them in node_ids / elem_ids and stores indices elsewhere. Element connectivity is converted from
// Abaqus to morse (Gmsh) node ordering. Set names are stored as first written; references to sets
// and materials inside the deck are case-insensitive. Sets, *BOUNDARY and *SOLID SECTION are
// resolved once the whole deck is read, as are the constraints and the surfaces a *COUPLING uses
// (a surface no *COUPLING uses is not checked), so they may refer to nodes, sets, surfaces and
// materials defined further down; a set name listed inside *NSET / *ELSET must be defined above
// (its members at that point are copied). *INCLUDE is textual: data lines of the keyword in force
// may continue in the included file. Elements not covered by a *SOLID SECTION get
// elem_material = -1. Mesh::units is "unknown" (decks carry no unit system); Mesh::source is the
// path.
//
// Errors (morse::Error, message "file:line: what") are raised for: missing deck or included file,
// unsupported element type, undefined node / element / set / surface / material, duplicate
// labels, truncated or malformed data lines, and unsupported features (nonzero prescribed
// displacements, anisotropic elasticity, non-rectangular node systems). For the constraints: an
// *EQUATION whose first coefficient is 0, with fewer terms than announced before the next keyword,
// a DOF outside 1..6, or node sets of different sizes; *RIGID BODY with ROT NODE= (the reference
// node carries the rotations) or without REF NODE= or nodes, a node both tied and pinned;
// *COUPLING not followed by *KINEMATIC or *DISTRIBUTING, with ORIENTATION= or INFLUENCE RADIUS=,
// on a surface that is not TYPE=NODE; *DISTRIBUTING with a WEIGHTING METHOD other than UNIFORM or
// COUPLING=STRUCTURAL; a node listed twice in a surface with different weights; a parameter these
// keywords do not take (POSITION=, ANALYTICAL SURFACE=, REMOVE, ...); a REF NODE set that does not
// hold exactly one node. The elimination (fe::eliminate_constraints) checks the rest (a dependent
// DOF clamped or dependent twice, cycles, rotations of solid nodes).
#pragma once

#include <string>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Reads the Abaqus/CalculiX deck at path (serial, call on one rank). Notices about ignored
/// keywords and data go to stderr if verbose. Throws morse::Error on any input error.
Mesh read_abaqus(const std::string& path, bool verbose = true);

}  // namespace morse::mesh
