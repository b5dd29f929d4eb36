// The repeatable factorization (morse/core/factor.hpp): a shell factor Mat whose work is done by
// a sequential MUMPS factor on rank 0 of the matrix gathered there.
#include "morse/core/factor.hpp"

#include <array>
#include <map>
#include <string>

#include "morse/core/error.hpp"
#include "morse/core/handle.hpp"
#include "morse/core/options.hpp"

namespace morse {

namespace {

bool g_repeatable = false;

// The state of one repeatable factor. Everything with a 0 is on rank 0 only (null elsewhere).
struct Repeatable {
  MPI_Comm comm = MPI_COMM_NULL;
  PetscMPIInt rank = 0;
  PetscInt n = 0;                        // global size
  Mat* sub = nullptr;                    // MatCreateSubMatrices' array: the whole A on rank 0
  Mat F0 = nullptr;                      // MUMPS factor of sub[0]
  VecScatter to0 = nullptr;              // a vector of A's layout to rank 0 and back
  Vec b0 = nullptr, x0 = nullptr;        // rank 0: length n; others: length 0
  std::map<PetscInt, PetscInt> icntl;    // set by MatMumpsSetIcntl, applied to F0
  std::map<PetscInt, PetscReal> cntl;    // set by MatMumpsSetCntl
  std::array<PetscInt, 81> infog{};      // INFOG(1..80) of the last factorization, all ranks
  std::array<PetscInt, 81> info{};       // INFO(1..80) of rank 0
  std::array<PetscReal, 41> rinfog{};    // RINFOG(1..40)
  std::array<PetscInt, 39> icntl_now{};  // ICNTL(1..38) of rank 0's factor, all ranks
  bool factored = false;
};

Repeatable* state(Mat F) {
  void* ctx = nullptr;
  (void)MatShellGetContext(F, &ctx);
  return static_cast<Repeatable*>(ctx);
}

// Runs work and returns the message of what it threw ("" if nothing). Not collective.
template <class Work>
std::string caught(Work&& work) {
  try {
    work();
  } catch (const std::exception& e) {
    const std::string err = message_of(e);
    return err.empty() ? "failed" : err;
  }
  return {};
}

// Runs work (on rank 0 only, or on every rank) and turns an exception into the same PETSc error
// on every rank, so that a failure of rank 0's MUMPS cannot leave the others waiting.
template <class Work>
PetscErrorCode collective(MPI_Comm comm, bool root_only, Work&& work) {
  PetscMPIInt rank = 0;
  MPI_Comm_rank(comm, &rank);
  const std::string err = !root_only || rank == 0 ? caught(work) : std::string();
  try {
    collective_check(comm, err);
  } catch (const std::exception& e) {
    SETERRQ(comm, PETSC_ERR_LIB, "repeatable factorization (MUMPS on rank 0): %s", e.what());
  }
  return 0;
}

void apply_settings(Repeatable& r) {
  for (auto [i, v] : r.icntl) MORSE_CALL(MatMumpsSetIcntl(r.F0, i, v));
  for (auto [i, v] : r.cntl) MORSE_CALL(MatMumpsSetCntl(r.F0, i, v));
}

// INFOG, INFO, RINFOG and ICNTL of rank 0's factor to every rank.
void share_info(Repeatable& r) {
  if (r.rank == 0) {
    for (PetscInt i = 1; i <= 80; ++i) {
      MORSE_CALL(MatMumpsGetInfog(r.F0, i, &r.infog[i]));
      MORSE_CALL(MatMumpsGetInfo(r.F0, i, &r.info[i]));
    }
    for (PetscInt i = 1; i <= 40; ++i) MORSE_CALL(MatMumpsGetRinfog(r.F0, i, &r.rinfog[i]));
    for (PetscInt i = 1; i <= 38; ++i) MORSE_CALL(MatMumpsGetIcntl(r.F0, i, &r.icntl_now[i]));
  }
  MPI_Bcast(r.icntl_now.data(), static_cast<int>(r.icntl_now.size()), MPIU_INT, 0, r.comm);
  MPI_Bcast(r.infog.data(), static_cast<int>(r.infog.size()), MPIU_INT, 0, r.comm);
  MPI_Bcast(r.info.data(), static_cast<int>(r.info.size()), MPIU_INT, 0, r.comm);
  MPI_Bcast(r.rinfog.data(), static_cast<int>(r.rinfog.size()), MPIU_REAL, 0, r.comm);
}

// A gathered to rank 0 (initial: structure and values; reuse: values).
void gather(Repeatable& r, Mat A, MatReuse reuse) {
  Unique<IS, ISDestroy> all;
  MORSE_CALL(ISCreateStride(PETSC_COMM_SELF, r.rank == 0 ? r.n : 0, 0, 1, all.ptr()));
  IS is = all.get();
  MORSE_CALL(MatCreateSubMatrices(A, 1, &is, &is, reuse, &r.sub));
  if (reuse == MAT_INITIAL_MATRIX && r.rank == 0) {
    // A Cholesky factor is asked for, so A is symmetric (MUMPS reads its upper triangle); the
    // submatrix does not inherit A's flags.
    MORSE_CALL(MatSetOption(r.sub[0], MAT_SYMMETRIC, PETSC_TRUE));
    MORSE_CALL(MatSetOption(r.sub[0], MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
    PetscBool known = PETSC_FALSE, flag = PETSC_FALSE;
    MORSE_CALL(MatIsSPDKnown(A, &known, &flag));
    if (known && flag) MORSE_CALL(MatSetOption(r.sub[0], MAT_SPD, PETSC_TRUE));
  }
}

PetscErrorCode symbolic(Mat F, Mat A, IS, const MatFactorInfo* info) {
  Repeatable& r = *state(F);
  PetscCall(collective(r.comm, false, [&] {
    if (r.F0) MORSE_CALL(MatDestroy(&r.F0));
    if (r.sub) MORSE_CALL(MatDestroySubMatrices(1, &r.sub));
    gather(r, A, MAT_INITIAL_MATRIX);
    if (!r.to0) {
      Unique<Vec, VecDestroy> v;
      MORSE_CALL(MatCreateVecs(A, v.ptr(), nullptr));
      MORSE_CALL(VecScatterCreateToZero(v.get(), &r.to0, &r.b0));
      MORSE_CALL(VecDuplicate(r.b0, &r.x0));
    }
  }));
  PetscCall(collective(r.comm, true, [&] {
    MORSE_CALL(MatGetFactor(r.sub[0], MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &r.F0));
    const char* prefix = nullptr;
    MORSE_CALL(MatGetOptionsPrefix(F, &prefix));
    MORSE_CALL(MatSetOptionsPrefix(r.F0, prefix));
    MORSE_CALL(MatSetFromOptions(r.F0));
    apply_settings(r);
    MORSE_CALL(MatCholeskyFactorSymbolic(r.F0, r.sub[0], nullptr, info));
  }));
  PetscCall(collective(r.comm, false, [&] { share_info(r); }));
  r.factored = false;
  return 0;
}

PetscErrorCode numeric(Mat F, Mat A, const MatFactorInfo* info) {
  Repeatable& r = *state(F);
  PetscCall(collective(r.comm, false, [&] { gather(r, A, MAT_REUSE_MATRIX); }));
  PetscCall(collective(r.comm, true, [&] {
    apply_settings(r);
    MORSE_CALL(MatCholeskyFactorNumeric(r.F0, r.sub[0], info));
    MatFactorError e = MAT_FACTOR_NOERROR;
    MORSE_CALL(MatFactorGetError(r.F0, &e));
    PetscInt infog1 = 0;
    if (e != MAT_FACTOR_NOERROR) MORSE_CALL(MatMumpsGetInfog(r.F0, 1, &infog1));
    MORSE_CHECK(e == MAT_FACTOR_NOERROR, "MUMPS's numerical factorization failed: INFOG(1) = ", infog1,
                infog1 == -10 ? " (numerically singular matrix)" : "");
  }));
  PetscCall(collective(r.comm, false, [&] { share_info(r); }));
  r.factored = true;
  return 0;
}

// b (A's layout) -> rank 0, solve, -> x. b0 and x0 may be placed on other storage.
void solve_on_root(Repeatable& r, Vec b, Vec x) {
  MORSE_CALL(VecScatterBegin(r.to0, b, r.b0, INSERT_VALUES, SCATTER_FORWARD));
  MORSE_CALL(VecScatterEnd(r.to0, b, r.b0, INSERT_VALUES, SCATTER_FORWARD));
  collective_check(r.comm, r.rank == 0 ? caught([&] { MORSE_CALL(MatSolve(r.F0, r.b0, r.x0)); }) : std::string());
  MORSE_CALL(VecScatterBegin(r.to0, r.x0, x, INSERT_VALUES, SCATTER_REVERSE));
  MORSE_CALL(VecScatterEnd(r.to0, r.x0, x, INSERT_VALUES, SCATTER_REVERSE));
}

PetscErrorCode solve(Mat F, Vec b, Vec x) {
  Repeatable& r = *state(F);
  return collective(r.comm, false, [&] { solve_on_root(r, b, x); });
}

// The columns of B to a dense n x k matrix on rank 0, one MUMPS solve with k right-hand sides
// (the factor is read once per block), the columns of the solution back to X.
PetscErrorCode mat_solve(Mat F, Mat B, Mat X) {
  Repeatable& r = *state(F);
  return collective(r.comm, false, [&] {
    PetscInt k = 0;
    MORSE_CALL(MatGetSize(B, nullptr, &k));
    Unique<Mat, MatDestroy> B0, X0;
    const PetscInt rows = r.rank == 0 ? r.n : 0;
    MORSE_CALL(MatCreateSeqDense(PETSC_COMM_SELF, rows, k, nullptr, B0.ptr()));
    MORSE_CALL(MatCreateSeqDense(PETSC_COMM_SELF, rows, k, nullptr, X0.ptr()));
    auto move_columns = [&](Mat dist, Mat seq, ScatterMode mode) {
      PetscScalar* a = nullptr;
      MORSE_CALL(MatDenseGetArray(seq, &a));
      for (PetscInt j = 0; j < k; ++j) {
        Vec col = nullptr;
        MORSE_CALL(VecPlaceArray(r.b0, a + j * rows));
        if (mode == SCATTER_FORWARD) {
          MORSE_CALL(MatDenseGetColumnVecRead(dist, j, &col));
          MORSE_CALL(VecScatterBegin(r.to0, col, r.b0, INSERT_VALUES, SCATTER_FORWARD));
          MORSE_CALL(VecScatterEnd(r.to0, col, r.b0, INSERT_VALUES, SCATTER_FORWARD));
          MORSE_CALL(MatDenseRestoreColumnVecRead(dist, j, &col));
        } else {
          MORSE_CALL(MatDenseGetColumnVecWrite(dist, j, &col));
          MORSE_CALL(VecScatterBegin(r.to0, r.b0, col, INSERT_VALUES, SCATTER_REVERSE));
          MORSE_CALL(VecScatterEnd(r.to0, r.b0, col, INSERT_VALUES, SCATTER_REVERSE));
          MORSE_CALL(MatDenseRestoreColumnVecWrite(dist, j, &col));
        }
        MORSE_CALL(VecResetArray(r.b0));
      }
      MORSE_CALL(MatDenseRestoreArray(seq, &a));
    };
    move_columns(B, B0.get(), SCATTER_FORWARD);
    collective_check(r.comm, r.rank == 0 && k > 0 ? caught([&] { MORSE_CALL(MatMatSolve(r.F0, B0.get(), X0.get())); })
                                                  : std::string());
    move_columns(X, X0.get(), SCATTER_REVERSE);
  });
}

// As MUMPS's: INFOG(12) negative pivots; zero ones (INFOG(28)) only with ICNTL(24) = 1.
PetscErrorCode inertia(Mat F, PetscInt* nneg, PetscInt* nzero, PetscInt* npos) {
  Repeatable& r = *state(F);
  PetscCheck(r.factored, r.comm, PETSC_ERR_ORDER,
             "repeatable factorization: inertia before the numerical factorization");
  const auto it = r.icntl.find(24);
  const bool nulls = it != r.icntl.end() && it->second == 1;
  PetscCheck(nulls || (!nzero && !npos), r.comm, PETSC_ERR_ARG_WRONGSTATE,
             "-mat_mumps_icntl_24 must be set as 1 for null pivot row detection");
  if (nneg) *nneg = r.infog[12];
  if (nzero) *nzero = r.infog[28];
  if (npos) *npos = r.n - r.infog[12] - r.infog[28];
  return 0;
}

// What PCFactor asks of a factor: the entries in the factor (INFOG(20), estimated at the analysis).
PetscErrorCode get_info(Mat F, MatInfoType, MatInfo* info) {
  Repeatable& r = *state(F);
  PetscCall(PetscMemzero(info, sizeof(*info)));
  info->block_size = 1.0;
  info->nz_allocated = info->nz_used = static_cast<PetscLogDouble>(r.infog[20]);
  return 0;
}

PetscErrorCode set_icntl(Mat F, PetscInt i, PetscInt v) {
  Repeatable& r = *state(F);
  r.icntl[i] = v;
  if (r.rank == 0 && r.F0) PetscCall(MatMumpsSetIcntl(r.F0, i, v));
  return 0;
}
PetscErrorCode get_icntl(Mat F, PetscInt i, PetscInt* v) {
  Repeatable& r = *state(F);
  // As set on this factor, else as MUMPS had it at the last analysis or factorization.
  const auto it = r.icntl.find(i);
  *v = it != r.icntl.end() ? it->second : i >= 1 && i <= 38 ? r.icntl_now[i] : 0;
  return 0;
}
PetscErrorCode set_cntl(Mat F, PetscInt i, PetscReal v) {
  Repeatable& r = *state(F);
  r.cntl[i] = v;
  if (r.rank == 0 && r.F0) PetscCall(MatMumpsSetCntl(r.F0, i, v));
  return 0;
}
template <class T, std::size_t N, std::array<T, N> Repeatable::*field>
PetscErrorCode get_array(Mat F, PetscInt i, T* v) {
  Repeatable& r = *state(F);
  PetscCheck(i >= 1 && i < static_cast<PetscInt>(N), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE,
             "repeatable factorization: index %" PetscInt_FMT " out of range", i);
  *v = (r.*field)[i];
  return 0;
}
PetscErrorCode solver_type(Mat, MatSolverType* type) {
  *type = kRepeatableSolver;
  return 0;
}

PetscErrorCode destroy(Mat F) {
  Repeatable* r = state(F);
  if (!r) return 0;
  if (r->F0) PetscCall(MatDestroy(&r->F0));
  if (r->sub) PetscCall(MatDestroySubMatrices(1, &r->sub));
  if (r->to0) PetscCall(VecScatterDestroy(&r->to0));
  if (r->b0) PetscCall(VecDestroy(&r->b0));
  if (r->x0) PetscCall(VecDestroy(&r->x0));
  delete r;
  return 0;
}

PetscErrorCode create(Mat A, MatFactorType type, Mat* F) {
  PetscCheck(type == MAT_FACTOR_CHOLESKY, PetscObjectComm(reinterpret_cast<PetscObject>(A)), PETSC_ERR_SUP,
             "the repeatable factorization is a Cholesky (LDL^T) factorization only");
  auto* r = new Repeatable;
  r->comm = PetscObjectComm(reinterpret_cast<PetscObject>(A));
  MPI_Comm_rank(r->comm, &r->rank);
  PetscInt m = 0, nl = 0, N = 0;
  PetscCall(MatGetLocalSize(A, &m, &nl));
  PetscCall(MatGetSize(A, &N, nullptr));
  r->n = N;
  PetscCall(MatCreateShell(r->comm, m, nl, N, N, r, F));
  PetscCall(MatSetFactorType(*F, MAT_FACTOR_CHOLESKY));
  using Op = void (*)(void);
  PetscCall(MatShellSetOperation(*F, MATOP_DESTROY, reinterpret_cast<Op>(destroy)));
  PetscCall(MatShellSetOperation(*F, MATOP_CHOLESKY_FACTOR_SYMBOLIC, reinterpret_cast<Op>(symbolic)));
  PetscCall(MatShellSetOperation(*F, MATOP_CHOLESKY_FACTOR_NUMERIC, reinterpret_cast<Op>(numeric)));
  PetscCall(MatShellSetOperation(*F, MATOP_SOLVE, reinterpret_cast<Op>(solve)));
  PetscCall(MatShellSetOperation(*F, MATOP_MAT_SOLVE, reinterpret_cast<Op>(mat_solve)));
  PetscCall(MatShellSetOperation(*F, MATOP_GET_INERTIA, reinterpret_cast<Op>(inertia)));
  PetscCall(MatShellSetOperation(*F, MATOP_GETINFO, reinterpret_cast<Op>(get_info)));
  auto* obj = reinterpret_cast<PetscObject>(*F);
  PetscCall(PetscObjectComposeFunction(obj, "MatFactorGetSolverType_C", solver_type));
  PetscCall(PetscObjectComposeFunction(obj, "MatMumpsSetIcntl_C", set_icntl));
  PetscCall(PetscObjectComposeFunction(obj, "MatMumpsGetIcntl_C", get_icntl));
  PetscCall(PetscObjectComposeFunction(obj, "MatMumpsSetCntl_C", set_cntl));
  PetscCall(PetscObjectComposeFunction(obj, "MatMumpsGetInfog_C", (get_array<PetscInt, 81, &Repeatable::infog>)));
  PetscCall(PetscObjectComposeFunction(obj, "MatMumpsGetInfo_C", (get_array<PetscInt, 81, &Repeatable::info>)));
  PetscCall(PetscObjectComposeFunction(obj, "MatMumpsGetRinfog_C", (get_array<PetscReal, 41, &Repeatable::rinfog>)));
  return 0;
}

PetscErrorCode read_repeatable(PetscBool* on) {
  PetscOptionsBegin(PETSC_COMM_WORLD, nullptr, "Factorization", nullptr);
  PetscCall(MorseOptionsBool("-factor_repeatable",
                             "every factorization by MUMPS on rank 0 alone (the matrix gathered there), so that "
                             "the same command on the same rank count gives the same bits (slower on several ranks)",
                             nullptr, *on, on, nullptr));
  PetscOptionsEnd();
  return 0;
}

}  // namespace

void init_factorization() {
  MORSE_CALL(MatInitializePackage());  // PETSc's own solver types first
  for (MatType t : {MATMPIAIJ, MATSEQAIJ})
    MORSE_CALL(MatSolverTypeRegister(kRepeatableSolver, t, MAT_FACTOR_CHOLESKY, create));
  read_factorization_options();
}

void read_factorization_options() {
  PetscBool on = PETSC_FALSE;
  MORSE_CALL(read_repeatable(&on));
  g_repeatable = on;
}

bool repeatable_factorization() { return g_repeatable; }
void set_repeatable_factorization(bool on) { g_repeatable = on; }

const char* cholesky_solver(MPI_Comm comm) {
  PetscMPIInt size = 1;
  MPI_Comm_size(comm, &size);
  return g_repeatable && size > 1 ? kRepeatableSolver : MATSOLVERMUMPS;
}

const char* cholesky_solver(Mat A) { return cholesky_solver(PetscObjectComm(reinterpret_cast<PetscObject>(A))); }

}  // namespace morse
