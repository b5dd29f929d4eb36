// Massless boundary: MacNeal's residual-flexibility form of a reduced model, as Monjaraz-Tec, Gross &
// Krack (2022) use it (see morse/nlrom/nlrom.hpp and docs/theory.md §11).
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "nlrom/modal_damping.hpp"

namespace morse::nlrom {

namespace {

// The (rows x cols) block of a row-major n x n matrix starting at (i0, j0).
std::vector<double> block(const std::vector<double>& A, std::size_t n, std::size_t i0, std::size_t rows, std::size_t j0,
                          std::size_t cols) {
  std::vector<double> B(rows * cols);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < cols; ++j) B[i * cols + j] = A[(i0 + i) * n + j0 + j];
  return B;
}

// X = A^-1 B for a symmetric positive definite A (n x n) and B (n x m), both row-major. Throws
// with `what` if A is not positive definite.
std::vector<double> spd_solve(std::vector<double> A, std::size_t n, std::vector<double> B, std::size_t m,
                              const char* what) {
  if (n == 0 || m == 0) return B;
  // Row-major symmetric A is its own column-major form; B row-major n x m is B^T column-major
  // (m x n), so solve on the transpose: X^T = B^T A^-1 (A symmetric) via column-major columns.
  std::vector<double> Bt(n * m);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < m; ++j) Bt[j * n + i] = B[i * m + j];
  PetscBLASInt nn = static_cast<PetscBLASInt>(n), mm = static_cast<PetscBLASInt>(m), info = 0;
  const char uplo = 'L';
  LAPACKpotrf_(&uplo, &nn, A.data(), &nn, &info);
  MORSE_CHECK(info == 0, what, " (Cholesky failed at pivot ", info, ")");
  LAPACKpotrs_(&uplo, &nn, &mm, A.data(), &nn, Bt.data(), &nn, &info);
  MORSE_CHECK(info == 0, what, " (LAPACK potrs info ", info, ")");
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < m; ++j) B[i * m + j] = Bt[j * n + i];
  return B;
}

// K_dd - K_ds K_ss^-1 K_sd: the dynamic stiffness with the first ns (static) coordinates condensed.
std::vector<double> condensed_stiffness(const ReducedModel& m, std::size_t ns) {
  const std::size_t r = static_cast<std::size_t>(m.r), nd = r - ns;
  auto Kdd = block(m.K, r, ns, nd, ns, nd);
  if (ns == 0) return Kdd;
  const auto Ksd = block(m.K, r, 0, ns, ns, nd);
  const auto X = spd_solve(block(m.K, r, 0, ns, 0, ns), ns, Ksd, nd,
                           "massless boundary: the stiffness of the static coordinates K_ss is not positive definite: "
                           "a boundary node has no stiffness of its own (an isolated node), so its static equilibrium "
                           "is singular");
  for (std::size_t i = 0; i < nd; ++i)
    for (std::size_t j = 0; j < nd; ++j) {
      double s = 0.0;
      for (std::size_t b = 0; b < ns; ++b) s += Ksd[b * nd + i] * X[b * nd + j];
      Kdd[i * nd + j] -= s;
    }
  for (std::size_t i = 0; i < nd; ++i)  // symmetric to round-off; make it exactly so
    for (std::size_t j = i + 1; j < nd; ++j)
      Kdd[i * nd + j] = Kdd[j * nd + i] = 0.5 * (Kdd[i * nd + j] + Kdd[j * nd + i]);
  return Kdd;
}

}  // namespace

