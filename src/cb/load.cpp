#include <hdf5.h>

#include <cmath>
#include <memory>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/fe/constraints.hpp"

namespace morse::cb {

namespace {

// Rank-0 reader of a morse HDF5 file; every failure becomes a message naming the file.
class Reader {
 public:
  explicit Reader(const std::string& path) : path_(path) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    file_ = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    MORSE_CHECK(file_ >= 0, "cannot open superelement file ", path);
  }
  ~Reader() {
    if (file_ >= 0) H5Fclose(file_);
  }
  bool has(const std::string& name) const {
    // Checks each path component so intermediate groups may be missing.
    std::size_t p = 1;
    while (true) {
      auto q = name.find('/', p);
      std::string part = name.substr(0, q);
      if (H5Lexists(file_, part.c_str(), H5P_DEFAULT) <= 0) return false;
      if (q == std::string::npos) return true;
      p = q + 1;
    }
  }
  std::vector<hsize_t> dims(const std::string& name) const {
    MORSE_CHECK(has(name), path_, " has no dataset ", name);
    hid_t ds = H5Dopen2(file_, name.c_str(), H5P_DEFAULT);
    hid_t sp = H5Dget_space(ds);
    std::vector<hsize_t> d(H5Sget_simple_extent_ndims(sp));
    H5Sget_simple_extent_dims(sp, d.data(), nullptr);
    H5Sclose(sp);
    H5Dclose(ds);
    return d;
  }
  template <class T>
  std::vector<T> read(const std::string& name, hid_t type) const {
    auto d = dims(name);
    hsize_t n = 1;
    for (auto x : d) n *= x;
    std::vector<T> v(n);
    hid_t ds = H5Dopen2(file_, name.c_str(), H5P_DEFAULT);
    herr_t st = H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Dclose(ds);
    MORSE_CHECK(st >= 0, "cannot read ", name, " from ", path_);
    return v;
  }
  /// Row j of a [n][rows][cols] dataset.
  std::vector<double> slab(const std::string& name, hsize_t j) const {
    auto d = dims(name);
    hid_t ds = H5Dopen2(file_, name.c_str(), H5P_DEFAULT);
    hid_t sp = H5Dget_space(ds);
    hsize_t start[3] = {j, 0, 0}, count[3] = {1, d[1], d[2]};
    H5Sselect_hyperslab(sp, H5S_SELECT_SET, start, nullptr, count, nullptr);
    hsize_t mcount = d[1] * d[2];
    hid_t ms = H5Screate_simple(1, &mcount, nullptr);
    std::vector<double> v(mcount);
    herr_t st = H5Dread(ds, H5T_NATIVE_DOUBLE, ms, sp, H5P_DEFAULT, v.data());
    H5Sclose(ms);
    H5Sclose(sp);
    H5Dclose(ds);
    MORSE_CHECK(st >= 0, "cannot read ", name, " from ", path_);
    return v;
  }

 private:
  std::string path_;
  hid_t file_ = -1;
};

template <class T>
void bcast(MPI_Comm comm, std::vector<T>& v, MPI_Datatype type) {
  std::uint64_t n = v.size();
  MPI_Bcast(&n, 1, MPI_UINT64_T, 0, comm);
  v.resize(n);
  MPI_Bcast(v.data(), static_cast<int>(n), type, 0, comm);
}

}  // namespace

