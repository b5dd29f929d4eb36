// io/model_file.cpp: the model parts of an output file: node sets, mode shapes, the DOF labels of
// matrix input (io/h5.hpp, docs/hdf5-schema.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/io/h5.hpp"

namespace morse::io {

void write_node_sets(H5Output& out, const mesh::LocalMesh& lm, const std::string& group) {
  int rank = 0, size = 1;
  MPI_Comm_rank(lm.comm, &rank);
  MPI_Comm_size(lm.comm, &size);
  // Every rank knows every set name (partition.hpp), in the same (map) order.
  for (const auto& [name, nodes] : lm.mesh.node_sets) {
    std::vector<std::int64_t> mine;
    for (auto k : nodes)
      if (lm.node_owner[k] == rank) mine.push_back(lm.mesh.node_ids[k]);
    int n = static_cast<int>(mine.size());
    std::vector<int> counts(size), displs(size, 0);
    MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, lm.comm);
    for (int q = 1; q < size; ++q) displs[q] = displs[q - 1] + counts[q - 1];
    std::vector<std::int64_t> all(rank == 0 ? displs[size - 1] + counts[size - 1] : 0);
    MPI_Gatherv(mine.data(), n, MPI_INT64_T, all.data(), counts.data(), displs.data(), MPI_INT64_T, 0, lm.comm);
    std::sort(all.begin(), all.end());
    out.write(group + "/" + name, all);
  }
}

void write_modes_dataset(H5Output& out, const std::string& name, const mesh::LocalMesh& lm,
                         const fe::DofMap& dofs, Mat V, PetscInt first, PetscInt count) {
  // One mode at a time: rank 0 never holds more than one gathered mode (4 MB for 170k nodes,
  // against 4 GB for 1000 modes at once).
  out.create_rows(name, {static_cast<hsize_t>(count), static_cast<hsize_t>(lm.n_global_nodes), 3});
  for (PetscInt j = 0; j < count; ++j) {
    Vec x;
    MORSE_CALL(MatDenseGetColumnVecRead(V, first + j, &x));
    auto nodal = gather_nodal(lm, dofs, x);
    MORSE_CALL(MatDenseRestoreColumnVecRead(V, first + j, &x));
    out.write_row(name, static_cast<hsize_t>(j), nodal);
  }
}

void write_modes(H5Output& out, const std::string& group, const mesh::LocalMesh& lm, const fe::DofMap& dofs,
                 const std::vector<double>& omega2, Mat V) {
  constexpr double kTwoPi = 6.283185307179586;
  std::vector<double> f;
  for (double l : omega2) f.push_back(std::sqrt(std::max(0.0, l)) / kTwoPi);
  out.write(group + "/frequencies_hz", f);
  out.write(group + "/eigenvalues", omega2);
  write_modes_dataset(out, group + "/mode_shapes", lm, dofs, V, 0, static_cast<PetscInt>(f.size()));
  out.attribute(group + "/mode_shapes", "description", "[mode][node][x,y,z], mass-normalized, nodes as /mesh/node_ids");
}

void write_dof_labels(H5Output& out, const std::vector<std::int64_t>& node,
                      const std::vector<std::int64_t>& component, const std::string& source,
                      std::int64_t n_rows_file) {
  out.write("/dofs/node", node);
  out.write("/dofs/component", component);
  out.attribute("/dofs", "description",
                "matrix input: node id and component (1..6) of every free row of K and M, in row order");
  out.attribute("/dofs", "source", source);
  out.attribute_int("/dofs", "n_rows_file", n_rows_file);
}

}  // namespace morse::io
