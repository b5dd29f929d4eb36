// A model given by its assembled operators (io/matrix_model.hpp): K, M and C read in one of the
// matrix formats of io/matrices.hpp, checked for symmetry, labelled by the DOF map, clamped.
#include "morse/io/matrix_model.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/io/matrices.hpp"

namespace morse::io {

namespace {

/// Largest |entry| of A and where it is (global row, column), on every rank. Collective.
struct MaxEntry {
  double value = 0;
  PetscInt i = -1, j = -1;
};
MaxEntry max_entry(Mat A) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(A));
  PetscInt rs = 0, re = 0;
  MORSE_CALL(MatGetOwnershipRange(A, &rs, &re));
  MaxEntry me;
  for (PetscInt i = rs; i < re; ++i) {
    PetscInt nc;
    const PetscInt* cols;
    const PetscScalar* vals;
    MORSE_CALL(MatGetRow(A, i, &nc, &cols, &vals));
    for (PetscInt k = 0; k < nc; ++k)
      if (std::abs(vals[k]) > me.value) me = {std::abs(vals[k]), i, cols[k]};
    MORSE_CALL(MatRestoreRow(A, i, &nc, &cols, &vals));
  }
  int size = 1;
  MPI_Comm_size(comm, &size);
  std::vector<MaxEntry> all(size);
  MPI_Allgather(&me, sizeof me, MPI_BYTE, all.data(), sizeof me, MPI_BYTE, comm);
  for (const auto& e : all)
    if (e.value > me.value || (e.value == me.value && e.i >= 0 && (me.i < 0 || e.i < me.i))) me = e;
  return me;
}

// Row label for messages (rank 0, which holds the DOF map).
std::string label(const DofMapFile& map, PetscInt row) {
  return cat(row + 1, " (node ", map.node[row], " component ", map.component[row], ")");
}

/// Measures max |A - A^T| / max |A|; above tol it is an error naming the worst entry, else A is
/// replaced by (A + A^T) / 2. Returns the measure. Collective.
double symmetrize(UMat* A, double tol, const std::string& what, const DofMapFile& map) {
  UMat At, D;
  MORSE_CALL(MatTranspose(A->get(), MAT_INITIAL_MATRIX, At.ptr()));
  MORSE_CALL(MatDuplicate(A->get(), MAT_COPY_VALUES, D.ptr()));
  MORSE_CALL(MatAXPY(D.get(), -1.0, At.get(), DIFFERENT_NONZERO_PATTERN));
  const MaxEntry a = max_entry(A->get()), d = max_entry(D.get());
  const double rel = a.value > 0 ? d.value / a.value : 0.0;
  std::string err;
  if (a.value == 0) err = cat(what, " is zero");
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(A->get()));
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rel > tol && rank != 0) err = "not symmetric";  // rank 0 holds the DOF map and says where
  if (rel > tol && rank == 0) {
    err = cat(what, " is not symmetric: |A(i,j) - A(j,i)| = ", d.value, " = ", rel, " x max|A| (tolerance ", tol,
              ", -matrices_symmetry_tol) at row ", label(map, d.i), ", column ", label(map, d.j));
  }
  collective_check(comm, err);
  if (d.value > 0) {
    MORSE_CALL(MatAXPY(A->get(), 1.0, At.get(), DIFFERENT_NONZERO_PATTERN));
    MORSE_CALL(MatScale(A->get(), 0.5));
  }
  MORSE_CALL(MatSetOption(A->get(), MAT_SYMMETRIC, PETSC_TRUE));
  MORSE_CALL(MatSetOption(A->get(), MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
  return rel;
}

}  // namespace

