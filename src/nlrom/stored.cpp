// Reading a `morse nlrom` file for the online stage (see morse/nlrom/nlrom.hpp).
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/detail/pack.hpp"
#include "morse/core/error.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/nlrom/nlrom.hpp"

namespace morse::nlrom {

std::vector<double> StoredModel::nodal_pattern(const std::string& set, const double dir[3]) const {
  const double n = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  const std::size_t nn = node_ids.size();
  std::vector<double> p(r(), 0.0);
  for (std::size_t j = 0; j < r(); ++j)
    for (auto k : sets.at(set))
      for (int c = 0; c < 3; ++c) p[j] += dir[c] / n * basis[(j * nn + k) * 3 + c];
  return p;
}

void StoredModel::displacements(const std::string& set, const double* q, std::vector<double>* out) const {
  const std::size_t nn = node_ids.size();
  for (auto k : sets.at(set))
    for (int c = 0; c < 3; ++c) {
      double u = 0.0;
      for (std::size_t j = 0; j < r(); ++j) u += basis[(j * nn + k) * 3 + c] * q[j];
      out->push_back(u);
    }
}

std::vector<double> StoredModel::field(const double* q) const {
  const std::size_t n = node_ids.size() * 3;
  std::vector<double> u(n, 0.0);
  for (std::size_t j = 0; j < r(); ++j) {
    const double* b = &basis[j * n];
    for (std::size_t i = 0; i < n; ++i) u[i] += b[i] * q[j];
  }
  return u;
}

std::vector<double> StoredModel::radial_row(const std::string& set, const std::string& option) const {
  const auto& rows = sets.at(set);
  MORSE_CHECK(rows.size() == 1, option, " ", set, " has ", rows.size(), " nodes; one is expected (a set of one node)");
  const std::size_t nn = node_ids.size(), k = rows[0];
  const double* x = &coords[3 * k];
  const double rho = std::hypot(x[0], x[1]);
  MORSE_CHECK(rho > 0, option, " ", set, ": node ", node_ids[k], " lies on the rotation axis (no radial direction)");
  std::vector<double> m(r());
  for (std::size_t j = 0; j < r(); ++j)
    m[j] = (x[0] * basis[(j * nn + k) * 3] + x[1] * basis[(j * nn + k) * 3 + 1]) / rho;
  return m;
}

std::vector<std::size_t> StoredModel::dof_rows(const std::vector<std::int64_t>& ids,
                                               const std::vector<std::int64_t>& comps) const {
  MORSE_CHECK(ids.size() == comps.size(), "DOF map: ", ids.size(), " node ids but ", comps.size(), " components");
  std::map<std::int64_t, std::size_t> pos;
  for (std::size_t k = 0; k < node_ids.size(); ++k) pos[node_ids[k]] = k;
  std::vector<std::size_t> rows(ids.size());
  for (std::size_t j = 0; j < ids.size(); ++j) {
    auto it = pos.find(ids[j]);
    MORSE_CHECK(it != pos.end(), "node ", ids[j], " is not a node of ", file, " (another mesh?)");
    MORSE_CHECK(comps[j] >= 0 && comps[j] < 3, "DOF map: component ", comps[j], " of node ", ids[j]);
    rows[j] = it->second * 3 + static_cast<std::size_t>(comps[j]);
  }
  return rows;
}

void StoredModel::dof_values(const std::vector<std::size_t>& rows, const double* q, std::vector<double>* out) const {
  const std::size_t stride = node_ids.size() * 3;
  for (auto row : rows) {
    double u = 0.0;
    for (std::size_t j = 0; j < r(); ++j) u += basis[j * stride + row] * q[j];
    out->push_back(u);
  }
}

std::vector<std::size_t> StoredModel::boundary_translations(const std::string& set) const {
  std::map<std::int64_t, std::size_t> first;  // node -> its first boundary coordinate
  for (std::size_t j = boundary_dof_node.size(); j-- > 0;) first[boundary_dof_node[j]] = j;
  std::vector<std::size_t> out;
  for (auto row : sets.at(set)) {
    const std::int64_t id = node_ids[row];
    auto it = first.find(id);
    MORSE_CHECK(it != first.end(), file, ": node ", id, " of set ", set,
                " is not a physical boundary node of the reduced model (its boundary set has ", boundary_nodes.size(),
                " nodes); rebuild it with morse nlrom -boundary naming a set that contains ", set);
    const std::size_t j = it->second;
    bool xyz = j + 2 < boundary_dof_node.size();
    for (int c = 0; xyz && c < 3; ++c) xyz = boundary_dof_node[j + c] == id && boundary_dof_component[j + c] == c + 1;
    MORSE_CHECK(xyz, file, ": node ", id, " of set ", set,
                " does not have its three translations among the boundary coordinates (a partly clamped node); "
                "contact and the massless boundary need them");
    out.push_back(j);
  }
  return out;
}

std::vector<double> StoredModel::fit(const std::vector<double>& u, double* rel_residual) const {
  const std::size_t n = node_ids.size() * 3, nr = r();
  MORSE_CHECK(u.size() == n, "fit: ", u.size(), " values for ", n, " basis rows");
  std::vector<double> G(nr * nr, 0.0), q(nr, 0.0);
  for (std::size_t i = 0; i < nr; ++i) {
    const double* bi = &basis[i * n];
    for (std::size_t j = 0; j <= i; ++j) {
      const double* bj = &basis[j * n];
      double s = 0.0;
      for (std::size_t k = 0; k < n; ++k) s += bi[k] * bj[k];
      G[i * nr + j] = G[j * nr + i] = s;
    }
    double s = 0.0;
    for (std::size_t k = 0; k < n; ++k) s += bi[k] * u[k];
    q[i] = s;
  }
  PetscBLASInt nn = static_cast<PetscBLASInt>(nr), one = 1, info = 0;
  const char uplo = 'L';
  LAPACKpotrf_(&uplo, &nn, G.data(), &nn, &info);
  MORSE_CHECK(info == 0, file, ": the basis is rank deficient (Cholesky of its Gram matrix, info ", info, ")");
  LAPACKpotrs_(&uplo, &nn, &one, G.data(), &nn, q.data(), &nn, &info);
  double e = 0.0, t = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    double v = 0.0;
    for (std::size_t j = 0; j < nr; ++j) v += basis[j * n + k] * q[j];
    e += (v - u[k]) * (v - u[k]);
    t += u[k] * u[k];
  }
  if (rel_residual) *rel_residual = t > 0 ? std::sqrt(e / t) : 0.0;
  return q;
}

