// Block shift-invert Krylov–Schur for K x = omega^2 M x (eigen/eigen.hpp, -<prefix>eigen_solver block).
//
// The operator is Op = (K - sigma M)^-1 M, self-adjoint in the M inner product; its eigenvalues
// theta = 1 / (omega^2 - sigma) are largest in magnitude for the omega^2 nearest sigma. One MUMPS
// Cholesky factorization of K - sigma M; each step applies Op to a block of b vectors at once
// (MatMatSolve: the factor is read once per block, not once per vector, which is what bounds a
// single-vector solve). The basis Q is kept M-orthonormal by block classical Gram–Schmidt (a
// local pass against the last two blocks, then one global pass, repeated by the DGKS test) and
// SVQB (the eigen-decomposition of the b x b Gram matrix), all BLAS-3. The projected matrix H = Q^T M Op Q is filled
// from the Gram–Schmidt coefficients; the Rayleigh–Ritz pairs of its leading part give the Ritz values, and the
// coupling block of the last (residual) block gives each Ritz pair's residual ||Op x - theta x||_M = ||B y||. When the
// basis is full, the method restarts à la Krylov–Schur: the best Ritz vectors are kept (their
// projected matrix is diagonal, coupled to the residual block by B Y), and the expansion goes
// on from the residual block. A Ritz pair is converged when ||B y|| <= tol |theta|.
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numeric>

#include "eigen/detail/singular.hpp"
#include "eigen/detail/testing.hpp"
#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/core/units.hpp"
#include "morse/eigen/eigen.hpp"

// LAPACK's MRRR symmetric eigensolver (not in PETSc's BLAS/LAPACK header; the LAPACK that
// PETSc links provides it).
extern "C" void dsyevr_(const char* jobz, const char* range, const char* uplo, const PetscBLASInt* n, double* a,
                        const PetscBLASInt* lda, const double* vl, const double* vu, const PetscBLASInt* il,
                        const PetscBLASInt* iu, const double* abstol, PetscBLASInt* m, double* w, double* z,
                        const PetscBLASInt* ldz, PetscBLASInt* isuppz, double* work, const PetscBLASInt* lwork,
                        PetscBLASInt* iwork, const PetscBLASInt* liwork, PetscBLASInt* info);

namespace morse::eigen {

namespace {

// A uniform value in [-0.5, 0.5) from a key (splitmix64): the start block depends on the global
// row and column only, so it is the same on any number of ranks.
double uniform(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  x ^= x >> 31;
  return static_cast<double>(x >> 11) * (1.0 / 9007199254740992.0) - 0.5;
}

PetscBLASInt blas(PetscInt v) {
  PetscBLASInt b = 0;
  MORSE_CALL(PetscBLASIntCast(v, &b));
  return b;
}

// One part of the block solver: a PETSc log event (-log_view) and its accumulated wall time.
class Phase {
 public:
  Phase(const char* name, double* seconds)
      : ev_(log_event(name)), seconds_(seconds), t0_(std::chrono::steady_clock::now()) {
    PetscLogEventBegin(ev_, 0, 0, 0, 0);
  }
  ~Phase() {
    PetscLogEventEnd(ev_, 0, 0, 0, 0);
    *seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }

 private:
  PetscLogEvent ev_;
  double* seconds_;
  std::chrono::steady_clock::time_point t0_;
};

// The local rows of an MPIDENSE matrix.
struct Local {
  PetscScalar* a = nullptr;
  PetscInt ld = 1;
};

class BlockSolver {
 public:
  BlockSolver(Mat K, Mat M, Mat F, PetscInt b, PetscInt kmax, bool positive, MPI_Comm comm)
      : K_(K), M_(M), F_(F), b_(b), kmax_(kmax), comm_(comm), positive_(positive) {
    MORSE_CALL(MatGetLocalSize(K, &m_, nullptr));
    MORSE_CALL(MatGetOwnershipRange(K, &rstart_, nullptr));
    MORSE_CALL(MatCreateDense(comm, m_, PETSC_DECIDE, PETSC_DETERMINE, kmax, nullptr, Q_.ptr()));
    MORSE_CALL(MatCreateDense(comm, m_, PETSC_DECIDE, PETSC_DETERMINE, kmax, nullptr, MQ_.ptr()));
    for (UMat* X : {&W_, &RHS_})
      MORSE_CALL(MatCreateDense(comm, m_, PETSC_DECIDE, PETSC_DETERMINE, b, nullptr, X->ptr()));
    H_.assign(static_cast<std::size_t>(kmax) * kmax, 0.0);
  }

  /// Runs until nev Ritz pairs (largest |theta|) are converged. Returns false if the restarts
  /// run out. theta and Y (m x nev, column-major) and m describe the result.
  bool run(PetscInt nev, double tol, PetscInt max_restarts, Progress* progress) {
    // Start block: deterministic pseudo-random, M-orthonormalized.
    {
      Local w = local(W_.get());
      for (PetscInt c = 0; c < b_; ++c)
        for (PetscInt r = 0; r < m_; ++r)
          w.a[r + w.ld * c] =
              uniform(static_cast<std::uint64_t>(rstart_ + r) * 1315423911ull + static_cast<std::uint64_t>(c));
      restore(W_.get(), w);
    }
    std::vector<double> R;
    normalize(0, &R);
    store_block(0);
    PetscInt k = b_;
    // Rayleigh–Ritz when the basis first exceeds nev and then at four equal steps up to the full
    // basis (it costs O(k^3) on every rank), and always before a restart.
    nev_ = nev;
    auto step = [&](PetscInt from) { return std::max(b_, ((kmax_ - from) / 4 / b_) * b_); };
    PetscInt next_check = std::min(kmax_, nev + b_), check_step = step(next_check);
    for (restarts_ = 0; restarts_ <= max_restarts; ++restarts_) {
      PetscInt m = 0, nconv = 0;
      std::vector<std::pair<PetscInt, PetscInt>> seen;  // (basis, converged) at this cycle's checks
      while (true) {
        const bool full = k + b_ > kmax_;
        if (full || k >= next_check) {
          m = k - b_;
          const double t_before = t_rr_;
          {
            Phase ph("BlockRayleighRitz", &t_rr_);
            rayleigh_ritz(m);
            nconv = converged(m, tol);
          }
          if (monitor_)
            print0(comm_, "  block monitor: restart %d, basis %d, %d of %d pairs converged (Rayleigh-Ritz %.2f s)\n",
                   (int)restarts_, (int)m, (int)nconv, (int)nev, t_rr_ - t_before);
          if (progress) progress->update(static_cast<double>(std::min(nconv, nev)));
          m_used_ = m;
          if (nconv >= nev) return true;
          if (full) break;
          seen.emplace_back(m, nconv);
          next_check = k + next_step(seen, nev, check_step);
        }
        expand(k);
        k += b_;
      }
      if (restarts_ == max_restarts) break;
      // Krylov–Schur restart: keep p Ritz vectors, then the residual block.
      const PetscInt p = std::min(std::max(std::min(m - b_, (nev + m) / 2), std::min(nconv + 1, m - b_)), nritz_);
      {
        Phase ph("BlockRestart", &t_restart_);
        restart(m, p);
      }
      k = p + b_;
      check_step = step(k);
      next_check = std::min(kmax_, k + check_step);
    }
    return false;
  }

  /// Rayleigh–Ritz every this many blocks (0: adaptive, see next_step); print each check.
  void set_checks(PetscInt every, bool monitor) {
    check_every_ = every;
    monitor_ = monitor;
  }
  PetscInt restarts() const { return restarts_; }
  /// theta of the converged Ritz pairs beyond the first nev (the last Rayleigh–Ritz).
  std::vector<double> converged_beyond(PetscInt nev, double tol) const {
    std::vector<double> t;
    for (PetscInt i = nev; i < nritz_; ++i)
      if (res_[i] <= tol * std::abs(theta_[i])) t.push_back(theta_[i]);
    return t;
  }
  PetscInt dim() const { return m_used_; }
  const std::vector<double>& theta() const { return theta_; }

