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
//                                           ignored; a nonzero prescribed value is an error. A
//                                           *BOUNDARY inside a *STEP is applied like the others.
//   *MATERIAL, NAME=name
//   *ELASTIC [, TYPE=ISO]                   E, nu[, temperature]: first line used
//   *DENSITY                                rho[, temperature]: first line used
//   *SOLID SECTION, ELSET=name, MATERIAL=name
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
// resolved once the whole deck is read, so they may refer to nodes, elements and materials
// defined further down; a set name listed inside *NSET / *ELSET must be defined above (its members
// at that point are copied). *INCLUDE is textual: data lines of the keyword in force may continue
// in the included file. Elements not covered by a *SOLID SECTION get elem_material = -1.
// Mesh::units is "unknown" (decks carry no unit system); Mesh::source is the path.
//
// Errors (morse::Error, message "file:line: what") are raised for: missing deck or included file,
// unsupported element type, undefined node / element / set / material, duplicate labels,
// truncated or malformed data lines, and unsupported features (nonzero prescribed
// displacements, anisotropic elasticity, non-rectangular node systems).
#pragma once

#include <string>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Reads the Abaqus/CalculiX deck at path (serial, call on one rank). Notices about ignored
/// keywords and data go to stderr if verbose. Throws morse::Error on any input error.
Mesh read_abaqus(const std::string& path, bool verbose = true);

}  // namespace morse::mesh