StoredModel read_stored_model(MPI_Comm comm, const std::string& file, const std::vector<std::string>& sets) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  StoredModel s;
  s.file = file;
  std::string err;
  detail::Packer pk;
  if (rank == 0) {
    auto& m = s.model;
    std::vector<hsize_t> d;
    bool ok = io::read_doubles(file, "/nlrom/M", &m.M, &d, &err) && d.size() == 2 && d[0] == d[1];
    if (ok)
      m.r = static_cast<PetscInt>(d[0]);
    else if (err.empty())
      err = cat(file, ": /nlrom/M is not square");
    // A linear model (-nlrom_forces none) stores no tensors: g.r = 0, and a nonlinear run is refused.
    const bool linear_model = ok && io::read_string_attribute(file, "/nlrom", "forces") == "none";
    ok = ok && io::read_doubles(file, "/nlrom/K", &m.K, &d, &err) &&
         io::read_doubles(file, "/nlrom/C", &m.C, &d, &err) &&
         (linear_model || (io::read_doubles(file, "/nlrom/A", &m.g.A, &d, &err) &&
                           io::read_doubles(file, "/nlrom/B", &m.g.B, &d, &err))) &&
         io::read_doubles(file, "/nlrom/basis", &s.basis, &d, &err) &&
         io::read_ints(file, "/mesh/node_ids", &s.node_ids, &d, &err) &&
         io::read_doubles(file, "/mesh/coordinates", &s.coords, &d, &err) &&
         io::read_ints(file, "/nlrom/boundary_nodes", &s.boundary_nodes, &d, &err);
    // What each boundary coordinate is; a file written before six-DOF boundaries existed holds
    // the three translations of each boundary node.
    if (ok && io::has_object(file, "/nlrom/boundary_dofs")) {
      std::vector<std::int64_t> pairs;
      ok = io::read_ints(file, "/nlrom/boundary_dofs", &pairs, &d, &err);
      if (ok && (d.size() != 2 || d[1] != 2)) {
        err = cat(file, ": /nlrom/boundary_dofs is not an (n_b, 2) array of (node, component)");
        ok = false;
      }
      for (std::size_t j = 0; ok && j < pairs.size() / 2; ++j) {
        const std::int64_t id = pairs[2 * j], c = pairs[2 * j + 1];
        if (c < 1 || c > 6 || !std::binary_search(s.boundary_nodes.begin(), s.boundary_nodes.end(), id)) {
          err = cat(file, ": /nlrom/boundary_dofs row ", j, " (node ", id, ", component ", c,
                    ") is not a component 1..6 of a node of /nlrom/boundary_nodes");
          ok = false;
        }
        s.boundary_dof_node.push_back(id);
        s.boundary_dof_component.push_back(static_cast<int>(c));
      }
    } else {
      for (std::int64_t id : s.boundary_nodes)
        for (int c = 1; c <= 3; ++c) s.boundary_dof_node.push_back(id), s.boundary_dof_component.push_back(c);
    }
    const std::size_t r = static_cast<std::size_t>(m.r);
    m.n_b = static_cast<PetscInt>(s.boundary_dof_node.size());
    m.g.r = linear_model ? 0 : r;
    if (ok && (m.K.size() != r * r || m.C.size() != r * r ||
               (!linear_model && (m.g.A.size() != n_quadratic(r) * r || m.g.B.size() != n_cubic(r) * r)) ||
               s.basis.size() != r * s.node_ids.size() * 3 || s.coords.size() != 3 * s.node_ids.size() ||
               static_cast<std::size_t>(m.n_b) > r)) {
      err = cat(file, ": inconsistent /nlrom datasets (r = ", r, ")");
      ok = false;
    }
    // Every stored number finite: a NaN or inf in an operator would surface much later as an
    // unrelated failure (a mass matrix "not positive definite", a time step "unstable").
    if (ok) {
      const std::pair<const char*, const std::vector<double>*> stored[] = {{"/nlrom/M", &m.M},
                                                                           {"/nlrom/K", &m.K},
                                                                           {"/nlrom/C", &m.C},
                                                                           {"/nlrom/A", &m.g.A},
                                                                           {"/nlrom/B", &m.g.B},
                                                                           {"/nlrom/basis", &s.basis},
                                                                           {"/mesh/coordinates", &s.coords}};
      for (const auto& [name, v] : stored) {
        const auto bad = std::find_if(v->begin(), v->end(), [](double x) { return !std::isfinite(x); });
        if (bad != v->end()) {
          err = cat(file, ": ", name, " holds a non-finite value (", *bad, " at entry ", bad - v->begin(),
                    "): the reduced model is corrupt; rebuild it with morse nlrom");
          ok = false;
          break;
        }
      }
    }
    std::string units, uerr;
    if (ok && io::read_string(file, "/meta/units", &units, &uerr)) s.units = units;
    if (ok) {  // a file written before the choice existed has no attribute: mass-carrying
      const auto bm = io::read_string_attribute(file, "/nlrom", "boundary_mass");
      m.massless = bm == "massless";
      m.n_static = m.n_b;
      double ns = 0;
      std::string aerr;
      if (m.massless && io::read_attribute(file, "/nlrom", "n_static_coordinates", &ns, &aerr)) {
        if (!(ns >= static_cast<double>(m.n_b) && ns < static_cast<double>(r))) {
          err = cat(file, ": /nlrom@n_static_coordinates ", ns, " is not in [n_b = ", m.n_b, ", r = ", r, ")");
          ok = false;
        }
        m.n_static = static_cast<PetscInt>(ns);
      }
      if (!bm.empty() && bm != "massless" && bm != "carrying") {
        err = cat(file, ": /nlrom@boundary_mass is '", bm, "' (carrying or massless)");
        ok = false;
      }
      // /nlrom/C is the damping whatever its model; a file written before the choice existed has
      // no attribute (modal damping, or none).
      const auto dm = io::read_string_attribute(file, "/nlrom", "damping");
      if (ok && !dm.empty() && dm != "none" && dm != "modal" && dm != "rayleigh") {
        err = cat(file, ": /nlrom@damping is '", dm, "' (none, modal or rayleigh)");
        ok = false;
      }
      for (std::size_t i = 0; ok && m.massless && i < r; ++i)
        for (std::size_t j = 0; j < static_cast<std::size_t>(m.n_static); ++j)
          if (m.M[i * r + j] != 0.0 || m.M[j * r + i] != 0.0) {
            err = cat(file, ": /nlrom@boundary_mass is massless but /nlrom/M has mass on static coordinate ", j);
            ok = false;
            break;
          }
    }
    if (ok) {
      std::map<std::int64_t, std::size_t> row;
      for (std::size_t k = 0; k < s.node_ids.size(); ++k) row[s.node_ids[k]] = k;
      for (const auto& set : sets) {
        if (s.sets.count(set)) continue;
        std::vector<std::int64_t> ids;
        if (!io::read_ints(file, "/nlrom/node_sets/" + set, &ids, &d, &err)) {
          err = cat(file, ": no node set '", set, "' in /nlrom/node_sets (sets are those of the mesh given to nlrom)");
          break;
        }
        auto& v = s.sets[set];
        for (auto id : ids) {
          auto it = row.find(id);
          if (it == row.end()) {
            err = cat(file, ": node ", id, " of set ", set, " is not in /mesh/node_ids");
            break;
          }
          v.push_back(it->second);
        }
        if (!err.empty()) break;
      }
    }
    if (err.empty()) {
      pk.put(m.r);
      pk.put(m.n_b);
      pk.put<int>(m.massless ? 1 : 0);
      pk.put(m.n_static);
      pk.put_vec(m.M), pk.put_vec(m.K), pk.put_vec(m.C), pk.put_vec(m.g.A), pk.put_vec(m.g.B);
      pk.put_vec(m.damping_omega), pk.put_vec(s.basis), pk.put_vec(s.node_ids);
      pk.put_vec(s.coords), pk.put_vec(s.boundary_nodes), pk.put_vec(s.boundary_dof_node);
      pk.put_vec(s.boundary_dof_component);
      pk.put_str(s.units);
      pk.put<std::uint64_t>(s.sets.size());
      for (const auto& [name, rows] : s.sets) pk.put_str(name), pk.put_vec(rows);
    }
  }
  collective_check(comm, err);
  int size = 1;
  MPI_Comm_size(comm, &size);
  if (size == 1) return s;
  auto& buf = pk.buffer();
  std::uint64_t n = buf.size();
  MPI_Bcast(&n, 1, MPI_UINT64_T, 0, comm);
  buf.resize(n);
  for (std::uint64_t off = 0; off < n; off += (1u << 30))
    MPI_Bcast(buf.data() + off, static_cast<int>(std::min<std::uint64_t>(1u << 30, n - off)), MPI_CHAR, 0, comm);
  if (rank != 0) {
    detail::Unpacker up(buf);
    auto& m = s.model;
    m.r = up.get<PetscInt>();
    m.n_b = up.get<PetscInt>();
    m.massless = up.get<int>() != 0;
    m.n_static = up.get<PetscInt>();
    m.M = up.get_vec<double>(), m.K = up.get_vec<double>(), m.C = up.get_vec<double>();
    m.g.A = up.get_vec<double>(), m.g.B = up.get_vec<double>();
    m.g.r = m.g.A.empty() && m.g.B.empty() ? 0 : static_cast<std::size_t>(m.r);
    m.damping_omega = up.get_vec<double>();
    s.basis = up.get_vec<double>();
    s.node_ids = up.get_vec<std::int64_t>();
    s.coords = up.get_vec<double>();
    s.boundary_nodes = up.get_vec<std::int64_t>();
    s.boundary_dof_node = up.get_vec<std::int64_t>();
    s.boundary_dof_component = up.get_vec<int>();
    s.units = up.get_str();
    const auto ns = up.get<std::uint64_t>();
    for (std::uint64_t i = 0; i < ns; ++i) {
      auto name = up.get_str();
      s.sets[name] = up.get_vec<std::size_t>();
    }
  }
  return s;
}

