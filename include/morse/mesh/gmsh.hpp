// morse/mesh/gmsh.hpp: reading and writing Gmsh .msh files (ASCII, MSH 4.1 and 2.2).
//
// Reading. The solid elements become the elements of the Mesh:
//   gmsh type  4 tet4, 11 tet10, 6 wedge6 (prism), 18 wedge15, 5 hex8, 17 hex20.
// Gmsh's node ordering is morse's (fe/element.hpp), so connectivity is copied unchanged.
// Elements of lower dimension (points, lines, triangles, quadrangles of any order) are read only
// to fill physical groups and are then dropped. Any other 3D type (pyramids, 27-node hexahedra,
// 18-node prisms, higher-order tetrahedra, ...) is an error.
//
// Physical groups become sets. A group of any dimension becomes the node set of all nodes of its
// elements; a 3D group also becomes the element set of its elements. The set is named by the
// group's $PhysicalNames entry, or "physical_<dim>_<tag>" if the group has no name. Groups that
// share a name are merged. Every group declared in the file yields a set, possibly empty.
//
// Node and element tags become Mesh::node_ids / Mesh::elem_ids; they need not be contiguous.
// A solid element that repeats the type and nodes of an earlier one (MSH 2 writes an element
// once per physical group it belongs to, under a new tag) is merged into the earlier one, which
// keeps its tag and gains the groups.
// All nodes of the file are kept, in file order, including nodes no solid element uses.
//
// Writing produces MSH 4.1 ASCII: the nodes, the solid elements (in Mesh order, with their ids),
// every node set as a dimension-0 physical group of point elements (type 15) and every element
// set as a 3D physical group. The file also carries a small $MorseSets section (ignored by Gmsh)
// which tells read_gmsh() that the 3D groups were written as element sets only, so that
// read_gmsh(write_gmsh(m)) reproduces nodes, elements, node sets and element sets exactly.
// Materials, fixed_dofs and units are not stored.
#pragma once

#include <string>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Reads an ASCII Gmsh file of format 4.1 or 2.2 (2.0 and 2.1 are read as 2.2) into a new Mesh
/// owned by the caller. Mesh::source is set to path; elem_material is -1 for every element.
/// Not collective: call it on one rank.
///
/// Throws morse::Error with a message "<path>:<line>: <what>" (or "<path>: <what>" when no line
/// applies, e.g. the file cannot be opened) if the file cannot be read, is binary, has another
/// format version, is truncated (end of file inside a section or a missing $End... line), contains
/// a malformed or out-of-range number, an unsupported 3D element type or an unknown element type,
/// references an undefined node, repeats a node tag (or an element tag with other nodes), is a
/// partitioned file, or contains no supported 3D element.
Mesh read_gmsh(const std::string& path);

/// Writes mesh as an ASCII MSH 4.1 file (see the top of this header for the layout). The file is
/// written to its temporary files::temp_path(path) and renamed to path once complete, so a reader
/// never sees a partial file. Coordinates are printed with %.17g and read back bit-identical. Not collective.
///
/// Throws morse::Error if a node or element id is not positive (Gmsh tags must be >= 1), a set
/// name contains a double quote or a line break, a set index is out of range, or the file cannot
/// be written or renamed (the temporary file is removed then).
void write_gmsh(const Mesh& mesh, const std::string& path);

}  // namespace morse::mesh