  /// The Ritz vectors of the pairs `pick` (indices into the wanted order), in that order, into
  /// the first pick.size() columns of the basis Q, in place: Q[:, j] = Q[:, 0:m] Y[:, pick[j]],
  /// one block of rows at a time (rows are independent), so no second n x count matrix is
  /// needed. The solver cannot continue afterwards. Returns Q.
  Mat ritz_vectors_in_place(const std::vector<PetscInt>& pick) {
    const PetscInt count = static_cast<PetscInt>(pick.size()), m = m_used_;
    std::vector<double> Yp(static_cast<std::size_t>(m) * count);
    for (PetscInt j = 0; j < count; ++j)
      std::copy_n(&Y_[static_cast<std::size_t>(m) * pick[j]], m, &Yp[static_cast<std::size_t>(m) * j]);
    times_in_place(Q_.get(), m, Yp.data(), count);
    return Q_.get();
  }
  /// Frees everything but the basis Q (M Q and the block work matrices): memory for the result.
  void release_work() {
    MQ_.reset();
    W_.reset();
    MW_.reset();
    RHS_.reset();
  }
  void release_basis() { Q_.reset(); }

 private:
  Local local(Mat A) {
    Local l;
    MORSE_CALL(MatDenseGetArray(A, &l.a));
    MORSE_CALL(MatDenseGetLDA(A, &l.ld));
    l.ld = std::max<PetscInt>(l.ld, 1);
    return l;
  }
  void restore(Mat A, Local& l) { MORSE_CALL(MatDenseRestoreArray(A, &l.a)); }
  const PetscBLASInt* ptr(PetscInt v) {
    scratch_[next_ = (next_ + 1) % 8] = blas(v);
    return &scratch_[next_];
  }
  PetscBLASInt& mloc() {
    mloc_ = blas(m_);
    return mloc_;
  }

  // A[:, 0:count] = A[:, 0:m] Y (Y m x count, column-major), in place, one block of 512 rows at a
  // time (row i of the product needs only row i of A): no n x count temporary, so restarts and
  // the final Ritz vectors need no memory beyond the basis.
  void times_in_place(Mat A, PetscInt m, const double* Y, PetscInt count) {
    if (count <= 0) return;
    Local q = local(A);
    const PetscScalar one = 1, zero = 0;
    const PetscInt rb = 512;
    std::vector<double> tmp(static_cast<std::size_t>(rb) * count);
    for (PetscInt r0 = 0; r0 < m_; r0 += rb) {
      const PetscInt rows = std::min(rb, m_ - r0);
      BLASgemm_("N", "N", ptr(rows), ptr(count), ptr(m), &one, q.a + r0, ptr(q.ld), Y, ptr(m), &zero, tmp.data(),
                ptr(rows));
      for (PetscInt c = 0; c < count; ++c)
        std::copy_n(&tmp[static_cast<std::size_t>(rows) * c], rows, q.a + r0 + q.ld * c);
    }
    restore(A, q);
  }

  // C (k x nb, column-major) = A^T B over all ranks, A and B local (m_ rows).
  void gram(const PetscScalar* A, PetscInt lda, PetscInt k, const PetscScalar* B, PetscInt ldb, PetscInt nb,
            std::vector<double>* C) {
    C->assign(static_cast<std::size_t>(k) * nb, 0.0);
    const PetscScalar one = 1, zero = 0;
    if (m_ > 0 && k > 0)
      BLASgemm_("T", "N", ptr(k), ptr(nb), &mloc(), &one, A, ptr(lda), B, ptr(ldb), &zero, C->data(), ptr(k));
    MPI_Allreduce(MPI_IN_PLACE, C->data(), static_cast<int>(C->size()), MPI_DOUBLE, MPI_SUM, comm_);
  }

  void mult_M(Mat X, UMat* MX) {
    if (*MX) {
      Mat reuse = MX->get();
      MORSE_CALL(MatMatMult(M_, X, MAT_REUSE_MATRIX, PETSC_DEFAULT, &reuse));
    } else {
      MORSE_CALL(MatMatMult(M_, X, MAT_INITIAL_MATRIX, PETSC_DEFAULT, MX->ptr()));
    }
  }

  // How W is made M-orthogonal to Q[:, 0:k] by classical Gram–Schmidt (W -= Q C with
  // C = (M Q)^T W, so no product with M is needed):
  //   Twice:  two passes against all of Q (CGS2);
  //   Local:  against the last two blocks, then one pass against all of Q. Op is M-self-adjoint,
  //           so W = Op Q_j is, in exact arithmetic, orthogonal to every block but the last two
  //           (block Lanczos); the local pass removes the large components, the global one what
  //           rounding left. normalize() checks the global pass (DGKS) and repeats it if it
  //           still cancelled much of W;
  //   Once:   one pass against all of Q (that repetition).
  enum class Passes { Twice, Local, Once };

  // Adds the coefficients to H[0:k, col:col+b] if record. Returns the squared norms of the last
  // pass's coefficient columns (the M-norm that pass removed). MW is left stale.
  std::vector<double> orthogonalize(PetscInt k, PetscInt col, bool record, Passes how = Passes::Twice) {
    std::vector<double> removed(b_, 0.0);
    if (k == 0) return removed;
    std::vector<std::pair<PetscInt, PetscInt>> ranges;  // [j0, j1) of Q per pass
    if (how == Passes::Local)
      ranges = {{std::max<PetscInt>(0, k - 2 * b_), k}, {0, k}};
    else if (how == Passes::Once)
      ranges = {{0, k}};
    else
      ranges = {{0, k}, {0, k}};
    std::vector<double> C;
    for (const auto& [j0, j1] : ranges) {
      const PetscInt kk = j1 - j0;
      Local q = local(Q_.get()), mq = local(MQ_.get()), w = local(W_.get());
      gram(mq.a + mq.ld * j0, mq.ld, kk, w.a, w.ld, b_, &C);
      const PetscScalar minus = -1, one = 1;
      if (m_ > 0)
        BLASgemm_("N", "N", &mloc(), ptr(b_), ptr(kk), &minus, q.a + q.ld * j0, ptr(q.ld), C.data(), ptr(kk), &one, w.a,
                  ptr(w.ld));
      restore(W_.get(), w);
      restore(MQ_.get(), mq);
      restore(Q_.get(), q);
      if (record)
        for (PetscInt c = 0; c < b_; ++c)
          for (PetscInt r = 0; r < kk; ++r) H_[j0 + r + kmax_ * (col + c)] += C[r + kk * c];
      for (PetscInt c = 0; c < b_; ++c) {
        double s2 = 0;
        for (PetscInt r = 0; r < kk; ++r) s2 += C[r + kk * c] * C[r + kk * c];
        removed[c] = s2;
      }
    }
    return removed;
  }

