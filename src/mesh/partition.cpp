#include "morse/mesh/partition.hpp"

#include <metis.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>
#include <utility>

#include "core/detail/pack.hpp"
#include "morse/core/error.hpp"

namespace morse::mesh {

bool LocalMesh::owns(std::int64_t k) const {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  return node_owner[k] == rank;
}

std::int64_t LocalMesh::local_of_global(std::int64_t g) const {
  auto it = std::lower_bound(global_node.begin(), global_node.end(), g);
  if (it == global_node.end() || *it != g) return -1;
  return it - global_node.begin();
}

std::string check_node_set(const LocalMesh& lm, const std::string& name, const std::string& role) {
  auto it = lm.node_set_sizes.find(name);
  if (it == lm.node_set_sizes.end()) {
    std::string known;
    for (const auto& [s, n] : lm.node_set_sizes) known += (known.empty() ? "" : ", ") + s;
    return cat(role, " '", name, "' not found in ", lm.mesh.source, " (node sets: ", known.empty() ? "none" : known,
               ")");
  }
  if (it->second == 0) return cat(role, " '", name, "' of ", lm.mesh.source, " is empty");
  return {};
}

void add_node_set(LocalMesh* lm, const std::string& name, const std::vector<std::int64_t>& ids,
                  const std::string& role) {
  std::string err;
  if (lm->node_set_sizes.count(name))
    err = cat(role, ": node set '", name, "' already exists in ", lm->mesh.source);
  else if (ids.empty())
    err = cat(role, ": node set '", name, "' has no node ids");
  collective_check(lm->comm, err);
  std::vector<std::int64_t> sorted(ids);
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  std::vector<int> found(sorted.size(), 0);
  auto& set = lm->mesh.node_sets[name];
  set.clear();
  const auto& node_ids = lm->mesh.node_ids;
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(node_ids.size()); ++k) {
    auto it = std::lower_bound(sorted.begin(), sorted.end(), node_ids[k]);
    if (it == sorted.end() || *it != node_ids[k]) continue;
    found[it - sorted.begin()] = 1;
    set.push_back(k);
  }
  // Six-DOF points are known on every rank.
  std::vector<std::int64_t> points;
  for (std::size_t i = 0; i < sorted.size(); ++i)
    if (lm->mesh.constraints.point_index(sorted[i]) >= 0) {
      found[i] = 1;
      points.push_back(sorted[i]);
    }
  MPI_Allreduce(MPI_IN_PLACE, found.data(), static_cast<int>(found.size()), MPI_INT, MPI_MAX, lm->comm);
  std::string missing;
  int n_missing = 0;
  for (std::size_t i = 0; i < sorted.size(); ++i)
    if (!found[i] && ++n_missing <= 10) missing += cat(n_missing > 1 ? ", " : "", sorted[i]);
  if (n_missing) {
    lm->mesh.node_sets.erase(name);
    points.clear();
    err = cat(role, ": node set '", name, "': ", n_missing, " id(s) are not nodes of ", lm->mesh.source, " (", missing,
              n_missing > 10 ? ", ..." : "", ")");
  }
  collective_check(lm->comm, err);
  if (!points.empty()) lm->mesh.constraints.point_sets[name] = points;
  lm->node_set_sizes[name] = static_cast<std::int64_t>(sorted.size());
}