void write_stored_model(io::H5Output& out, const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const Basis& basis,
                        const ReducedModel& rm, const StoredInfo& info, Mat T) {
  auto gm = mesh::gather_to_rank0(lm);
  io::write_mesh(out, gm);
  // Node sets by node id (simulate reconstructs and loads sets without the mesh file): the
  // owned members of every set, gathered on rank 0.
  io::write_node_sets(out, lm, "/nlrom/node_sets");
  const PetscInt r = basis.r();
  const auto R = static_cast<hsize_t>(r);
  out.write("/nlrom/M", rm.M, {R, R});
  out.write("/nlrom/K", rm.K, {R, R});
  out.write("/nlrom/C", rm.C, {R, R});
  if (info.forces != "none") {  // a linear model (-nlrom_forces none) has no tensors
    out.write("/nlrom/A", rm.g.A, {static_cast<hsize_t>(n_quadratic(r)), R});
    out.write("/nlrom/B", rm.g.B, {static_cast<hsize_t>(n_cubic(r)), R});
    out.attribute("/nlrom/A", "description",
                  "quadratic coefficients A~^m_ij (eq. 28): row = (i <= j) lexicographic, column m");
    out.attribute("/nlrom/B", "description",
                  "cubic coefficients B~^m_ijk (eq. 28): row = (i <= j <= k) lexicographic, column m");
  }
  std::vector<double> nodal;
  UVec u;  // a column expanded on the nodes (T)
  if (T) MORSE_CALL(MatCreateVecs(T, nullptr, u.ptr()));
  for (PetscInt j = 0; j < r; ++j) {
    Vec c;
    MORSE_CALL(MatDenseGetColumnVecRead(basis.V.get(), j, &c));
    if (T) MORSE_CALL(MatMult(T, c, u.get()));
    auto col = io::gather_nodal(lm, dofs, T ? u.get() : c);
    MORSE_CALL(MatDenseRestoreColumnVecRead(basis.V.get(), j, &c));
    nodal.insert(nodal.end(), col.begin(), col.end());
  }
  out.write("/nlrom/basis", nodal, {R, static_cast<hsize_t>(lm.n_global_nodes), 3});
  out.attribute("/nlrom/basis", "description", "[column][node][x,y,z] basis vectors, nodes as /mesh/node_ids");
  std::string labels;
  for (const auto& l : basis.labels) labels += l + "\n";
  out.write_string("/nlrom/labels", labels);
  out.write("/nlrom/boundary_nodes", basis.cb.boundary_node_ids);
  MORSE_CHECK(basis.cb.boundary_dof_node.size() >= static_cast<std::size_t>(basis.n_b) &&
                  basis.cb.boundary_dof_component.size() >= static_cast<std::size_t>(basis.n_b),
              "nlrom: the basis does not say what its ", basis.n_b, " boundary coordinates are");
  std::vector<std::int64_t> bdofs;  // (node, component) of each boundary coordinate, as /rom/boundary_dofs
  for (PetscInt j = 0; j < basis.n_b; ++j)
    bdofs.push_back(basis.cb.boundary_dof_node[j]), bdofs.push_back(basis.cb.boundary_dof_component[j]);
  out.write("/nlrom/boundary_dofs", bdofs, {static_cast<hsize_t>(basis.n_b), 2});
  if (!basis.md_pairs.empty()) {
    std::vector<std::int64_t> pairs, sel;
    for (std::size_t k = 0; k < basis.md_pairs.size(); ++k) {
      pairs.push_back(basis.md_pairs[k].first + 1);
      pairs.push_back(basis.md_pairs[k].second + 1);
      sel.push_back(basis.md_selected[k]);
    }
    out.write("/nlrom/derivatives/pairs", pairs, {basis.md_pairs.size(), 2});
    out.write("/nlrom/derivatives/weights", basis.md_weights);
    out.write("/nlrom/derivatives/selected", sel);
    out.attribute("/nlrom/derivatives", "selection", info.derivative_selection);
  }
  if (!basis.pod_singular_values.empty()) out.write("/nlrom/pod/singular_values", basis.pod_singular_values);
  if (!rm.damping_omega.empty()) out.write("/nlrom/damping/omega", rm.damping_omega);
  out.attribute("/nlrom", "basis", info.basis);
  out.attribute("/nlrom", "boundary_mass", rm.massless ? std::string("massless") : std::string("carrying"));
  if (rm.massless) {
    out.attribute_int("/nlrom", "n_static_coordinates", rm.n_static);
    out.attribute("/nlrom", "massless_interior", info.massless_interior);
    out.attribute("/nlrom", "massless_fmax", info.massless_fmax);
  }
  out.attribute("/nlrom", "mass_scaling_fmax", info.mass_scaling_fmax);
  out.attribute_int("/nlrom", "mass_scaled_modes", static_cast<PetscInt>(info.mass_scaled_modes));
  out.attribute("/nlrom", "forces", info.forces);
  out.attribute("/nlrom", "boundary_set", info.boundary_set);
  out.attribute_int("/nlrom", "r", r);
  out.attribute_int("/nlrom", "n_boundary_dofs", basis.n_b);
  out.attribute_int("/nlrom", "n_fixed_modes", basis.n_fixed);
  out.attribute_int("/nlrom", "n_extra", basis.n_extra);
  out.attribute("/nlrom", "step_displacement", info.step_displacement);
  out.attribute_int("/nlrom", "filter_pod", info.filter_pod);
  out.attribute("/nlrom", "damping", info.damping);
  out.attribute("/nlrom", "modal_damping_ratio", info.modal_damping_ratio);
  out.attribute("/nlrom", "rayleigh_alpha", info.rayleigh_alpha);
  out.attribute("/nlrom", "rayleigh_beta", info.rayleigh_beta);
  out.attribute("/nlrom", "t1_basis_seconds", basis.seconds);
  out.attribute("/nlrom", "t2_forces_seconds", info.t2_forces_seconds);
  out.attribute("/nlrom", "t3_projection_seconds", info.t3_projection_seconds);
}

}  // namespace morse::nlrom
