// bench/mumps_repeat.cpp: are MUMPS's factorization and solves bitwise repeatable from run to run?
// (issue 26 item 8). Built and driven by bench/mumps_repeat.sh; uses only the public library API.
//
//     mpirun -n 2 ./mumps_repeat -mesh meshes/blade.msh -clamp root [-sigmas 0,1e7] [-nrhs 16] [-nrep 8]
//                                [-dump DIR] [any -mat_mumps_icntl_* / -mat_mumps_cntl_* option]
//
// Assembles K and M of the mesh (fe::mesh_model, clamping the node set -clamp), fills x with
// sin(0.37 i + 1) and a dense B (n x nrhs) with cos(0.11 i (j + 1) + j), then for every sigma
// factors A = K - sigma M with MUMPS Cholesky (PETSc's MATSOLVERMUMPS, LDL^T for an indefinite A)
// and solves A y = x -nrep times (default 8; MatSolve) and A X = B twice (MatMatSolve). Prints one
// JSON line on rank 0: an FNV-1a hash of the bits of K x, M x, and per sigma of y (first solve), of
// y (second solve) and of X (first MatMatSolve), each hash as "h_rank0.h_rank1..." (each rank
// hashes its owned rows); the number of distinct y among the nrep solves and of X among the two
// MatMatSolves of the run (solve_in_run_distinct, matmatsolve_in_run_distinct); plus a few MUMPS
// INFOG values (3: estimated factor entries, 5: largest front, 29: factor entries, 9 and 10 real
// and integer workspace); with -mat_mumps_icntl_33 1 also the determinant's mantissa (hex) and
// exponent (RINFOG(12), INFOG(34)), a fingerprint of the factor's pivots. With -dump DIR, rank 0
// also writes K x, M x, every first y and every column of the last X as PETSc binary vectors to
// DIR/vecs.bin (in that order), for the driver's max-difference figure.
#include <petscsys.h>
#include <petscmat.h>
#include <petscviewer.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "morse/core/factor.hpp"
#include "morse/core/session.hpp"
#include "morse/fe/model.hpp"