void add_spiders(LocalMesh* lm, const std::vector<std::string>& sets, double radius, SpiderType type) {
  auto& cs = lm->mesh.constraints;
  const auto& m = lm->mesh;
  int rank = 0;
  MPI_Comm_rank(lm->comm, &rank);
  std::string err;
  if (!(radius > 0) || !std::isfinite(radius))
    err = cat("-mesh_spider_radius ", radius, " must be positive (the spiders' reach)");
  for (const auto& name : sets) {
    if (!err.empty()) break;
    err = check_node_set(*lm, name, "-mesh_spiders: node set");
    if (err.empty() && cs.point_sets.count(name))
      err = cat("-mesh_spiders: node set '", name, "' holds six-DOF points; spiders go on solid nodes");
    if (err.empty() && lm->node_set_sizes.count(name + "_spiders"))
      err = cat("-mesh_spiders: node set '", name, "_spiders' exists already in ", m.source);
  }
  collective_check(lm->comm, err);
  // The largest id in use, for the new points' ids.
  std::int64_t top = 0;
  for (auto id : m.node_ids) top = std::max(top, id);
  for (auto id : cs.point_ids) top = std::max(top, id);
  MPI_Allreduce(MPI_IN_PLACE, &top, 1, MPI_INT64_T, MPI_MAX, lm->comm);
  // Allgather of (id, x, y, z) records, as doubles (ids below 2^53).
  auto allgather = [&](const std::vector<double>& mine) {
    int size = 1;
    MPI_Comm_size(lm->comm, &size);
    int n = static_cast<int>(mine.size());
    std::vector<int> counts(size), displs(size, 0);
    MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, lm->comm);
    for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    std::vector<double> all(displs[size - 1] + counts[size - 1]);
    MPI_Allgatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, lm->comm);
    return all;
  };
  std::int64_t next = top;
  // The other node sets (not given to -mesh_spiders): a spider's point joins T_spiders for every
  // such set T that holds its centre node, so that sets naming interface nodes name their points.
  std::vector<std::string> others;
  for (const auto& kv : m.node_sets)
    if (std::find(sets.begin(), sets.end(), kv.first) == sets.end() && !cs.point_sets.count(kv.first))
      others.push_back(kv.first);
  std::vector<std::vector<std::int64_t>> other_nodes;  // sorted local node indices of each
  for (const auto& t : others) {
    other_nodes.push_back(m.node_sets.at(t));
    std::sort(other_nodes.back().begin(), other_nodes.back().end());
  }
  std::set<std::string> inherited;
  for (const auto& name : sets) {
    // The set's nodes (owned), on every rank, by id.
    std::vector<double> mine;
    for (auto k : m.node_sets.at(name))
      if (lm->node_owner[k] == rank)
        mine.insert(mine.end(),
                    {static_cast<double>(m.node_ids[k]), m.coords[3 * k], m.coords[3 * k + 1], m.coords[3 * k + 2]});
    auto centres = allgather(mine);
    const std::size_t nc = centres.size() / 4;
    // (centre id, other set) pairs of the owned centres, on every rank.
    std::vector<double> member;
    for (auto k : m.node_sets.at(name))
      if (lm->node_owner[k] == rank)
        for (std::size_t t = 0; t < others.size(); ++t)
          if (std::binary_search(other_nodes[t].begin(), other_nodes[t].end(), k))
            member.insert(member.end(), {static_cast<double>(m.node_ids[k]), static_cast<double>(t)});
    const auto memberships = allgather(member);
    std::vector<std::size_t> order(nc);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](auto a, auto b) { return centres[4 * a] < centres[4 * b]; });
    // The owned nodes within the radius of each centre: (centre, node id) pairs.
    std::vector<double> near;
    for (std::size_t c = 0; c < nc; ++c)
      for (std::int64_t k = 0; k < m.num_nodes(); ++k) {
        if (lm->node_owner[k] != rank) continue;
        double d2 = 0;
        for (int j = 0; j < 3; ++j) d2 += std::pow(m.coords[3 * k + j] - centres[4 * c + 1 + j], 2);
        if (d2 <= radius * radius)
          near.insert(near.end(), {static_cast<double>(c), static_cast<double>(m.node_ids[k])});
      }
    const auto all = allgather(near);
    std::vector<std::vector<std::int64_t>> members(nc);
    for (std::size_t i = 0; i < all.size(); i += 2)
      members[static_cast<std::size_t>(all[i])].push_back(static_cast<std::int64_t>(all[i + 1]));
    auto& points = cs.point_sets[name + "_spiders"];
    for (auto c : order) {
      auto& nodes = members[c];
      std::sort(nodes.begin(), nodes.end());
      const std::int64_t pid = ++next;
      const auto centre = static_cast<std::int64_t>(centres[4 * c]);
      cs.point_ids.push_back(pid);
      cs.point_coords.insert(cs.point_coords.end(), &centres[4 * c + 1], &centres[4 * c + 4]);
      cs.point_mass.push_back(0.0);
      cs.point_fixed.push_back(0);
      points.push_back(pid);
      for (std::size_t i = 0; i < memberships.size(); i += 2)
        if (static_cast<std::int64_t>(memberships[i]) == centre) {
          const std::string t = others[static_cast<std::size_t>(memberships[i + 1])] + "_spiders";
          cs.point_sets[t].push_back(pid);
          inherited.insert(t);
        }
      const std::string where = cat("-mesh_spiders ", name, ": the spider at node ", centre, " (point ", pid, ", ",
                                    nodes.size(), " nodes within ", radius, ")");
      if (type == SpiderType::Rigid) {
        RigidElement r;
        r.id = pid;
        r.where = where;
        r.reference = pid;
        r.components = 63;
        r.dependent = nodes;
        cs.rigid.push_back(std::move(r));
      } else {
        InterpolationElement r;
        r.id = pid;
        r.where = where;
        r.reference = pid;
        r.ref_components = 63;
        r.nodes = nodes;
        r.weights.assign(nodes.size(), 1.0);
        r.node_components.assign(nodes.size(), 7);
        cs.interpolation.push_back(std::move(r));
      }
    }
    lm->mesh.node_sets[name + "_spiders"];  // every rank knows the name (no solid node in it)
    lm->node_set_sizes[name + "_spiders"] = static_cast<std::int64_t>(points.size());
  }
  std::string clash;
  for (const auto& t : inherited) {
    if (lm->node_set_sizes.count(t) && clash.empty()) clash = t;
    lm->mesh.node_sets[t];
    lm->node_set_sizes[t] = static_cast<std::int64_t>(cs.point_sets[t].size());
  }
  collective_check(lm->comm, clash.empty() ? ""
                                           : cat("-mesh_spiders: node set '", clash, "' exists already in ", m.source,
                                                 " (the spiders' points of set '", clash.substr(0, clash.size() - 8),
                                                 "' would take its name)"));
}

