// Block shift-invert Krylov–Schur for K x = omega^2 M x (cb/eigen.hpp, -<prefix>eigen_solver block).
//
// The operator is Op = (K - sigma M)^-1 M, self-adjoint in the M inner product; its eigenvalues
// theta = 1 / (omega^2 - sigma) are largest in magnitude for the omega^2 nearest sigma. One MUMPS
// Cholesky factorization of K - sigma M; each step applies Op to a block of b vectors at once
// (MatMatSolve: the factor is read once per block, not once per vector, which is what bounds a
// single-vector solve). The basis Q is kept M-orthonormal by block classical Gram–Schmidt done
// twice (two GEMMs per pass) and SVQB (the eigen-decomposition of the b x b Gram matrix), all
// BLAS-3. The projected matrix H = Q^T M Op Q is filled from the Gram–Schmidt coefficients; the
// Rayleigh–Ritz pairs of its leading part give the Ritz values, and the coupling block of the
// last (residual) block gives each Ritz pair's residual ||Op x - theta x||_M = ||B y||. When the
// basis is full, the method restarts à la Krylov–Schur: the best Ritz vectors are kept (their
// projected matrix is diagonal, coupled to the residual block by B Y), and the expansion goes
// on from the residual block. A Ritz pair is converged when ||B y|| <= tol |theta|.
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <numeric>

#include "morse/cb/eigen.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"

// LAPACK's MRRR symmetric eigensolver (not in PETSc's BLAS/LAPACK header; the LAPACK that
// PETSc links provides it).
extern "C" void dsyevr_(const char* jobz, const char* range, const char* uplo, const PetscBLASInt* n, double* a,
                        const PetscBLASInt* lda, const double* vl, const double* vu, const PetscBLASInt* il,
                        const PetscBLASInt* iu, const double* abstol, PetscBLASInt* m, double* w, double* z,
                        const PetscBLASInt* ldz, PetscBLASInt* isuppz, double* work, const PetscBLASInt* lwork,
                        PetscBLASInt* iwork, const PetscBLASInt* liwork, PetscBLASInt* info);

namespace morse::cb {

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
    for (UMat* X : {&W_, &RHS_}) MORSE_CALL(MatCreateDense(comm, m_, PETSC_DECIDE, PETSC_DETERMINE, b, nullptr, X->ptr()));
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
          w.a[r + w.ld * c] = uniform(static_cast<std::uint64_t>(rstart_ + r) * 1315423911ull + static_cast<std::uint64_t>(c));
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
    if (how == Passes::Local) ranges = {{std::max<PetscInt>(0, k - 2 * b_), k}, {0, k}};
    else if (how == Passes::Once) ranges = {{0, k}};
    else ranges = {{0, k}, {0, k}};
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

