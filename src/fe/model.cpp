#include "morse/fe/model.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include "core/detail/exchange.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/fe/constraints.hpp"
#include "morse/fe/element.hpp"
#include "morse/mesh/mesh.hpp"

namespace morse::fe {

namespace {

// Asks each ghost node's owner for the node's global DOFs.
void fetch_ghost_dofs(const mesh::LocalMesh& lm, std::vector<PetscInt>& node_dof) {
  int rank = 0, size = 1;
  MPI_Comm_rank(lm.comm, &rank);
  MPI_Comm_size(lm.comm, &size);
  const std::int64_t n = lm.mesh.num_nodes();
  std::vector<std::vector<std::int64_t>> ask(size), ask_local(size);
  for (std::int64_t k = 0; k < n; ++k)
    if (lm.node_owner[k] != rank) {
      ask[lm.node_owner[k]].push_back(lm.global_node[k]);
      ask_local[lm.node_owner[k]].push_back(k);
    }
  const auto asked = detail::exchange(lm.comm, ask);
  // Answer: three DOFs per asked node, to the rank that asked.
  std::vector<std::vector<std::int64_t>> answer(size);
  for (int q = 0; q < size; ++q)
    for (int i = asked.offset[q]; i < asked.offset[q + 1]; ++i) {
      auto k = lm.local_of_global(asked.words[i]);
      for (int d = 0; d < 3; ++d) answer[q].push_back(node_dof[3 * k + d]);
    }
  const auto got = detail::exchange(lm.comm, answer);
  for (int r = 0; r < size; ++r)
    for (std::size_t i = 0; i < ask_local[r].size(); ++i)
      for (int d = 0; d < 3; ++d)
        node_dof[3 * ask_local[r][i] + d] = static_cast<PetscInt>(got.words[got.offset[r] + 3 * i + d]);
}

}  // namespace

DofLayout number_dofs(const mesh::LocalMesh& lm, const std::vector<std::string>& clamp_sets) {
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  const auto& m = lm.mesh;
  const std::int64_t n = m.num_nodes();
  std::vector<std::uint8_t> clamped(n, 0);
  // Whether the deck fixes any DOF is a property of the whole mesh: a rank whose piece holds no
  // fixed node (or no node at all: fewer elements than ranks) has an empty fixed_dofs.
  const bool deck_fixes =
      std::find(clamp_sets.begin(), clamp_sets.end(), mesh::kDeckBoundarySet) != clamp_sets.end() &&
      (any_rank(lm.comm, std::any_of(m.fixed_dofs.begin(), m.fixed_dofs.end(), [](std::uint8_t f) { return f & 7; })) ||
       std::any_of(m.constraints.point_fixed.begin(), m.constraints.point_fixed.end(),
                   [](std::uint8_t f) { return f != 0; }));
  std::string err;
  for (const auto& name : clamp_sets) {
    if (name == mesh::kDeckBoundarySet) {
      if (!deck_fixes) {
        err = cat("-clamp ", name, ": the mesh ", m.source, " fixes no DOF with *BOUNDARY");
        break;
      }
      for (std::int64_t k = 0; k < static_cast<std::int64_t>(m.fixed_dofs.size()); ++k)
        clamped[k] |= m.fixed_dofs[k] & 7;
      continue;
    }
    err = mesh::check_node_set(lm, name, "node set");
    if (!err.empty()) break;
    const auto& members = m.node_sets.at(name);
    for (auto k : members) clamped[k] = 7;
  }
  collective_check(lm.comm, err);

  DofLayout dm;
  dm.comm = lm.comm;
  dm.node_dof.assign(3 * n, -1);
  PetscInt count = 0;
  std::int64_t n_clamped = 0;
  for (std::int64_t k = 0; k < n; ++k) {
    if (lm.node_owner[k] != rank) continue;
    for (int d = 0; d < 3; ++d) {
      if (clamped[k] & (1u << d))
        ++n_clamped;
      else
        dm.node_dof[3 * k + d] = count++;
    }
  }
  dm.n_owned = count;
  MPI_Exscan(&count, &dm.first, 1, MPIU_INT, MPI_SUM, lm.comm);
  if (rank == 0) dm.first = 0;
  MPI_Allreduce(&count, &dm.n_global, 1, MPIU_INT, MPI_SUM, lm.comm);
  MPI_Allreduce(&n_clamped, &dm.n_clamped_global, 1, MPI_INT64_T, MPI_SUM, lm.comm);
  dm.node.resize(count);
  dm.component.resize(count);
  for (std::int64_t k = 0; k < n; ++k)
    if (lm.node_owner[k] == rank)
      for (int d = 0; d < 3; ++d)
        if (PetscInt& g = dm.node_dof[3 * k + d]; g >= 0) {
          dm.node[g] = m.node_ids[k];
          dm.component[g] = d + 1;
          g += dm.first;
        }
  for (const auto& [name, members] : m.node_sets) {
    auto& rows = dm.sets[name];
    for (auto k : members)
      if (lm.node_owner[k] == rank)
        for (int d = 0; d < 3; ++d)
          if (dm.node_dof[3 * k + d] >= 0) rows.push_back(dm.node_dof[3 * k + d]);
    std::sort(rows.begin(), rows.end());
  }
  fetch_ghost_dofs(lm, dm.node_dof);
  return dm;
}

std::vector<LabeledRow> set_rows(const DofLayout& dofs, const std::string& set, const std::string& role) {
  auto it = dofs.sets.find(set);
  std::string list;
  for (const auto& [s, rows] : dofs.sets) list += (list.empty() ? "" : ", ") + s;
  MORSE_CHECK(it != dofs.sets.end(), role, " '", set,
              "' is not a row set of the DOF map or a -mesh_node_set_ option (sets: ", list.empty() ? "none" : list,
              ")");
  std::vector<LabeledRow> mine;
  for (auto r : it->second) mine.push_back({r, dofs.node[r - dofs.first], dofs.component[r - dofs.first]});
  int size = 1;
  MPI_Comm_size(dofs.comm, &size);
  int bytes = static_cast<int>(mine.size() * sizeof(LabeledRow));
  std::vector<int> counts(size), displs(size, 0);
  MPI_Allgather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, dofs.comm);
  for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
  std::vector<LabeledRow> all((displs[size - 1] + counts[size - 1]) / sizeof(LabeledRow));
  MPI_Allgatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, dofs.comm);
  MORSE_CHECK(!all.empty(), role, " '", set, "' is empty (after the clamp)");
  std::sort(all.begin(), all.end(), [](const LabeledRow& a, const LabeledRow& b) {
    return a.node != b.node ? a.node < b.node : a.component < b.component;
  });
  return all;
}

