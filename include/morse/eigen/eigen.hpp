// morse/eigen/eigen.hpp: generalized symmetric eigenproblems K x = omega^2 M x with SLEPc.
//
// Shift-invert with a MUMPS Cholesky factorization. By count (nev lowest pairs about the shift)
// or by cutoff (every pair below omega2_max, by spectrum slicing with MUMPS inertia). The
// eigenvectors are M-normalized and their sign is fixed so that w^T x > 0 for a reference
// vector w that depends only on the mesh (global node index and direction), so results do not
// depend on the number of ranks.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "morse/core/handle.hpp"

namespace morse::eigen {

struct EigenSettings {
  PetscInt nev = 0;                   ///< number of pairs wanted (count mode), or
  double omega2_max = -1;             ///< cutoff in (rad/s)^2: all pairs with omega^2 <= cutoff (slicing)
  double shift = 0.0;                 ///< shift-invert target in (rad/s)^2 (count mode)
  double tol = 1e-10;                 ///< relative residual tolerance (overridable with -<prefix>eps_tol)
  std::string prefix;                 ///< options prefix of the EPS (its ST/KSP/PC inherit it)
  std::string what = "eigenproblem";  ///< name used in messages
  /// Count mode with nev >= count_slicing (and shift 0): find the cutoff below which lie nev to
  /// ~1.2 nev eigenvalues by inertia counts (Sylvester: negative pivots of K - sigma M), then
  /// solve by spectrum slicing and keep the nev lowest. With one shift, every Krylov vector is
  /// orthogonalized against all converged ones, which dominates for hundreds of modes; slicing
  /// orthogonalizes within each subinterval. 0: never. -<prefix>count_slicing overrides.
  PetscInt count_slicing = 500;
  /// Prefix of the stage names (<stage>Factor, <stage>EigenSolve, <stage>EigenVectors), so that
  /// several eigen solves of one run stay apart in the stage table and in -log_view.
  std::string stage;
  /// Count mode with one shift: check the claim "these are the nev pairs nearest the shift (the
  /// nev lowest for shift <= 0)" by Sylvester's inertia (one LDL^T factorization, two for a
  /// shift inside the spectrum). -<prefix>check_inertia overrides.
  bool check_inertia = true;
  /// Solver: "block" (default) or "krylovschur" (-<prefix>eigen_solver overrides).
  std::string solver = "block";
  /// The caller uses the factorization after the solve (Eigenpairs::factor(), as the
  /// Craig–Bampton constraint modes do). When false, the block solver's factorization is made
  /// with the root front unsplit (MUMPS ICNTL(13) = 1, so that its inertia is exact) and the
  /// Sylvester check refactors it in place at its shifts: no second symbolic analysis and no
  /// second factor in memory; Eigenpairs::factor() is then null.
  bool keep_factor = true;
  /// A singular K (at shift 0) is solved about an automatic negative shift (solve_eigen). False:
  /// it is an error, for callers that need K itself to be regular (Craig–Bampton's K_ii, whose
  /// factor the constraint modes reuse: a boundary that does not hold the rigid motions).
  bool allow_singular = true;
};

struct Eigenpairs {
  std::vector<double> omega2;  ///< ascending
  UMat V;                      ///< MPIDENSE, one M-normalized eigenvector per column
  UEPS eps;                    ///< the solver, kept alive so its factorization can be reused
  PetscInt iterations = 0;
  double factor_seconds = 0;    ///< numeric factorization time (count mode)
  bool slicing = false;         ///< solved by spectrum slicing
  double slice_omega2 = 0;      ///< count mode by slicing: the cutoff used
  PetscInt inertia_counts = 0;  ///< count mode by slicing: factorizations spent finding it
  /// Slicing (Krylov–Schur): subcommunicators that solved slices concurrently
  /// (-<prefix>eps_krylovschur_partitions; 1: all ranks on every slice).
  PetscInt partitions = 1;
  /// Sylvester check of a solve: the number of eigenvalues below the cutoff (cutoff or count by
  /// slicing) from the inertia of K - cutoff*M; in count mode with one shift, the number in the
  /// window [check_lo, check_hi] just wider than the pairs returned; -1 when not checked
  /// (-<prefix>check_inertia false).
  PetscInt inertia_count = -1;
  double check_lo = 0, check_hi = 0;  ///< count mode with one shift: the window checked
  /// max over the returned pairs of ||K x - omega^2 M x|| / (||K||_inf ||x||) (checked <= tol).
  double max_residual = 0;
  /// The leading pairs of zero frequency (rigid-body modes of a model free in some motions):
  /// omega^2 below 1e-12 max_i K_ii / M_ii, stored as exactly 0, their basis fixed by sign_ref
  /// (not by the rank count), their number checked by Sylvester's inertia.
  PetscInt zero_modes = 0;
  /// The block solver's own factorization (the Krylov–Schur solver's lives in its EPS).
  UMat block_factor;
  /// The shift the solve used (EigenSettings::shift, or the automatic one of a singular K).
  double shift = 0.0;
  /// The MUMPS Cholesky factor of K - shift*M used by the solver, or null (slicing mode). A caller
  /// that needs K's own factor checks shift == 0 (after an automatic shift it is not).
  Mat factor() const;
};

/// Solves K x = omega^2 M x. sign_ref (same layout as K) fixes the eigenvector signs; may be
/// null. Every mode is guaranteed: a solve that claims all pairs below a cutoff (cutoff, or
/// count by slicing) is checked against Sylvester's inertia of K - cutoff*M, and every returned
/// pair against its residual ||K x - omega^2 M x|| / (||K||_inf ||x||) <= tol; both are printed.
/// A singular K (a model free in rigid-body motion) is solved about an automatic negative shift
/// (theory §2), its zero modes returned first as omega^2 = 0 in a basis fixed by sign_ref
/// (Eigenpairs::zero_modes). Throws morse::Error (collectively) if nev exceeds the problem size,
/// if K - shift*M is singular at a nonzero shift, if fewer pairs converge than
/// requested, if the inertia count disagrees with the pairs found (a missed or spurious mode) or
/// if a residual exceeds the tolerance. Collective.
Eigenpairs solve_eigen(Mat K, Mat M, const EigenSettings& s, Vec sign_ref);

/// Eigenvalues below this are zero to round-off (rigid-body modes): 1e-12 max_i K_ii / M_ii.
/// Collective.
double zero_threshold(Mat K, Mat M);

/// The k reference vectors that fix the basis of a cluster of zero modes independently of the
/// solver and the rank count: w_j = cos(2 pi (j+1) (sign_ref - 1/2)) elementwise, j < k (sign_ref
/// depends on the mesh only). Collective.
std::vector<UVec> zero_mode_references(Vec sign_ref, PetscInt k);

/// The canonical basis of a k-dimensional eigenspace: with X any M-orthonormal basis of it and
/// C = X^T M W (k x k, column-major, W = zero_mode_references), C = Q R (R with a positive
/// diagonal) and X Q is the M-orthonormal Gram-Schmidt basis of the projections of w_1..w_k,
/// the same for every X. False if the projections are (nearly) dependent. Not collective.
bool canonical_rotation(PetscInt k, const std::vector<double>& C, std::vector<double>* Q);

/// The last steps of every solver: the signs of out->V from sign_ref (may be null), then the
/// residual check of every pair against tol (printed). Collective.
void finish_pairs(Mat K, Mat M, const EigenSettings& s, double tol, Vec sign_ref, Eigenpairs* out);

/// Sylvester check of a count solve with one shift (see EigenSettings::check_inertia): the pairs
/// returned (out->omega2, ascending) claim to be the s.nev eigenvalues nearest s.shift. The
/// eigenvalues in a window just wider than theirs, [shift - d, shift + d] with d the largest
/// distance times (1 + 1e-6), are counted from the inertia of K - (shift +/- d) M and must equal
/// the pairs found in it: those returned and `extra`, the other converged pairs of the solve
/// (a tie at the edge of the window). A mismatch is a collective error naming the count; the
/// check is printed. Collective.
void check_count_by_inertia(Mat K, Mat M, const EigenSettings& s, const std::vector<double>& extra, Eigenpairs* out);

/// Whether the count check of a one-shift solve will run: EigenSettings::check_inertia, or
/// -<prefix>check_inertia. Collective.
bool count_check_wanted(MPI_Comm comm, const EigenSettings& s);

/// Relative residuals ||K x_j - omega2_j M x_j|| / (||K||_inf ||x_j||) of the columns of V (MPIDENSE,
/// K's row layout), computed in blocks of columns. Collective.
std::vector<double> relative_residuals(Mat K, Mat M, Mat V, const std::vector<double>& omega2);

/// Rayleigh quotients x^T K x / x^T M x of the columns of V (MPIDENSE, K's row layout): the
/// eigenvalue estimate whose error is quadratic in the vector's, used by spectrum slicing, whose
/// Ritz values omega^2 = shift + 1/theta carry the error tol |omega^2 - shift| of a shift far
/// from them. Collective.
std::vector<double> rayleigh_quotients(Mat K, Mat M, Mat V);

/// The block shift-invert Krylov–Schur solver (src/eigen/block_eigen.cpp), which solve_eigen uses
/// with -<prefix>eigen_solver block (the default): count mode, or cutoff mode as the count from
/// Sylvester's inertia at the cutoff then a count solve (checked: exactly that many, all below
/// it). Options -<prefix>block_size (8 below 100 modes, else 16), -<prefix>block_max_dim (nev +
/// max(1.2 nev, 6 blocks)), -<prefix>block_max_restarts (200), -<prefix>eps_tol; MUMPS options
/// of its factorization as -<prefix>block_mat_mumps_*. With -<prefix>block_slices S > 1 (or
/// -<prefix>block_partitions P > 1), spectrum slicing: [0, cutoff] (count mode: a cutoff from
/// inertia counts, the nev lowest kept) cut into S slices, each counted by Sylvester's inertia
/// at its ends and solved by a count solve about its middle, checked slice by slice; the slices
/// are spread over P subcommunicators that work side by side (P must divide the ranks).
/// Collective.
/// A problem too small for a block basis (nev + 2 blocks > the number of DOFs) is handed to
/// solve_eigen_krylovschur, with a notice.
Eigenpairs solve_eigen_block(Mat K, Mat M, const EigenSettings& s, Vec sign_ref);

/// SLEPc's Krylov–Schur with MUMPS shift-invert (one vector at a time), which solve_eigen uses
/// with -<prefix>eigen_solver krylovschur: count mode with one shift or, for many modes, by
/// inertia search and spectrum slicing (-<prefix>count_slicing); cutoff mode by spectrum
/// slicing. Collective.
Eigenpairs solve_eigen_krylovschur(Mat K, Mat M, const EigenSettings& s, Vec sign_ref);

/// Sets an option in the database unless the user already gave it.
void set_default_option(const std::string& name, const std::string& value);

/// Number of null pivots MUMPS found in the factor F (needs ICNTL(24)=1).
PetscInt mumps_null_pivots(Mat F);

/// Number of eigenvalues of K x = lambda M x below sigma, from the inertia of an LDL^T
/// factorization of K - sigma M (MUMPS, symmetric indefinite). K and M must have the same
/// layout; the symbolic factorization is done once per counter. Collective.
class InertiaCounter {
 public:
  /// With `reuse`, a MUMPS symmetric (LDL^T) factor whose analysis was made on a matrix with K's
  /// pattern and ICNTL(13) = 1: each count refactors it in place (no new analysis), which
  /// destroys what it held. It is used only when K and M share their pattern; it must outlive
  /// the counter.
  InertiaCounter(Mat K, Mat M, const std::string& prefix, Mat reuse = nullptr);
  PetscInt count(double sigma);
  PetscInt factorizations() const { return calls_; }