  // M-orthonormalizes W against itself (SVQB twice), given nothing; k = columns of Q it must stay
  // orthogonal to when directions are replaced. R (b x b, column-major) is returned with
  // W_in = W_out R. Directions that vanish (an invariant subspace) are replaced by new random
  // vectors orthogonal to Q, with zero rows in R.
  // M W is computed afresh at each pass (after Gram–Schmidt W can be much smaller than before,
  // so an M W carried along would have lost its accuracy) and carried through the pass's
  // transformation, so MW = M W on return.
  // With `removed` (the squared coefficient norms of a Local orthogonalization's global pass,
  // recorded into H column col): if that pass removed more of a column than it left (DGKS,
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
    std::stable_sort(order.begin(), order.end(), [&](PetscInt a, PetscInt b) { return std::abs(lam[a]) > std::abs(lam[b]); });
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
  PetscInt solves_ = 0, extra_passes_ = 0;
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

// Bytes of memory available on this machine now (Linux MemAvailable), or -1 if unknown.
double available_bytes() {
  std::ifstream f("/proc/meminfo");
  std::string key;
  double kb = 0;
  std::string unit;
  while (f >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024.0;
  return -1.0;
}

// The default basis (kdim vectors) capped so that Q and M Q (2 kdim doubles per local row) fit
// in 70 % of the memory available on each node once the factor exists, the ranks of a node
// sharing it; the same on every rank. A cap below nev + 2 blocks is an error that says what the
// solve needs. Collective.
PetscInt memory_capped_basis(MPI_Comm comm, PetscInt m_local, PetscInt nev, PetscInt b, PetscInt kdim,
                             double budget_gb, const EigenSettings& s) {
  MPI_Comm node;
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  double rows = static_cast<double>(m_local);
  MPI_Allreduce(MPI_IN_PLACE, &rows, 1, MPI_DOUBLE, MPI_SUM, node);
  MPI_Comm_free(&node);
  const double avail = available_bytes();
  // The budget of the basis on a node: -block_memory_gb, else 70 % of what is available.
  const double budget = budget_gb > 0 ? budget_gb * 1e9 : (avail > 0 ? 0.7 * avail : -1.0);
  // Vectors of the basis that fit on this node (+inf if the memory is unknown).
  double fit = budget > 0 && rows > 0 ? budget / (2.0 * sizeof(double) * rows) : 1e300;
  MPI_Allreduce(MPI_IN_PLACE, &fit, 1, MPI_DOUBLE, MPI_MIN, comm);
  if (fit >= static_cast<double>(kdim)) return kdim;
  const PetscInt cap = static_cast<PetscInt>(fit / b) * b;
  const double need_gb = 2.0 * sizeof(double) * rows * static_cast<double>(nev + 2 * b) / 1e9;
  collective_check(comm, cap >= nev + 2 * b
                             ? std::string()
                             : cat(s.what, ": the block basis for ", nev, " modes needs at least ", nev + 2 * b,
                                   " vectors, about ", need_gb, " GB on a node, and the basis may use ", budget / 1e9,
                                   " GB (-", s.prefix, "block_memory_gb, default 70 % of the memory available): "
                                   "ask for fewer modes per solve, run on more nodes, or use -", s.prefix,
                                   "eigen_solver krylovschur"));
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
// spectrum), its wall
// time in *seconds; a singular K (null pivots at shift 0) is an error that names the likely
// cause.
UMat factor_shifted(Mat K, Mat M, double shift, const EigenSettings& s, double* seconds) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  StageTimer timer(comm, s.stage + "Factor");
  auto t0 = std::chrono::steady_clock::now();
  UMat A, F;
  Mat Ash = K;
  if (shift != 0.0) {
    MORSE_CALL(MatDuplicate(K, MAT_COPY_VALUES, A.ptr()));
    MORSE_CALL(MatAXPY(A.get(), -shift, M, DIFFERENT_NONZERO_PATTERN));
    MORSE_CALL(MatSetOption(A.get(), MAT_SYMMETRIC, PETSC_TRUE));
    Ash = A.get();
  }
  MORSE_CALL(MatGetFactor(Ash, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, F.ptr()));
  MORSE_CALL(MatSetOptionsPrefix(F.get(), (s.prefix + "block_").c_str()));
  MORSE_CALL(MatMumpsSetIcntl(F.get(), 24, 1));  // null pivots: singular K
  MORSE_CALL(MatSetFromOptions(F.get()));
  MatFactorInfo info;
  MORSE_CALL(MatFactorInfoInitialize(&info));
  MORSE_CALL(MatCholeskyFactorSymbolic(F.get(), Ash, nullptr, &info));
  MORSE_CALL(MatCholeskyFactorNumeric(F.get(), Ash, &info));
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const PetscInt nulls = mumps_null_pivots(F.get());
  collective_check(comm, nulls > 0 ? (shift == 0.0 ? cat(s.what, ": the stiffness matrix is singular (", nulls,
                                                         " null pivots): the model is not restrained against "
                                                         "rigid-body motion; check -clamp and the boundary set")
                                                   : cat(s.what, ": K - sigma M is singular at the shift sigma = ",
                                                         shift, " (", nulls, " null pivots)"))
                                   : std::string());
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
  for (std::size_t j = 0; j < cols.size(); ++j) std::copy_n(a + lda * cols[j].second, m, d + ldd * static_cast<PetscInt>(j));
  MORSE_CALL(MatDenseRestoreArray(dst, &d));
  MORSE_CALL(MatDenseRestoreArrayRead(src, &a));
}

}  // namespace

Eigenpairs solve_eigen_block(Mat K, Mat M, const EigenSettings& s, Vec sign_ref) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(K));
  PetscInt n = 0, m_local = 0;
  MORSE_CALL(MatGetSize(K, &n, nullptr));
  MORSE_CALL(MatGetLocalSize(K, &m_local, nullptr));
  PetscInt b = -1, kmax = -1, max_restarts = 200, check_every = 0;
  PetscBool monitor = PETSC_FALSE;
  PetscReal tol = s.tol, memory_gb = -1;
  auto get_options = [&]() -> PetscErrorCode {
    PetscOptionsBegin(comm, s.prefix.c_str(), "morse block eigen solver", "");
    PetscCall(PetscOptionsInt("-block_size", "Vectors per block (one multi-RHS MUMPS solve each; default 8 below 100 "
                              "modes, else 16)", "", b, &b, nullptr));
    PetscCall(PetscOptionsInt("-block_max_dim", "Largest basis before a restart (default nev + max(1.2 nev, 6 blocks))", "",
                              kmax, &kmax, nullptr));
    PetscCall(PetscOptionsReal("-block_memory_gb",
                               "Memory for the basis (Q and M Q) per node [GB] when -block_max_dim is not given "
                               "(default: 70% of the memory available after the factorization)",
                               "", memory_gb, &memory_gb, nullptr));
    PetscCall(PetscOptionsInt("-block_max_restarts", "Restarts before giving up", "", max_restarts, &max_restarts, nullptr));
    PetscCall(PetscOptionsInt("-block_check_every", "Rayleigh-Ritz every N blocks (default 0: adaptive, extrapolated "
                              "from the converged counts)", "", check_every, &check_every, nullptr));
    PetscCall(PetscOptionsBool("-block_monitor", "Print the converged count at every Rayleigh-Ritz", "", monitor,
                               &monitor, nullptr));
    PetscCall(PetscOptionsReal("-eps_tol", "Relative residual tolerance of the Ritz pairs", "", tol, &tol, nullptr));
    PetscOptionsEnd();
    return PETSC_SUCCESS;
  };
  MORSE_CALL(get_options());
  MORSE_CHECK(b >= 1 || b == -1, "-", s.prefix, "block_size must be >= 1 (got ", b, ")");
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
  // Measured (bench/README.md, eigen_bench.py): 50 modes of the rotor 37 deck are fastest with
  // blocks of 8 (fewer vectors solved), 1000 of the stator with 16 (32 needs a restart).
  if (b < 0) b = nev < 100 ? 8 : 16;
  const bool kmax_given = kmax >= 0;
  MORSE_CHECK(!kmax_given || kmax >= std::min(n, nev + 2 * b), "-", s.prefix, "block_max_dim ", kmax,
              " is too small for ", nev, " modes with blocks of ", b, " (at least nev + 2 blocks)");
  // A restart keeps at least nev Ritz vectors and the residual block, so the basis must hold
  // nev + 2 blocks, better 3. Small problems (n not far above nev) get smaller blocks.
  b = std::min(b, std::max<PetscInt>(1, n / 3));
  while (b > 1 && basis_size(n, nev, b, kmax) < nev + 3 * b) b = std::max<PetscInt>(1, b / 2);
  if (basis_size(n, nev, b, kmax) < nev + 2 * b) {
    // Nearly every mode of the problem is wanted: a Krylov space that fills the whole space is
    // SLEPc's case.
    print0(comm, "  %s: %d modes of %d DOFs leave no room for a block basis; solved by Krylov-Schur\n",
           s.what.c_str(), (int)nev, (int)n);
    return solve_eigen_krylovschur(K, M, s, sign_ref);
  }
  PetscInt kdim = basis_size(n, nev, b, kmax);
  UMat F = factor_shifted(K, M, s.shift, s, &out.factor_seconds);
  if (!kmax_given) kdim = memory_capped_basis(comm, m_local, nev, b, kdim, memory_gb, s);
  // With shift <= 0 every theta = 1/(omega^2 - shift) is positive (K is semi-definite and was
  // factored without a null pivot), so the wanted ones are the largest.
  MORSE_CHECK(check_every >= 0, "-", s.prefix, "block_check_every must be >= 0 (got ", check_every, ")");
  BlockSolver solver(K, M, F.get(), b, kdim, s.shift <= 0.0, comm);
  solver.set_checks(check_every, monitor);
  bool ok = false;
  {
    StageTimer timer(comm, s.stage + "EigenSolve");
    Progress progress(comm, s.what, static_cast<double>(nev));
    ok = solver.run(nev, tol, max_restarts, &progress);
  }
  MORSE_CHECK(ok, s.what, ": the block solver did not converge ", nev, " pairs in ", max_restarts,
              " restarts; raise -", s.prefix, "block_max_dim or -", s.prefix, "block_max_restarts");
  out.iterations = solver.restarts();
  out.block_factor = std::move(F);
  {
    StageTimer extract(comm, s.stage + "EigenVectors");
    // Ascending omega^2 = shift + 1/theta. The Ritz vectors are formed in place in the basis and
    // the work matrices freed before V is allocated, so extraction never needs more memory than
    // the solve (for 1000 modes of 478k DOFs: 3.8 GB instead of 7.6 GB more).
    std::vector<std::pair<double, PetscInt>> order;
    for (PetscInt i = 0; i < nev; ++i) order.emplace_back(s.shift + 1.0 / solver.theta()[i], i);
    std::sort(order.begin(), order.end());
    std::vector<PetscInt> pick;
    std::vector<std::pair<double, PetscInt>> first;
    for (PetscInt j = 0; j < nev; ++j) {
      pick.push_back(order[j].second);
      first.emplace_back(order[j].first, j);
    }
    Mat Q = solver.ritz_vectors_in_place(pick);
    solver.release_work();
    MORSE_CALL(MatCreateDense(comm, m_local, PETSC_DECIDE, n, nev, nullptr, out.V.ptr()));
    copy_columns(Q, first, out.V.get());
    solver.release_basis();
    for (const auto& o : order) out.omega2.push_back(o.first);
  }
  print0(comm, "  %s: block Krylov-Schur, blocks of %d, basis %d, %d restart(s), %d block solves (%d vectors)\n",
         s.what.c_str(), (int)b, (int)kdim, (int)solver.restarts(), (int)solver.solves_, (int)(solver.solves_ * b));
  print0(comm, "  %s: block solves %.2f s, orthogonalization %.2f s (%d of %d blocks reorthogonalized), Rayleigh-Ritz "
         "%.2f s, restarts %.2f s\n", s.what.c_str(), solver.t_solve_, solver.t_orth_, (int)solver.extra_passes_,
         (int)solver.solves_, solver.t_rr_, solver.t_restart_);
  if (cutoff) {
    // The inertia count says how many lie below the cutoff: exactly that many must be found, all
    // below it (one above means one below was missed).
    const PetscInt found = nev - std::min(s.drop_for_test, nev);
    out.omega2.resize(found);
    const double top = found ? out.omega2.back() : 0.0;
    collective_check(comm, found == nev && top <= s.omega2_max * (1 + 1e-8)
                               ? std::string()
                               : cat(s.what, ": Sylvester's inertia of K - omega^2 M counts ", nev, " eigenvalues below ",
                                     std::sqrt(s.omega2_max) / (2 * M_PI), " Hz but the solve returned ", found,
                                     found ? cat(" up to ", std::sqrt(std::max(top, 0.0)) / (2 * M_PI), " Hz") : std::string(),
                                     ": it missed modes"));
    print0(comm, "  %s: %d pairs below %.6g Hz = Sylvester inertia count of K - omega^2 M (every mode found)\n",
           s.what.c_str(), (int)nev, std::sqrt(s.omega2_max) / (2 * M_PI));
  }
  finish_pairs(K, M, s, tol, sign_ref, &out);
  if (!cutoff) {
    std::vector<double> extra;
    for (double t : solver.converged_beyond(nev, tol)) extra.push_back(s.shift + 1.0 / t);
    check_count_by_inertia(K, M, s, extra, &out);
  }
  return out;
}

}  // namespace morse::cb
