// morse/core/factor.hpp: the sparse Cholesky (LDL^T) factorization behind every direct solve of
// morse, and its bitwise repeatable variant on several ranks.
//
// MUMPS on several ranks is not bitwise repeatable: its parallel triangular solves (and now and
// then its factorization) change their last bits from run to run, even with the same factor in
// the same run (bench/mumps_repeat.sh; docs/user-guide.md "What is bitwise reproducible"). With
// the global option -factor_repeatable, every factorization of morse is done instead by MUMPS on
// rank 0 alone, on the matrix gathered there, and every solve gathers its right-hand sides to
// rank 0 and scatters the solutions back: the same command on the same rank count then gives the
// same bits. It costs the parallel speed-up of the factorization and the solves (the other ranks
// wait) and the whole factor's memory on rank 0; the assembly, products and everything else stay
// parallel.
#pragma once

#include <petscmat.h>

namespace morse {

/// The solver type of the repeatable factorization (registered by Session for MATMPIAIJ and MATSEQAIJ,
/// Cholesky): a factor Mat that behaves as MUMPS's for MatCholeskyFactorSymbolic/Numeric,
/// MatSolve, MatMatSolve, MatGetInertia, MatMumpsSetIcntl/SetCntl/GetIcntl and
/// MatMumpsGetInfog/GetInfo/GetRinfog (INFO as on rank 0). -<prefix>mat_mumps_* options of the
/// factor reach MUMPS on rank 0.
constexpr const char* kRepeatableSolver = "morse_repeatable";

/// Registers kRepeatableSolver with PETSc and reads -factor_repeatable. Session calls it once
/// after PETSc is initialized. Collective on PETSC_COMM_WORLD.
void init_factorization();

/// Reads (and registers, for -help and the unknown-option check) -factor_repeatable; each
/// command does, after it clears the registrations. Collective on PETSC_COMM_WORLD.
void read_factorization_options();

/// Whether -factor_repeatable is on (set_repeatable_factorization overrides it, for tests).
bool repeatable_factorization();
void set_repeatable_factorization(bool on);

/// The solver type for a Cholesky factor of a matrix on comm: kRepeatableSolver if
/// -factor_repeatable is on and comm has several ranks, else MATSOLVERMUMPS (one rank is
/// repeatable as it is).
const char* cholesky_solver(MPI_Comm comm);
/// The same for a factor of A (A's communicator).
const char* cholesky_solver(Mat A);

}  // namespace morse
