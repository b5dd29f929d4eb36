// Massless boundary: the Craig-Bampton variant of the mass redistribution of Monjaraz-Tec, Gross
// & Krack (2022) (see morse/nlrom/nlrom.hpp and docs/theory.md §11).
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/nlrom/nlrom.hpp"

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
  MORSE_CHECK(n_b > 0 && n_b <= r_ && M.size() == r * r && K.size() == r * r, "massless boundary: a model of ", r,
              " coordinates with ", n_b, " boundary coordinates has no boundary to make massless");
  const std::size_t ni = r - nb;
  MORSE_CHECK(ni > 0, "massless boundary: the basis has no internal coordinate to carry the mass (r = n_b = ", r,
              "): add fixed-interface modes");
  MORSE_CHECK(fmax_hz >= 0 && std::isfinite(fmax_hz), "-nlrom_massless_fmax must be a finite frequency >= 0 (got ",
              fmax_hz, ")");
  const auto Mii = block(M, r, nb, ni, nb, ni);
  // X = M_ii^-1 M_ib (ni x nb): eta = eta' - X u_b.
  const auto X = spd_solve(Mii, ni, block(M, r, nb, ni, 0, nb), nb,
                           "massless boundary: the internal mass M_ii is not positive definite");
  // The held-boundary modes of (K_ii, M_ii): the blocks are unchanged by the change of eta.
  std::vector<double> Y;
  const auto w = eigen::dense_eigenvalues(static_cast<int>(ni), block(K, r, nb, ni, nb, ni), Mii, &Y);
  const double wc = fmax_hz > 0 ? std::pow(2.0 * M_PI * fmax_hz, 2) : std::numeric_limits<double>::infinity();
  std::vector<std::size_t> order;  // quasi-static modes (w > wc) first, then the dynamic ones, each ascending
  for (std::size_t k = 0; k < ni; ++k)
    if (w[k] > wc) order.push_back(k);
  const std::size_t n_high = order.size();
  MORSE_CHECK(n_high < ni, "-nlrom_massless_fmax ", fmax_hz, " Hz is below every internal mode (the lowest is ",
              std::sqrt(std::max(w[0], 0.0)) / (2.0 * M_PI), " Hz): no dynamic coordinate would be left");
  for (std::size_t k = 0; k < ni; ++k)
    if (!(w[k] > wc)) order.push_back(k);
  *n_static = static_cast<PetscInt>(nb + n_high);
  // T = S blockdiag(I, Y P): [I 0; -X Y P].
  std::vector<double> T(r * r, 0.0);
  for (std::size_t b = 0; b < nb; ++b) T[b * r + b] = 1.0;
  for (std::size_t i = 0; i < ni; ++i) {
    for (std::size_t b = 0; b < nb; ++b) T[(nb + i) * r + b] = -X[i * nb + b];
    for (std::size_t c = 0; c < ni; ++c) T[(nb + i) * r + nb + c] = Y[i * ni + order[c]];
  }
  return T;
}

void relabel_massless(Basis* basis, PetscInt n_static) {
  const PetscInt r = basis->r();
  basis->labels.resize(static_cast<std::size_t>(basis->n_b));
  for (PetscInt k = basis->n_b; k < n_static; ++k)
    basis->labels.push_back(cat("quasi-static mode ", k - basis->n_b + 1));
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

void make_massless(ReducedModel* rm, PetscInt n_static, double xi, PetscInt k) {
  const std::size_t r = static_cast<std::size_t>(rm->r), ns = static_cast<std::size_t>(n_static), nd = r - ns;
  MORSE_CHECK(rm->n_b > 0 && n_static >= rm->n_b && ns < r,
              "massless boundary: the model needs boundary and dynamic "
              "coordinates (r = ",
              r, ", n_b = ", rm->n_b, ", static ", ns, ")");
  MORSE_CHECK(k >= 0 && static_cast<std::size_t>(k) <= nd, "massless boundary: ", k,
              " damped modes asked from a model of ", nd, " dynamic coordinates");
  const auto Keff = condensed_stiffness(*rm, ns);  // also proves K_ss positive definite
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < r; ++j)
      if (i < ns || j < ns) rm->M[i * r + j] = 0.0;
  std::fill(rm->C.begin(), rm->C.end(), 0.0);
  rm->damping_omega.clear();
  if (xi > 0 && k > 0) {
    const auto Mdd = block(rm->M, r, ns, nd, ns, nd);
    std::vector<double> X;  // M_dd-normalized modes of the free model, column m = mode m
    const auto w = eigen::dense_eigenvalues(static_cast<int>(nd), Keff, Mdd, &X);
    for (PetscInt m = 0; m < k; ++m) {
      const double om = std::sqrt(std::max(0.0, w[static_cast<std::size_t>(m)]));
      rm->damping_omega.push_back(om);
      std::vector<double> Mx(nd, 0.0);
      for (std::size_t i = 0; i < nd; ++i)
        for (std::size_t j = 0; j < nd; ++j) Mx[i] += Mdd[i * nd + j] * X[j * nd + static_cast<std::size_t>(m)];
      for (std::size_t i = 0; i < nd; ++i)
        for (std::size_t j = 0; j < nd; ++j) rm->C[(ns + i) * r + ns + j] += 2.0 * xi * om * Mx[i] * Mx[j];
    }
  }
  rm->massless = true;
  rm->n_static = n_static;
}

double massless_critical_step(const ReducedModel& m, double* free_boundary) {
  const std::size_t r = static_cast<std::size_t>(m.r), ns = static_cast<std::size_t>(m.n_static), nd = r - ns;
  const auto Mdd = block(m.M, r, ns, nd, ns, nd);
  const auto held = eigen::dense_eigenvalues(static_cast<int>(nd), block(m.K, r, ns, nd, ns, nd), Mdd, nullptr);
  if (free_boundary) {
    const auto w = eigen::dense_eigenvalues(static_cast<int>(nd), condensed_stiffness(m, ns), Mdd, nullptr);
    *free_boundary = 2.0 / std::sqrt(std::max(w.back(), 1e-300));
  }
  return 2.0 / std::sqrt(std::max(held.back(), 1e-300));
}

}  // namespace morse::nlrom
