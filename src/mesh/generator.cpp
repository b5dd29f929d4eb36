#include "morse/mesh/generator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <unordered_map>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"

namespace morse::mesh {

namespace {

// Local vertex numbering of a cell: bit 0 = +x, bit 1 = +y, bit 2 = +z.
constexpr int kHex[8] = {0, 1, 3, 2, 4, 5, 7, 6};
constexpr int kWedges[2][6] = {{0, 1, 3, 4, 5, 7}, {0, 3, 2, 4, 7, 6}};

// Mid-edge node tables (vertex pairs), as documented in fe/element.hpp.
constexpr int kTet10Edges[6][2] = {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {2, 3}, {1, 3}};
constexpr int kWedge15Edges[9][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 4}, {2, 5}, {3, 4}, {3, 5}, {4, 5}};
constexpr int kHex20Edges[12][2] = {{0, 1}, {0, 3}, {0, 4}, {1, 2}, {1, 5}, {2, 3},
                                    {2, 6}, {3, 7}, {4, 5}, {4, 7}, {5, 6}, {6, 7}};

/// The six Kuhn tetrahedra of the unit cell, each positively oriented.
std::vector<std::array<int, 4>> kuhn_tets() {
  std::vector<std::array<int, 4>> tets;
  int perm[3] = {0, 1, 2};
  do {
    const int a = 1 << perm[0], b = a | (1 << perm[1]);
    std::array<int, 4> t{0, a, b, 7};
    // Orientation: det of the edge vectors from vertex 0.
    double v[3][3];
    for (int r = 0; r < 3; ++r)
      for (int d = 0; d < 3; ++d) v[r][d] = (t[r + 1] >> d) & 1;
    const double det = v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1]) -
                       v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0]) +
                       v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]);
    if (det < 0) std::swap(t[1], t[2]);
    tets.push_back(t);
  } while (std::next_permutation(perm, perm + 3));
  return tets;
}

}  // namespace