  // M-orthonormalizes W against itself (SVQB, twice unless the block is well conditioned), given nothing; k = columns
  // of Q it must stay orthogonal to when directions are replaced. R (b x b, column-major) is returned with W_in = W_out
  // R. Directions that vanish (an invariant subspace) are replaced by new random vectors orthogonal to Q, with zero
  // rows in R. M W is computed afresh at each pass (after Gram–Schmidt W can be much smaller than before, so an M W
  // carried along would have lost its accuracy) and carried through the pass's transformation, so MW = M W on return; a
  // well-conditioned block stops after one pass. With `removed` (the squared coefficient norms of a Local
  // orthogonalization's global pass, recorded into H column col): if that pass removed more of a column than it left
  // (DGKS,
  // ||C_c||^2 > ||W_c||_M^2), the global pass is repeated before anything else.
  void normalize(PetscInt k, std::vector<double>* R, const std::vector<double>* removed = nullptr, PetscInt col = 0) {
    R->assign(static_cast<std::size_t>(b_) * b_, 0.0);
    for (PetscInt i = 0; i < b_; ++i) (*R)[i + b_ * i] = 1.0;
    int attempts = 0;
    bool checked = removed == nullptr;
    for (int pass = 0; pass < 2; ++pass) {
      mult_M(W_.get(), &MW_);
      Local w = local(W_.get()), mw = local(MW_.get());
      std::vector<double> G;
      gram(w.a, w.ld, b_, mw.a, mw.ld, b_, &G);
      restore(MW_.get(), mw);
      restore(W_.get(), w);
      if (!checked) {
        checked = true;
        bool again = false;
        for (PetscInt c = 0; c < b_; ++c) again = again || (*removed)[c] > G[c + b_ * c];
        if (again) {
          ++extra_passes_;
          orthogonalize(k, col, true, Passes::Once);
          pass = -1;
          continue;
        }
      }
      for (PetscInt i = 0; i < b_; ++i)
        for (PetscInt j = 0; j < i; ++j) G[i + b_ * j] = G[j + b_ * i] = 0.5 * (G[i + b_ * j] + G[j + b_ * i]);
      std::vector<double> lam(b_), work(std::max<PetscInt>(1, 8 * b_));
      PetscBLASInt info = 0, lwork = blas(work.size());
      LAPACKsyev_("V", "U", ptr(b_), G.data(), ptr(b_), lam.data(), work.data(), &lwork, &info);
      MORSE_CHECK(info == 0, "block eigen solver: LAPACK syev failed (", info, ")");
      const double top = std::max(lam[b_ - 1], 0.0);
      // T = S diag(1/sqrt(lam)) for the kept directions; Rp = diag(sqrt(lam)) S^T.
      std::vector<double> T(static_cast<std::size_t>(b_) * b_, 0.0), Rp(static_cast<std::size_t>(b_) * b_, 0.0);
      std::vector<PetscInt> lost;
      for (PetscInt c = 0; c < b_; ++c) {
        if (!(lam[c] > 1e-20 * top) || top == 0) {
          lost.push_back(c);
          continue;
        }
        const double s = std::sqrt(lam[c]);
        for (PetscInt r = 0; r < b_; ++r) {
          T[r + b_ * c] = G[r + b_ * c] / s;
          Rp[c + b_ * r] = G[r + b_ * c] * s;
        }
      }
      apply_right(W_.get(), T);
      apply_right(MW_.get(), T);
      // R = Rp R
      std::vector<double> Rn(static_cast<std::size_t>(b_) * b_, 0.0);
      for (PetscInt c = 0; c < b_; ++c)
        for (PetscInt r = 0; r < b_; ++r) {
          double v = 0;
          for (PetscInt t = 0; t < b_; ++t) v += Rp[r + b_ * t] * (*R)[t + b_ * c];
          Rn[r + b_ * c] = v;
        }
      R->swap(Rn);
      if (!lost.empty()) {
        MORSE_CHECK(++attempts < 8, "block eigen solver: the Krylov space cannot be extended (", lost.size(),
                    " directions lost repeatedly); lower -<prefix>block_max_dim");
        // New random directions in the lost columns, orthogonal to Q and to the kept columns.
        Local w2 = local(W_.get());
        for (PetscInt c : lost)
          for (PetscInt r = 0; r < m_; ++r)
            w2.a[r + w2.ld * c] =
                uniform((static_cast<std::uint64_t>(rstart_ + r) * 2654435761ull) ^ (0x5bd1e995ull * (replaced_ + 1)));
        restore(W_.get(), w2);
        ++replaced_;
        orthogonalize(k, 0, false);
        pass = -1;  // start the two passes again (R keeps zero rows for the new directions)
        continue;
      }
      // A well-conditioned block (kappa(G) <= 100, kappa(W) <= 10) is M-orthonormal to about
      // eps kappa(G) after one SVQB pass, and M W carried through its T (no Gram–Schmidt in
      // between) is as accurate as a fresh product: the second pass, and its product with M,
      // would change nothing. Ill-conditioned blocks get both.
      if (pass == 0 && lam[0] >= 1e-2 * top) {
        ++single_svqb_;
        break;
      }
    }
  }

  // X <- X T (b x b) for an MPIDENSE X with b columns.
  void apply_right(Mat X, const std::vector<double>& T) {
    Local x = local(X);
    std::vector<double> tmp(static_cast<std::size_t>(m_) * b_);
    const PetscScalar one = 1, zero = 0;
    if (m_ > 0) {
      BLASgemm_("N", "N", &mloc(), ptr(b_), ptr(b_), &one, x.a, ptr(x.ld), T.data(), ptr(b_), &zero, tmp.data(),
                ptr(m_));
      for (PetscInt c = 0; c < b_; ++c) std::copy_n(&tmp[static_cast<std::size_t>(m_) * c], m_, x.a + x.ld * c);
    }
    restore(X, x);
  }

  // Q[:, col:col+b] = W, MQ[:, col:col+b] = RHS = M W (= MW after normalize).
  void store_block(PetscInt col) {
    Local q = local(Q_.get()), mq = local(MQ_.get()), w = local(W_.get()), mw = local(MW_.get()),
          rhs = local(RHS_.get());
    for (PetscInt c = 0; c < b_; ++c) {
      std::copy_n(w.a + w.ld * c, m_, q.a + q.ld * (col + c));
      std::copy_n(mw.a + mw.ld * c, m_, mq.a + mq.ld * (col + c));
      std::copy_n(mw.a + mw.ld * c, m_, rhs.a + rhs.ld * c);
    }
    restore(RHS_.get(), rhs);
    restore(MQ_.get(), mq);
    restore(MW_.get(), mw);
    restore(W_.get(), w);
    restore(Q_.get(), q);
  }

  // One block step: W = Op Q[:, k-b:k], orthogonalized against Q[:, 0:k], normalized into
  // Q[:, k:k+b]; fills H[0:k+b, k-b:k].
  void expand(PetscInt k) {
    const PetscInt j0 = k - b_;
    {
      Phase ph("BlockSolve", &t_solve_);
      MORSE_CALL(MatMatSolve(F_, RHS_.get(), W_.get()));
    }
    ++solves_;
    Phase ph("BlockOrthogonalize", &t_orth_);
    const auto removed = orthogonalize(k, j0, true, Passes::Local);
    std::vector<double> R;
    normalize(k, &R, &removed, j0);
    for (PetscInt c = 0; c < b_; ++c)
      for (PetscInt r = 0; r < b_; ++r) H_[(k + r) + kmax_ * (j0 + c)] = R[r + b_ * c];
    store_block(k);
  }

  // Vectors to add before the next Rayleigh–Ritz, given this cycle's checks (basis, converged).
  // Rayleigh–Ritz costs O(m^3) on every rank (5 s at m = 2,144 for the stator's 1000 modes), a
  // block a few tenths of a second, so checks should be few and land just past convergence:
  // once two checks show progress, the basis where the converged count reaches nev is
  // extrapolated linearly from the last two, and the check is placed one block beyond it (at
  // most twice `fallback` ahead, the equal step to the full basis); before that, `fallback`.
  // Measured on the stator (1000 modes, -block_monitor): the converged count grows by 50–100 per
  // 128 vectors, a little concave, then jumps (919 to 1016) at the end; the checks land at 1,008,
  // 1,296, 1,872 and 2,064 vectors against 1,016, 1,312, 1,608, 1,904 and 2,144 with equal steps.
  PetscInt next_step(const std::vector<std::pair<PetscInt, PetscInt>>& seen, PetscInt nev, PetscInt fallback) const {
    if (check_every_ > 0) return check_every_ * b_;
    if (seen.size() < 2) return fallback;
    const auto [m1, n1] = seen[seen.size() - 2];
    const auto [m2, n2] = seen.back();
    if (n2 <= n1) return fallback;
    const double slope = static_cast<double>(n2 - n1) / static_cast<double>(m2 - m1);
    const double more = static_cast<double>(nev - n2) / slope;
    const PetscInt blocks = static_cast<PetscInt>(std::ceil(more / static_cast<double>(b_))) + 1;
    return std::clamp<PetscInt>(blocks * b_, b_, 2 * fallback);
  }

  // Residuals ||B y_i|| of the Ritz pairs (B = H[m:m+b, 0:m], the coupling to the residual
  // block); returns how many leading pairs satisfy ||B y_i|| <= tol |theta_i|.
  PetscInt converged(PetscInt m, double tol) {
    res_.assign(nritz_, 0.0);
    for (PetscInt i = 0; i < nritz_; ++i) {
      double s2 = 0;
      for (PetscInt r = 0; r < b_; ++r) {
        double v = 0;
        for (PetscInt c = 0; c < m; ++c) v += H_[(m + r) + kmax_ * c] * Y_[c + m * i];
        s2 += v * v;
      }
      res_[i] = std::sqrt(s2);
    }
    PetscInt nconv = 0;
    while (nconv < nritz_ && res_[nconv] <= tol * std::abs(theta_[nconv])) ++nconv;
    return nconv;
  }