std::vector<double> massless_transform(const std::vector<double>& M, const std::vector<double>& K, PetscInt r_,
                                       PetscInt n_b, double fmax_hz, PetscInt* n_static) {
  const std::size_t r = static_cast<std::size_t>(r_), nb = static_cast<std::size_t>(n_b);
  MORSE_CHECK(n_b > 0 && n_b < r_ && M.size() == r * r && K.size() == r * r, "massless boundary: a model of ", r,
              " coordinates with ", n_b, " boundary coordinates has no boundary to make massless, or nothing else");
  MORSE_CHECK(fmax_hz >= 0 && std::isfinite(fmax_hz), "-nlrom_massless_fmax must be a finite frequency >= 0 (got ",
              fmax_hz, ")");
  // The modes of the reduced model with its boundary free, M-normalized, ascending.
  std::vector<double> X;
  const auto w = eigen::dense_eigenvalues(static_cast<int>(r), K, M, &X);
  std::size_t nd = r - nb;
  if (fmax_hz > 0) {
    const double wc = std::pow(2.0 * M_PI * fmax_hz, 2);
    nd = 0;
    while (nd < r - nb && w[nd] <= wc) ++nd;
    MORSE_CHECK(nd > 0, "-nlrom_massless_fmax ", fmax_hz, " Hz is below the lowest mode of the model (",
                std::sqrt(w[0]) / (2.0 * M_PI), " Hz): no dynamic mode would be left");
  }
  // The residual flexibility at the boundary must be regular: a boundary coordinate that no residual
  // mode moves (for example a face whose nodes move together in every high mode) has none. Then
  // the highest dynamic modes join the residual set, one at a time, until it is (each try costs
  // r n_b^2).
  const std::size_t nd_asked = nd;
  std::vector<double> G, Gbb, PsiT;
  for (;; --nd) {
    MORSE_CHECK(nd > 0,
                "massless boundary: the residual flexibility of the boundary is singular even with every "
                "mode residual: a boundary coordinate without stiffness of its own");
    // G = sum over residual modes x_k x_k[b]^T / w_k (r x nb), the residual flexibility (MacNeal).
    G.assign(r * nb, 0.0);
    for (std::size_t k = nd; k < r; ++k)
      for (std::size_t i = 0; i < r; ++i) {
        const double xi = X[i * r + k] / w[k];
        if (xi == 0.0) continue;
        for (std::size_t b = 0; b < nb; ++b) G[i * nb + b] += xi * X[b * r + k];
      }
    Gbb = block(G, nb, 0, nb, 0, nb);
    for (std::size_t a = 0; a < nb; ++a)
      for (std::size_t b = a + 1; b < nb; ++b)
        Gbb[a * nb + b] = Gbb[b * nb + a] = 0.5 * (Gbb[a * nb + b] + Gbb[b * nb + a]);
    // Regular: a Cholesky factor whose smallest pivot is above 1e-10 of the largest (squared).
    std::vector<double> L(Gbb);
    PetscBLASInt nn = static_cast<PetscBLASInt>(nb), info = 0;
    const char uplo = 'L';
    LAPACKpotrf_(&uplo, &nn, L.data(), &nn, &info);
    double lo = 1e300, hi = 0.0;
    for (std::size_t a = 0; info == 0 && a < nb; ++a) {
      const double d = L[a * nb + a] * L[a * nb + a];
      lo = std::min(lo, d), hi = std::max(hi, d);
    }
    if (info == 0 && lo > 1e-10 * hi) break;
  }
  if (nd < nd_asked)  // the same on every rank
    print0(PETSC_COMM_WORLD,
           "morse: massless boundary: %zu dynamic modes instead of %zu: the residual flexibility of the boundary "
           "needs the %zu highest modes\n",
           nd, nd_asked, r - nd);
  const std::size_t nr = r - nd;  // residual modes: their flexibility at the boundary, their mass dropped
  // Psi = G G_bb^-1 (r x nb): the identity on the boundary.
  std::vector<double> Gt(nb * r);  // G^T, nb x r
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t b = 0; b < nb; ++b) Gt[b * r + i] = G[i * nb + b];
  PsiT = spd_solve(Gbb, nb, Gt, r, "massless boundary: the residual flexibility of the boundary is singular");
  // Z: the residual modes' combinations that vanish on the boundary (nr - nb of them), kept as
  // quasi-static coordinates: the null space of X_R[b, :] by the eigenvectors of X_R[b,:]^T X_R[b,:]
  // with the smallest eigenvalues, then K-orthogonal and M-normalized within.
  std::vector<double> Z;  // r x nz, row-major
  const std::size_t nz = nr - nb;
  if (nz > 0) {
    std::vector<double> P(nr * nr, 0.0), I(nr * nr, 0.0), Y;
    for (std::size_t a = 0; a < nr; ++a) {
      I[a * nr + a] = 1.0;
      for (std::size_t c = 0; c < nr; ++c) {
        double x = 0.0;
        for (std::size_t b = 0; b < nb; ++b) x += X[b * r + nd + a] * X[b * r + nd + c];
        P[a * nr + c] = x;
      }
    }
    eigen::dense_eigenvalues(static_cast<int>(nr), P, I, &Y);  // ascending: the first nz span the null space
    std::vector<double> Z0(r * nz, 0.0);
    for (std::size_t i = nb; i < r; ++i)  // zero on the boundary by construction; set it exactly
      for (std::size_t c = 0; c < nz; ++c) {
        double x = 0.0;
        for (std::size_t a = 0; a < nr; ++a) x += X[i * r + nd + a] * Y[a * nr + c];
        Z0[i * nz + c] = x;
      }
    // Within span(Z0): X_R's modes are K- and M-orthogonal, so Z0^T K Z0 and Z0^T M Z0 are
    // diag(w_R) and I restricted; diagonalize them together for modal quasi-static coordinates.
    std::vector<double> Kz(nz * nz, 0.0), Mz(nz * nz, 0.0), W;
    for (std::size_t a = 0; a < nz; ++a)
      for (std::size_t c = 0; c < nz; ++c) {
        double k = 0.0, m = 0.0;
        for (std::size_t t = 0; t < nr; ++t) {
          k += Y[t * nr + a] * w[nd + t] * Y[t * nr + c];
          m += Y[t * nr + a] * Y[t * nr + c];
        }
        Kz[a * nz + c] = k, Mz[a * nz + c] = m;
      }
    eigen::dense_eigenvalues(static_cast<int>(nz), Kz, Mz, &W);
    Z.assign(r * nz, 0.0);
    for (std::size_t i = 0; i < r; ++i)
      for (std::size_t c = 0; c < nz; ++c) {
        double x = 0.0;
        for (std::size_t a = 0; a < nz; ++a) x += Z0[i * nz + a] * W[a * nz + c];
        Z[i * nz + c] = x;
      }
  }
  *n_static = static_cast<PetscInt>(nb + nz);
  // T = [Psi | Z | X_D - Psi X_D[b, :]].
  std::vector<double> T(r * r, 0.0);
  for (std::size_t i = 0; i < r; ++i) {
    for (std::size_t b = 0; b < nb; ++b) T[i * r + b] = i < nb ? (i == b ? 1.0 : 0.0) : PsiT[b * r + i];
    for (std::size_t c = 0; c < nz; ++c) T[i * r + nb + c] = Z[i * nz + c];
    for (std::size_t k = 0; k < nd; ++k) {
      double x = 0.0;
      if (i >= nb) {
        x = X[i * r + k];
        for (std::size_t b = 0; b < nb; ++b) x -= PsiT[b * r + i] * X[b * r + k];
      }
      T[i * r + nb + nz + k] = x;
    }
  }
  return T;
}

