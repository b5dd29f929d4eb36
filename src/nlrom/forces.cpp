// Reduced St Venant–Kirchhoff forces: STEP (seed 003 eq. 29–37) and exact projection.
#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/nlrom/nlrom.hpp"

namespace morse::nlrom {

void CubicForce::evaluate(const double* q, double* g) const {
  std::fill(g, g + r, 0.0);
  std::size_t m2 = 0, m3 = 0;
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j) {
      const double qq = q[i] * q[j];
      const double* a = &A[m2++ * r];
      for (std::size_t p = 0; p < r; ++p) g[p] += a[p] * qq;
      for (std::size_t k = j; k < r; ++k) {
        const double qqq = qq * q[k];
        const double* b = &B[m3++ * r];
        for (std::size_t p = 0; p < r; ++p) g[p] += b[p] * qqq;
      }
    }
}

void CubicForce::jacobian(const double* q, double* J) const {
  // Column m of dg/dq accumulated contiguously (Jc[m r + p]), then transposed to row-major.
  std::vector<double> Jc(r * r, 0.0);
  auto axpy = [&](std::size_t m, const double* c, double s) {
    double* col = &Jc[m * r];
    for (std::size_t p = 0; p < r; ++p) col[p] += c[p] * s;
  };
  std::size_t m2 = 0, m3 = 0;
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i; j < r; ++j) {
      const double* a = &A[m2++ * r];
      axpy(i, a, q[j]);  // d(q_i q_j) = q_j dq_i + q_i dq_j (both land on i when i = j)
      axpy(j, a, q[i]);
      for (std::size_t k = j; k < r; ++k) {
        const double* b = &B[m3++ * r];
        axpy(i, b, q[j] * q[k]);
        axpy(j, b, q[i] * q[k]);
        axpy(k, b, q[i] * q[j]);
      }
    }
  for (std::size_t p = 0; p < r; ++p)
    for (std::size_t m = 0; m < r; ++m) J[p * r + m] = Jc[m * r + p];
}

double CubicForce::max_abs_A() const {
  double m = 0;
  for (double v : A) m = std::max(m, std::abs(v));
  return m;
}

double CubicForce::max_abs_B() const {
  double m = 0;
  for (double v : B) m = std::max(m, std::abs(v));
  return m;
}

CubicForce exact_forces(const fe::Svk& svk, Mat Phi) {
  PetscInt r = 0;
  MORSE_CALL(MatGetSize(Phi, nullptr, &r));
  CubicForce f;
  f.r = static_cast<std::size_t>(r);
  svk.project_tensors(Phi, &f.A, &f.B);
  return f;
}