namespace {

// Removes nodes that no element uses (Gmsh files carry geometry points, decks carry spare
// nodes); they would have no stiffness and make K singular.
//
// Unused nodes that a constraint names become the constraints' six-DOF points (with their
// coordinates, point mass and set memberships); a constraint naming an id that is no node at all
// is an error, as is a point mass on an unused node that no constraint names.
void drop_unused_nodes(Mesh* m) {
  const std::int64_t n = m->num_nodes();
  std::vector<std::int64_t> map(n, -1);
  for (auto k : m->elem_nodes) map[k] = 0;
  auto& cs = m->constraints;
  cs.point_ids.clear();
  cs.point_coords.clear();
  cs.point_mass.clear();
  cs.point_fixed.clear();
  cs.point_sets.clear();
  if (!cs.empty()) {
    const auto named = cs.referenced_ids();
    std::vector<std::pair<std::int64_t, std::int64_t>> points;  // (id, node)
    std::vector<std::int64_t> by_id(n);
    std::iota(by_id.begin(), by_id.end(), 0);
    std::sort(by_id.begin(), by_id.end(), [&](auto a, auto b) { return m->node_ids[a] < m->node_ids[b]; });
    for (auto id : named) {
      auto it = std::lower_bound(by_id.begin(), by_id.end(), id,
                                 [&](std::int64_t k, std::int64_t v) { return m->node_ids[k] < v; });
      MORSE_CHECK(it != by_id.end() && m->node_ids[*it] == id, m->source, ": a constraint names node ", id,
                  ", which is not a node of the mesh");
      if (map[*it] < 0) points.emplace_back(id, *it);
    }
    for (auto [id, k] : points) {
      cs.point_ids.push_back(id);
      cs.point_coords.insert(cs.point_coords.end(), &m->coords[3 * k], &m->coords[3 * k] + 3);
      cs.point_mass.push_back(m->point_mass.empty() ? 0.0 : m->point_mass[k]);
      cs.point_fixed.push_back(m->fixed_dofs.empty() ? 0 : m->fixed_dofs[k]);
      if (!m->point_mass.empty()) m->point_mass[k] = 0.0;
    }
    std::vector<char> is_point(n, 0);
    for (auto [id, k] : points) is_point[k] = 1;
    for (const auto& [name, v] : m->node_sets)
      for (auto k : v)
        if (is_point[k]) cs.point_sets[name].push_back(m->node_ids[k]);
    for (auto& [name, v] : cs.point_sets) std::sort(v.begin(), v.end());
  }
  for (std::int64_t k = 0; k < n; ++k)
    MORSE_CHECK(map[k] >= 0 || m->point_mass.empty() || m->point_mass[k] == 0.0, m->source, ": node ", m->node_ids[k],
                " carries a point mass but no solid element or constraint uses it");
  std::int64_t next = 0;
  for (std::int64_t k = 0; k < n; ++k)
    if (map[k] == 0) map[k] = next++;
  if (next == n) return;
  std::vector<std::int64_t> ids(next);
  std::vector<double> xyz(3 * next);
  std::vector<std::uint8_t> fixed(m->fixed_dofs.empty() ? 0 : next);
  std::vector<double> pmass(m->point_mass.empty() ? 0 : next);
  for (std::int64_t k = 0; k < n; ++k) {
    if (map[k] < 0) continue;
    ids[map[k]] = m->node_ids[k];
    std::copy_n(&m->coords[3 * k], 3, &xyz[3 * map[k]]);
    if (!fixed.empty()) fixed[map[k]] = m->fixed_dofs[k];
    if (!pmass.empty()) pmass[map[k]] = m->point_mass[k];
  }
  for (auto& k : m->elem_nodes) k = map[k];
  for (auto& [name, v] : m->node_sets) {
    std::vector<std::int64_t> w;
    for (auto k : v)
      if (map[k] >= 0) w.push_back(map[k]);
    v.swap(w);
  }
  m->node_ids.swap(ids);
  m->coords.swap(xyz);
  m->fixed_dofs.swap(fixed);
  m->point_mass.swap(pmass);
}

std::vector<int> partition_elements(const Mesh& m, int n_parts) {
  const std::int64_t ne = m.num_elements();
  std::vector<int> part(ne, 0);
  if (n_parts == 1 || ne == 0) return part;
  if (ne < n_parts) {
    std::iota(part.begin(), part.end(), 0);
    return part;
  }
  // Dual graph on corner nodes: neighbours share a face (>= 3 corners).
  std::vector<idx_t> eptr(ne + 1, 0), eind;
  eind.reserve(ne * 8);
  for (std::int64_t e = 0; e < ne; ++e) {
    const int nv = vertices_per_element(m.elem_types[e]);
    for (int a = 0; a < nv; ++a) eind.push_back(static_cast<idx_t>(m.elem_nodes[m.elem_offsets[e] + a]));
    eptr[e + 1] = static_cast<idx_t>(eind.size());
  }
  idx_t n_el = static_cast<idx_t>(ne), n_nodes = static_cast<idx_t>(m.num_nodes());
  idx_t ncommon = 3, nparts = n_parts, objval = 0;
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = 7;
  options[METIS_OPTION_NUMBERING] = 0;
  std::vector<idx_t> epart(ne), npart(n_nodes);
  int status = METIS_PartMeshDual(&n_el, &n_nodes, eptr.data(), eind.data(), nullptr, nullptr, &ncommon, &nparts,
                                  nullptr, options, &objval, epart.data(), npart.data());
  MORSE_CHECK(status == METIS_OK, "METIS_PartMeshDual failed (status ", status, ") on ", m.source);
  for (std::int64_t e = 0; e < ne; ++e) part[e] = static_cast<int>(epart[e]);
  return part;
}

void pack_constraints(const Constraints& c, detail::Packer& p) {
  p.put<std::uint64_t>(c.rigid.size());
  for (const auto& r : c.rigid) {
    p.put(r.id);
    p.put_str(r.where);
    p.put(r.reference);
    p.put(r.components);
    p.put_vec(r.dependent);
  }
  p.put<std::uint64_t>(c.interpolation.size());
  for (const auto& r : c.interpolation) {
    p.put(r.id);
    p.put_str(r.where);
    p.put(r.reference);
    p.put(r.ref_components);
    p.put_vec(r.nodes);
    p.put_vec(r.weights);
    p.put_vec(r.node_components);
  }
  p.put<std::uint64_t>(c.linear.size());
  for (const auto& r : c.linear) {
    p.put(r.id);
    p.put_str(r.where);
    p.put_vec(r.terms);
  }
  p.put_vec(c.point_ids);
  p.put_vec(c.point_coords);
  p.put_vec(c.point_mass);
  p.put_vec(c.point_fixed);
  p.put_vec(c.mass_ids);
  p.put_vec(c.mass_matrices);
  p.put<std::uint64_t>(c.point_sets.size());
  for (const auto& [name, v] : c.point_sets) {
    p.put_str(name);
    p.put_vec(v);
  }
}

Constraints unpack_constraints(detail::Unpacker& u) {
  Constraints c;
  c.rigid.resize(u.get<std::uint64_t>());
  for (auto& r : c.rigid) {
    r.id = u.get<std::int64_t>();
    r.where = u.get_str();
    r.reference = u.get<std::int64_t>();
    r.components = u.get<ComponentMask>();
    r.dependent = u.get_vec<std::int64_t>();
  }
  c.interpolation.resize(u.get<std::uint64_t>());
  for (auto& r : c.interpolation) {
    r.id = u.get<std::int64_t>();
    r.where = u.get_str();
    r.reference = u.get<std::int64_t>();
    r.ref_components = u.get<ComponentMask>();
    r.nodes = u.get_vec<std::int64_t>();
    r.weights = u.get_vec<double>();
    r.node_components = u.get_vec<ComponentMask>();
  }
  c.linear.resize(u.get<std::uint64_t>());
  for (auto& r : c.linear) {
    r.id = u.get<std::int64_t>();
    r.where = u.get_str();
    r.terms = u.get_vec<Term>();
  }
  c.point_ids = u.get_vec<std::int64_t>();
  c.point_coords = u.get_vec<double>();
  c.point_mass = u.get_vec<double>();
  c.point_fixed = u.get_vec<std::uint8_t>();
  c.mass_ids = u.get_vec<std::int64_t>();
  c.mass_matrices = u.get_vec<double>();
  const auto n = u.get<std::uint64_t>();
  for (std::uint64_t i = 0; i < n; ++i) {
    auto name = u.get_str();
    c.point_sets[name] = u.get_vec<std::int64_t>();
  }
  return c;
}

void pack_piece(const Mesh& m, const std::vector<int>& part, const std::vector<int>& owner, int r,
                std::vector<std::int64_t>& g2l, std::vector<std::int64_t>& e2l, detail::Packer& p) {
  std::vector<std::int64_t> elems, nodes;
  for (std::int64_t e = 0; e < m.num_elements(); ++e)
    if (part[e] == r) elems.push_back(e);
  for (auto e : elems)
    for (auto k = m.elem_offsets[e]; k < m.elem_offsets[e + 1]; ++k) nodes.push_back(m.elem_nodes[k]);
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  for (std::size_t i = 0; i < nodes.size(); ++i) g2l[nodes[i]] = static_cast<std::int64_t>(i);
  for (std::size_t i = 0; i < elems.size(); ++i) e2l[elems[i]] = static_cast<std::int64_t>(i);

  std::vector<std::int64_t> ids(nodes.size());
  std::vector<double> xyz(3 * nodes.size());
  std::vector<int> own(nodes.size());
  std::vector<std::uint8_t> fixed(m.fixed_dofs.empty() ? 0 : nodes.size());
  std::vector<double> pmass(m.point_mass.empty() ? 0 : nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    ids[i] = m.node_ids[nodes[i]];
    std::copy_n(&m.coords[3 * nodes[i]], 3, &xyz[3 * i]);
    own[i] = owner[nodes[i]];
    if (!fixed.empty()) fixed[i] = m.fixed_dofs[nodes[i]];
    if (!pmass.empty()) pmass[i] = m.point_mass[nodes[i]];
  }
  std::vector<int> types(elems.size()), mats(elems.size());
  std::vector<std::int64_t> offs(1, 0), conn, eids(elems.size());
  for (std::size_t i = 0; i < elems.size(); ++i) {
    auto e = elems[i];
    types[i] = static_cast<int>(m.elem_types[e]);
    mats[i] = m.elem_material[e];
    eids[i] = m.elem_ids[e];
    for (auto k = m.elem_offsets[e]; k < m.elem_offsets[e + 1]; ++k) conn.push_back(g2l[m.elem_nodes[k]]);
    offs.push_back(static_cast<std::int64_t>(conn.size()));
  }
  p.put_vec(nodes);
  p.put_vec(ids);
  p.put_vec(xyz);
  p.put_vec(own);
  p.put_vec(fixed);
  p.put_vec(pmass);
  p.put_vec(elems);
  p.put_vec(types);
  p.put_vec(mats);
  p.put_vec(offs);
  p.put_vec(conn);
  p.put_vec(eids);
  for (const auto* sets : {&m.node_sets, &m.elem_sets}) {
    const auto& map = sets == &m.node_sets ? g2l : e2l;
    p.put<std::uint64_t>(sets->size());
    for (const auto& [name, v] : *sets) {
      std::vector<std::int64_t> loc;
      for (auto k : v)
        if (map[k] >= 0) loc.push_back(map[k]);
      p.put_str(name);
      p.put<std::int64_t>(static_cast<std::int64_t>(v.size()));
      p.put_vec(loc);
    }
  }
  pack_constraints(m.constraints, p);
  for (auto k : nodes) g2l[k] = -1;
  for (auto e : elems) e2l[e] = -1;
}

LocalMesh unpack_piece(MPI_Comm comm, const std::vector<char>& buf) {
  detail::Unpacker u(buf);
  LocalMesh lm;
  lm.comm = comm;
  Mesh& m = lm.mesh;
  lm.n_global_nodes = u.get<std::int64_t>();
  lm.n_global_elements = u.get<std::int64_t>();
  m.units = u.get_str();
  m.source = u.get_str();
  auto n_mat = u.get<std::uint64_t>();
  for (std::uint64_t i = 0; i < n_mat; ++i) {
    Material mat;
    mat.name = u.get_str();
    mat.E = u.get<double>();
    mat.nu = u.get<double>();
    mat.rho = u.get<double>();
    m.materials.push_back(mat);
  }
  lm.elements_per_rank = u.get_vec<std::int64_t>();
  lm.global_node = u.get_vec<std::int64_t>();
  m.node_ids = u.get_vec<std::int64_t>();
  m.coords = u.get_vec<double>();
  lm.node_owner = u.get_vec<int>();
  m.fixed_dofs = u.get_vec<std::uint8_t>();
  m.point_mass = u.get_vec<double>();
  lm.global_elem = u.get_vec<std::int64_t>();
  auto types = u.get_vec<int>();
  m.elem_types.resize(types.size());
  for (std::size_t i = 0; i < types.size(); ++i) m.elem_types[i] = static_cast<ElementType>(types[i]);
  m.elem_material = u.get_vec<int>();
  m.elem_offsets = u.get_vec<std::int64_t>();
  m.elem_nodes = u.get_vec<std::int64_t>();
  m.elem_ids = u.get_vec<std::int64_t>();
  for (int s = 0; s < 2; ++s) {
    auto& sets = s == 0 ? m.node_sets : m.elem_sets;
    auto& sizes = s == 0 ? lm.node_set_sizes : lm.elem_set_sizes;
    auto n = u.get<std::uint64_t>();
    for (std::uint64_t i = 0; i < n; ++i) {
      auto name = u.get_str();
      sizes[name] = u.get<std::int64_t>();
      sets[name] = u.get_vec<std::int64_t>();
    }
  }
  m.constraints = unpack_constraints(u);
  // A set's size counts its points too (a boundary set may hold only points).
  for (const auto& [name, ids] : m.constraints.point_sets)
    lm.node_set_sizes[name] += static_cast<std::int64_t>(ids.size());
  return lm;
}

}  // namespace

