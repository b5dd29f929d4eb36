#include "morse/cb/craig_bampton.hpp"

#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"
#include "morse/core/log.hpp"
#include "morse/core/units.hpp"
#include "morse/eigen/eigen.hpp"

namespace morse::cb {

namespace {

struct BoundaryNode {
  std::int64_t id;
  std::int64_t global;
};

// The nodes of a mesh's boundary set on every rank, sorted by id (owned copies gathered), after
// the mesh's own checks: the set exists and is not empty, and no DOF of its nodes is clamped.
std::vector<BoundaryNode> mesh_boundary_nodes(const mesh::LocalMesh& lm, const fe::DofLayout& dofs,
                                              const std::string& set) {
  const auto& m = lm.mesh;
  std::string err = mesh::check_node_set(lm, set, "boundary node set");
  collective_check(lm.comm, err);
  auto it = m.node_sets.find(set);
  int rank = 0, size = 1;
  MPI_Comm_rank(lm.comm, &rank);
  MPI_Comm_size(lm.comm, &size);
  std::vector<BoundaryNode> mine;
  for (auto k : it->second) {
    if (lm.node_owner[k] != rank) continue;
    for (int d = 0; d < 3; ++d)
      if (dofs.node_dof[3 * k + d] < 0 && err.empty())
        err = cat("node ", m.node_ids[k], " of boundary set '", set, "' has a clamped DOF (direction ", "xyz"[d],
                  "), or one made dependent by a rigid or interpolation element or an MPC; a boundary node cannot be "
                  "clamped or dependent");
    mine.push_back({m.node_ids[k], lm.global_node[k]});
  }
  collective_check(lm.comm, err);
  int n = static_cast<int>(mine.size() * sizeof(BoundaryNode));
  std::vector<int> counts(size), displs(size, 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, lm.comm);
  for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
  std::vector<BoundaryNode> all((displs[size - 1] + counts[size - 1]) / sizeof(BoundaryNode));
  MPI_Allgatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, lm.comm);
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  return all;
}

}  // namespace

std::vector<double> transpose_product(MPI_Comm comm, Mat A, Mat B) {
  PetscInt m = 0, na = 0, nb = 0, lda = 0, ldb = 0;
  MORSE_CALL(MatGetLocalSize(A, &m, nullptr));
  MORSE_CALL(MatGetSize(A, nullptr, &na));
  MORSE_CALL(MatGetSize(B, nullptr, &nb));
  MORSE_CALL(MatDenseGetLDA(A, &lda));
  MORSE_CALL(MatDenseGetLDA(B, &ldb));
  const PetscScalar *a, *b;
  MORSE_CALL(MatDenseGetArrayRead(A, &a));
  MORSE_CALL(MatDenseGetArrayRead(B, &b));
  std::vector<double> c(static_cast<std::size_t>(na) * nb, 0.0);  // column-major na x nb
  if (m > 0) {
    PetscBLASInt M_ = static_cast<PetscBLASInt>(na), N_ = static_cast<PetscBLASInt>(nb),
                 K_ = static_cast<PetscBLASInt>(m), LDA = static_cast<PetscBLASInt>(lda),
                 LDB = static_cast<PetscBLASInt>(ldb), LDC = M_;
    double one = 1.0, zero = 0.0;
    BLASgemm_("T", "N", &M_, &N_, &K_, &one, a, &LDA, b, &LDB, &zero, c.data(), &LDC);
  }
  MORSE_CALL(MatDenseRestoreArrayRead(A, &a));
  MORSE_CALL(MatDenseRestoreArrayRead(B, &b));
  MPI_Allreduce(MPI_IN_PLACE, c.data(), static_cast<int>(c.size()), MPI_DOUBLE, MPI_SUM, comm);
  std::vector<double> r(c.size());
  for (PetscInt i = 0; i < na; ++i)
    for (PetscInt j = 0; j < nb; ++j) r[i * nb + j] = c[j * na + i];
  return r;
}

