// sim/stress.cpp: stress recovery of a displacement field (sim::recover_stress).
//
// Each rank evaluates its own elements: the stress at the points of the stiffness rule (the
// element mean and max of von Mises) and at the element's own nodes (reference_nodes), where the
// displacement interpolation is differentiated directly (no extrapolation from the quadrature
// points, so a field the element represents exactly is recovered exactly at the nodes). The
// nodal contributions go to rank 0 tagged by (node, global element) and are summed in that order.
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <unordered_map>

#include "morse/core/error.hpp"
#include "morse/fe/element.hpp"
#include "morse/sim/sim.hpp"

namespace morse::sim {

double von_mises(const double s[6]) {
  const double a = s[0] - s[1], b = s[1] - s[2], c = s[2] - s[0];
  return std::sqrt(0.5 * (a * a + b * b + c * c) + 3.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]));
}

void stress_from_gradient(StressMeasure m, double E, double nu, const double H[9], double s[6]) {
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  double e[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      e[3 * i + j] = 0.5 * (H[3 * i + j] + H[3 * j + i]);
      if (m == StressMeasure::Nonlinear)
        for (int k = 0; k < 3; ++k) e[3 * i + j] += 0.5 * H[3 * k + i] * H[3 * k + j];
    }
  const double tr = e[0] + e[4] + e[8];
  double S[9];
  for (int i = 0; i < 9; ++i) S[i] = 2 * mu * e[i];
  for (int i = 0; i < 3; ++i) S[4 * i] += lambda * tr;
  if (m == StressMeasure::Nonlinear) {  // sigma = F S F^T / J
    double F[9], FS[9], sig[9];
    for (int i = 0; i < 9; ++i) F[i] = H[i] + (i % 4 == 0 ? 1.0 : 0.0);
    const double J =
        F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6]) + F[2] * (F[3] * F[7] - F[4] * F[6]);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        FS[3 * i + j] = 0.0;
        for (int k = 0; k < 3; ++k) FS[3 * i + j] += F[3 * i + k] * S[3 * k + j];
      }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        sig[3 * i + j] = 0.0;
        for (int k = 0; k < 3; ++k) sig[3 * i + j] += FS[3 * i + k] * F[3 * j + k];
        sig[3 * i + j] /= J;
      }
    std::copy(sig, sig + 9, S);
  }
  s[0] = S[0], s[1] = S[4], s[2] = S[8], s[3] = S[5], s[4] = S[2], s[5] = S[1];
}

namespace {

// H[3i + j] = sum_a u_a,i g_a,j.
void gradient(int n, const double* g, const double* ue, double H[9]) {
  std::fill(H, H + 9, 0.0);
  for (int a = 0; a < n; ++a)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) H[3 * i + j] += ue[3 * a + i] * g[3 * a + j];
}

struct NodalPart {
  std::int64_t node, elem;
  double s[6];
};

}  // namespace

void check_stress_mesh(const mesh::LocalMesh& lm, const std::vector<std::int64_t>& node_ids,
                       const std::vector<double>& coords, const std::string& mesh_file, const std::string& rom_file) {
  const auto n = static_cast<std::int64_t>(node_ids.size());
  collective_check(
      lm.comm, lm.n_global_nodes == n
                   ? std::string()
                   : cat("the mesh ", mesh_file, " has ", lm.n_global_nodes, " nodes but the reduced model ", rom_file,
                         " was built on a mesh of ", n, ": give the mesh given to morse nlrom"));
  // The model's size: the diagonal of its nodes' bounding box.
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::size_t k = 0; k < node_ids.size(); ++k)
    for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], coords[3 * k + d]), hi[d] = std::max(hi[d], coords[3 * k + d]);
  const double size = n ? std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) : 0.0, tol = 1e-6 * size;
  std::unordered_map<std::int64_t, std::size_t> row;
  for (std::size_t k = 0; k < node_ids.size(); ++k) row[node_ids[k]] = k;
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  std::string err;
  for (std::int64_t k = 0; k < lm.mesh.num_nodes() && err.empty(); ++k) {
    if (lm.node_owner[k] != rank) continue;
    const std::int64_t id = lm.mesh.node_ids[k];
    const auto it = row.find(id);
    if (it == row.end()) {
      err = cat("node ", id, " of the mesh ", mesh_file, " is not a node of the reduced model ", rom_file,
                ": give the mesh given to morse nlrom");
      break;
    }
    const double* x = &lm.mesh.coords[3 * k];
    const double* y = &coords[3 * it->second];
    const double dist = std::hypot(x[0] - y[0], x[1] - y[1], x[2] - y[2]);
    if (!(dist <= tol))
      err = cat("node ", id, " of the mesh ", mesh_file, " is at (", x[0], ", ", x[1], ", ", x[2], ") but at (", y[0],
                ", ", y[1], ", ", y[2], ") in the reduced model ", rom_file, " (", dist,
                " apart, more than 1e-6 of the model's size ", size,
                "): give the mesh given to morse nlrom, in the same units");
  }
  collective_check(lm.comm, err);
}