  // Ritz pairs of the symmetric part of H[0:m, 0:m], in the wanted order (largest |theta|).
  // Only the pairs a restart or the result can use are computed (LAPACK syevr, MRRR): the
  // largest max(nev, (nev + m)/2) + 1 when every theta is positive (shift below the spectrum:
  // K - shift M positive definite), else all of them, ordered by |theta|.
  void rayleigh_ritz(PetscInt m) {
    std::vector<double> A(static_cast<std::size_t>(m) * m), lam(m);
    for (PetscInt c = 0; c < m; ++c)
      for (PetscInt r = 0; r < m; ++r) A[r + m * c] = 0.5 * (H_[r + kmax_ * c] + H_[c + kmax_ * r]);
    const PetscInt want = positive_ ? std::min(m, std::max(nev_, (nev_ + m) / 2) + 1) : m;
    std::vector<double> Z(static_cast<std::size_t>(m) * want);
    std::vector<PetscBLASInt> isuppz(2 * static_cast<std::size_t>(std::max<PetscInt>(want, 1)));
    const PetscBLASInt nm = blas(m), il = blas(m - want + 1), iu = blas(m);
    PetscBLASInt found = 0, info = 0, lwork = -1, liwork = -1, iwq = 0;
    const double zero = 0.0;
    double wq = 0;
    const char* range = positive_ ? "I" : "A";
    dsyevr_("V", range, "U", &nm, A.data(), &nm, &zero, &zero, &il, &iu, &zero, &found, lam.data(), Z.data(), &nm,
            isuppz.data(), &wq, &lwork, &iwq, &liwork, &info);
    lwork = static_cast<PetscBLASInt>(wq);
    liwork = iwq;
    std::vector<double> work(std::max<PetscBLASInt>(lwork, 1));
    std::vector<PetscBLASInt> iwork(std::max<PetscBLASInt>(liwork, 1));
    dsyevr_("V", range, "U", &nm, A.data(), &nm, &zero, &zero, &il, &iu, &zero, &found, lam.data(), Z.data(), &nm,
            isuppz.data(), work.data(), &lwork, iwork.data(), &liwork, &info);
    MORSE_CHECK(info == 0 && found == want, "block eigen solver: LAPACK syevr failed on the projected matrix (", info,
                ", ", found, " of ", want, " pairs)");
    std::vector<PetscInt> order(want);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](PetscInt a, PetscInt b) { return std::abs(lam[a]) > std::abs(lam[b]); });
    nritz_ = want;
    theta_.resize(want);
    Y_.resize(static_cast<std::size_t>(m) * want);
    for (PetscInt i = 0; i < want; ++i) {
      theta_[i] = lam[order[i]];
      std::copy_n(&Z[static_cast<std::size_t>(m) * order[i]], m, &Y_[static_cast<std::size_t>(m) * i]);
    }
  }

  // Keeps the first p Ritz vectors of the m-dimensional basis and the residual block Q[:, m:m+b]
  // (the same combinations of M Q in MQ).
  void restart(PetscInt m, PetscInt p) {
    for (Mat A : {Q_.get(), MQ_.get()}) {
      times_in_place(A, m, Y_.data(), p);
      Local q = local(A);
      if (m_ > 0)
        for (PetscInt c = 0; c < b_; ++c) std::copy_n(q.a + q.ld * (m + c), m_, q.a + q.ld * (p + c));
      restore(A, q);
    }
    // H: diag(theta) coupled to the residual block by B Y.
    std::vector<double> BY(static_cast<std::size_t>(b_) * p, 0.0);
    for (PetscInt i = 0; i < p; ++i)
      for (PetscInt r = 0; r < b_; ++r) {
        double v = 0;
        for (PetscInt c = 0; c < m; ++c) v += H_[(m + r) + kmax_ * c] * Y_[c + m * i];
        BY[r + b_ * i] = v;
      }
    std::fill(H_.begin(), H_.end(), 0.0);
    for (PetscInt i = 0; i < p; ++i) {
      H_[i + kmax_ * i] = theta_[i];
      for (PetscInt r = 0; r < b_; ++r) H_[(p + r) + kmax_ * i] = BY[r + b_ * i];
    }
    // RHS still holds M times the residual block (the last block stored).
  }

  Mat K_, M_, F_;
  PetscInt b_, kmax_;
  MPI_Comm comm_;
  PetscInt m_ = 0, rstart_ = 0;
  UMat Q_, MQ_, W_, MW_, RHS_;
  std::vector<double> H_, theta_, Y_, res_;
  PetscInt restarts_ = 0, m_used_ = 0, replaced_ = 0, nev_ = 0, nritz_ = 0;
  bool positive_ = true;  // every theta > 0 (shift below the spectrum)
  PetscInt check_every_ = 0;
  bool monitor_ = false;
  PetscBLASInt scratch_[8] = {}, mloc_ = 0;
  int next_ = 0;

 public:
  PetscInt solves_ = 0, extra_passes_ = 0, single_svqb_ = 0;
  double t_solve_ = 0, t_orth_ = 0, t_rr_ = 0, t_restart_ = 0;
};

// The basis in whole blocks of bb, at most n: kmax if given, else k + max(1.2 k, 6 blocks)
// (measured on the stator, 1000 modes: a basis of 2.2 k converges without a restart, which
// 2 k does not, and the restart costs more than the extra vectors).
PetscInt basis_size(PetscInt n, PetscInt k, PetscInt bb, PetscInt kmax) {
  const PetscInt want = kmax >= 0 ? kmax : k + std::max((6 * k + 4) / 5, 6 * bb);
  const PetscInt d = std::min(n, ((want + bb - 1) / bb) * bb);
  return d == n ? (n / bb) * bb : d;
}

// The default basis (kdim vectors) capped so that Q and M Q (2 kdim doubles per local row) fit
// in 70 % of the memory available on each node once the factor exists, the ranks of a node
// sharing it; the same on every rank. A cap below nev + 2 blocks is an error that says what the
// solve needs. Collective.
PetscInt memory_capped_basis(MPI_Comm comm, PetscInt m_local, PetscInt nev, PetscInt b, PetscInt kdim, double budget_gb,
                             const EigenSettings& s, double share = 1.0) {
  MPI_Comm node;
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  double rows = static_cast<double>(m_local);
  MPI_Allreduce(MPI_IN_PLACE, &rows, 1, MPI_DOUBLE, MPI_SUM, node);
  MPI_Comm_free(&node);
  const double avail = available_bytes();
  // The budget of the basis on a node: -block_memory_gb, else 70 % of what is available.
  // `share`: the fraction of it this solve may take (slices solved side by side on one node).
  const double budget = share * (budget_gb > 0 ? budget_gb * 1e9 : (avail > 0 ? 0.7 * avail : -1.0));
  // Vectors of the basis that fit on this node (+inf if the memory is unknown).
  double fit = budget > 0 && rows > 0 ? budget / (2.0 * sizeof(double) * rows) : 1e300;
  MPI_Allreduce(MPI_IN_PLACE, &fit, 1, MPI_DOUBLE, MPI_MIN, comm);
  if (fit >= static_cast<double>(kdim)) return kdim;
  const PetscInt cap = static_cast<PetscInt>(fit / b) * b;
  const double need_gb = 2.0 * sizeof(double) * rows * static_cast<double>(nev + 2 * b) / 1e9;
  collective_check(
      comm, cap >= nev + 2 * b
                ? std::string()
                : cat(s.what, ": the block basis for ", nev, " modes needs at least ", nev + 2 * b, " vectors, about ",
                      need_gb, " GB on a node, and the basis may use ", budget / 1e9, " GB (-", s.prefix,
                      "block_memory_gb, default 70 % of the memory available): "
                      "ask for fewer modes per solve, run on more nodes, or use -",
                      s.prefix, "eigen_solver krylovschur"));
  print0(comm,
         "  %s: block basis capped at %d vectors (default %d) to fit Q and M Q in %.3g GB per node (%s): expect "
         "restarts; -%sblock_max_dim sets the basis\n",
         s.what.c_str(), (int)cap, (int)kdim, budget / 1e9,
         budget_gb > 0 ? cat("-", s.prefix, "block_memory_gb").c_str()
                       : cat("70% of the ", avail / 1e9, " GB available after the factorization").c_str(),
         s.prefix.c_str());
  return cap;
}