CubicForce step_forces(const fe::Svk& svk, Mat Phi, const StepSettings& s) {
  MORSE_CHECK(s.displacement > 0 && std::isfinite(s.displacement), "-step_displacement must be positive (got ",
              s.displacement, ")");
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)Phi, &comm));
  StageTimer stage(comm, "Step");
  PetscInt rr = 0;
  MORSE_CALL(MatGetSize(Phi, nullptr, &rr));
  const std::size_t r = static_cast<std::size_t>(rr);
  // Amplitudes: q_i max|phi_i| = displacement.
  std::vector<double> amp(r);
  for (std::size_t i = 0; i < r; ++i) {
    Vec c;
    double m;
    MORSE_CALL(MatDenseGetColumnVecRead(Phi, static_cast<PetscInt>(i), &c));
    MORSE_CALL(VecNorm(c, NORM_INFINITY, &m));
    MORSE_CALL(MatDenseRestoreColumnVecRead(Phi, static_cast<PetscInt>(i), &c));
    MORSE_CHECK(m > 0, "STEP: basis vector ", i, " is zero");
    amp[i] = s.displacement / m;
  }
  // Imposed fields, eq. 29, 35, 36: +-i; (+i+j, -i-j, +i-j); +i+j+k.
  const std::size_t nf = step_evaluations(r);
  std::vector<double> Q(nf * r, 0.0);
  std::size_t f = 0;
  auto put = [&](std::size_t i, double sign) { Q[f * r + i] = sign * amp[i]; };
  for (std::size_t i = 0; i < r; ++i) {
    put(i, 1), ++f;
    put(i, -1), ++f;
  }
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i + 1; j < r; ++j) {
      put(i, 1), put(j, 1), ++f;
      put(i, -1), put(j, -1), ++f;
      put(i, 1), put(j, -1), ++f;
    }
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i + 1; j < r; ++j)
      for (std::size_t k = j + 1; k < r; ++k) put(i, 1), put(j, 1), put(k, 1), ++f;
  MORSE_CHECK(f == nf, "STEP: internal count mismatch");

  // Reduced forces of every field, eq. 31–32 (filtered: Phi^T Phi_f Phi_f^T g).
  std::vector<double> F;
  if (s.filter) {
    PetscInt nfl = 0;
    MORSE_CALL(MatGetSize(s.filter, nullptr, &nfl));
    auto Ff = svk.reduced_nonlinear_forces(Phi, s.filter, Q, static_cast<PetscInt>(nf), s.chunk);
    auto P = cb::transpose_product(comm, Phi, s.filter);  // r x nfl, row-major
    F.assign(nf * r, 0.0);
    for (std::size_t e = 0; e < nf; ++e)
      for (std::size_t p = 0; p < r; ++p) {
        double v = 0.0;
        for (PetscInt l = 0; l < nfl; ++l) v += P[p * nfl + l] * Ff[e * nfl + l];
        F[e * r + p] = v;
      }
  } else {
    F = svk.reduced_nonlinear_forces(Phi, nullptr, Q, static_cast<PetscInt>(nf), s.chunk);
  }

  CubicForce out;
  out.r = r;
  out.A.assign(n_quadratic(r) * r, 0.0);
  out.B.assign(n_cubic(r) * r, 0.0);
  auto i2 = [&](std::size_t i, std::size_t j) { return i * r - i * (i - 1) / 2 + (j - i); };
  // Lexicographic index of (i <= j <= k): count the monomials before i, then (j, k) within i.
  std::vector<std::size_t> start3(r + 1, 0);
  for (std::size_t i = 0; i < r; ++i) start3[i + 1] = start3[i] + n_quadratic(r - i);
  auto i3 = [&](std::size_t i, std::size_t j, std::size_t k) {
    const std::size_t m = r - i, jj = j - i, kk = k - i;  // (jj <= kk) among m coordinates
    return start3[i] + jj * m - jj * (jj - 1) / 2 + (kk - jj);
  };
  auto Arow = [&](std::size_t i, std::size_t j) { return &out.A[i2(i, j) * r]; };
  auto Brow = [&](std::size_t i, std::size_t j, std::size_t k) { return &out.B[i3(i, j, k) * r]; };
  f = 0;
  for (std::size_t i = 0; i < r; ++i, f += 2) {  // eq. 34
    const double a = amp[i];
    for (std::size_t p = 0; p < r; ++p) {
      const double fa = F[f * r + p], fb = F[(f + 1) * r + p];
      Arow(i, i)[p] = (fa + fb) / (2 * a * a);
      Brow(i, i, i)[p] = (fa - fb) / (2 * a * a * a);
    }
  }
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i + 1; j < r; ++j, f += 3) {
      const double a = amp[i], b = amp[j];
      for (std::size_t p = 0; p < r; ++p) {
        const double f1 = F[f * r + p], f2 = F[(f + 1) * r + p], f3 = F[(f + 2) * r + p];
        const double sq = Arow(i, i)[p] * a * a + Arow(j, j)[p] * b * b;
        const double cu = Brow(i, i, i)[p] * a * a * a, cv = Brow(j, j, j)[p] * b * b * b;
        const double aij = ((f1 + f2) / 2 - sq) / (a * b);
        Arow(i, j)[p] = aij;
        const double s1 = (f1 - f2) / 2 - cu - cv;            // B_iij a^2 b + B_ijj a b^2
        const double s2 = f3 - (sq - aij * a * b) - cu + cv;  // -B_iij a^2 b + B_ijj a b^2
        Brow(i, j, j)[p] = (s1 + s2) / (2 * a * b * b);
        Brow(i, i, j)[p] = (s1 - s2) / (2 * a * a * b);
      }
    }
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = i + 1; j < r; ++j)
      for (std::size_t k = j + 1; k < r; ++k, ++f) {
        const double x[3] = {amp[i], amp[j], amp[k]};
        const std::size_t id[3] = {i, j, k};
        for (std::size_t p = 0; p < r; ++p) {
          double rest = 0.0;
          for (int u = 0; u < 3; ++u)
            for (int v = u; v < 3; ++v) {
              rest += Arow(id[u], id[v])[p] * x[u] * x[v];
              for (int w = v; w < 3; ++w)
                if (!(u == 0 && v == 1 && w == 2)) rest += Brow(id[u], id[v], id[w])[p] * x[u] * x[v] * x[w];
            }
          Brow(i, j, k)[p] = (F[f * r + p] - rest) / (x[0] * x[1] * x[2]);
        }
      }
  return out;
}

}  // namespace morse::nlrom