void relabel_massless(Basis* basis, PetscInt n_static, bool scaled) {
  const PetscInt r = basis->r();
  basis->labels.resize(static_cast<std::size_t>(basis->n_b));
  for (PetscInt k = basis->n_b; k < n_static; ++k)
    basis->labels.push_back(cat(scaled ? "mass-scaled mode " : "quasi-static mode ", k - basis->n_b + 1));
  for (PetscInt k = n_static; k < r; ++k) basis->labels.push_back(cat("dynamic mode ", k - n_static + 1));
}

UMat transform_basis(Mat V, const std::vector<double>& S) {
  PetscInt m = 0, r = 0, N = 0, lda = 0;
  MORSE_CALL(MatGetLocalSize(V, &m, nullptr));
  MORSE_CALL(MatGetSize(V, &N, &r));
  MORSE_CHECK(S.size() == static_cast<std::size_t>(r) * r, "transform_basis: S is not ", r, " x ", r);
  MORSE_CALL(MatDenseGetLDA(V, &lda));
  MPI_Comm comm = PetscObjectComm((PetscObject)V);
  UMat W;
  MORSE_CALL(MatCreateDense(comm, m, PETSC_DECIDE, N, r, nullptr, W.ptr()));
  const PetscScalar* v = nullptr;
  PetscScalar* w = nullptr;
  PetscInt ldw = 0;
  MORSE_CALL(MatDenseGetLDA(W.get(), &ldw));
  MORSE_CALL(MatDenseGetArrayRead(V, &v));
  MORSE_CALL(MatDenseGetArrayWrite(W.get(), &w));
  // Column j of W = sum_k S[k][j] column k of V, summed in k order (the same on every rank count).
  for (PetscInt j = 0; j < r; ++j) {
    PetscScalar* wj = w + static_cast<std::size_t>(j) * ldw;
    for (PetscInt i = 0; i < m; ++i) wj[i] = 0.0;
    for (PetscInt k = 0; k < r; ++k) {
      const double s = S[static_cast<std::size_t>(k) * r + j];
      if (s == 0.0) continue;
      const PetscScalar* vk = v + static_cast<std::size_t>(k) * lda;
      for (PetscInt i = 0; i < m; ++i) wj[i] += s * vk[i];
    }
  }
  MORSE_CALL(MatDenseRestoreArrayRead(V, &v));
  MORSE_CALL(MatDenseRestoreArrayWrite(W.get(), &w));
  MORSE_CALL(MatAssemblyBegin(W.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(W.get(), MAT_FINAL_ASSEMBLY));
  return W;
}

void make_massless(ReducedModel* rm, PetscInt n_static, double xi, PetscInt k, double scaled_fmax) {
  const std::size_t r = static_cast<std::size_t>(rm->r);
  MORSE_CHECK(rm->n_b > 0 && n_static >= rm->n_b && static_cast<std::size_t>(n_static) < r,
              "massless boundary: the model needs boundary and dynamic "
              "coordinates (r = ",
              r, ", n_b = ", rm->n_b, ", static ", n_static, ")");
  MORSE_CHECK(std::isfinite(scaled_fmax) && scaled_fmax >= 0, "massless boundary: the scaling frequency ", scaled_fmax,
              " Hz is not a finite frequency >= 0");
  // Scaled: the z coordinates [n_b, n_static) stay dynamic with mass max(1, K_zz / w_c^2).
  const std::size_t z0 = static_cast<std::size_t>(rm->n_b), z1 = static_cast<std::size_t>(n_static);
  const double wc2 = std::pow(2.0 * M_PI * scaled_fmax, 2);
  if (scaled_fmax > 0) n_static = rm->n_b;
  const std::size_t ns = static_cast<std::size_t>(n_static), nd = r - ns;
  if (k == kAllModes) k = static_cast<PetscInt>(nd);
  MORSE_CHECK(k >= 0 && static_cast<std::size_t>(k) <= nd, "massless boundary: ", k,
              " damped modes asked from a model of ", nd, " dynamic coordinates");
  const auto Keff = condensed_stiffness(*rm, ns);  // also proves K_ss positive definite
  // MacNeal: the residual mass is dropped, so the mass is that of the M-normalized dynamic modes
  // (and of the scaled z).
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < r; ++j) {
      double m = i >= ns && i == j ? 1.0 : 0.0;
      if (scaled_fmax > 0 && i == j && i >= z0 && i < z1) m = std::max(1.0, rm->K[i * r + i] / wc2);
      rm->M[i * r + j] = m;
    }
  // Modal damping of the model with its static coordinates condensed, on the dynamic block only.
  rm->damping_omega.clear();
  const auto Cdd = detail::modal_damping_matrix(nd, Keff, block(rm->M, r, ns, nd, ns, nd), xi, k, &rm->damping_omega);
  std::fill(rm->C.begin(), rm->C.end(), 0.0);
  for (std::size_t i = 0; i < nd; ++i)
    for (std::size_t j = 0; j < nd; ++j) rm->C[(ns + i) * r + ns + j] = Cdd[i * nd + j];
  rm->massless = true;
  rm->n_static = n_static;
}