Mesh generate_box(const BoxSpec& spec) {
  const double len[3] = {spec.lx, spec.ly, spec.lz};
  const std::int64_t n[3] = {spec.nx, spec.ny, spec.nz};
  for (int d = 0; d < 3; ++d) {
    MORSE_CHECK(std::isfinite(len[d]) && len[d] > 0, "generate_box: box size ", spec.lx, " x ", spec.ly, " x ", spec.lz,
                " must be positive");
    MORSE_CHECK(n[d] >= 1, "generate_box: cell counts ", spec.nx, " x ", spec.ny, " x ", spec.nz, " must be >= 1");
    MORSE_CHECK(std::isfinite(spec.origin[d]), "generate_box: origin is not finite");
  }
  MORSE_CHECK(spec.distortion >= 0 && spec.distortion < 0.5, "generate_box: distortion ", spec.distortion,
              " must be in [0, 0.5)");
  const std::int64_t n1[3] = {n[0] + 1, n[1] + 1, n[2] + 1};
  const std::int64_t nv = n1[0] * n1[1] * n1[2];
  // Upper bound of nodes: vertices + edges + face diagonals + cell diagonals < 8 * nv.
  MORSE_CHECK(nv < (std::int64_t{1} << 28), "generate_box: ", spec.nx, "x", spec.ny, "x", spec.nz,
              " cells are too many");

  const ElementType type = spec.type;
  const bool quadratic = is_quadratic(type);
  const int nvert = vertices_per_element(type);
  const int npe = nodes_per_element(type);
  {
    // What the mesh and the text of its file take, before anything is allocated: per node its
    // id, coordinates, place in set "all" and ~80 characters; per element its type, id,
    // material, offset, place in set "all" and 20 bytes per node (index and text); the mid-edge
    // table of a quadratic mesh (its node vectors are reserved for 8 nodes per vertex).
    const int per_cell = type == ElementType::Hex8 || type == ElementType::Hex20       ? 1
                         : type == ElementType::Wedge6 || type == ElementType::Wedge15 ? 2
                                                                                       : 6;
    const double nodes = (quadratic ? 8.0 : 1.0) * static_cast<double>(nv);
    const double elems = static_cast<double>(per_cell) * static_cast<double>(n[0] * n[1] * n[2]);
    const double bytes = nodes * 120.0 + elems * (32.0 + 20.0 * npe) + (quadratic ? 7.0 * 80.0 * nv : 0.0);
    const std::string err = memory_error(cat("a box of ", spec.nx, "x", spec.ny, "x", spec.nz, " ", element_name(type),
                                             " cells (", static_cast<std::int64_t>(elems), " elements)"),
                                         bytes, "the mesh and the text of its file");
    MORSE_CHECK(err.empty(), err);
  }

  Mesh m;
  m.source = cat("box ", element_name(type), " ", spec.nx, "x", spec.ny, "x", spec.nz, " size ", spec.lx, "x", spec.ly,
                 "x", spec.lz);
  if (spec.distortion > 0) m.source += cat(" distortion ", spec.distortion, " seed ", spec.seed);

  // --- vertices
  std::mt19937 rng(spec.seed);
  auto uniform = [&rng] {  // in [-1, 1), from the raw (platform-independent) engine output
    return static_cast<double>(rng()) / 2147483648.0 - 1.0;
  };
  const std::int64_t ncells = n[0] * n[1] * n[2];
  m.node_ids.reserve(static_cast<std::size_t>(quadratic ? 8 * nv : nv));
  m.coords.reserve(3 * m.node_ids.capacity());
  std::int64_t g[3];
  for (g[2] = 0; g[2] < n1[2]; ++g[2])
    for (g[1] = 0; g[1] < n1[1]; ++g[1])
      for (g[0] = 0; g[0] < n1[0]; ++g[0]) {
        double x[3];
        for (int d = 0; d < 3; ++d) {
          const double h = len[d] / static_cast<double>(n[d]);
          const double u = uniform();
          x[d] = g[d] == n[d] ? len[d] : len[d] * static_cast<double>(g[d]) / n[d];
          if (spec.distortion > 0 && g[d] > 0 && g[d] < n[d]) x[d] += spec.distortion * h * u;
          x[d] += spec.origin[d];
        }
        m.add_node(m.num_nodes() + 1, x[0], x[1], x[2]);
      }

  // --- mid-edge nodes, created once per edge
  std::unordered_map<std::int64_t, std::int64_t> edge_node;
  std::vector<std::pair<std::int64_t, std::int64_t>> mid_ends;  // endpoints of mid node nv + k
  auto mid_node = [&](std::int64_t a, std::int64_t b) {
    if (a > b) std::swap(a, b);
    auto [it, added] = edge_node.emplace(a * nv + b, m.num_nodes());
    if (added) {
      const double* pa = &m.coords[3 * a];
      const double* pb = &m.coords[3 * b];
      m.add_node(m.num_nodes() + 1, 0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.5 * (pa[2] + pb[2]));
      mid_ends.emplace_back(a, b);
    }
    return it->second;
  };

  // --- elements
  const auto tets = kuhn_tets();
  std::vector<std::vector<int>> local;  // local vertex lists of the elements of one cell
  switch (type) {
    case ElementType::Hex8:
    case ElementType::Hex20:
      local.emplace_back(kHex, kHex + 8);
      break;
    case ElementType::Wedge6:
    case ElementType::Wedge15:
      for (const auto& w : kWedges) local.emplace_back(w, w + 6);
      break;
    case ElementType::Tet4:
    case ElementType::Tet10:
      for (const auto& t : tets) local.emplace_back(t.begin(), t.end());
      break;
  }
  const int(*edges)[2] = nullptr;
  switch (type) {
    case ElementType::Tet10:
      edges = kTet10Edges;
      break;
    case ElementType::Wedge15:
      edges = kWedge15Edges;
      break;
    case ElementType::Hex20:
      edges = kHex20Edges;
      break;
    default:
      break;
  }

  const std::size_t ne_total = static_cast<std::size_t>(ncells) * local.size();
  m.elem_types.reserve(ne_total);
  m.elem_ids.reserve(ne_total);
  m.elem_material.reserve(ne_total);
  m.elem_offsets.reserve(ne_total + 1);
  m.elem_nodes.reserve(ne_total * static_cast<std::size_t>(npe));
  std::int64_t conn[20];
  for (g[2] = 0; g[2] < n[2]; ++g[2])
    for (g[1] = 0; g[1] < n[1]; ++g[1])
      for (g[0] = 0; g[0] < n[0]; ++g[0]) {
        std::int64_t corner[8];
        for (int c = 0; c < 8; ++c)
          corner[c] = (g[0] + (c & 1)) + n1[0] * ((g[1] + ((c >> 1) & 1)) + n1[1] * (g[2] + (c >> 2)));
        for (const auto& lv : local) {
          for (int v = 0; v < nvert; ++v) conn[v] = corner[lv[v]];
          for (int k = 0; quadratic && k < npe - nvert; ++k)
            conn[nvert + k] = mid_node(conn[edges[k][0]], conn[edges[k][1]]);
          m.add_element(m.num_elements() + 1, type, conn);
        }
      }

  // --- sets
  auto grid_index = [&](std::int64_t v, int d) {
    return d == 0 ? v % n1[0] : d == 1 ? (v / n1[0]) % n1[1] : v / (n1[0] * n1[1]);
  };
  auto vertex_on = [&](std::int64_t v, int d, bool high) { return grid_index(v, d) == (high ? n[d] : 0); };
  static const char* const kFaceNames[3][2] = {{"x0", "x1"}, {"y0", "y1"}, {"z0", "z1"}};
  for (int d = 0; d < 3; ++d)
    for (int side = 0; side < 2; ++side) {
      auto& set = m.node_sets[kFaceNames[d][side]];
      for (std::int64_t v = 0; v < nv; ++v)
        if (vertex_on(v, d, side)) set.push_back(v);
      for (std::size_t k = 0; k < mid_ends.size(); ++k)
        if (vertex_on(mid_ends[k].first, d, side) && vertex_on(mid_ends[k].second, d, side))
          set.push_back(nv + static_cast<std::int64_t>(k));
    }
  auto& all_nodes = m.node_sets["all"];
  all_nodes.resize(static_cast<std::size_t>(m.num_nodes()));
  for (std::int64_t k = 0; k < m.num_nodes(); ++k) all_nodes[k] = k;
  auto& all_elems = m.elem_sets["all"];
  all_elems.resize(static_cast<std::size_t>(m.num_elements()));
  for (std::int64_t e = 0; e < m.num_elements(); ++e) all_elems[e] = e;
  m.normalize_sets();
  return m;
}

}  // namespace morse::mesh