 private:
  Mat K_, M_;
  UMat A_, F_;
  Mat reuse_ = nullptr;
  std::string prefix_;
  bool same_pattern_ = false;
  PetscInt calls_ = 0;
};

/// A cutoff sigma with nev <= N(sigma) <= 1.2 nev eigenvalues of K x = lambda M x below it, N
/// from inertia counts (InertiaCounter with `prefix`); *count = N(sigma), *factorizations = the
/// counts spent. Collective.
double count_cutoff(Mat K, Mat M, PetscInt nev, const std::string& prefix, const std::string& what,
                    PetscInt* factorizations, PetscInt* count);

/// Dense generalized symmetric eigenvalues of (K, M), row-major n x n, ascending (LAPACK sygv).
/// If vectors is not null it receives the M-normalized eigenvectors (column k = mode k,
/// row-major n x n). With vectors_max finite, only the eigenvectors of the eigenvalues
/// <= vectors_max are computed (LAPACK sygvx, bisection and inverse iteration: a few times
/// cheaper than all of them when they are few); the other columns are zero.
std::vector<double> dense_eigenvalues(int n, const std::vector<double>& K, const std::vector<double>& M,
                                      std::vector<double>* vectors = nullptr,
                                      double vectors_max = std::numeric_limits<double>::infinity());

}  // namespace morse::eigen