fe::Model matrix_model(MPI_Comm comm, const MatrixInput& in) {
  MORSE_CHECK(!in.K.empty() && !in.M.empty(), "give both -matrices_K and -matrices_M");
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  fe::Model md;
  auto& dofs = md.dofs;
  dofs.comm = comm;
  md.source = in.K;
  md.units = in.units.empty() ? "unknown" : in.units;
  UMat K = read_matrix(comm, in.K, "-matrices_K"), M = read_matrix(comm, in.M, "-matrices_M"), C;
  PetscInt n = 0, nm = 0, nc = 0;
  MORSE_CALL(MatGetSize(K.get(), &n, nullptr));
  MORSE_CALL(MatGetSize(M.get(), &nm, nullptr));
  MORSE_CHECK(n == nm, "size mismatch: -matrices_K ", in.K, " is ", n, " x ", n, " but -matrices_M ", in.M, " is ", nm,
              " x ", nm);
  if (!in.C.empty()) {
    C = read_matrix(comm, in.C, "-matrices_C");
    MORSE_CALL(MatGetSize(C.get(), &nc, nullptr));
    MORSE_CHECK(n == nc, "size mismatch: -matrices_K ", in.K, " is ", n, " x ", n, " but -matrices_C ", in.C, " is ",
                nc, " x ", nc);
  }

  // DOF map: read on rank 0 (kept there for messages), labels scattered, sets broadcast.
  DofMapFile map;
  std::string err;
  if (rank == 0) try {
      if (!in.dofmap.empty()) {
        map = read_dof_map(in.dofmap, n);
      } else {
        for (PetscInt r = 0; r < n; ++r) {
          map.node.push_back(r / 3 + 1);
          map.component.push_back(r % 3 + 1);
        }
      }
    } catch (const Error& e) {
      err = e.what();
    }
  collective_check(comm, err);
  md.asymmetry_K = symmetrize(&K, in.symmetry_tol, cat("-matrices_K ", in.K), map);
  md.asymmetry_M = symmetrize(&M, in.symmetry_tol, cat("-matrices_M ", in.M), map);
  if (C) symmetrize(&C, in.symmetry_tol, cat("-matrices_C ", in.C), map);

  PetscInt rs = 0, re = 0;
  MORSE_CALL(MatGetOwnershipRange(K.get(), &rs, &re));
  std::vector<std::int64_t> node(re - rs), comp(re - rs);
  {
    std::vector<int> counts(size), displs(size, 0);
    int m = static_cast<int>(re - rs);
    MPI_Gather(&m, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
    for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    std::vector<std::int64_t> comp_all(map.component.begin(), map.component.end());
    MPI_Scatterv(map.node.data(), counts.data(), displs.data(), MPI_INT64_T, node.data(), m, MPI_INT64_T, 0, comm);
    MPI_Scatterv(comp_all.data(), counts.data(), displs.data(), MPI_INT64_T, comp.data(), m, MPI_INT64_T, 0, comm);
  }
  // Row sets of the file, then node sets of the command line.
  std::map<std::string, std::vector<PetscInt>> sets;
  {
    std::vector<char> packed;
    std::int64_t bytes = 0;
    if (rank == 0) {
      std::ostringstream os;
      for (const auto& [name, rows] : map.sets) {
        os << name << ' ' << rows.size();
        for (auto r : rows) os << ' ' << r;
        os << '\n';
      }
      auto s = os.str();
      packed.assign(s.begin(), s.end());
      bytes = static_cast<std::int64_t>(packed.size());
    }
    MPI_Bcast(&bytes, 1, MPI_INT64_T, 0, comm);
    packed.resize(bytes);
    MPI_Bcast(packed.data(), static_cast<int>(bytes), MPI_CHAR, 0, comm);
    std::istringstream is(std::string(packed.begin(), packed.end()));
    std::string name;
    std::size_t count = 0;
    while (is >> name >> count) {
      auto& v = sets[name];
      v.resize(count);
      for (auto& r : v) is >> r;
    }
  }
  for (const auto& [name, ids] : in.node_sets) {
    MORSE_CHECK(!sets.count(name), "-mesh_node_set_", name, ": the DOF map already defines set '", name, "'");
    std::vector<std::int64_t> sorted(ids.begin(), ids.end());
    std::sort(sorted.begin(), sorted.end());
    std::vector<int> found(sorted.size(), 0), found_all(sorted.size(), 0);
    std::vector<PetscInt> mine;
    for (PetscInt r = rs; r < re; ++r) {
      auto it = std::lower_bound(sorted.begin(), sorted.end(), node[r - rs]);
      if (it != sorted.end() && *it == node[r - rs]) {
        mine.push_back(r);
        found[it - sorted.begin()] = 1;
      }
    }
    MPI_Allreduce(found.data(), found_all.data(), static_cast<int>(found.size()), MPI_INT, MPI_MAX, comm);
    for (std::size_t k = 0; k < sorted.size(); ++k)
      MORSE_CHECK(found_all[k], "-mesh_node_set_", name, ": node ", sorted[k], " has no row in the matrices (",
                  in.dofmap.empty() ? "no DOF map: rows are nodes 1.., 3 per node" : "DOF map " + in.dofmap, ")");
    int cnt = static_cast<int>(mine.size());
    std::vector<int> counts(size), displs(size, 0);
    MPI_Allgather(&cnt, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
    for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    auto& v = sets[name];
    v.resize(displs[size - 1] + counts[size - 1]);
    MPI_Allgatherv(mine.data(), cnt, MPIU_INT, v.data(), counts.data(), displs.data(), MPIU_INT, comm);
  }

  // Clamp: remove the rows of the named sets.
  std::vector<PetscInt> clamped;
  for (const auto& name : in.clamp) {
    auto it = sets.find(name);
    if (it == sets.end()) {
      std::string list;
      for (const auto& [s, rows] : sets) list += (list.empty() ? "" : ", ") + s;
      throw Error(cat("-clamp ", name, ": no such row set in the DOF map or -mesh_node_set_ options (sets: ",
                      list.empty() ? "none" : list, ")"));
    }
    clamped.insert(clamped.end(), it->second.begin(), it->second.end());
  }
  std::sort(clamped.begin(), clamped.end());
  clamped.erase(std::unique(clamped.begin(), clamped.end()), clamped.end());
  auto new_row = [&](PetscInt r) {
    return r - static_cast<PetscInt>(std::lower_bound(clamped.begin(), clamped.end(), r) - clamped.begin());
  };
  auto is_clamped = [&](PetscInt r) { return std::binary_search(clamped.begin(), clamped.end(), r); };
  if (clamped.empty()) {
    md.K = std::move(K), md.M = std::move(M), md.C = std::move(C);
    dofs.node = std::move(node);
    dofs.component.assign(comp.begin(), comp.end());
  } else {
    std::vector<PetscInt> keep;
    for (PetscInt r = rs; r < re; ++r)
      if (!is_clamped(r)) {
        keep.push_back(r);
        dofs.node.push_back(node[r - rs]);
        dofs.component.push_back(static_cast<int>(comp[r - rs]));
      }
    UIS is;
    MORSE_CALL(ISCreateGeneral(comm, static_cast<PetscInt>(keep.size()), keep.data(), PETSC_COPY_VALUES, is.ptr()));
    MORSE_CALL(MatCreateSubMatrix(K.get(), is.get(), is.get(), MAT_INITIAL_MATRIX, md.K.ptr()));
    MORSE_CALL(MatCreateSubMatrix(M.get(), is.get(), is.get(), MAT_INITIAL_MATRIX, md.M.ptr()));
    if (C) MORSE_CALL(MatCreateSubMatrix(C.get(), is.get(), is.get(), MAT_INITIAL_MATRIX, md.C.ptr()));
    for (Mat A : {md.K.get(), md.M.get(), md.C.get()}) {
      if (!A) continue;
      MORSE_CALL(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
      MORSE_CALL(MatSetOption(A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
    }
  }
  PetscInt e = 0;
  MORSE_CALL(MatGetOwnershipRange(md.K.get(), &dofs.first, &e));
  MORSE_CALL(MatGetSize(md.K.get(), &dofs.n_global, nullptr));
  dofs.n_owned = e - dofs.first;
  dofs.n_clamped_global = n - dofs.n_global;
  // Row sets in the free numbering, owned rows only.
  for (auto& [name, rows] : sets) {
    std::vector<PetscInt> v;
    for (auto r : rows)
      if (!is_clamped(r))
        if (PetscInt f = new_row(r); f >= dofs.first && f < e) v.push_back(f);
    std::sort(v.begin(), v.end());
    dofs.sets[name] = std::move(v);
  }
  MORSE_CHECK(dofs.n_global > 0, "-clamp removes every row of the matrices");
  return md;
}

std::vector<std::string> model_matrix_files(const std::string& prefix, const std::string& format) {
  const std::string ext = format == "mtx" ? ".mtx" : ".petsc";
  return {prefix + "_K" + ext, prefix + "_M" + ext, prefix + "_dofmap.txt"};
}

void write_model_matrices(MPI_Comm comm, const fe::Model& md, const std::string& prefix, const std::string& format) {
  const auto names = model_matrix_files(prefix, format);
  write_matrix(md.K.get(), names[0], true);
  write_matrix(md.M.get(), names[1], true);
  auto map = mesh_dof_map(*md.mesh, md.dofs);
  std::string err;
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0) try {
      write_dof_map(names[2], map);
    } catch (const std::exception& e) {
      err = message_of(e);
    }
  collective_check(comm, err);
}

}  // namespace morse::io
