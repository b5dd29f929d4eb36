// Private to src/rampup: the LAPACK routines that petscblaslapack.h does not declare (banded LU
// and the generalized nonsymmetric eigenproblem), with PETSc's integer type.
#pragma once

// clang-format off
#include <petscsys.h>  // first: petscblaslapack.h needs it
#include <petscblaslapack.h>
// clang-format on

extern "C" {
void dgbtrf_(const PetscBLASInt* m, const PetscBLASInt* n, const PetscBLASInt* kl, const PetscBLASInt* ku, double* ab,
             const PetscBLASInt* ldab, PetscBLASInt* ipiv, PetscBLASInt* info);
void dgbtrs_(const char* trans, const PetscBLASInt* n, const PetscBLASInt* kl, const PetscBLASInt* ku,
             const PetscBLASInt* nrhs, const double* ab, const PetscBLASInt* ldab, const PetscBLASInt* ipiv, double* b,
             const PetscBLASInt* ldb, PetscBLASInt* info);
void dggev_(const char* jobvl, const char* jobvr, const PetscBLASInt* n, double* a, const PetscBLASInt* lda, double* b,
            const PetscBLASInt* ldb, double* alphar, double* alphai, double* beta, double* vl, const PetscBLASInt* ldvl,
            double* vr, const PetscBLASInt* ldvr, double* work, const PetscBLASInt* lwork, PetscBLASInt* info);
}
