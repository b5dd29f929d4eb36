// io/model_file.cpp: the model parts of an output file: node sets, mode shapes, the DOF labels of
// matrix input (io/h5.hpp, docs/hdf5-schema.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/units.hpp"
#include "morse/fe/constraints.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/partition.hpp"

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
    // The set's six-DOF points (rigid and interpolation elements), known on every rank.
    if (auto it = lm.mesh.constraints.point_sets.find(name); rank == 0 && it != lm.mesh.constraints.point_sets.end())
      all.insert(all.end(), it->second.begin(), it->second.end());
    std::sort(all.begin(), all.end());
    out.write(group + "/" + name, all);
  }
}

void write_modes_dataset(H5Output& out, const std::string& name, const fe::Model& md, Mat V, PetscInt first,
                         PetscInt count) {
  // One mode at a time: rank 0 never holds more than one gathered mode (4 MB for 170k nodes,
  // against 4 GB for 1000 modes at once).
  if (!md.mesh) {
    out.create_rows(name, {static_cast<hsize_t>(count), static_cast<hsize_t>(md.dofs.n_global)});
    for (PetscInt j = 0; j < count; ++j) {
      Vec x;
      MORSE_CALL(MatDenseGetColumnVecRead(V, first + j, &x));
      VecScatter sc;
      Vec all;
      MORSE_CALL(VecScatterCreateToZero(x, &sc, &all));
      MORSE_CALL(VecScatterBegin(sc, x, all, INSERT_VALUES, SCATTER_FORWARD));
      MORSE_CALL(VecScatterEnd(sc, x, all, INSERT_VALUES, SCATTER_FORWARD));
      MORSE_CALL(MatDenseRestoreColumnVecRead(V, first + j, &x));
      PetscInt n = 0;
      const PetscScalar* a;
      MORSE_CALL(VecGetLocalSize(all, &n));
      MORSE_CALL(VecGetArrayRead(all, &a));
      std::vector<double> row(a, a + n);
      MORSE_CALL(VecRestoreArrayRead(all, &a));
      MORSE_CALL(VecScatterDestroy(&sc));
      MORSE_CALL(VecDestroy(&all));
      out.write_row(name, static_cast<hsize_t>(j), row);
    }
    return;
  }
  out.create_rows(name, {static_cast<hsize_t>(count), static_cast<hsize_t>(md.mesh->n_global_nodes), 3});
  // The six-DOF points' DOFs (rigid and interpolation elements): rank 0's last rows, written
  // beside the nodal field as name_points [mode][point][1..6], points as /mesh/point_ids (0 for
  // a DOF that is not the model's: dropped or dependent), so that the vector can be read back.
  const std::vector<std::int64_t>& pids = md.mesh->mesh.constraints.point_ids;
  const std::vector<std::int64_t> point_row = fe::point_dof_slots(md);  // owned row -> 6 p + c - 1, or -1
  if (!point_row.empty()) {
    out.create_rows(name + "_points", {static_cast<hsize_t>(count), static_cast<hsize_t>(pids.size()), 6});
    out.attribute(name + "_points", "description",
                  "[mode][point][components 1..6] of the six-DOF points, points as /mesh/point_ids; 0 where the "
                  "DOF is not one of the model's");
  }
  for (PetscInt j = 0; j < count; ++j) {
    Vec x;
    MORSE_CALL(MatDenseGetColumnVecRead(V, first + j, &x));
    // The nodes' translations: u = T u_bar with rigid/interpolation elements or MPCs.
    auto u = fe::expand(md, x);
    auto nodal = gather_nodal(*md.mesh, fe::node_layout(md), u.get());
    if (!point_row.empty()) {
      // Points' rows are owned by rank 0 (fe/constraints.hpp), so rank 0 alone has them.
      std::vector<double> pv(6 * pids.size(), 0.0);
      const PetscScalar* a;
      MORSE_CALL(VecGetArrayRead(x, &a));
      for (std::size_t i = 0; i < point_row.size(); ++i)
        if (point_row[i] >= 0) pv[static_cast<std::size_t>(point_row[i])] = a[i];
      MORSE_CALL(VecRestoreArrayRead(x, &a));
      out.write_row(name + "_points", static_cast<hsize_t>(j), pv);
    }
    MORSE_CALL(MatDenseRestoreColumnVecRead(V, first + j, &x));
    out.write_row(name, static_cast<hsize_t>(j), nodal);
  }
}

void write_modes(H5Output& out, const std::string& group, const fe::Model& md, const std::vector<double>& omega2,
                 Mat V) {
  out.write(group + "/frequencies_hz", hz(omega2));
  out.write(group + "/eigenvalues", omega2);
  write_modes_dataset(out, group + "/mode_shapes", md, V, 0, static_cast<PetscInt>(omega2.size()));
  out.attribute(group + "/mode_shapes", "description",
                md.mesh ? "[mode][node][x,y,z], mass-normalized, nodes as /mesh/node_ids"
                        : "[mode][row], mass-normalized, rows as /dofs/node and /dofs/component");
}

void write_model(H5Output& out, const fe::Model& md) {
  if (md.mesh) {
    write_mesh(out, mesh::gather_to_rank0(*md.mesh));
    write_node_sets(out, *md.mesh, "/mesh/node_sets");
    return;
  }
  std::vector<std::int64_t> node, comp;
  fe::gather_labels(md.dofs, &node, &comp);
  write_dof_labels(out, node, comp, md.source, md.dofs.n_global + md.dofs.n_clamped_global);
}

void write_dof_labels(H5Output& out, const std::vector<std::int64_t>& node, const std::vector<std::int64_t>& component,
                      const std::string& source, std::int64_t n_rows_file) {
  out.write("/dofs/node", node);
  out.write("/dofs/component", component);
  out.attribute("/dofs", "description",
                "matrix input: node id and component (1..6) of every free row of K and M, in row order");
  out.attribute("/dofs", "source", source);
  out.attribute_int("/dofs", "n_rows_file", n_rows_file);
}

}  // namespace morse::io