// One MUMPS symmetric factorization of K - shift M (LDL^T: indefinite for a shift inside the
// spectrum), its wall time in *seconds (the Factor stage if `timed`); with `for_inertia` its
// root front stays unsplit (ICNTL(13) = 1) so that the Sylvester check can refactor it. A
// singular K (null pivots at shift 0) throws detail::SingularAtZero, which solve_eigen answers
// with a negative shift.
UMat factor_shifted(Mat K, Mat M, double shift, const EigenSettings& s, double* seconds, bool timed, bool for_inertia) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  std::unique_ptr<StageTimer> timer;
  if (timed) timer = std::make_unique<StageTimer>(comm, s.stage + "Factor");
  auto t0 = std::chrono::steady_clock::now();
  UMat A, F;
  Mat Ash = K;
  if (shift != 0.0) {
    MORSE_CALL(MatDuplicate(K, MAT_COPY_VALUES, A.ptr()));
    MORSE_CALL(MatAXPY(A.get(), -shift, M, DIFFERENT_NONZERO_PATTERN));
    MORSE_CALL(MatSetOption(A.get(), MAT_SYMMETRIC, PETSC_TRUE));
    Ash = A.get();
  }
  MORSE_CALL(MatGetFactor(Ash, cholesky_solver(Ash), MAT_FACTOR_CHOLESKY, F.ptr()));
  MORSE_CALL(MatSetOptionsPrefix(F.get(), (s.prefix + "block_").c_str()));
  MORSE_CALL(MatMumpsSetIcntl(F.get(), 24, 1));  // null pivots: singular K
  MORSE_CALL(MatSetFromOptions(F.get()));
  // A factor that the Sylvester check will refactor for its inertia: the root front unsplit
  // (ScaLAPACK's root has no inertia), set after the user's options as in InertiaCounter.
  if (for_inertia) MORSE_CALL(MatMumpsSetIcntl(F.get(), 13, 1));
  MatFactorInfo info;
  MORSE_CALL(MatFactorInfoInitialize(&info));
  MORSE_CALL(MatCholeskyFactorSymbolic(F.get(), Ash, nullptr, &info));
  MORSE_CALL(MatCholeskyFactorNumeric(F.get(), Ash, &info));
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  detail::check_null_pivots(comm, F.get(), shift, s.what);
  // Every -<prefix>block_ option has been read now (the solver's at its start, the factor's
  // here): a misspelled one is refused before the solve, not at the end of the run.
  options::check_prefix_used(comm, s.prefix + "block_", cat("the block eigen solver of the ", s.what));
  return F;
}

// dst[:, j] = src[:, cols[j].second] (MPIDENSE, the same row layout).
void copy_columns(Mat src, const std::vector<std::pair<double, PetscInt>>& cols, Mat dst) {
  const PetscScalar* a = nullptr;
  PetscScalar* d = nullptr;
  PetscInt lda = 0, ldd = 0, m = 0;
  MORSE_CALL(MatGetLocalSize(src, &m, nullptr));
  MORSE_CALL(MatDenseGetLDA(src, &lda));
  MORSE_CALL(MatDenseGetLDA(dst, &ldd));
  MORSE_CALL(MatDenseGetArrayRead(src, &a));
  MORSE_CALL(MatDenseGetArray(dst, &d));
  for (std::size_t j = 0; j < cols.size(); ++j)
    std::copy_n(a + lda * cols[j].second, m, d + ldd * static_cast<PetscInt>(j));
  MORSE_CALL(MatDenseRestoreArray(dst, &d));
  MORSE_CALL(MatDenseRestoreArrayRead(src, &a));
}

// The block solver's options (-<prefix>block_*, -<prefix>eps_tol).
struct BlockOptions {
  PetscInt b = -1, kmax = -1, max_restarts = 200, check_every = 0, slices = 1, partitions = 1;
  PetscBool monitor = PETSC_FALSE;
  PetscReal tol = 0, memory_gb = -1;
};

BlockOptions block_options(MPI_Comm comm, const EigenSettings& s) {
  BlockOptions o;
  o.tol = s.tol;
  options::add_prefix(s.prefix, options::Solver::Eigen);
  auto get_options = [&]() -> PetscErrorCode {
    PetscOptionsBegin(comm, s.prefix.c_str(), "morse block eigen solver", "");
    PetscCall(MorseOptionsInt("-block_size",
                              "Vectors per block (one multi-RHS MUMPS solve each; default 8 below 100 "
                              "modes, else 16)",
                              "", o.b, &o.b, nullptr));
    PetscCall(MorseOptionsInt("-block_max_dim", "Largest basis before a restart (default nev + max(1.2 nev, 6 blocks))",
                              "", o.kmax, &o.kmax, nullptr));
    PetscCall(MorseOptionsReal("-block_memory_gb",
                               "Memory for the basis (Q and M Q) per node [GB] when -block_max_dim is not given "
                               "(default: 70% of the memory available after the factorization)",
                               "", o.memory_gb, &o.memory_gb, nullptr));
    PetscCall(MorseOptionsInt("-block_max_restarts", "Restarts before giving up", "", o.max_restarts, &o.max_restarts,
                              nullptr));
    PetscCall(MorseOptionsInt("-block_check_every",
                              "Rayleigh-Ritz every N blocks (default 0: adaptive, extrapolated "
                              "from the converged counts)",
                              "", o.check_every, &o.check_every, nullptr));
    PetscCall(MorseOptionsBool("-block_monitor", "Print the converged count at every Rayleigh-Ritz", "", o.monitor,
                               &o.monitor, nullptr));
    PetscCall(MorseOptionsInt("-block_slices",
                              "Spectrum slicing: solve [0, cutoff] in this many slices, one shift and "
                              "one Sylvester count each (default 1: one shift; -block_partitions if that is larger)",
                              "", o.slices, &o.slices, nullptr));
    PetscCall(MorseOptionsInt("-block_partitions",
                              "Subcommunicators solving slices side by side (each holds a copy of "
                              "K and M and its own factorizations)",
                              "", o.partitions, &o.partitions, nullptr));
    PetscCall(
        MorseOptionsReal("-eps_tol", "Relative residual tolerance of the Ritz pairs", "", o.tol, &o.tol, nullptr));
    PetscOptionsEnd();
    return PETSC_SUCCESS;
  };
  MORSE_CALL(get_options());
  MORSE_CHECK(o.b >= 1 || o.b == -1, "-", s.prefix, "block_size must be >= 1 (got ", o.b, ")");
  MORSE_CHECK(o.check_every >= 0, "-", s.prefix, "block_check_every must be >= 0 (got ", o.check_every, ")");
  MORSE_CHECK(o.partitions >= 1, "-", s.prefix, "block_partitions must be >= 1 (got ", o.partitions, ")");
  MORSE_CHECK(o.slices >= 1, "-", s.prefix, "block_slices must be >= 1 (got ", o.slices, ")");
  if (o.slices < o.partitions) o.slices = o.partitions;
  return o;
}

// Block size and basis for nev pairs of an n-DOF problem; false if nev + 2 blocks do not fit
// (nearly every mode of the problem wanted).
bool block_shape(PetscInt n, PetscInt nev, const BlockOptions& o, const EigenSettings& s, PetscInt* b_out,
                 PetscInt* kdim) {
  // Measured (bench/README.md, eigen_bench.py): 50 modes of the rotor 37 deck are fastest with
  // blocks of 8 (fewer vectors solved), 1000 of the stator with 16 (32 needs a restart).
  PetscInt b = o.b < 0 ? (nev < 100 ? 8 : 16) : o.b;
  MORSE_CHECK(o.kmax < 0 || o.kmax >= std::min(n, nev + 2 * b), "-", s.prefix, "block_max_dim ", o.kmax,
              " is too small for ", nev, " modes with blocks of ", b, " (at least nev + 2 blocks)");
  // A restart keeps at least nev Ritz vectors and the residual block, so the basis must hold
  // nev + 2 blocks, better 3. Small problems (n not far above nev) get smaller blocks.
  b = std::min(b, std::max<PetscInt>(1, n / 3));
  while (b > 1 && basis_size(n, nev, b, o.kmax) < nev + 3 * b) b = std::max<PetscInt>(1, b / 2);
  *b_out = b;
  *kdim = basis_size(n, nev, b, o.kmax);
  return *kdim >= nev + 2 * b;
}