namespace {

void symmetrize(std::vector<double>& A, PetscInt n) {
  for (PetscInt i = 0; i < n; ++i)
    for (PetscInt j = i + 1; j < n; ++j) {
      double v = 0.5 * (A[i * n + j] + A[j * n + i]);
      A[i * n + j] = A[j * n + i] = v;
    }
}

}  // namespace

UVec sign_reference(const fe::Model& md) {
  const auto& dofs = md.dofs;
  UVec w;
  MORSE_CALL(VecCreateMPI(dofs.comm, dofs.n_owned, dofs.n_global, w.ptr()));
  PetscScalar* a;
  MORSE_CALL(VecGetArray(w.get(), &a));
  if (md.mesh) {
    const auto& lm = *md.mesh;
    int rank = 0;
    MPI_Comm_rank(lm.comm, &rank);
    for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k) {
      if (lm.node_owner[k] != rank) continue;
      for (int d = 0; d < 3; ++d) {
        PetscInt g = dofs.node_dof[3 * k + d];
        if (g < 0) continue;
        // A fixed, irregular positive weight (golden-ratio sequence) per (node, direction).
        double x = std::fmod(0.6180339887498949 * static_cast<double>(3 * lm.global_node[k] + d + 1), 1.0);
        a[g - dofs.first] = 0.5 + x;
      }
    }
  } else {
    for (PetscInt r = 0; r < dofs.n_owned; ++r)
      a[r] = 0.5 + std::fmod(0.6180339887498949 * static_cast<double>(dofs.first + r + 1), 1.0);
  }
  MORSE_CALL(VecRestoreArray(w.get(), &a));
  return w;
}

void set_boundary(const fe::Model& md, const std::string& set, CBResult* out) {
  collective_check(md.dofs.comm, set.empty() ? "no boundary set given (-boundary SET)" : "");
  out->boundary_global_nodes.clear();
  if (md.mesh)
    for (const auto& b : mesh_boundary_nodes(*md.mesh, md.dofs, set)) out->boundary_global_nodes.push_back(b.global);
  const auto rows = fe::set_rows(md.dofs, set, "boundary set");
  out->n_b = static_cast<PetscInt>(rows.size());
  out->boundary_node_ids.clear();
  out->boundary_dofs.clear();
  out->boundary_dof_node.clear();
  out->boundary_dof_component.clear();
  for (const auto& r : rows) {
    out->boundary_dofs.push_back(r.row);
    out->boundary_dof_node.push_back(r.node);
    out->boundary_dof_component.push_back(r.component);
    if (out->boundary_node_ids.empty() || out->boundary_node_ids.back() != r.node)
      out->boundary_node_ids.push_back(r.node);
  }
}

std::vector<double> project_symmetric(MPI_Comm comm, Mat A, Mat T) {
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(T, nullptr, &n));
  UMat AT;
  MORSE_CALL(MatMatMult(A, T, MAT_INITIAL_MATRIX, PETSC_DEFAULT, AT.ptr()));
  auto R = transpose_product(comm, T, AT.get());
  symmetrize(R, n);
  return R;
}

void project(MPI_Comm comm, Mat K, Mat M, double damping, CBResult* out) {
  const PetscInt nr = out->n();
  out->K = project_symmetric(comm, K, out->T.get());
  out->M = project_symmetric(comm, M, out->T.get());
  out->C.assign(static_cast<std::size_t>(nr) * nr, 0.0);
  for (PetscInt j = 0; j < out->n_phi; ++j) {
    PetscInt q = out->n_b + j;
    out->C[q * nr + q] = 2.0 * damping * std::sqrt(std::max(0.0, out->fixed_omega2[j]));
  }
}