namespace {

#define CHK(call) PetscCallAbort(PETSC_COMM_WORLD, call)

std::uint64_t fnv(const PetscScalar* a, PetscInt n, std::uint64_t h = 1469598103934665603ull) {
  for (PetscInt i = 0; i < n; ++i) {
    std::uint64_t b;
    std::memcpy(&b, &a[i], sizeof b);
    h = (h ^ b) * 1099511628211ull;
  }
  return h;
}

// "h_rank0.h_rank1..." on rank 0 (empty elsewhere).
std::string gather_hash(MPI_Comm comm, std::uint64_t h) {
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  std::vector<std::uint64_t> all(size);
  MPI_Gather(&h, 1, MPI_UINT64_T, all.data(), 1, MPI_UINT64_T, 0, comm);
  std::string s;
  char buf[24];
  for (int r = 0; rank == 0 && r < size; ++r) {
    std::snprintf(buf, sizeof buf, "%s%016llx", r ? "." : "", (unsigned long long)all[r]);
    s += buf;
  }
  return s;
}

std::string vec_hash(Vec v) {
  const PetscScalar* a;
  PetscInt n;
  CHK(VecGetLocalSize(v, &n));
  CHK(VecGetArrayRead(v, &a));
  const std::uint64_t h = fnv(a, n);
  CHK(VecRestoreArrayRead(v, &a));
  return gather_hash(PetscObjectComm((PetscObject)v), h);
}

std::string dense_hash(Mat X) {
  const PetscScalar* a;
  PetscInt m, n, lda;
  CHK(MatGetLocalSize(X, &m, nullptr));
  CHK(MatGetSize(X, nullptr, &n));
  CHK(MatDenseGetLDA(X, &lda));
  CHK(MatDenseGetArrayRead(X, &a));
  std::uint64_t h = 1469598103934665603ull;
  for (PetscInt j = 0; j < n; ++j) h = fnv(a + j * lda, m, h);
  CHK(MatDenseRestoreArrayRead(X, &a));
  return gather_hash(PetscObjectComm((PetscObject)X), h);
}

void run(MPI_Comm comm) {
  char mesh[PETSC_MAX_PATH_LEN] = "meshes/blade.msh", clamp[256] = "root", dump[PETSC_MAX_PATH_LEN] = "";
  PetscReal sigmas[16] = {0.0, 1e7};
  PetscInt nsig = 16, nrhs = 16, nrep = 8;
  PetscBool has_sig = PETSC_FALSE, has_dump = PETSC_FALSE;
  CHK(PetscOptionsGetString(nullptr, nullptr, "-mesh", mesh, sizeof mesh, nullptr));
  CHK(PetscOptionsGetString(nullptr, nullptr, "-clamp", clamp, sizeof clamp, nullptr));
  CHK(PetscOptionsGetString(nullptr, nullptr, "-dump", dump, sizeof dump, &has_dump));
  CHK(PetscOptionsGetRealArray(nullptr, nullptr, "-sigmas", sigmas, &nsig, &has_sig));
  if (!has_sig) nsig = 2;
  CHK(PetscOptionsGetInt(nullptr, nullptr, "-nrhs", &nrhs, nullptr));
  CHK(PetscOptionsGetInt(nullptr, nullptr, "-nrep", &nrep, nullptr));

  morse::fe::MeshInput in;
  in.path = mesh;
  in.clamp = {clamp};
  in.material = {"steel", 210e9, 0.3, 7850.0};  // only for elements without a material
  morse::fe::Model md = morse::fe::mesh_model(comm, in);
  Mat K = md.K.get(), M = md.M.get();

  Vec x, y;
  CHK(MatCreateVecs(K, &x, &y));
  PetscInt lo, hi, n;
  CHK(VecGetOwnershipRange(x, &lo, &hi));
  CHK(VecGetSize(x, &n));
  for (PetscInt i = lo; i < hi; ++i) CHK(VecSetValue(x, i, std::sin(0.37 * i + 1.0), INSERT_VALUES));
  CHK(VecAssemblyBegin(x));
  CHK(VecAssemblyEnd(x));
  Mat B, X;
  CHK(MatCreateDense(comm, hi - lo, PETSC_DECIDE, PETSC_DETERMINE, nrhs, nullptr, &B));
  for (PetscInt j = 0; j < nrhs; ++j)
    for (PetscInt i = lo; i < hi; ++i) CHK(MatSetValue(B, i, j, std::cos(0.11 * i * (j + 1) + j), INSERT_VALUES));
  CHK(MatAssemblyBegin(B, MAT_FINAL_ASSEMBLY));
  CHK(MatAssemblyEnd(B, MAT_FINAL_ASSEMBLY));
  CHK(MatDuplicate(B, MAT_DO_NOT_COPY_VALUES, &X));

  PetscViewer dv = nullptr;
  if (has_dump) {
    const std::string file = std::string(dump) + "/vecs.bin";
    CHK(PetscViewerBinaryOpen(comm, file.c_str(), FILE_MODE_WRITE, &dv));
    CHK(PetscViewerBinarySetSkipInfo(dv, PETSC_TRUE));
  }
  int size;
  MPI_Comm_size(comm, &size);
  std::string out = "{\"ranks\": " + std::to_string(size) + ", \"n\": " + std::to_string(n);
  CHK(MatMult(K, x, y));
  out += ", \"Kx\": \"" + vec_hash(y) + "\"";
  if (dv) CHK(VecView(y, dv));
  CHK(MatMult(M, x, y));
  out += ", \"Mx\": \"" + vec_hash(y) + "\"";
  if (dv) CHK(VecView(y, dv));
  out += ", \"per_sigma\": [";
  for (PetscInt s = 0; s < nsig; ++s) {
    Mat A, F;
    CHK(MatDuplicate(K, MAT_COPY_VALUES, &A));
    CHK(MatAXPY(A, -sigmas[s], M, SAME_NONZERO_PATTERN));
    CHK(MatGetFactor(A, morse::cholesky_solver(PETSC_COMM_WORLD), MAT_FACTOR_CHOLESKY, &F));  // -factor_repeatable
    MatFactorInfo info;
    CHK(MatFactorInfoInitialize(&info));
    CHK(MatCholeskyFactorSymbolic(F, A, nullptr, &info));
    CHK(MatCholeskyFactorNumeric(F, A, &info));
    CHK(MatSolve(F, x, y));
    const std::string h1 = vec_hash(y);
    if (dv) CHK(VecView(y, dv));
    std::string h2;
    std::set<std::string> in_run = {h1};
    for (PetscInt k = 1; k < nrep; ++k) {  // the same solve again, same factor, same run
      CHK(MatSolve(F, x, y));
      if (k == 1) h2 = vec_hash(y);
      in_run.insert(vec_hash(y));
    }
    std::set<std::string> in_run_x;
    std::string hx;
    for (PetscInt k = 0; k < 2; ++k) {
      CHK(MatMatSolve(F, B, X));
      in_run_x.insert(k ? dense_hash(X) : (hx = dense_hash(X)));
    }
    if (dv)
      for (PetscInt j = 0; j < nrhs; ++j) {
        Vec c;
        CHK(MatDenseGetColumnVecRead(X, j, &c));
        CHK(VecView(c, dv));
        CHK(MatDenseRestoreColumnVecRead(X, j, &c));
      }
    char head[128];
    std::snprintf(head, sizeof head, "%s{\"sigma\": %.17g", s ? ", " : "", (double)sigmas[s]);
    out += std::string(head) + ", \"solve\": \"" + h1 + "\", \"solve_again\": \"" + h2 + "\", \"matmatsolve\": \"" +
           hx + "\", \"solve_in_run_distinct\": " + std::to_string(in_run.size()) +
           ", \"matmatsolve_in_run_distinct\": " + std::to_string(in_run_x.size()) + ", \"infog\": {";
    const int ig[] = {3, 5, 9, 10, 29};
    for (int k = 0; k < 5; ++k) {
      PetscInt v;
      CHK(MatMumpsGetInfog(F, ig[k], &v));
      out += (k ? ", \"" : "\"") + std::to_string(ig[k]) + "\": " + std::to_string(v);
    }
    out += "}";
    PetscInt icntl33 = 0;  // with -mat_mumps_icntl_33 1: the determinant, from the factor's pivots
    CHK(MatMumpsGetIcntl(F, 33, &icntl33));
    if (icntl33) {
      PetscReal mant, expo;
      PetscInt e34;
      CHK(MatMumpsGetRinfog(F, 12, &mant));
      CHK(MatMumpsGetRinfog(F, 13, &expo));
      CHK(MatMumpsGetInfog(F, 34, &e34));
      char det[96];
      std::snprintf(det, sizeof det, ", \"determinant\": \"%a * 2^%lld\"", (double)mant, (long long)e34);
      out += det;
    }
    out += "}";
    CHK(MatDestroy(&F));
    CHK(MatDestroy(&A));
  }
  out += "]}\n";
  CHK(PetscPrintf(comm, "%s", out.c_str()));
  if (dv) CHK(PetscViewerDestroy(&dv));
  CHK(MatDestroy(&X));
  CHK(MatDestroy(&B));
  CHK(VecDestroy(&x));
  CHK(VecDestroy(&y));
}

}  // namespace

int main(int argc, char** argv) {
  morse::Session session(&argc, &argv, "bench/mumps_repeat: bit patterns of K x, M x and MUMPS solves\n");
  run(PETSC_COMM_WORLD);
  return 0;
}