namespace morse::mesh {

PetscErrorCode box_spec_from_options(MPI_Comm comm, BoxSpec* b, std::string* error) {
  char type[64] = "";
  PetscCall(PetscStrncpy(type, element_name(b->type), sizeof type));
  PetscInt nx = b->nx, ny = b->ny, nz = b->nz;
  PetscOptionsBegin(comm, nullptr, "morse mesh box options", "");
  PetscCall(MorseOptionsString("-box_type", "Element type: tet4 tet10 wedge6 wedge15 hex8 hex20", "", type, type,
                               sizeof type, nullptr));
  PetscCall(MorseOptionsReal("-box_lx", "Length in x", "", b->lx, &b->lx, nullptr));
  PetscCall(MorseOptionsReal("-box_ly", "Length in y", "", b->ly, &b->ly, nullptr));
  PetscCall(MorseOptionsReal("-box_lz", "Length in z", "", b->lz, &b->lz, nullptr));
  PetscCall(MorseOptionsInt("-box_nx", "Cells in x", "", nx, &nx, nullptr));
  PetscCall(MorseOptionsInt("-box_ny", "Cells in y", "", ny, &ny, nullptr));
  PetscCall(MorseOptionsInt("-box_nz", "Cells in z", "", nz, &nz, nullptr));
  PetscCall(MorseOptionsReal("-box_distortion", "Random vertex displacement / cell size", "", b->distortion,
                             &b->distortion, nullptr));
  PetscOptionsEnd();
  b->nx = static_cast<int>(nx), b->ny = static_cast<int>(ny), b->nz = static_cast<int>(nz);
  if (!parse_element_name(type, &b->type))
    *error = cat("-box_type ", type, ": unknown element type (tet4 tet10 wedge6 wedge15 hex8 hex20)");
  else if (!(b->nx > 0 && b->ny > 0 && b->nz > 0 && b->lx > 0 && b->ly > 0 && b->lz > 0))
    *error = "-box_n* and -box_l* must be positive";
  return PETSC_SUCCESS;
}

}  // namespace morse::mesh
