#include "morse/mesh/mesh.hpp"

#include <algorithm>

#include "morse/core/error.hpp"

namespace morse::mesh {

namespace {
struct TypeInfo {
  const char* name;
  int n_nodes;
  int n_vertices;
};
constexpr TypeInfo kInfo[kNumElementTypes] = {
    {"tet4", 4, 4}, {"tet10", 10, 4}, {"wedge6", 6, 6}, {"wedge15", 15, 6}, {"hex8", 8, 8}, {"hex20", 20, 8},
};
}  // namespace

int nodes_per_element(ElementType t) { return kInfo[static_cast<int>(t)].n_nodes; }
int vertices_per_element(ElementType t) { return kInfo[static_cast<int>(t)].n_vertices; }
const char* element_name(ElementType t) { return kInfo[static_cast<int>(t)].name; }
bool is_quadratic(ElementType t) { return nodes_per_element(t) != vertices_per_element(t); }

bool parse_element_name(const std::string& name, ElementType* t) {
  for (int i = 0; i < kNumElementTypes; ++i)
    if (name == kInfo[i].name) {
      *t = static_cast<ElementType>(i);
      return true;
    }
  return false;
}

std::int64_t Mesh::add_node(std::int64_t id, double x, double y, double z) {
  node_ids.push_back(id);
  coords.insert(coords.end(), {x, y, z});
  return num_nodes() - 1;
}

std::int64_t Mesh::add_element(std::int64_t id, ElementType t, const std::int64_t* nodes, int material) {
  const int n = nodes_per_element(t);
  elem_types.push_back(t);
  elem_nodes.insert(elem_nodes.end(), nodes, nodes + n);
  elem_offsets.push_back(static_cast<std::int64_t>(elem_nodes.size()));
  elem_ids.push_back(id);
  elem_material.push_back(material);
  return num_elements() - 1;
}

void assign_set_material(Mesh* m, const Material& mat) {
  auto it = m->elem_sets.find(mat.name);
  if (it == m->elem_sets.end()) {
    std::string known;
    for (const auto& [name, v] : m->elem_sets) known += (known.empty() ? "" : ", ") + name;
    throw Error(cat("-material_sets: element set '", mat.name, "' not found in ", m->source,
                    " (element sets: ", known.empty() ? "none" : known, ")"));
  }
  m->materials.push_back(mat);
  for (auto e : it->second) m->elem_material[e] = static_cast<int>(m->materials.size()) - 1;
}

void Mesh::normalize_sets() {
  for (auto* sets : {&node_sets, &elem_sets})
    for (auto& [name, v] : *sets) {
      std::sort(v.begin(), v.end());
      v.erase(std::unique(v.begin(), v.end()), v.end());
    }
}

}  // namespace morse::mesh