void gather_labels(const DofLayout& dofs, std::vector<std::int64_t>* node, std::vector<std::int64_t>* component) {
  int size = 1, rank = 0;
  MPI_Comm_size(dofs.comm, &size);
  MPI_Comm_rank(dofs.comm, &rank);
  int m = static_cast<int>(dofs.n_owned);
  std::vector<int> counts(size), displs(size, 0);
  MPI_Gather(&m, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, dofs.comm);
  for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
  node->assign(rank == 0 ? dofs.n_global : 0, 0);
  component->assign(rank == 0 ? dofs.n_global : 0, 0);
  std::vector<std::int64_t> comp(dofs.component.begin(), dofs.component.end());
  MPI_Gatherv(dofs.node.data(), m, MPI_INT64_T, node->data(), counts.data(), displs.data(), MPI_INT64_T, 0, dofs.comm);
  MPI_Gatherv(comp.data(), m, MPI_INT64_T, component->data(), counts.data(), displs.data(), MPI_INT64_T, 0, dofs.comm);
}

Model mesh_model(MPI_Comm comm, const MeshInput& in, bool keep_node_stiffness) {
  Model md;
  md.source = in.path;
  {
    StageTimer t(comm, "ReadDistribute");
    md.mesh = mesh::read_and_distribute(comm, in.path, in.skip_unsupported);
    if (!in.units.empty()) md.mesh->mesh.units = in.units;
    for (const auto& sm : in.set_materials) mesh::assign_set_material(&md.mesh->mesh, sm);
    for (const auto& [name, ids] : in.node_sets) mesh::add_node_set(&*md.mesh, name, ids, "-mesh_node_set_" + name);
    if (!in.spider_sets.empty()) mesh::add_spiders(&*md.mesh, in.spider_sets, in.spider_radius, in.spider_type);
  }
  md.units = md.mesh->mesh.units;
  {
    StageTimer t(comm, "NumberDofs");
    md.dofs = number_dofs(*md.mesh, in.clamp);
  }
  auto ops = assemble(*md.mesh, md.dofs, in.material);
  md.K = std::move(ops.K);
  md.M = std::move(ops.M);
  md.volume = ops.volume;
  md.mass = ops.mass;
  if (!md.mesh->mesh.constraints.empty()) eliminate_constraints(&md, in.clamp, keep_node_stiffness);
  return md;
}