double massless_critical_step(const ReducedModel& m, double* free_boundary) {
  const std::size_t r = static_cast<std::size_t>(m.r), ns = static_cast<std::size_t>(m.n_static), nd = r - ns;
  const auto Mdd = block(m.M, r, ns, nd, ns, nd);
  const auto held = eigen::dense_eigenvalues(static_cast<int>(nd), block(m.K, r, ns, nd, ns, nd), Mdd, nullptr);
  if (free_boundary) *free_boundary = 2.0 / std::sqrt(std::max(free_eigenvalues(m).back(), 1e-300));
  return 2.0 / std::sqrt(std::max(held.back(), 1e-300));
}

double massless_critical_step(const ReducedModel& m, const std::vector<double>& held, std::size_t nh) {
  const std::size_t r = static_cast<std::size_t>(m.r), ns = static_cast<std::size_t>(m.n_static), nd = r - ns;
  MORSE_CHECK(held.size() == ns * nh && nh <= ns, "massless_critical_step: held directions are not ", ns, " x ", nh);
  if (nh == 0) return 2.0 / std::sqrt(std::max(free_eigenvalues(m).back(), 1e-300));
  // C: an orthonormal basis of the complement of span(held) in the static coordinates, the
  // eigenvectors of I - H (H^T H)^-1 H^T with eigenvalue 1.
  std::vector<double> HtH(nh * nh, 0.0), Ht(nh * ns);
  for (std::size_t a = 0; a < nh; ++a) {
    for (std::size_t i = 0; i < ns; ++i) Ht[a * ns + i] = held[i * nh + a];
    for (std::size_t b = 0; b < nh; ++b)
      for (std::size_t i = 0; i < ns; ++i) HtH[a * nh + b] += held[i * nh + a] * held[i * nh + b];
  }
  const auto X = spd_solve(HtH, nh, Ht, ns, "massless_critical_step: the held directions are dependent");
  std::vector<double> P(ns * ns, 0.0), I(ns * ns, 0.0), Y;
  for (std::size_t i = 0; i < ns; ++i) {
    I[i * ns + i] = 1.0;
    for (std::size_t j = 0; j < ns; ++j) {
      double x = i == j ? 1.0 : 0.0;
      for (std::size_t a = 0; a < nh; ++a) x -= held[i * nh + a] * X[a * ns + j];
      P[i * ns + j] = x;
    }
  }
  for (std::size_t i = 0; i < ns; ++i)
    for (std::size_t j = i + 1; j < ns; ++j) P[i * ns + j] = P[j * ns + i] = 0.5 * (P[i * ns + j] + P[j * ns + i]);
  eigen::dense_eigenvalues(static_cast<int>(ns), P, I, &Y);  // ascending: the last ns - nh have eigenvalue 1
  const std::size_t nf = ns - nh;
  // The model on [C a; eta]: K' = [C^T K_ss C, C^T K_sd; K_ds C, K_dd], M' = diag(0, I).
  ReducedModel red;
  red.r = static_cast<PetscInt>(nf + nd);
  red.n_static = static_cast<PetscInt>(nf);
  red.massless = true;
  const std::size_t rr = nf + nd;
  red.K.assign(rr * rr, 0.0), red.M.assign(rr * rr, 0.0);
  auto col = [&](std::size_t c, std::size_t i) { return c < nf ? Y[i * ns + nh + c] : 0.0; };  // static part
  for (std::size_t a = 0; a < rr; ++a)
    for (std::size_t b = 0; b < rr; ++b) {
      double x = 0.0;
      if (a < nf && b < nf) {
        for (std::size_t i = 0; i < ns; ++i)
          for (std::size_t j = 0; j < ns; ++j) x += col(a, i) * m.K[i * r + j] * col(b, j);
      } else if (a < nf) {
        for (std::size_t i = 0; i < ns; ++i) x += col(a, i) * m.K[i * r + ns + (b - nf)];
      } else if (b < nf) {
        for (std::size_t j = 0; j < ns; ++j) x += m.K[(ns + (a - nf)) * r + j] * col(b, j);
      } else {
        x = m.K[(ns + (a - nf)) * r + ns + (b - nf)];
        red.M[a * rr + b] = m.M[(ns + (a - nf)) * r + ns + (b - nf)];
      }
      red.K[a * rr + b] = x;
    }
  return 2.0 / std::sqrt(std::max(free_eigenvalues(red).back(), 1e-300));
}

std::vector<double> free_eigenvalues(const ReducedModel& m) {
  if (!m.massless) return eigen::dense_eigenvalues(static_cast<int>(m.r), m.K, m.M, nullptr);
  const std::size_t r = static_cast<std::size_t>(m.r), ns = static_cast<std::size_t>(m.n_static), nd = r - ns;
  return eigen::dense_eigenvalues(static_cast<int>(nd), condensed_stiffness(m, ns), block(m.M, r, ns, nd, ns, nd),
                                  nullptr);
}

}  // namespace morse::nlrom