LocalMesh distribute(MPI_Comm comm, Mesh* serial) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  std::string err;
  if (rank == 0 && serial->num_elements() == 0)
    err = cat("mesh ", serial->source, " has no solid element (tet4/10, wedge6/15, hex8/20)");
  collective_check(comm, err);

  std::vector<char> mine;
  if (rank == 0) {
    Mesh& m = *serial;
    m.normalize_sets();
    std::vector<int> part;
    try {
      drop_unused_nodes(&m);
      part = partition_elements(m, size);
    } catch (const std::exception& e) {  // METIS's status, or std::bad_alloc: every rank reports it
      err = message_of(e);
    }
    collective_check(comm, err);
    std::vector<int> owner(m.num_nodes(), size);
    std::vector<std::int64_t> per_rank(size, 0);
    for (std::int64_t e = 0; e < m.num_elements(); ++e) {
      ++per_rank[part[e]];
      for (auto k = m.elem_offsets[e]; k < m.elem_offsets[e + 1]; ++k)
        owner[m.elem_nodes[k]] = std::min(owner[m.elem_nodes[k]], part[e]);
    }
    std::vector<std::int64_t> g2l(m.num_nodes(), -1), e2l(m.num_elements(), -1);
    for (int r = size - 1; r >= 0; --r) {
      detail::Packer p;
      p.put<std::int64_t>(m.num_nodes());
      p.put<std::int64_t>(m.num_elements());
      p.put_str(m.units);
      p.put_str(m.source);
      p.put<std::uint64_t>(m.materials.size());
      for (const auto& mat : m.materials) {
        p.put_str(mat.name);
        p.put(mat.E);
        p.put(mat.nu);
        p.put(mat.rho);
      }
      p.put_vec(per_rank);
      pack_piece(m, part, owner, r, g2l, e2l, p);
      if (r == 0) {
        mine.swap(p.buffer());
      } else {
        std::uint64_t n = p.buffer().size();
        MPI_Send(&n, 1, MPI_UINT64_T, r, 11, comm);
        MPI_Send(p.buffer().data(), static_cast<int>(n), MPI_CHAR, r, 12, comm);
      }
    }
    *serial = Mesh();
  } else {
    collective_check(comm, err);
    std::uint64_t n = 0;
    MPI_Recv(&n, 1, MPI_UINT64_T, 0, 11, comm, MPI_STATUS_IGNORE);
    mine.resize(n);
    MPI_Recv(mine.data(), static_cast<int>(n), MPI_CHAR, 0, 12, comm, MPI_STATUS_IGNORE);
  }
  return unpack_piece(comm, mine);
}