namespace {

// The Craig-Bampton core on the free-DOF operators K and M (same row layout), with the boundary
// layout of out (set_boundary) and the sign-reference vector w. Collective.
CBResult craig_bampton(Mat K, Mat M, Vec w, const CBSettings& s, CBResult out) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  fe::DofLayout dofs;  // the row layout of K
  {
    PetscInt rend = 0;
    MORSE_CALL(MatGetOwnershipRange(K, &dofs.first, &rend));
    MORSE_CALL(MatGetSize(K, &dofs.n_global, nullptr));
    dofs.n_owned = rend - dofs.first;
  }
  MORSE_CHECK(static_cast<PetscInt>(out.boundary_dofs.size()) == out.n_b && out.n_b > 0,
              "craig_bampton: the boundary layout is empty or inconsistent");
  std::unordered_map<PetscInt, PetscInt> pos;  // global DOF -> boundary position
  for (PetscInt j = 0; j < out.n_b; ++j) pos[out.boundary_dofs[j]] = j;
  // Interior / boundary index sets of the owned rows, ascending.
  std::vector<PetscInt> ib, ii;
  for (PetscInt g = dofs.first; g < dofs.first + dofs.n_owned; ++g) (pos.count(g) ? ib : ii).push_back(g);
  UIS is_b, is_i;
  MORSE_CALL(ISCreateGeneral(comm, static_cast<PetscInt>(ib.size()), ib.data(), PETSC_COPY_VALUES, is_b.ptr()));
  MORSE_CALL(ISCreateGeneral(comm, static_cast<PetscInt>(ii.size()), ii.data(), PETSC_COPY_VALUES, is_i.ptr()));
  const PetscInt n_i = dofs.n_global - out.n_b;
  MORSE_CHECK(n_i > 0, "the boundary set '", s.boundary_set, "' holds every free DOF: no interior left");

