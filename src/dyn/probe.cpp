// Node-set displacement probes (see morse/dyn/dyn.hpp).
#include <algorithm>

#include "morse/core/error.hpp"
#include "morse/dyn/dyn.hpp"

namespace morse::dyn {

SetProbe::SetProbe(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::string& set)
    : comm_(lm.comm), name_(set) {
  collective_check(lm.comm, mesh::check_node_set(lm, set, "monitored node set"));
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  // Global node indices and ids of the owned set nodes, gathered so every rank knows the order.
  std::vector<std::int64_t> mine;
  for (auto k : lm.mesh.node_sets.at(set))
    if (lm.node_owner[k] == rank) mine.insert(mine.end(), {lm.global_node[k], lm.mesh.node_ids[k]});
  int n = static_cast<int>(mine.size()), size = 1;
  MPI_Comm_size(lm.comm, &size);
  std::vector<int> counts(size), displs(size, 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, lm.comm);
  for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
  std::vector<std::int64_t> all(displs[size - 1] + counts[size - 1]);
  MPI_Allgatherv(mine.data(), n, MPI_INT64_T, all.data(), counts.data(), displs.data(), MPI_INT64_T, lm.comm);
  std::vector<std::pair<std::int64_t, std::int64_t>> nodes;  // (global index, id)
  for (std::size_t i = 0; i + 1 < all.size(); i += 2) nodes.emplace_back(all[i], all[i + 1]);
  std::sort(nodes.begin(), nodes.end());
  n_ = nodes.size();
  if (rank == 0)
    for (auto& p : nodes) ids_.push_back(p.second);
  for (auto k : lm.mesh.node_sets.at(set)) {
    if (lm.node_owner[k] != rank) continue;
    const auto slot =
        std::lower_bound(nodes.begin(), nodes.end(), std::make_pair(lm.global_node[k], std::int64_t(-1))) -
        nodes.begin();
    for (int d = 0; d < 3; ++d)
      if (dofs.node_dof[3 * k + d] >= 0)
        local_.emplace_back(static_cast<int>(3 * slot + d), dofs.node_dof[3 * k + d] - dofs.first);
  }
}

std::vector<double> SetProbe::sample(Vec u) const {
  std::vector<double> mine(3 * n_, 0.0), out;
  const PetscScalar* a;
  MORSE_CALL(VecGetArrayRead(u, &a));
  for (const auto& [slot, i] : local_) mine[slot] = a[i];
  MORSE_CALL(VecRestoreArrayRead(u, &a));
  int rank = 0;
  MPI_Comm_rank(comm_, &rank);
  if (rank == 0) out.resize(3 * n_);
  MPI_Reduce(mine.data(), out.data(), static_cast<int>(3 * n_), MPI_DOUBLE, MPI_SUM, 0, comm_);
  return out;
}

}  // namespace morse::dyn