Mesh gather_to_rank0(const LocalMesh& lm) {
  int rank = 0, size = 1;
  MPI_Comm_rank(lm.comm, &rank);
  MPI_Comm_size(lm.comm, &size);
  const Mesh& m = lm.mesh;
  detail::Packer p;
  {
    std::vector<std::int64_t> gn, ids;
    std::vector<double> xyz;
    for (std::int64_t k = 0; k < m.num_nodes(); ++k)
      if (lm.node_owner[k] == rank) {
        gn.push_back(lm.global_node[k]);
        ids.push_back(m.node_ids[k]);
        xyz.insert(xyz.end(), &m.coords[3 * k], &m.coords[3 * k] + 3);
      }
    std::vector<int> types(m.elem_types.size());
    for (std::size_t e = 0; e < types.size(); ++e) types[e] = static_cast<int>(m.elem_types[e]);
    std::vector<std::int64_t> conn(m.elem_nodes.size());
    for (std::size_t i = 0; i < conn.size(); ++i) conn[i] = lm.global_node[m.elem_nodes[i]];
    p.put_vec(gn);
    p.put_vec(ids);
    p.put_vec(xyz);
    p.put_vec(lm.global_elem);
    p.put_vec(m.elem_ids);
    p.put_vec(types);
    p.put_vec(m.elem_material);
    p.put_vec(m.elem_offsets);
    p.put_vec(conn);
  }
  int n = static_cast<int>(p.buffer().size());
  std::vector<int> counts(size), displs(size, 0);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, lm.comm);
  std::vector<char> all;
  if (rank == 0) {
    for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    all.resize(displs[size - 1] + counts[size - 1]);
  }
  MPI_Gatherv(p.buffer().data(), n, MPI_CHAR, all.data(), counts.data(), displs.data(), MPI_CHAR, 0, lm.comm);
  Mesh out;
  if (rank != 0) return out;
  out.units = m.units;
  out.source = m.source;
  out.materials = m.materials;
  out.constraints = m.constraints;
  out.node_ids.resize(lm.n_global_nodes);
  out.coords.resize(3 * lm.n_global_nodes);
  std::vector<std::int64_t> eorder(lm.n_global_elements);
  std::vector<ElementType> etype(lm.n_global_elements);
  std::vector<int> emat(lm.n_global_elements);
  std::vector<std::int64_t> eid(lm.n_global_elements);
  std::vector<std::vector<std::int64_t>> econn(lm.n_global_elements);
  for (int r = 0; r < size; ++r) {
    std::vector<char> piece(all.begin() + displs[r], all.begin() + displs[r] + counts[r]);
    detail::Unpacker u(piece);
    auto gn = u.get_vec<std::int64_t>();
    auto ids = u.get_vec<std::int64_t>();
    auto xyz = u.get_vec<double>();
    for (std::size_t i = 0; i < gn.size(); ++i) {
      out.node_ids[gn[i]] = ids[i];
      std::copy_n(&xyz[3 * i], 3, &out.coords[3 * gn[i]]);
    }
    auto ge = u.get_vec<std::int64_t>();
    auto eids = u.get_vec<std::int64_t>();
    auto types = u.get_vec<int>();
    auto mats = u.get_vec<int>();
    auto offs = u.get_vec<std::int64_t>();
    auto conn = u.get_vec<std::int64_t>();
    for (std::size_t e = 0; e < ge.size(); ++e) {
      etype[ge[e]] = static_cast<ElementType>(types[e]);
      emat[ge[e]] = mats[e];
      eid[ge[e]] = eids[e];
      econn[ge[e]].assign(conn.begin() + offs[e], conn.begin() + offs[e + 1]);
    }
  }
  for (std::int64_t e = 0; e < lm.n_global_elements; ++e) out.add_element(eid[e], etype[e], econn[e].data(), emat[e]);
  return out;
}

}  // namespace morse::mesh
