// src/eigen/detail/singular.hpp: the signal by which a solver tells solve_eigen that K itself
// (shift 0) is singular, so that solve_eigen solves again about a negative shift (private).
#pragma once

#include <petscmat.h>

#include <string>

#include "morse/core/error.hpp"

namespace morse::eigen::detail {

/// Thrown on every rank (the null-pivot count of a MUMPS factor is global) when the factorization
/// of K at shift 0 has null pivots: the model has rigid-body (or mechanism) modes. solve_eigen
/// catches it and solves about an automatic negative shift.
class SingularAtZero : public Error {
 public:
  explicit SingularAtZero(const std::string& what)
      : Error(cat(what,
                  ": the stiffness matrix is singular: the model is not restrained against rigid-body motion; "
                  "check -clamp and the boundary set")) {}
};

/// Throws SingularAtZero on every rank if the factor F of K - shift M (MUMPS, ICNTL(24) = 1) has
/// null pivots and shift is 0, else a collective Error that says the shifted matrix is
/// singular. MUMPS's null-pivot count is not the rank deficiency (a free solid, 6 rigid-body
/// modes, may show 3), so it is not printed as one. Collective.
void check_null_pivots(MPI_Comm comm, Mat F, double shift, const std::string& what);

/// max_i K_ii / M_ii: a lower bound of the largest eigenvalue of (K, M), the scale of the
/// automatic shift and of the zero-eigenvalue threshold. Collective.
double stiffness_scale(Mat K, Mat M);

/// The automatic shift of a singular K: 10 to 1000 times below the lowest eigenvalue above the
/// zero ones, bracketed by Sylvester's inertia at 1e-10, 1e-8, ... of stiffness_scale: *below
/// eigenvalues lie below the bracket [*lowest_lo, *lowest_hi) of the next one (*lowest_lo = 0:
/// the bracket is the first count). Collective.
double auto_shift(Mat K, Mat M, const std::string& prefix, PetscInt* below, double* lowest_lo, double* lowest_hi);

/// Eigenvalues below zero_threshold(scale) = 1e-12 scale are zero to round-off: rigid-body modes.
/// Their computed values are round-off of order 1e-17 scale; the first flexible mode of a solid
/// lies many decades above (scale 1e13 (rad/s)^2 for 1 cm steel elements: 10 (rad/s)^2, 0.5 Hz).
inline double zero_threshold(double scale) { return 1e-12 * scale; }

}  // namespace morse::eigen::detail