StressField recover_stress(const mesh::LocalMesh& lm, const mesh::Material& fallback,
                           const std::vector<std::int64_t>& node_ids, const std::vector<double>& u, StressMeasure m) {
  const MPI_Comm comm = lm.comm;
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const auto& mm = lm.mesh;
  std::string err;
  if (u.size() != 3 * node_ids.size())
    err = cat("stress: ", u.size(), " displacement values for ", node_ids.size(), " nodes");
  std::unordered_map<std::int64_t, std::size_t> row;
  for (std::size_t k = 0; k < node_ids.size(); ++k) row.emplace(node_ids[k], k);
  std::vector<const double*> ul(mm.node_ids.size(), nullptr);
  for (std::size_t k = 0; k < mm.node_ids.size() && err.empty(); ++k) {
    auto it = row.find(mm.node_ids[k]);
    if (it == row.end())
      err = cat("stress: mesh node ", mm.node_ids[k],
                " has no displacement (the reduced model was built on another mesh?)");
    else
      ul[k] = &u[3 * it->second];
  }
  bool need_fallback = false;
  for (int mat : mm.elem_material) need_fallback = need_fallback || mat < 0;
  if (err.empty() && need_fallback && !(fallback.E > 0 && fallback.nu > -1 && fallback.nu < 0.5))
    err = "stress: elements without a material in the mesh need -material_E and -material_nu";
  collective_check(comm, err);

  // Local elements: quadrature points and nodes.
  const std::size_t ne = mm.elem_types.size();
  std::vector<double> emean(ne), emax(ne);
  std::vector<NodalPart> parts;
  double xyz[3 * fe::kMaxNodes], ue[3 * fe::kMaxNodes], g[3 * fe::kMaxNodes], H[9], s[6];
  for (std::size_t e = 0; e < ne; ++e) {
    const auto t = mm.elem_types[e];
    const int n = mesh::nodes_per_element(t);
    const std::int64_t* nodes = &mm.elem_nodes[mm.elem_offsets[e]];
    for (int a = 0; a < n; ++a)
      for (int d = 0; d < 3; ++d) xyz[3 * a + d] = mm.coords[3 * nodes[a] + d], ue[3 * a + d] = ul[nodes[a]][d];
    const auto& mat = mm.elem_material[e] >= 0 ? mm.materials[mm.elem_material[e]] : fallback;
    const auto& rule = fe::stiffness_rule(t);
    double vol = 0.0, acc = 0.0, top = 0.0;
    for (std::size_t q = 0; q < rule.points.size(); ++q) {
      const double det = fe::shape_gradients(t, xyz, rule.points[q].data(), g);
      MORSE_CHECK(det > 0, "stress: element ", mm.elem_ids[e], " is inverted or degenerate (det J = ", det, ")");
      gradient(n, g, ue, H);
      stress_from_gradient(m, mat.E, mat.nu, H, s);
      const double vm = von_mises(s), w = rule.weights[q] * det;
      vol += w, acc += w * vm, top = std::max(top, vm);
    }
    emean[e] = acc / vol, emax[e] = top;
    const auto& ref = fe::reference_nodes(t);
    for (int a = 0; a < n; ++a) {
      NodalPart p;
      p.node = lm.global_node[nodes[a]];
      p.elem = lm.global_elem[e];
      const double det = fe::shape_gradients(t, xyz, ref[a].data(), g);
      MORSE_CHECK(det > 0, "stress: element ", mm.elem_ids[e], " is inverted at its node ", mm.node_ids[nodes[a]],
                  " (det J = ", det, ")");
      gradient(n, g, ue, H);
      stress_from_gradient(m, mat.E, mat.nu, H, p.s);
      parts.push_back(p);
    }
  }

  StressField f;
  // The largest quadrature-point value and its element (the lowest global element on ties, so
  // that the answer does not depend on the partition).
  struct {
    double v;
    int elem;
  } loc{-1.0, 0}, glob{};
  for (std::size_t e = 0; e < ne; ++e) {
    const int ge = static_cast<int>(lm.global_elem[e]);
    if (emax[e] > loc.v || (emax[e] == loc.v && ge < loc.elem)) loc.v = emax[e], loc.elem = ge;
  }
  MPI_Allreduce(&loc, &glob, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm);
  std::int64_t id = -1;
  for (std::size_t e = 0; e < ne; ++e)
    if (lm.global_elem[e] == glob.elem) id = mm.elem_ids[e];
  MPI_Allreduce(MPI_IN_PLACE, &id, 1, MPI_INT64_T, MPI_MAX, comm);
  f.max_mises = glob.v;
  f.max_element_id = id;

  // Gather to rank 0: element values by global element, nodal parts in (node, element) order.
  auto gather = [&](const void* data, int bytes, std::vector<char>* all) {
    std::vector<int> counts(size), displs(size, 0);
    MPI_Gather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
    if (rank == 0) {
      for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
      all->resize(static_cast<std::size_t>(displs[size - 1]) + counts[size - 1]);
    }
    MPI_Gatherv(data, bytes, MPI_CHAR, all->data(), counts.data(), displs.data(), MPI_CHAR, 0, comm);
  };
  std::vector<double> epack;
  for (std::size_t e = 0; e < ne; ++e)
    epack.insert(epack.end(), {static_cast<double>(lm.global_elem[e]), emean[e], emax[e]});
  std::vector<char> eall, nall;
  gather(epack.data(), static_cast<int>(epack.size() * sizeof(double)), &eall);
  gather(parts.data(), static_cast<int>(parts.size() * sizeof(NodalPart)), &nall);
  if (rank != 0) return f;
  f.element_mises.assign(lm.n_global_elements, 0.0);
  f.element_mises_max.assign(lm.n_global_elements, 0.0);
  const double* ep = reinterpret_cast<const double*>(eall.data());
  for (std::size_t i = 0; i + 2 < eall.size() / sizeof(double); i += 3) {
    const auto ge = static_cast<std::size_t>(ep[i]);
    f.element_mises[ge] = ep[i + 1], f.element_mises_max[ge] = ep[i + 2];
  }
  std::vector<NodalPart> all(nall.size() / sizeof(NodalPart));
  std::copy(nall.begin(), nall.end(), reinterpret_cast<char*>(all.data()));
  std::sort(all.begin(), all.end(),
            [](const NodalPart& a, const NodalPart& b) { return std::tie(a.node, a.elem) < std::tie(b.node, b.elem); });
  f.nodal_stress.assign(6 * lm.n_global_nodes, 0.0);
  f.nodal_mises.assign(lm.n_global_nodes, 0.0);
  for (std::size_t i = 0; i < all.size();) {
    std::size_t j = i;
    double sum[6] = {};
    for (; j < all.size() && all[j].node == all[i].node; ++j)
      for (int c = 0; c < 6; ++c) sum[c] += all[j].s[c];
    double* out = &f.nodal_stress[6 * all[i].node];
    for (int c = 0; c < 6; ++c) out[c] = sum[c] / static_cast<double>(j - i);
    f.nodal_mises[all[i].node] = von_mises(out);
    i = j;
  }
  return f;
}

}  // namespace morse::sim