  UMat Kii, Mii, Kib;
  MORSE_CALL(MatCreateSubMatrix(K, is_i.get(), is_i.get(), MAT_INITIAL_MATRIX, Kii.ptr()));
  MORSE_CALL(MatCreateSubMatrix(M, is_i.get(), is_i.get(), MAT_INITIAL_MATRIX, Mii.ptr()));
  MORSE_CALL(MatCreateSubMatrix(K, is_i.get(), is_b.get(), MAT_INITIAL_MATRIX, Kib.ptr()));
  for (Mat A : {Kii.get(), Mii.get()}) {
    MORSE_CALL(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
    MORSE_CALL(MatSetOption(A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
  }

  // Column j of K_ib is the j-th boundary DOF of the concatenated is_b.
  std::vector<PetscInt> col_pos(out.n_b);
  {
    int size = 1;
    MPI_Comm_size(comm, &size);
    int n = static_cast<int>(ib.size());
    std::vector<int> counts(size), displs(size, 0);
    MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
    for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    std::vector<PetscInt> cols(out.n_b);
    MPI_Allgatherv(ib.data(), n, MPIU_INT, cols.data(), counts.data(), displs.data(), MPIU_INT, comm);
    for (PetscInt j = 0; j < out.n_b; ++j) col_pos[j] = pos.at(cols[j]);
  }

  // Fixed-interface modes (eq. 4).
  eigen::Eigenpairs eig;
  const bool want_modes = s.fmax_hz > 0 || s.n_fixed > 0;
  if (want_modes) {
    MORSE_CHECK(s.fmax_hz > 0 || s.n_fixed <= n_i, s.n_fixed,
                " fixed-interface modes requested but the model has only ", n_i, " interior DOFs");
    Vec wi;
    MORSE_CALL(VecGetSubVector(w, is_i.get(), &wi));
    eigen::EigenSettings es;
    es.prefix = s.prefix;
    es.what = "fixed-interface modes";
    es.allow_singular = false;  // K_ii must be regular: its factor gives the constraint modes
    if (s.fmax_hz > 0)
      es.omega2_max = omega2_of_hz(s.fmax_hz);
    else
      es.nev = s.n_fixed;
    eig = eigen::solve_eigen(Kii.get(), Mii.get(), es, wi);
    MORSE_CALL(VecRestoreSubVector(w, is_i.get(), &wi));
    out.fixed_omega2 = eig.omega2;
    out.factor_seconds = eig.factor_seconds;
  }
  out.n_phi = static_cast<PetscInt>(out.fixed_omega2.size());

  // Constraint modes (eq. 3): one factorization, one block solve.
  UMat Psi;
  {
    StageTimer t(comm, "ConstraintModes");
    UMat own_factor;
    Mat F = want_modes && eig.shift == 0.0 ? eig.factor() : nullptr;  // K_ii's own factor only
    out.factor_reused = F != nullptr;
    if (!F) {
      auto t0 = std::chrono::steady_clock::now();
      MORSE_CALL(MatGetFactor(Kii.get(), cholesky_solver(Kii.get()), MAT_FACTOR_CHOLESKY, own_factor.ptr()));
      F = own_factor.get();
      MORSE_CALL(MatMumpsSetIcntl(F, 24, 1));
      MatFactorInfo info;
      MORSE_CALL(MatFactorInfoInitialize(&info));
      MORSE_CALL(MatCholeskyFactorSymbolic(F, Kii.get(), nullptr, &info));
      MORSE_CALL(MatCholeskyFactorNumeric(F, Kii.get(), &info));
      PetscInt nulls = eigen::mumps_null_pivots(F);
      MORSE_CHECK(nulls == 0, "K_ii is singular (", nulls,
                  " null pivots): the model with its boundary set clamped is not restrained; "
                  "check -clamp and -boundary");
      out.factor_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    UMat B;
    MORSE_CALL(MatConvert(Kib.get(), MATDENSE, MAT_INITIAL_MATRIX, B.ptr()));
    MORSE_CALL(MatScale(B.get(), -1.0));
    MORSE_CALL(MatDuplicate(B.get(), MAT_DO_NOT_COPY_VALUES, Psi.ptr()));
    MORSE_CALL(MatMatSolve(F, B.get(), Psi.get()));
  }

  // Basis T on the free DOFs (eq. 5), reduced operators (eq. 6).
  StageTimer t(comm, "Project");
  const PetscInt nr = out.n();
  MORSE_CALL(MatCreateDense(comm, dofs.n_owned, PETSC_DECIDE, dofs.n_global, nr, nullptr, out.T.ptr()));
  {
    PetscScalar* tt;
    PetscInt ldt = 0, ldp = 0, ldv = 0;
    MORSE_CALL(MatDenseGetLDA(out.T.get(), &ldt));
    MORSE_CALL(MatDenseGetArrayWrite(out.T.get(), &tt));
    std::fill(tt, tt + static_cast<std::size_t>(ldt) * nr, 0.0);
    const PetscScalar *psi, *phi = nullptr;
    MORSE_CALL(MatDenseGetLDA(Psi.get(), &ldp));
    MORSE_CALL(MatDenseGetArrayRead(Psi.get(), &psi));
    if (out.n_phi) {
      MORSE_CALL(MatDenseGetLDA(eig.V.get(), &ldv));
      MORSE_CALL(MatDenseGetArrayRead(eig.V.get(), &phi));
    }
    for (auto g : ib) tt[(g - dofs.first) + static_cast<std::size_t>(ldt) * pos.at(g)] = 1.0;
    for (std::size_t r = 0; r < ii.size(); ++r) {
      const std::size_t l = ii[r] - dofs.first;
      for (PetscInt j = 0; j < out.n_b; ++j)
        tt[l + static_cast<std::size_t>(ldt) * col_pos[j]] = psi[r + static_cast<std::size_t>(ldp) * j];
      for (PetscInt j = 0; j < out.n_phi; ++j)
        tt[l + static_cast<std::size_t>(ldt) * (out.n_b + j)] = phi[r + static_cast<std::size_t>(ldv) * j];
    }
    MORSE_CALL(MatDenseRestoreArrayRead(Psi.get(), &psi));
    if (out.n_phi) MORSE_CALL(MatDenseRestoreArrayRead(eig.V.get(), &phi));
    MORSE_CALL(MatDenseRestoreArrayWrite(out.T.get(), &tt));
  }
  project(comm, K, M, s.damping, &out);
  if (!s.keep_basis) out.T.reset();
  return out;
}

}  // namespace

CBResult craig_bampton(const fe::Model& md, const CBSettings& s) {
  CBResult out;
  set_boundary(md, s.boundary_set, &out);
  UVec w = sign_reference(md);
  return craig_bampton(md.K.get(), md.M.get(), w.get(), s, std::move(out));
}

}  // namespace morse::cb