namespace {

// Rows of the owned DOFs in CSR form: offsets (n_owned + 1) and sorted global columns.
struct Pattern {
  std::vector<PetscInt> offsets, columns;
};

// The exact sparsity of K on the owned rows: DOFs (r, c) couple when their nodes share an
// element. Ghost nodes' couplings found on other ranks are sent to the owners, with the
// neighbours' DOF numbers (an owner need not know a remote neighbour).
Pattern sparsity_pattern(const mesh::LocalMesh& lm, const DofLayout& dofs) {
  int rank = 0, size = 1;
  MPI_Comm_rank(lm.comm, &rank);
  MPI_Comm_size(lm.comm, &size);
  const auto& m = lm.mesh;
  const std::int64_t nn = m.num_nodes(), ne = m.num_elements();
  // node -> elements (CSR)
  std::vector<std::int64_t> ne_off(nn + 1, 0), ne_idx(m.elem_nodes.size());
  for (auto k : m.elem_nodes) ++ne_off[k + 1];
  for (std::int64_t k = 0; k < nn; ++k) ne_off[k + 1] += ne_off[k];
  {
    std::vector<std::int64_t> pos(ne_off.begin(), ne_off.end() - 1);
    for (std::int64_t e = 0; e < ne; ++e)
      for (auto j = m.elem_offsets[e]; j < m.elem_offsets[e + 1]; ++j) ne_idx[pos[m.elem_nodes[j]]++] = e;
  }
  // Neighbours of each local node as global node indices, with their DOFs.
  struct Nb {
    std::int64_t g;
    PetscInt dof[3];
  };
  std::vector<std::vector<Nb>> nbrs(nn);
  std::vector<std::int64_t> scratch;
  for (std::int64_t k = 0; k < nn; ++k) {
    scratch.clear();
    for (auto j = ne_off[k]; j < ne_off[k + 1]; ++j) {
      const auto e = ne_idx[j];
      scratch.insert(scratch.end(), m.elem_nodes.begin() + m.elem_offsets[e],
                     m.elem_nodes.begin() + m.elem_offsets[e + 1]);
    }
    std::sort(scratch.begin(), scratch.end());
    scratch.erase(std::unique(scratch.begin(), scratch.end()), scratch.end());
    for (auto q : scratch)
      nbrs[k].push_back(
          {lm.global_node[q], {dofs.node_dof[3 * q], dofs.node_dof[3 * q + 1], dofs.node_dof[3 * q + 2]}});
  }
  // Ghost nodes: send (global node, count, neighbours...) to the owner, as int64 words.
  std::vector<std::vector<std::int64_t>> send(size);
  for (std::int64_t k = 0; k < nn; ++k) {
    const int o = lm.node_owner[k];
    if (o == rank) continue;
    auto& b = send[o];
    b.push_back(lm.global_node[k]);
    b.push_back(static_cast<std::int64_t>(nbrs[k].size()));
    for (const auto& x : nbrs[k]) b.insert(b.end(), {x.g, x.dof[0], x.dof[1], x.dof[2]});
  }
  const auto recv = detail::exchange(lm.comm, send);
  const auto& rbuf = recv.words;
  for (std::size_t i = 0; i < rbuf.size();) {
    const auto k = lm.local_of_global(rbuf[i]);
    const auto cnt = rbuf[i + 1];
    i += 2;
    for (std::int64_t c = 0; c < cnt; ++c, i += 4)
      nbrs[k].push_back({rbuf[i],
                         {static_cast<PetscInt>(rbuf[i + 1]), static_cast<PetscInt>(rbuf[i + 2]),
                          static_cast<PetscInt>(rbuf[i + 3])}});
  }
  // Owned rows, in DOF order (owned nodes are numbered in local order).
  Pattern p;
  p.offsets.assign(1, 0);
  p.offsets.reserve(dofs.n_owned + 1);
  std::vector<PetscInt> cols;
  for (std::int64_t k = 0; k < nn; ++k) {
    if (lm.node_owner[k] != rank) continue;
    cols.clear();
    for (const auto& x : nbrs[k])
      for (int d = 0; d < 3; ++d)
        if (x.dof[d] >= 0) cols.push_back(x.dof[d]);
    std::sort(cols.begin(), cols.end());
    cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
    for (int d = 0; d < 3; ++d) {
      if (dofs.node_dof[3 * k + d] < 0) continue;
      p.columns.insert(p.columns.end(), cols.begin(), cols.end());
      p.offsets.push_back(static_cast<PetscInt>(p.columns.size()));
    }
  }
  return p;
}

std::string check_material(const mesh::Material& m) {
  if (!(m.E > 0) || !std::isfinite(m.E)) return cat("Young's modulus E = ", m.E, " must be > 0");
  if (!(m.nu > -1.0 && m.nu < 0.5)) return cat("Poisson's ratio nu = ", m.nu, " must be in (-1, 0.5)");
  if (!(m.rho > 0) || !std::isfinite(m.rho)) return cat("density rho = ", m.rho, " must be > 0");
  // The solvers square and multiply them: beyond these, K or M lose their meaning in doubles.
  for (auto [what, v] : {std::pair<const char*, double>{"Young's modulus E", m.E}, {"density rho", m.rho}})
    if (v < options::kMinMagnitude || v > options::kMaxMagnitude)
      return cat(what, " = ", v, " must be in [", options::kMinMagnitude, ", ", options::kMaxMagnitude, "]");
  return {};
}

}  // namespace

