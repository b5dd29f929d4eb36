// morse/mesh/mesh.hpp: the mesh data model.
//
// A Mesh is a plain, serial container: nodes, elements, named node and element sets, materials
// and DOFs fixed by the input deck. Readers and generators fill one on rank 0; distribute()
// (partition.hpp) cuts it into per-rank pieces (LocalMesh) and the serial copy is dropped.
//
// Node ordering inside an element is morse's, which equals Gmsh's convention for every type
// (see fe/element.hpp: reference coordinates and mid-edge node table). Readers of other formats
// convert to it.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "morse/mesh/constraints.hpp"

namespace morse::mesh {

/// Supported solid element types.
enum class ElementType : int { Tet4 = 0, Tet10, Wedge6, Wedge15, Hex8, Hex20 };

constexpr int kNumElementTypes = 6;

/// Number of nodes of an element type.
int nodes_per_element(ElementType t);
/// Number of corner (vertex) nodes of an element type.
int vertices_per_element(ElementType t);
/// Human-readable name: "tet4", "tet10", "wedge6", "wedge15", "hex8", "hex20".
const char* element_name(ElementType t);
/// True for quadratic (serendipity / 10-node) types.
bool is_quadratic(ElementType t);
/// Parses a name as returned by element_name(); returns false if unknown.
bool parse_element_name(const std::string& name, ElementType* t);

/// Isotropic linear elastic material. Units as in the mesh (SI unless Mesh::units says else).
struct Material {
  std::string name;
  double E = 0.0;    ///< Young's modulus
  double nu = 0.0;   ///< Poisson's ratio
  double rho = 0.0;  ///< density
};

/// Serial mesh. Indices into node and element arrays are 0-based; ids are the file's labels.
struct Mesh {
  // --- nodes
  std::vector<std::int64_t> node_ids;  ///< external node label of node k
  std::vector<double> coords;          ///< x,y,z of node k at 3k..3k+2

  // --- elements (CSR connectivity)
  std::vector<ElementType> elem_types;
  std::vector<std::int64_t> elem_offsets{0};  ///< nodes of element e: elem_nodes[off[e]..off[e+1])
  std::vector<std::int64_t> elem_nodes;       ///< node indices (not ids)
  std::vector<std::int64_t> elem_ids;         ///< external element label of element e
  std::vector<int> elem_material;             ///< index into materials, -1 = from options

  std::vector<Material> materials;

  // --- sets: sorted, unique indices (not ids)
  std::map<std::string, std::vector<std::int64_t>> node_sets;
  std::map<std::string, std::vector<std::int64_t>> elem_sets;

  /// DOFs fixed by the deck (*BOUNDARY): bit d (0=x,1=y,2=z) of fixed_dofs[k] set if fixed;
  /// bits 3-5 (rotations) count only for six-DOF points (Constraints::point_fixed). Empty when
  /// the deck fixes nothing.
  std::vector<std::uint8_t> fixed_dofs;

  /// Lumped point masses (Nastran CONM2), added to the three translational diagonal entries of
  /// M at node k. Empty when the deck has none.
  std::vector<double> point_mass;

  /// Rigid and interpolation elements, linear constraints and their six-DOF points (by external
  /// ids; mesh/constraints.hpp). Replicated on every rank of a distributed mesh.
  Constraints constraints;

  /// Unit system, recorded in output files: "SI" (m, kg, s, N, Pa) or e.g. "mm-t-s".
  std::string units = "SI";
  /// Where the mesh came from (file name or generator description), for messages and output.
  std::string source;

  std::int64_t num_nodes() const { return static_cast<std::int64_t>(node_ids.size()); }
  std::int64_t num_elements() const { return static_cast<std::int64_t>(elem_types.size()); }

  /// Appends a node and returns its index.
  std::int64_t add_node(std::int64_t id, double x, double y, double z);
  /// Appends an element (nodes are indices, in morse ordering) and returns its index.
  std::int64_t add_element(std::int64_t id, ElementType t, const std::int64_t* nodes, int material = -1);
  /// Sorts and de-duplicates every set.
  void normalize_sets();
};

/// Gives every element of the element set named mat.name the material mat (appended to
/// m->materials). Throws morse::Error naming the set and listing the element sets if it does not
/// exist. Not collective (every rank of a distributed mesh knows every set name).
void assign_set_material(Mesh* m, const Material& mat);

/// Name of the pseudo node set that stands for "the DOFs fixed by *BOUNDARY in the deck".
inline constexpr const char* kDeckBoundarySet = "*BOUNDARY";

}  // namespace morse::mesh