// One count solve by the block solver: the nev pairs nearest `shift` (the lowest for shift <= 0),
// ascending. `timed`: the Factor, EigenSolve and EigenVectors stages are recorded (the slices
// of a spectrum-slicing solve, different on different subcommunicators, are not); `share`: the
// part of the node's memory the basis may take; `for_inertia`: the factor is made so that the
// Sylvester check can refactor it in place (MUMPS ICNTL(13) = 1).
struct CountSolve {
  std::vector<double> omega2;  // ascending
  UMat V, F;
  std::vector<double> extra;  // omega^2 of the other converged Ritz pairs
  PetscInt b = 0, kdim = 0, restarts = 0, solves = 0, extra_passes = 0, single_svqb = 0;
  double factor_seconds = 0, t_solve = 0, t_orth = 0, t_rr = 0, t_restart = 0;
};

CountSolve block_count_solve(Mat K, Mat M, PetscInt nev, double shift, const EigenSettings& s, const BlockOptions& o,
                             bool timed, double share, bool for_inertia, Progress* progress) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  PetscInt n = 0, m_local = 0;
  MORSE_CALL(MatGetSize(K, &n, nullptr));
  MORSE_CALL(MatGetLocalSize(K, &m_local, nullptr));
  CountSolve r;
  const bool fits = block_shape(n, nev, o, s, &r.b, &r.kdim);
  MORSE_CHECK(fits, s.what, ": ", nev, " pairs of ", n, " DOFs leave no room for a block basis");
  r.F = factor_shifted(K, M, shift, s, &r.factor_seconds, timed, for_inertia);
  if (o.kmax < 0) r.kdim = memory_capped_basis(comm, m_local, nev, r.b, r.kdim, o.memory_gb, s, share);
  // With shift <= 0 every theta = 1/(omega^2 - shift) is positive (K is semi-definite and was
  // factored without a null pivot), so the wanted ones are the largest.
  BlockSolver solver(K, M, r.F.get(), r.b, r.kdim, shift <= 0.0, comm);
  solver.set_checks(o.check_every, o.monitor);
  bool ok = false;
  {
    std::unique_ptr<StageTimer> timer;
    if (timed) timer = std::make_unique<StageTimer>(comm, s.stage + "EigenSolve");
    ok = solver.run(nev, o.tol, o.max_restarts, progress);
  }
  MORSE_CHECK(ok, s.what, ": the block solver did not converge ", nev, " pairs in ", o.max_restarts,
              " restarts; raise -", s.prefix, "block_max_dim or -", s.prefix, "block_max_restarts");
  r.restarts = solver.restarts();
  r.solves = solver.solves_;
  r.extra_passes = solver.extra_passes_;
  r.single_svqb = solver.single_svqb_;
  r.t_solve = solver.t_solve_;
  r.t_orth = solver.t_orth_;
  r.t_rr = solver.t_rr_;
  r.t_restart = solver.t_restart_;
  for (double t : solver.converged_beyond(nev, o.tol)) r.extra.push_back(shift + 1.0 / t);
  std::unique_ptr<StageTimer> timer;
  if (timed) timer = std::make_unique<StageTimer>(comm, s.stage + "EigenVectors");
  // Ascending omega^2 = shift + 1/theta. The Ritz vectors are formed in place in the basis and
  // the work matrices freed before V is allocated, so extraction never needs more memory than
  // the solve (for 1000 modes of 478k DOFs: 3.8 GB instead of 7.6 GB more).
  std::vector<std::pair<double, PetscInt>> order;
  for (PetscInt i = 0; i < nev; ++i) order.emplace_back(shift + 1.0 / solver.theta()[i], i);
  std::sort(order.begin(), order.end());
  std::vector<PetscInt> pick;
  std::vector<std::pair<double, PetscInt>> first;
  for (PetscInt j = 0; j < nev; ++j) {
    pick.push_back(order[j].second);
    first.emplace_back(order[j].first, j);
  }
  Mat Q = solver.ritz_vectors_in_place(pick);
  solver.release_work();
  MORSE_CALL(MatCreateDense(comm, m_local, PETSC_DECIDE, n, nev, nullptr, r.V.ptr()));
  copy_columns(Q, first, r.V.get());
  solver.release_basis();
  for (const auto& x : order) r.omega2.push_back(x.first);
  return r;
}

// Moves the columns of per-partition dense matrices (each on its subcommunicator, rows in that
// subcommunicator's layout of the same n global rows) into V (MPIDENSE on comm, its own row
// layout): column c of this partition's Vsub goes to column dest[c] of V (skipped if < 0). Every
// rank passes its own partition's Vsub (null if it has no columns) and dest. MPI_Alltoallv in
// rounds of at most 32 columns, so no message exceeds 32 local row blocks. Collective on comm.
void gather_columns(MPI_Comm comm, Mat Vsub, PetscInt sub_rstart, PetscInt sub_rend, const std::vector<PetscInt>& dest,
                    Mat V) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  const PetscInt* ranges = nullptr;
  MORSE_CALL(MatGetOwnershipRanges(V, &ranges));
  PetscInt vr0 = 0, vr1 = 0;
  MORSE_CALL(MatGetOwnershipRange(V, &vr0, &vr1));
  // Every rank's subcommunicator rows, and how many columns it sends per round.
  std::vector<PetscInt> sub0(size), sub1(size);
  MPI_Allgather(&sub_rstart, 1, MPIU_INT, sub0.data(), 1, MPIU_INT, comm);
  MPI_Allgather(&sub_rend, 1, MPIU_INT, sub1.data(), 1, MPIU_INT, comm);
  const PetscInt ncols = static_cast<PetscInt>(dest.size());
  std::vector<PetscInt> all_ncols(size);
  MPI_Allgather(&ncols, 1, MPIU_INT, all_ncols.data(), 1, MPIU_INT, comm);
  const PetscInt most = *std::max_element(all_ncols.begin(), all_ncols.end());
  // Every rank's destination columns (ranks of one partition have the same).
  std::vector<int> dcount(size), ddispl(size);
  for (int q = 0; q < size; ++q) dcount[q] = static_cast<int>(all_ncols[q]);
  for (int q = 1; q < size; ++q) ddispl[q] = ddispl[q - 1] + dcount[q - 1];
  std::vector<PetscInt> all_dest(static_cast<std::size_t>(ddispl[size - 1] + dcount[size - 1]));
  MPI_Allgatherv(dest.data(), static_cast<int>(ncols), MPIU_INT, all_dest.data(), dcount.data(), ddispl.data(),
                 MPIU_INT, comm);
  const PetscScalar* a = nullptr;
  PetscInt lda = 1;
  if (Vsub) {
    MORSE_CALL(MatDenseGetArrayRead(Vsub, &a));
    MORSE_CALL(MatDenseGetLDA(Vsub, &lda));
  }
  PetscScalar* v = nullptr;
  PetscInt ldv = 1;
  MORSE_CALL(MatDenseGetArray(V, &v));
  MORSE_CALL(MatDenseGetLDA(V, &ldv));
  const PetscInt round = 32;
  auto overlap = [](PetscInt a0, PetscInt a1, PetscInt b0, PetscInt b1) {
    return std::make_pair(std::max(a0, b0), std::min(a1, b1));
  };
  for (PetscInt c0 = 0; c0 < most; c0 += round) {
    std::vector<int> scount(size), sdispl(size), rcount(size), rdispl(size);
    std::vector<double> sendbuf, recvbuf;
    const PetscInt mine = std::max<PetscInt>(0, std::min(round, ncols - c0));
    for (int q = 0; q < size; ++q) {
      const auto [r0, r1] = overlap(sub_rstart, sub_rend, ranges[q], ranges[q + 1]);
      sdispl[q] = static_cast<int>(sendbuf.size());
      if (r1 > r0)
        for (PetscInt c = c0; c < c0 + mine; ++c)
          sendbuf.insert(sendbuf.end(), a + (r0 - sub_rstart) + lda * c, a + (r1 - sub_rstart) + lda * c);
      scount[q] = static_cast<int>(sendbuf.size()) - sdispl[q];
    }
    int total = 0;
    for (int q = 0; q < size; ++q) {
      const auto [r0, r1] = overlap(sub0[q], sub1[q], vr0, vr1);
      const PetscInt theirs = std::max<PetscInt>(0, std::min(round, all_ncols[q] - c0));
      rdispl[q] = total;
      rcount[q] = r1 > r0 ? static_cast<int>((r1 - r0) * theirs) : 0;
      total += rcount[q];
    }
    recvbuf.resize(static_cast<std::size_t>(total));
    MPI_Alltoallv(sendbuf.data(), scount.data(), sdispl.data(), MPI_DOUBLE, recvbuf.data(), rcount.data(),
                  rdispl.data(), MPI_DOUBLE, comm);
    for (int q = 0; q < size; ++q) {
      const auto [r0, r1] = overlap(sub0[q], sub1[q], vr0, vr1);
      if (r1 <= r0) continue;
      const PetscInt theirs = std::max<PetscInt>(0, std::min(round, all_ncols[q] - c0));
      for (PetscInt c = 0; c < theirs; ++c) {
        const PetscInt d = all_dest[static_cast<std::size_t>(ddispl[q] + c0 + c)];
        if (d < 0) continue;
        std::copy_n(&recvbuf[static_cast<std::size_t>(rdispl[q] + (r1 - r0) * c)], r1 - r0, v + (r0 - vr0) + ldv * d);
      }
    }
  }
  MORSE_CALL(MatDenseRestoreArray(V, &v));
  if (Vsub) MORSE_CALL(MatDenseRestoreArrayRead(Vsub, &a));
}

