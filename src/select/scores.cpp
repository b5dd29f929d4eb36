#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "morse/core/error.hpp"
#include "morse/core/units.hpp"
#include "morse/select/select.hpp"

namespace morse::select {

namespace {
struct Named {
  Method m;
  const char* name;
};
constexpr Named kMethods[] = {{Method::Frequency, "frequency"}, {Method::LPF, "lpf"},   {Method::EIM, "eim"},
                              {Method::VEIM, "veim"},           {Method::DEIM, "deim"}, {Method::OMR, "omr"},
                              {Method::CMSChi, "cmschi"},       {Method::EBR, "ebr"},   {Method::IMR, "imr"}};

double dot(const double* x, const double* y, PetscInt n) {
  double s = 0;
  for (PetscInt k = 0; k < n; ++k) s += x[k] * y[k];
  return s;
}
}  // namespace

bool parse_method(const std::string& name, Method* m) {
  for (const auto& x : kMethods)
    if (name == x.name) {
      *m = x.m;
      return true;
    }
  return false;
}

std::vector<double> InterfaceCoupling::P() const {
  std::vector<double> p(a.size());
  for (std::size_t k = 0; k < p.size(); ++k) p[k] = -(a[k] + g[k]);
  return p;
}

InterfaceCoupling interface_coupling(MPI_Comm comm, Mat K, Mat M, const cb::CBResult& cb) {
  MORSE_CHECK(cb.T, "interface_coupling: the Craig-Bampton basis was not kept");
  InterfaceCoupling ic;
  ic.n_b = cb.n_b;
  ic.n_phi = cb.n_phi;
  ic.lambda = cb.fixed_omega2;
  if (cb.n_phi == 0) return ic;
  PetscInt rstart = 0, rend = 0, m_local = 0;
  MORSE_CALL(MatGetOwnershipRange(cb.T.get(), &rstart, &rend));
  m_local = rend - rstart;
  // E_b: identity rows at the boundary DOFs; Psi_pad: Psi with zero boundary rows.
  UMat Eb, Psi;
  MORSE_CALL(MatCreateDense(comm, m_local, PETSC_DECIDE, PETSC_DETERMINE, cb.n_b, nullptr, Eb.ptr()));
  MORSE_CALL(MatCreateDense(comm, m_local, PETSC_DECIDE, PETSC_DETERMINE, cb.n_b, nullptr, Psi.ptr()));
  {
    PetscScalar *e, *p;
    const PetscScalar* t;
    PetscInt lde, ldp, ldt;
    MORSE_CALL(MatDenseGetLDA(Eb.get(), &lde));
    MORSE_CALL(MatDenseGetLDA(Psi.get(), &ldp));
    MORSE_CALL(MatDenseGetLDA(cb.T.get(), &ldt));
    MORSE_CALL(MatDenseGetArrayWrite(Eb.get(), &e));
    MORSE_CALL(MatDenseGetArrayWrite(Psi.get(), &p));
    MORSE_CALL(MatDenseGetArrayRead(cb.T.get(), &t));
    std::vector<char> is_b(m_local, 0);
    for (PetscInt j = 0; j < cb.n_b; ++j) {
      PetscInt g = cb.boundary_dofs[j];
      if (g >= rstart && g < rend) is_b[g - rstart] = 1;
    }
    for (PetscInt j = 0; j < cb.n_b; ++j)
      for (PetscInt r = 0; r < m_local; ++r) {
        e[r + lde * j] = 0.0;
        p[r + ldp * j] = is_b[r] ? 0.0 : t[r + ldt * j];
      }
    for (PetscInt j = 0; j < cb.n_b; ++j) {
      PetscInt g = cb.boundary_dofs[j];
      if (g >= rstart && g < rend) e[(g - rstart) + lde * j] = 1.0;
    }
    MORSE_CALL(MatDenseRestoreArrayRead(cb.T.get(), &t));
    MORSE_CALL(MatDenseRestoreArrayWrite(Psi.get(), &p));
    MORSE_CALL(MatDenseRestoreArrayWrite(Eb.get(), &e));
  }
  Mat Phi;  // fixed-interface columns of T (zero on boundary rows)
  MORSE_CALL(MatDenseGetSubMatrix(cb.T.get(), PETSC_DECIDE, PETSC_DECIDE, cb.n_b, cb.n(), &Phi));
  UMat ME, KE, MPsi;
  MORSE_CALL(MatMatMult(M, Eb.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, ME.ptr()));
  MORSE_CALL(MatMatMult(K, Eb.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, KE.ptr()));
  MORSE_CALL(MatMatMult(M, Psi.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, MPsi.ptr()));
  ic.a = cb::transpose_product(comm, Phi, ME.get());
  ic.c = cb::transpose_product(comm, Phi, KE.get());
  ic.g = cb::transpose_product(comm, Phi, MPsi.get());
  MORSE_CALL(MatDenseRestoreSubMatrix(cb.T.get(), &Phi));
  return ic;
}

namespace {

// EBR (seed 000 eq. 18–20): for each harmonic k and load f_k on the boundary, the undamped
// superelement response x = (K_CB - omega_k^2 M_CB)^{-1} [f_k; 0] gives boundary motion u_b and
// modal amplitudes eta; mode i stores the mean energy
//   1/2 (lambda_i + omega_k^2) eta_i^2 + omega_k^2 eta_i (M_CB,ib u_b)
// (its own strain + kinetic energy, and its kinetic coupling with the boundary motion, the
// phase factor of eq. 19 being the sign of the real responses). Harmonics are spread over ranks.
std::vector<double> ebr_scores(MPI_Comm comm, const InterfaceCoupling& ic, const cb::CBResult& cb,
                               const Excitation& ex) {
  const PetscInt nb = cb.n_b, nr = cb.n(), nphi = cb.n_phi;
  MORSE_CHECK(!ex.freq_hz.empty(), "EBR needs an excitation: give -select_ebr_freq (Hz) or use the default");
  const bool table = !ex.load.empty();
  if (table) {
    MORSE_CHECK(ex.load.size() == ex.freq_hz.size(), "EBR excitation: one load vector per harmonic expected");
    bool any = false;
    for (const auto& f : ex.load) {
      MORSE_CHECK(static_cast<PetscInt>(f.size()) == nb, "EBR excitation: a load vector has ", f.size(),
                  " entries for ", nb, " boundary DOFs");
      for (auto v : f) any = any || v != 0.0;
    }
    MORSE_CHECK(any, "EBR without excitation: every amplitude of the load table is zero");
  } else {
    MORSE_CHECK(ex.amplitude.size() == ex.freq_hz.size() && ex.phase_deg.size() == ex.freq_hz.size(),
                "EBR excitation: -select_ebr_freq, -select_ebr_amp and -select_ebr_phase must have the same length");
    bool any = false;
    for (double a : ex.amplitude) any = any || a != 0.0;
    MORSE_CHECK(any, "EBR without excitation: every amplitude of -select_ebr_amp is zero");
  }
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  std::vector<double> s(nphi, 0.0);
  std::string err;
  for (std::size_t k = rank; k < ex.freq_hz.size() && err.empty(); k += size) {
    const double w2 = omega2_of_hz(ex.freq_hz[k]);
    std::vector<double> A(static_cast<std::size_t>(nr) * nr);
    for (PetscInt i = 0; i < nr * nr; ++i) A[i] = cb.K[i] - w2 * cb.M[i];
    // All components: one real unit load per boundary DOF, each scored on its own. Otherwise
    // one complex load f, solved as [Re f, Im f]: the response Re(x e^{i w t}) has the period
    // means of both parts added, so the mode's energy is the sum over the two columns.
    const PetscInt nrhs = ex.all_components ? nb : 2;
    std::vector<double> X(static_cast<std::size_t>(nr) * nrhs, 0.0);  // column-major
    for (PetscInt r = 0; r < nb; ++r) {
      if (ex.all_components) {
        X[r + nr * r] = ex.amplitude[k];
        continue;
      }
      const std::complex<double> f =
          table ? ex.load[k][r] : std::polar(ex.amplitude[k], ex.phase_deg[k] * M_PI / 180.0);
      X[r] = f.real();
      X[r + nr] = f.imag();
    }
    PetscBLASInt n = nr, nrhs_ = nrhs, info = 0;
    std::vector<PetscBLASInt> piv(nr);
    LAPACKgesv_(&n, &nrhs_, A.data(), &n, piv.data(), X.data(), &n, &info);
    if (info != 0) {
      err = cat("EBR: excitation frequency ", ex.freq_hz[k], " Hz is at a resonance of the superelement");
      break;
    }
    for (PetscInt i = 0; i < nphi; ++i) {
      double e_sum = 0;
      for (PetscInt j = 0; j < nrhs; ++j) {
        const double* x = &X[static_cast<std::size_t>(nr) * j];
        const double eta = x[nb + i];
        double coupling = 0;
        for (PetscInt r = 0; r < nb; ++r) coupling += cb.M[(nb + i) * nr + r] * x[r];
        const double e = 0.5 * (ic.lambda[i] + w2) * eta * eta + w2 * eta * coupling;
        if (ex.all_components)
          s[i] += std::abs(e);
        else
          e_sum += e;
      }
      if (!ex.all_components) s[i] += std::abs(e_sum);
    }
  }
  collective_check(comm, err);
  MPI_Allreduce(MPI_IN_PLACE, s.data(), static_cast<int>(nphi), MPI_DOUBLE, MPI_SUM, comm);
  return s;
}

// IMR (seed 000 eq. 21–22) with omega_f = (1 + shift) omega_zeta:
//   S_{zeta,i} = Gamma2_{zeta,i} / (lambda_i / lambda_zeta - 1) * m_i,
//   Gamma2_{zeta,i} = phi_i^T (M_sb v_b + M_ss v_s) = X1 + X2,
//   m_i = (lambda_zeta X1 + lambda_f g_i . v_b) / (lambda_f (lambda_zeta - lambda_f)) + X2 / lambda_f,
// summed in absolute value over the chosen system modes.
std::vector<double> imr_scores(const InterfaceCoupling& ic, const ImrData& d) {
  const PetscInt nphi = ic.n_phi, nb = ic.n_b;
  std::vector<double> s(nphi, 0.0);
  if (d.clamped) {
    // The system modes are fixed-interface modes: each contributes only to itself.
    for (auto z : d.clamped_modes) s[z] = 1.0;
    return s;
  }
  const PetscInt nz = static_cast<PetscInt>(d.lambda.size());
  for (PetscInt z = 0; z < nz; ++z) {
    const double lz = d.lambda[z], lf = std::pow(1.0 + d.shift, 2) * lz;
    for (PetscInt i = 0; i < nphi; ++i) {
      const double x1 = d.X1[i * nz + z], x2 = d.X2[i * nz + z];
      const double gv = dot(&ic.g[i * nb], &d.vb[z * nb], nb);
      const double m = (lz * x1 + lf * gv) / (lf * (lz - lf)) + x2 / lf;
      const double denom = ic.lambda[i] / lz - 1.0;
      s[i] += std::abs((x1 + x2) * m / (std::abs(denom) < 1e-14 ? 1e-14 : denom));
    }
  }
  return s;
}

}  // namespace

std::vector<double> scores(MPI_Comm comm, Method m, const InterfaceCoupling& ic, const cb::CBResult& cb,
                           const Excitation& ex, const ImrData* imr) {
  const PetscInt nphi = ic.n_phi, nb = ic.n_b;
  std::vector<double> s(nphi, 0.0);
  if (m == Method::EBR) return ebr_scores(comm, ic, cb, ex);
  if (m == Method::IMR) {
    MORSE_CHECK(imr, "IMR needs the full system's modes");
    return imr_scores(ic, *imr);
  }
  for (PetscInt i = 0; i < nphi; ++i) {
    const double *a = &ic.a[i * nb], *c = &ic.c[i * nb], *g = &ic.g[i * nb];
    const double l = ic.lambda[i];
    double p2 = 0;
    for (PetscInt r = 0; r < nb; ++r) p2 += (a[r] + g[r]) * (a[r] + g[r]);
    switch (m) {
      case Method::Frequency:
      case Method::EIM:
        s[i] = p2;
        break;
      case Method::VEIM:
        s[i] = p2 / l;
        break;
      case Method::DEIM:
        s[i] = p2 / (l * l);
        break;
      case Method::LPF:
        s[i] = dot(g, g, nb);
        break;
      case Method::OMR:
        s[i] = l * dot(a, a, nb) - 2.0 * dot(a, c, nb) + dot(c, c, nb) / l;
        break;
      case Method::CMSChi:
        s[i] = p2 / l;
        break;
      default:
        break;
    }
  }
  return s;
}

Selection truncate(Method m, const std::vector<double>& score, PetscInt count, double fraction) {
  const PetscInt n = static_cast<PetscInt>(score.size());
  Selection sel;
  sel.ranking.resize(n);
  std::iota(sel.ranking.begin(), sel.ranking.end(), 0);
  if (m != Method::Frequency)
    std::stable_sort(sel.ranking.begin(), sel.ranking.end(),
                     [&](PetscInt x, PetscInt y) { return score[x] > score[y]; });
  double total = 0;
  for (double v : score) total += v;
  sel.cumulative.resize(n);
  double run = 0;
  for (PetscInt k = 0; k < n; ++k) {
    run += score[sel.ranking[k]];
    sel.cumulative[k] = total > 0 ? run / total : 0.0;
  }
  PetscInt keep = n;
  if (count >= 0) {
    MORSE_CHECK(count <= n, "-select_num_modes ", count, " exceeds the ", n, " candidate fixed-interface modes");
    keep = count;
  } else {
    keep = 0;
    while (keep < n && sel.cumulative[keep] < fraction * (1 - 1e-12)) ++keep;
    keep = std::min(n, keep + 1);
  }
  sel.selected.assign(sel.ranking.begin(), sel.ranking.begin() + keep);
  std::sort(sel.selected.begin(), sel.selected.end());
  sel.retained = keep > 0 ? sel.cumulative[keep - 1] : 0.0;
  return sel;
}

std::vector<double> directional_mass_fractions(const InterfaceCoupling& ic, double total_mass) {
  const PetscInt nb = ic.n_b;
  auto P = ic.P();
  std::vector<double> f(3 * ic.n_phi, 0.0);
  for (PetscInt i = 0; i < ic.n_phi; ++i)
    for (int d = 0; d < 3; ++d) {
      double pr = 0;
      for (PetscInt r = d; r < nb; r += 3) pr += P[i * nb + r];
      f[3 * i + d] = pr * pr / total_mass;
    }
  return f;
}

namespace {

// Local rows of an MPIDENSE matrix as a column-major array (copy) with its row range.
struct LocalDense {
  PetscInt rstart = 0, m = 0, n = 0;
  std::vector<double> a;  // column-major m x n
};

LocalDense local_copy(Mat A) {
  LocalDense d;
  PetscInt rend, lda;
  MORSE_CALL(MatGetOwnershipRange(A, &d.rstart, &rend));
  MORSE_CALL(MatGetSize(A, nullptr, &d.n));
  MORSE_CALL(MatDenseGetLDA(A, &lda));
  d.m = rend - d.rstart;
  d.a.resize(static_cast<std::size_t>(d.m) * d.n);
  const PetscScalar* x;
  MORSE_CALL(MatDenseGetArrayRead(A, &x));
  for (PetscInt j = 0; j < d.n; ++j)
    for (PetscInt r = 0; r < d.m; ++r) d.a[r + d.m * j] = x[r + lda * j];
  MORSE_CALL(MatDenseRestoreArrayRead(A, &x));
  return d;
}

UMat dense_from_local(MPI_Comm comm, const LocalDense& d) {
  UMat A;
  MORSE_CALL(MatCreateDense(comm, d.m, PETSC_DECIDE, PETSC_DETERMINE, d.n, nullptr, A.ptr()));
  PetscScalar* x;
  PetscInt lda;
  MORSE_CALL(MatDenseGetLDA(A.get(), &lda));
  MORSE_CALL(MatDenseGetArrayWrite(A.get(), &x));
  for (PetscInt j = 0; j < d.n; ++j)
    for (PetscInt r = 0; r < d.m; ++r) x[r + lda * j] = d.a[r + d.m * j];
  MORSE_CALL(MatDenseRestoreArrayWrite(A.get(), &x));
  return A;
}

}  // namespace

ImrData imr_data(MPI_Comm comm, Mat M, const cb::CBResult& cb, Mat V, const std::vector<double>& lambda,
                 const std::vector<PetscInt>& modes, double shift) {
  ImrData d;
  d.shift = shift;
  const PetscInt nb = cb.n_b, nz = static_cast<PetscInt>(modes.size());
  auto full = local_copy(V);
  LocalDense vb{full.rstart, full.m, nz, {}}, vs{full.rstart, full.m, nz, {}};
  vb.a.assign(static_cast<std::size_t>(full.m) * nz, 0.0);
  vs.a.assign(static_cast<std::size_t>(full.m) * nz, 0.0);
  std::vector<char> is_b(full.m, 0);
  std::vector<PetscInt> bpos(full.m, -1);
  for (PetscInt j = 0; j < nb; ++j) {
    PetscInt g = cb.boundary_dofs[j] - full.rstart;
    if (g >= 0 && g < full.m) is_b[g] = 1, bpos[g] = j;
  }
  d.vb.assign(static_cast<std::size_t>(nz) * nb, 0.0);
  for (PetscInt z = 0; z < nz; ++z) {
    d.lambda.push_back(lambda[modes[z]]);
    for (PetscInt r = 0; r < full.m; ++r) {
      const double v = full.a[r + full.m * modes[z]];
      (is_b[r] ? vb : vs).a[r + full.m * z] = v;
      if (is_b[r]) d.vb[z * nb + bpos[r]] = v;
    }
  }
  MPI_Allreduce(MPI_IN_PLACE, d.vb.data(), static_cast<int>(d.vb.size()), MPI_DOUBLE, MPI_SUM, comm);
  auto Vb = dense_from_local(comm, vb), Vs = dense_from_local(comm, vs);
  UMat MVb, MVs;
  MORSE_CALL(MatMatMult(M, Vb.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, MVb.ptr()));
  MORSE_CALL(MatMatMult(M, Vs.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, MVs.ptr()));
  Mat Phi;
  MORSE_CALL(MatDenseGetSubMatrix(cb.T.get(), PETSC_DECIDE, PETSC_DECIDE, cb.n_b, cb.n(), &Phi));
  d.X1 = cb::transpose_product(comm, Phi, MVb.get());
  d.X2 = cb::transpose_product(comm, Phi, MVs.get());
  MORSE_CALL(MatDenseRestoreSubMatrix(cb.T.get(), &Phi));
  return d;
}

MacBasis mac_basis(MPI_Comm comm, Mat V, Mat MV, Mat T) {
  MacBasis b;
  MORSE_CALL(MatGetSize(V, nullptr, &b.n_v));
  MORSE_CALL(MatGetSize(T, nullptr, &b.n_r));
  b.VT = cb::transpose_product(comm, V, T);
  b.WT = cb::transpose_product(comm, MV, T);
  b.TT = cb::transpose_product(comm, T, T);
  auto v = local_copy(V), w = local_copy(MV);
  b.vv.assign(b.n_v, 0.0);
  b.vmv.assign(b.n_v, 0.0);
  for (PetscInt i = 0; i < b.n_v; ++i) {
    const double* vi = &v.a[static_cast<std::size_t>(v.m) * i];
    b.vv[i] = dot(vi, vi, v.m);
    b.vmv[i] = dot(&w.a[static_cast<std::size_t>(w.m) * i], vi, v.m);
  }
  MPI_Allreduce(MPI_IN_PLACE, b.vv.data(), static_cast<int>(b.n_v), MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, b.vmv.data(), static_cast<int>(b.n_v), MPI_DOUBLE, MPI_SUM, comm);
  return b;
}

std::vector<double> mac_matrix(const MacBasis& b, const std::vector<double>& Q, PetscInt n_q,
                               const std::vector<double>* M_cb) {
  const PetscInt nv = b.n_v, nr = b.n_r;
  const std::vector<double>& A = M_cb ? b.WT : b.VT;
  const std::vector<double>& G = M_cb ? *M_cb : b.TT;  // Gram matrix of the basis
  // num = A Q (nv x nq); uu_k = q_k^T G q_k.
  std::vector<double> num(static_cast<std::size_t>(nv) * n_q, 0.0), GQ(static_cast<std::size_t>(nr) * n_q, 0.0),
      uu(n_q, 0.0);
  for (PetscInt i = 0; i < nv; ++i)
    for (PetscInt j = 0; j < nr; ++j) {
      const double a = A[i * nr + j];
      if (a == 0.0) continue;
      for (PetscInt k = 0; k < n_q; ++k) num[i * n_q + k] += a * Q[j * n_q + k];
    }
  for (PetscInt r = 0; r < nr; ++r)
    for (PetscInt j = 0; j < nr; ++j) {
      const double g = G[r * nr + j];
      if (g == 0.0) continue;
      for (PetscInt k = 0; k < n_q; ++k) GQ[r * n_q + k] += g * Q[j * n_q + k];
    }
  for (PetscInt r = 0; r < nr; ++r)
    for (PetscInt k = 0; k < n_q; ++k) uu[k] += Q[r * n_q + k] * GQ[r * n_q + k];
  const std::vector<double>& vn = M_cb ? b.vmv : b.vv;
  for (PetscInt i = 0; i < nv; ++i)
    for (PetscInt k = 0; k < n_q; ++k) {
      double& x = num[i * n_q + k];
      x = (vn[i] > 0 && uu[k] > 0) ? x * x / (vn[i] * uu[k]) : 0.0;
    }
  return num;
}

std::vector<double> restrict_operator(const std::vector<double>& A, PetscInt n_b, PetscInt n,
                                      const std::vector<PetscInt>& selected) {
  std::vector<PetscInt> idx(n_b);
  std::iota(idx.begin(), idx.end(), 0);
  for (auto s : selected) idx.push_back(n_b + s);
  const std::size_t m = idx.size();
  std::vector<double> R(m * m);
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < m; ++j) R[i * m + j] = A[idx[i] * n + idx[j]];
  return R;
}

}  // namespace morse::select