Operators assemble(const mesh::LocalMesh& lm, const DofLayout& dofs, const mesh::Material& fallback) {
  const auto& m = lm.mesh;
  const std::int64_t ne = m.num_elements();
  // Validate materials before any collective matrix work.
  std::string err;
  bool need_fallback = false;
  for (std::int64_t e = 0; e < ne && err.empty(); ++e) {
    int mi = m.elem_material[e];
    if (mi < 0) {
      need_fallback = true;
    } else {
      auto why = check_material(m.materials[mi]);
      if (!why.empty()) err = cat("material '", m.materials[mi].name, "' of ", m.source, ": ", why);
    }
  }
  if (err.empty() && need_fallback) {
    auto why = check_material(fallback);
    if (!why.empty())
      err = cat("elements of ", m.source, " (e.g. element ", m.elem_ids[0],
                ") have no material in the mesh; give -material_E, -material_nu and "
                "-material_rho (",
                why, ")");
  }
  collective_check(lm.comm, err);

  auto create = [&](Mat* A, MatType type) {
    MORSE_CALL(MatCreate(lm.comm, A));
    MORSE_CALL(MatSetSizes(*A, dofs.n_owned, dofs.n_owned, dofs.n_global, dofs.n_global));
    MORSE_CALL(MatSetType(*A, type));
  };

  auto element_dofs = [&](std::int64_t e, PetscInt* idx, double* xyz) {
    const auto off = m.elem_offsets[e];
    const int nn = static_cast<int>(m.elem_offsets[e + 1] - off);
    for (int a = 0; a < nn; ++a) {
      const auto k = m.elem_nodes[off + a];
      for (int d = 0; d < 3; ++d) {
        idx[3 * a + d] = dofs.node_dof[3 * k + d];
        if (xyz) xyz[3 * a + d] = m.coords[3 * k + d];
      }
    }
    return 3 * nn;
  };

  Operators ops;
  {
    // Exact non-zero structure, set once with zeros so element insertion never shifts entries.
    StageTimer t(lm.comm, "Preallocate");
    auto rows = sparsity_pattern(lm, dofs);
    create(ops.K.ptr(), MATAIJ);
    MORSE_CALL(MatSeqAIJSetPreallocationCSR(ops.K.get(), rows.offsets.data(), rows.columns.data(), nullptr));
    MORSE_CALL(MatMPIAIJSetPreallocationCSR(ops.K.get(), rows.offsets.data(), rows.columns.data(), nullptr));
  }
  StageTimer t(lm.comm, "Assemble");
  MORSE_CALL(MatDuplicate(ops.K.get(), MAT_DO_NOT_COPY_VALUES, ops.M.ptr()));
  for (Mat A : {ops.K.get(), ops.M.get()}) {
    MORSE_CALL(MatSetOption(A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
    MORSE_CALL(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
    MORSE_CALL(MatSetOption(A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
  }

  std::vector<double> Ke(kMaxDofs * kMaxDofs), Me(kMaxDofs * kMaxDofs);
  double xyz[3 * kMaxNodes];
  PetscInt idx[kMaxDofs];
  double volume = 0.0, mass = 0.0;
  Progress progress(lm.comm, "assembly", static_cast<double>(ne));
  for (std::int64_t e = 0; e < ne && err.empty(); ++e) {
    const int nd = element_dofs(e, idx, xyz);
    const auto type = m.elem_types[e];
    const auto& mat = m.elem_material[e] >= 0 ? m.materials[m.elem_material[e]] : fallback;
    double detk = element_stiffness(type, xyz, mat.E, mat.nu, Ke.data());
    double detm = element_mass(type, xyz, mat.rho, Me.data());
    double detj = std::min({detk, detm, min_jacobian(type, xyz)});
    if (!(detj > 0)) {
      err = cat("element ", m.elem_ids[e], " (", mesh::element_name(type), ") of ", m.source,
                " is inverted or degenerate (min det J = ", detj, ")");
      break;
    }
    double v = element_volume(type, xyz);
    volume += v;
    mass += mat.rho * v;
    MORSE_CALL(MatSetValues(ops.K.get(), nd, idx, nd, idx, Ke.data(), ADD_VALUES));
    MORSE_CALL(MatSetValues(ops.M.get(), nd, idx, nd, idx, Me.data(), ADD_VALUES));
    if ((e & 1023) == 0) progress.update(static_cast<double>(e));
  }
  collective_check(lm.comm, err);
  // Point masses (CONM2) on the owned nodes: m on the three translational diagonal entries.
  if (!m.point_mass.empty()) {
    int rank = 0;
    MPI_Comm_rank(lm.comm, &rank);
    for (std::int64_t k = 0; k < m.num_nodes(); ++k) {
      if (lm.node_owner[k] != rank || m.point_mass[k] == 0.0) continue;
      mass += m.point_mass[k];
      for (int d = 0; d < 3; ++d) {
        PetscInt g = dofs.node_dof[3 * k + d];
        if (g >= 0) MORSE_CALL(MatSetValue(ops.M.get(), g, g, m.point_mass[k], ADD_VALUES));
      }
    }
  }
  for (Mat A : {ops.K.get(), ops.M.get()}) {
    MORSE_CALL(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
    MORSE_CALL(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  }
  MPI_Allreduce(&volume, &ops.volume, 1, MPI_DOUBLE, MPI_SUM, lm.comm);
  MPI_Allreduce(&mass, &ops.mass, 1, MPI_DOUBLE, MPI_SUM, lm.comm);
  return ops;
}

MeshQuality mesh_quality(MPI_Comm comm, const mesh::LocalMesh& lm) {
  const auto& m = lm.mesh;
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  MeshQuality q;
  q.per_type.assign(mesh::kNumElementTypes, 0);
  double xyz[3 * kMaxNodes];
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    const auto type = m.elem_types[e];
    ++q.per_type[static_cast<int>(type)];
    const auto off = m.elem_offsets[e];
    for (int a = 0; a < mesh::nodes_per_element(type); ++a)
      for (int d = 0; d < 3; ++d) xyz[3 * a + d] = m.coords[3 * m.elem_nodes[off + a] + d];
    const double j = min_jacobian(type, xyz);
    if (j <= 0) ++q.n_inverted;
    if (j < q.min_jacobian) q.min_jacobian = j, q.worst_element = m.elem_ids[e];
    q.volume += element_volume(type, xyz);
  }
  MPI_Allreduce(MPI_IN_PLACE, q.per_type.data(), mesh::kNumElementTypes, MPI_INT64_T, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &q.volume, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &q.n_inverted, 1, MPI_INT64_T, MPI_SUM, comm);
  struct {
    double v;
    int r;
  } in{q.min_jacobian, rank}, out;
  MPI_Allreduce(&in, &out, 1, MPI_DOUBLE_INT, MPI_MINLOC, comm);
  q.min_jacobian = out.v;
  MPI_Bcast(&q.worst_element, 1, MPI_INT64_T, out.r, comm);
  for (std::int64_t k = 0; k < m.num_nodes(); ++k)
    if (lm.node_owner[k] == rank && !m.fixed_dofs.empty() && (m.fixed_dofs[k] & 7)) ++q.n_fixed_nodes;
  MPI_Allreduce(MPI_IN_PLACE, &q.n_fixed_nodes, 1, MPI_INT64_T, MPI_SUM, comm);
  return q;
}

}  // namespace morse::fe