CBResult load_basis(const fe::Model& md, const std::string& path, const std::string& boundary_set, double damping) {
  MORSE_CHECK(md.mesh, "a superelement basis file (", path, ") needs a mesh model");
  const auto& lm = *md.mesh;
  const auto& dofs = md.dofs;
  MPI_Comm comm = lm.comm;
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  CBResult out;
  set_boundary(md, boundary_set, &out);
  StageTimer t(comm, "LoadBasis");
  std::unique_ptr<Reader> rd;
  std::vector<std::int64_t> ids, bnodes;
  std::vector<double> lambda;
  std::string err;
  // Six-DOF points (rigid and interpolation elements): their DOFs are in <dataset>_points
  // (io::write_modes_dataset), points as /mesh/point_ids.
  const std::vector<std::int64_t>& pids = lm.mesh.constraints.point_ids;
  const bool points = md.constraints && !pids.empty();
  if (rank == 0) try {
      rd = std::make_unique<Reader>(path);
      for (const char* d : {"/cb/constraint_modes", "/cb/fixed_interface/mode_shapes"}) {
        MORSE_CHECK(rd->has(d), path, " has no ", d, ": write it with `morse reduce -cb_write_basis`");
        MORSE_CHECK(!points || rd->has(cat(d, "_points")), path, " has no ", d,
                    "_points (the six-DOF points' DOFs of the basis): make it again with this version of `morse "
                    "reduce -cb_write_basis`");
      }
      ids = rd->read<std::int64_t>("/mesh/node_ids", H5T_NATIVE_INT64);
      bnodes = rd->read<std::int64_t>("/rom/boundary_nodes", H5T_NATIVE_INT64);
      lambda = rd->read<double>("/cb/fixed_interface/eigenvalues", H5T_NATIVE_DOUBLE);
      auto dc = rd->dims("/cb/constraint_modes"), dp = rd->dims("/cb/fixed_interface/mode_shapes");
      MORSE_CHECK(dc.size() == 3 && dp.size() == 3 && dc[1] == ids.size() && dp[1] == ids.size() &&
                      dp[0] == lambda.size() && dc[0] == static_cast<hsize_t>(out.n_b),
                  path, ": inconsistent basis dataset shapes (", dc[0], " constraint modes for ", out.n_b,
                  " boundary DOFs of node set '", boundary_set, "')");
      if (points) {
        MORSE_CHECK(rd->has("/mesh/point_ids") && rd->read<std::int64_t>("/mesh/point_ids", H5T_NATIVE_INT64) == pids,
                    path, " was made with other six-DOF points (/mesh/point_ids)");
        for (const auto& [d, modes] : {std::pair<const char*, hsize_t>{"/cb/constraint_modes_points", dc[0]},
                                       {"/cb/fixed_interface/mode_shapes_points", dp[0]}}) {
          auto dq = rd->dims(d);
          MORSE_CHECK(dq.size() == 3 && dq[0] == modes && dq[1] == pids.size() && dq[2] == 6, path, ": ", d,
                      " must be [", modes, " modes][", pids.size(), " points][6]");
        }
      }
    } catch (const Error& e) {
      err = e.what();
    }
  collective_check(comm, err);
  bcast(comm, ids, MPI_INT64_T);
  bcast(comm, bnodes, MPI_INT64_T);
  bcast(comm, lambda, MPI_DOUBLE);
  // Same mesh (node ids in global order) and same boundary.
  if (static_cast<std::int64_t>(ids.size()) != lm.n_global_nodes)
    err = cat(path, " was made on a mesh with ", ids.size(), " nodes; this mesh has ", lm.n_global_nodes);
  else
    for (std::int64_t k = 0; k < lm.mesh.num_nodes() && err.empty(); ++k)
      if (ids[lm.global_node[k]] != lm.mesh.node_ids[k])
        err = cat(path, " was made on another mesh (node ", lm.mesh.node_ids[k], " differs)");
  if (err.empty() && bnodes != out.boundary_node_ids)
    err = cat(path, ": its boundary nodes differ from node set '", boundary_set, "'");
  collective_check(comm, err);

  out.fixed_omega2 = lambda;
  out.n_phi = static_cast<PetscInt>(lambda.size());
  const PetscInt nr = out.n();
  MORSE_CALL(MatCreateDense(comm, dofs.n_owned, PETSC_DECIDE, dofs.n_global, nr, nullptr, out.T.ptr()));
  PetscScalar* tt;
  PetscInt ldt;
  MORSE_CALL(MatDenseGetLDA(out.T.get(), &ldt));
  MORSE_CALL(MatDenseGetArrayWrite(out.T.get(), &tt));
  const std::vector<std::int64_t> point_slot = fe::point_dof_slots(md);  // owned row -> 6 p + c - 1, or -1
  Progress progress(comm, "loading the basis", static_cast<double>(nr));
  for (PetscInt j = 0; j < nr; ++j) {
    std::vector<double> field;
    if (rank == 0)
      field =
          j < out.n_b ? rd->slab("/cb/constraint_modes", j) : rd->slab("/cb/fixed_interface/mode_shapes", j - out.n_b);
    bcast(comm, field, MPI_DOUBLE);
    for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k) {
      if (lm.node_owner[k] != rank) continue;
      for (int d = 0; d < 3; ++d) {
        PetscInt g = dofs.node_dof[3 * k + d];
        if (g >= 0) tt[(g - dofs.first) + static_cast<std::size_t>(ldt) * j] = field[3 * lm.global_node[k] + d];
      }
    }
    // The points' DOFs: rank 0's rows labelled with a point id (independent node DOFs are the
    // expanded field's values there, u = T u_bar being the identity on them).
    if (points && rank == 0) {
      const auto pv = j < out.n_b ? rd->slab("/cb/constraint_modes_points", j)
                                  : rd->slab("/cb/fixed_interface/mode_shapes_points", j - out.n_b);
      for (std::size_t i = 0; i < point_slot.size(); ++i)
        if (point_slot[i] >= 0) tt[i + static_cast<std::size_t>(ldt) * j] = pv[static_cast<std::size_t>(point_slot[i])];
    }
    progress.update(static_cast<double>(j + 1));
  }
  MORSE_CALL(MatDenseRestoreArrayWrite(out.T.get(), &tt));
  MORSE_CALL(MatAssemblyBegin(out.T.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(out.T.get(), MAT_FINAL_ASSEMBLY));
  project(comm, md.K.get(), md.M.get(), damping, &out);
  return out;
}

}  // namespace morse::cb