// Spectrum slicing with the block solver (theory §3): every eigenvalue in [0, top] (cutoff
// mode: top = the cutoff; count mode: a cutoff with nev to 1.2 nev below it from inertia
// counts, and the nev lowest kept). [0, top] is cut into S slices at beta_i = top (i/S)^(2/3)
// (Weyl's law N ~ omega^3 for a 3D solid: about equal counts), the eigenvalues in each counted by
// Sylvester's inertia at its ends, then found by a count solve about its middle: the n_i pairs
// nearest the middle are exactly those inside, so each slice is checked (n_i pairs, all inside)
// and the counts add up to N(top). The slices are spread over P subcommunicators (copies of K
// and M by MatCreateRedundantMatrix), which count and solve side by side; the eigenvectors are
// moved to K's layout at the end.
Eigenpairs solve_block_slices(Mat K, Mat M, const EigenSettings& s, const BlockOptions& o, Vec sign_ref) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  int size = 1, rank = 0;
  MPI_Comm_size(comm, &size);
  MPI_Comm_rank(comm, &rank);
  const PetscInt S = o.slices, P = o.partitions;
  MORSE_CHECK(P <= size && size % P == 0, "-", s.prefix, "block_partitions ", P, " must divide the number of ranks (",
              size, ")");
  MORSE_CHECK(s.omega2_max > 0 || s.shift == 0.0, s.what, ": spectrum slicing (-", s.prefix,
              "block_slices) finds the lowest modes; it takes no shift (got ", s.shift, ")");
  Eigenpairs out;
  out.slicing = true;
  out.partitions = P;
  const auto t_all = std::chrono::steady_clock::now();
  double top = s.omega2_max;
  PetscInt N = 0;
  if (s.omega2_max > 0) {
    StageTimer timer(comm, s.stage + "InertiaCount");
    InertiaCounter c(K, M, s.prefix);
    N = c.count(top);
    out.inertia_counts = 1;
    MORSE_CHECK(N > 0, s.what, ": no eigenvalue below the cutoff (omega^2 = ", top, ")");
  } else {
    MORSE_CHECK(s.nev > 0, s.what, ": the number of modes must be positive (got ", s.nev, ")");
    StageTimer timer(comm, s.stage + "SliceCutoff");
    top = count_cutoff(K, M, s.nev, s.prefix, s.what, &out.inertia_counts, &N);
  }
  out.inertia_count = N;
  out.slice_omega2 = top;
  const PetscInt n_out = s.omega2_max > 0 ? N : s.nev;
  // The slices' ends, and which partition takes which slice (slice i: partition i mod P).
  std::vector<double> beta(S + 1);
  for (PetscInt i = 0; i <= S; ++i)
    beta[i] = top * std::pow(static_cast<double>(i) / static_cast<double>(S), 2.0 / 3.0);
  beta[S] = top;
  // The lowest slice starts below 0 (at -1e-10 of the stiffness scale): the zero eigenvalues of a
  // model free in some rigid-body motions, computed as round-off of either sign, lie inside it,
  // and N(beta_0) = 0 holds for any model.
  beta[0] = -1e-10 * detail::stiffness_scale(K, M);
  const int part = static_cast<int>(rank / (size / P));
  MPI_Comm sub = MPI_COMM_NULL;
  MPI_Comm_split(comm, part, rank, &sub);
  // Freed on every way out (an error in a slice throws collectively).
  std::unique_ptr<MPI_Comm, void (*)(MPI_Comm*)> sub_guard(&sub, [](MPI_Comm* c) {
    if (*c != MPI_COMM_NULL) MPI_Comm_free(c);
  });
  UMat Ksub, Msub;
  Mat Ks = K, Ms = M;
  if (P > 1) {
    MORSE_CALL(MatCreateRedundantMatrix(K, P, sub, MAT_INITIAL_MATRIX, Ksub.ptr()));
    MORSE_CALL(MatCreateRedundantMatrix(M, P, sub, MAT_INITIAL_MATRIX, Msub.ptr()));
    Ks = Ksub.get();
    Ms = Msub.get();
  }
  // N(beta_i) at the inner ends, counted by the partition of slice i - 1, shared.
  std::vector<PetscInt> below(S + 1, 0);
  below[S] = N;
  std::string err;
  std::vector<std::pair<PetscInt, CountSolve>> mine;  // (slice, its pairs)
  double t_count = 0, t_solve = 0;
  {
    StageTimer timer(comm, s.stage + "SliceCounts");
    const auto t0 = std::chrono::steady_clock::now();
    if (S > 1) {
      InertiaCounter c(Ks, Ms, s.prefix);
      for (PetscInt i = 1; i < S; ++i)
        if ((i - 1) % P == part) below[i] = c.count(beta[i]);
    }
    MPI_Allreduce(MPI_IN_PLACE, below.data(), static_cast<int>(S + 1), MPIU_INT, MPI_MAX, comm);
    t_count = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  for (PetscInt i = 0; i < S; ++i)
    MORSE_CHECK(below[i + 1] >= below[i], s.what, ": inertia counts not monotone at ", beta[i + 1], " (", below[i + 1],
                " < ", below[i], ")");
  {
    StageTimer timer(comm, s.stage + "EigenSolve");
    const auto t0 = std::chrono::steady_clock::now();
    for (PetscInt i = part; i < S; i += P) {
      const PetscInt ni = below[i + 1] - below[i];
      if (ni == 0) continue;
      // About the middle, where the ni nearest pairs are exactly those inside. The lowest slice
      // could be solved about 0 (its ni pairs are the ni lowest), but measured on the stator
      // (1000 modes, 2 slices) that took 142 s against 122 s about the middle: from 0 the
      // pairs near the slice's top converge last, as in a one-shift solve.
      const double sigma = 0.5 * (beta[i] + beta[i + 1]);
      // Converged pairs of the slice, printed by rank 0 of comm (it works in partition 0).
      Progress progress(comm, cat(s.what, " slice ", i + 1, "/", S), static_cast<double>(ni));
      CountSolve r = block_count_solve(Ks, Ms, ni, sigma, s, o, false, 1.0 / P, false, &progress);
      // Ritz values about a shift in the slice carry an error of about tol |omega^2 - shift|, 1e-8
      // relative for the lowest modes of the first slice: the Rayleigh quotients are exact to
      // the square of the vectors' error.
      r.omega2 = rayleigh_quotients(Ks, Ms, r.V.get());
      // Fault injection: the highest slice loses its `drop_for_test` highest pairs.
      if (i == S - 1 && detail::drop_for_test() > 0)
        r.omega2.resize(r.omega2.size() - std::min<std::size_t>(detail::drop_for_test(), r.omega2.size()));
      PetscInt inside = 0;
      for (double w : r.omega2) inside += w >= beta[i] * (1 - 1e-12) && w <= beta[i + 1] * (1 + 1e-12) ? 1 : 0;
      if (inside != ni && err.empty())
        err = cat(s.what, ": slice ", i + 1, " of ", S, " [", hz(beta[i]), ", ", hz(beta[i + 1]),
                  "] Hz: Sylvester's inertia counts ", ni, " eigenvalues in it but the solve found ", inside,
                  ": it missed modes; raise -", s.prefix, "block_max_dim or use more slices");
      mine.emplace_back(i, std::move(r));
    }
    t_solve = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  collective_check(comm, err);
  // The eigenvalues and vectors, in K's layout, ascending (the slices are, and each slice nearly:
  // the Rayleigh quotients of a cluster may come in another order than its Ritz values).
  std::vector<double> all(static_cast<std::size_t>(N), -1e300);
  // Block solves counted once per partition (by its first rank).
  int sub_rank = 0;
  MPI_Comm_rank(sub, &sub_rank);
  PetscInt solves = 0, vectors = 0;
  for (const auto& [i, r] : mine) {
    std::copy(r.omega2.begin(), r.omega2.end(), all.begin() + below[i]);
    if (sub_rank == 0) solves += r.solves, vectors += r.solves * r.b;
  }
  MPI_Allreduce(MPI_IN_PLACE, all.data(), static_cast<int>(N), MPI_DOUBLE, MPI_MAX, comm);
  // position[k]: where pair k (slice order) goes in ascending order (ties kept in slice order).
  std::vector<PetscInt> sorted(N), position(N);
  std::iota(sorted.begin(), sorted.end(), 0);
  std::stable_sort(sorted.begin(), sorted.end(), [&](PetscInt a, PetscInt b) { return all[a] < all[b]; });
  for (PetscInt k = 0; k < N; ++k) position[sorted[k]] = k;
  MPI_Allreduce(MPI_IN_PLACE, &solves, 1, MPIU_INT, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &vectors, 1, MPIU_INT, MPI_SUM, comm);
  {
    StageTimer timer(comm, s.stage + "EigenVectors");
    PetscInt m_local = 0, n = 0, r0 = 0, r1 = 0;
    MORSE_CALL(MatGetSize(K, &n, nullptr));
    MORSE_CALL(MatGetLocalSize(K, &m_local, nullptr));
    MORSE_CALL(MatCreateDense(comm, m_local, PETSC_DECIDE, n, n_out, nullptr, out.V.ptr()));
    MORSE_CALL(MatGetOwnershipRange(Ks, &r0, &r1));
    // One round per slice index of a partition: partition p sends its k-th slice.
    const PetscInt rounds = (S + P - 1) / P;
    for (PetscInt k = 0; k < rounds; ++k) {
      const PetscInt i = part + k * P;
      // This partition's k-th slice, if it has one (empty slices were not solved).
      auto it = std::find_if(mine.begin(), mine.end(), [&](const auto& x) { return x.first == i; });
      std::vector<PetscInt> dest;
      if (it != mine.end())
        for (PetscInt c = 0; c < static_cast<PetscInt>(it->second.omega2.size()); ++c)
          dest.push_back(position[below[i] + c] < n_out ? position[below[i] + c] : -1);
      gather_columns(comm, it != mine.end() ? it->second.V.get() : nullptr, r0, r1, dest, out.V.get());
      if (it != mine.end()) it->second.V.reset();
    }
  }
  std::sort(all.begin(), all.end());
  out.omega2.assign(all.begin(), all.begin() + n_out);
  mine.clear();
  Ksub.reset();
  Msub.reset();
  print0(comm,
         "  %s: block solver in %d slices of [0, %.6g] Hz on %d subcommunicator(s) of %d rank(s): counts %.1f s, "
         "solves %.1f s, %d block solves (%d vectors)\n",
         s.what.c_str(), (int)S, hz(top), (int)P, size / (int)P, t_count, t_solve, (int)solves, (int)vectors);
  print0(comm,
         "  %s: %d pairs below %.6g Hz = Sylvester inertia count of K - omega^2 M, slice by slice (every mode "
         "found%s, %.1f s in all)\n",
         s.what.c_str(), (int)N, hz(top), n_out < N ? cat(", the ", n_out, " lowest kept").c_str() : "",
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t_all).count());
  finish_pairs(K, M, s, o.tol, sign_ref, &out);
  return out;
}

}  // namespace

Eigenpairs solve_eigen_block(Mat K, Mat M, const EigenSettings& s, Vec sign_ref) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(K, &n, nullptr));
  const BlockOptions o = block_options(comm, s);
  if (o.slices > 1) return solve_block_slices(K, M, s, o, sign_ref);
  Eigenpairs out;
  PetscInt nev = s.nev;
  const bool cutoff = s.omega2_max > 0;
  if (cutoff) {
    // Every mode below the cutoff: their number from Sylvester's inertia, then that many.
    StageTimer timer(comm, s.stage + "InertiaCount");
    InertiaCounter c(K, M, s.prefix);
    nev = c.count(s.omega2_max);
    out.inertia_count = nev;
    out.inertia_counts = 1;
    MORSE_CHECK(nev > 0, s.what, ": no eigenvalue below the cutoff (omega^2 = ", s.omega2_max, ")");
  }
  MORSE_CHECK(nev > 0, s.what, ": the number of modes must be positive (got ", nev, ")");
  MORSE_CHECK(nev <= n, s.what, ": ", nev, " modes requested but the problem has only ", n, " DOFs");
  PetscInt b = 0, kdim = 0;
  if (!block_shape(n, nev, o, s, &b, &kdim) || kdim >= n) {
    // Nearly every mode of the problem is wanted, or the basis would fill the whole space (a tiny
    // model: its next block lies in the span, and orthogonalizing it to round-off cost 7e-9 in the
    // residuals of a repeated eigenvalue on 12 DOFs): a Krylov space that fills the whole space
    // is SLEPc's case.
    print0(comm, "  %s: %d modes of %d DOFs leave no room for a block basis; solved by Krylov-Schur\n", s.what.c_str(),
           (int)nev, (int)n);
    return solve_eigen_krylovschur(K, M, s, sign_ref);
  }
  CountSolve r;
  {
    Progress progress(comm, s.what, static_cast<double>(nev));
    // The factor is refactored in place by the count check when the caller does not keep it.
    const bool for_inertia = !cutoff && !s.keep_factor && count_check_wanted(comm, s);
    r = block_count_solve(K, M, nev, s.shift, s, o, true, 1.0, for_inertia, &progress);
  }
  out.iterations = r.restarts;
  out.factor_seconds = r.factor_seconds;
  out.block_factor = std::move(r.F);
  out.V = std::move(r.V);
  out.omega2 = std::move(r.omega2);
  print0(comm, "  %s: block Krylov-Schur, blocks of %d, basis %d, %d restart(s), %d block solves (%d vectors)\n",
         s.what.c_str(), (int)r.b, (int)r.kdim, (int)r.restarts, (int)r.solves, (int)(r.solves * r.b));
  print0(comm,
         "  %s: block solves %.2f s, orthogonalization %.2f s (%d of %d blocks reorthogonalized, %d with one "
         "SVQB pass), Rayleigh-Ritz %.2f s, restarts %.2f s\n",
         s.what.c_str(), r.t_solve, r.t_orth, (int)r.extra_passes, (int)r.solves, (int)r.single_svqb, r.t_rr,
         r.t_restart);
  if (cutoff) {
    // The inertia count says how many lie below the cutoff: exactly that many must be found, all
    // below it (one above means one below was missed).
    const PetscInt found = nev - std::min(detail::drop_for_test(), nev);
    out.omega2.resize(found);
    const double top = found ? out.omega2.back() : 0.0;
    collective_check(comm, found == nev && top <= s.omega2_max * (1 + 1e-8)
                               ? std::string()
                               : cat(s.what, ": Sylvester's inertia of K - omega^2 M counts ", nev,
                                     " eigenvalues below ", hz(s.omega2_max), " Hz but the solve returned ", found,
                                     found ? cat(" up to ", hz(top), " Hz") : std::string(), ": it missed modes"));
    print0(comm, "  %s: %d pairs below %.6g Hz = Sylvester inertia count of K - omega^2 M (every mode found)\n",
           s.what.c_str(), (int)nev, hz(s.omega2_max));
  }
  finish_pairs(K, M, s, o.tol, sign_ref, &out);
  if (!cutoff) check_count_by_inertia(K, M, s, r.extra, &out);
  return out;
}

}  // namespace morse::eigen
