// select/verify.cpp: the selection of every method and its check against the full model
// (select::verify, morse/select/select.hpp): MAC of the restricted superelement's in-band modes
// against the full model's, with the IMR system modes and the EBR excitation they need.
#include <petscmat.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/handle.hpp"
#include "morse/core/log.hpp"
#include "morse/core/units.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/select/select.hpp"

namespace morse::select {

namespace {

// The zero-frequency (rigid-body) modes of a restricted superelement of a model free in some
// motions, the leading `k` columns of `vec` (row-major n x n, column = mode; rows = the CB
// coordinates idx): rotated to the basis eigen::solve_eigen gives the full model's zero modes
// (eigen::canonical_rotation with the same reference vectors), so that each pairs with one full-
// model mode by MAC instead of mixing freely in their eigenspace. G = W^T M T (k x nr, row-major).
void canonical_zero_modes(int n, PetscInt k, PetscInt nr, const std::vector<PetscInt>& idx,
                          const std::vector<double>& G, std::vector<double>* vec_) {
  auto& vec = *vec_;
  std::vector<double> C(static_cast<std::size_t>(k * k), 0.0), Q;
  for (PetscInt j = 0; j < k; ++j)
    for (PetscInt a = 0; a < k; ++a)
      for (int row = 0; row < n; ++row)
        C[static_cast<std::size_t>(a + k * j)] +=
            vec[static_cast<std::size_t>(row) * n + a] * G[static_cast<std::size_t>(j * nr + idx[row])];
  if (!eigen::canonical_rotation(k, C, &Q)) return;
  std::vector<double> t(static_cast<std::size_t>(k));
  for (int row = 0; row < n; ++row) {
    for (PetscInt j = 0; j < k; ++j) {
      double x = 0;
      for (PetscInt a = 0; a < k; ++a)
        x += vec[static_cast<std::size_t>(row) * n + a] * Q[static_cast<std::size_t>(a + k * j)];
      t[static_cast<std::size_t>(j)] = x;
    }
    for (PetscInt j = 0; j < k; ++j) vec[static_cast<std::size_t>(row) * n + j] = t[static_cast<std::size_t>(j)];
  }
}

}  // namespace

VerifyResult verify(MPI_Comm comm, Mat K, Mat M, const cb::CBResult& res, Vec w, const VerifySettings& s) {
  VerifyResult out;
  const PetscInt nb = res.n_b, nr = res.n(), nphi = res.n_phi;
  const double f_an = s.fmax_analysis_hz;
  out.fmax_analysis_hz = f_an;
  const double l_an = std::pow(kTwoPi * f_an, 2);
  auto& ic = out.ic;
  {
    StageTimer t(comm, "InterfaceCoupling");
    ic = interface_coupling(comm, K, M, res);
  }
  // Full-model modes with the real boundary conditions (clamp only): MAC reference and IMR.
  eigen::Eigenpairs fom;
  out.checked = s.check;
  const bool imr_free =
      std::find(s.methods.begin(), s.methods.end(), Method::IMR) != s.methods.end() && s.imr_support == "free";
  if (s.check || imr_free) {
    eigen::EigenSettings es;
    es.prefix = "select_fom_";
    es.stage = "Fom";
    es.what = "full-model modes";
    if (s.fom_modes > 0)
      es.nev = s.fom_modes;
    else
      es.omega2_max = l_an;
    fom = eigen::solve_eigen(K, M, es, w);
  }
  const PetscInt n_fom = s.check ? static_cast<PetscInt>(fom.omega2.size()) : 0;
  if (s.check) out.fom_omega2 = fom.omega2;

  auto& ex = out.excitation;
  if (!s.ebr_load.empty()) {
    ex = read_ebr_load(comm, s.ebr_load, res);
  } else if (s.ebr_given) {
    ex.freq_hz = s.ebr_freq;
    ex.amplitude = s.ebr_amp.empty() ? std::vector<double>(ex.freq_hz.size(), 1.0) : s.ebr_amp;
    ex.phase_deg = s.ebr_phase.empty() ? std::vector<double>(ex.freq_hz.size(), 0.0) : s.ebr_phase;
    ex.all_components = false;
  } else {
    for (int k = 1; k <= 8; ++k) ex.freq_hz.push_back(f_an * (k - 0.5) / 8.0);
    ex.amplitude.assign(8, 1.0);
    ex.phase_deg.assign(8, 0.0);
  }
  std::unique_ptr<ImrData> imr;
  if (std::find(s.methods.begin(), s.methods.end(), Method::IMR) != s.methods.end()) {
    StageTimer t(comm, "ImrSystemModes");
    std::vector<PetscInt> modes;
    for (auto m1 : s.imr_modes) modes.push_back(m1 - 1);
    if (s.imr_support == "clamped") {
      imr = std::make_unique<ImrData>();
      imr->clamped = true;
      if (modes.empty())
        for (PetscInt i = 0; i < nphi && res.fixed_omega2[i] <= l_an; ++i) modes.push_back(i);
      for (auto m : modes)
        MORSE_CHECK(m >= 0 && m < nphi, "-select_imr_modes ", m + 1, " is out of range (1..", nphi,
                    " fixed-interface modes)");
      imr->clamped_modes = modes;
    } else {
      eigen::Eigenpairs sys;
      Mat Ks = K;
      UMat Kspring;
      eigen::Eigenpairs* use = &fom;
      if (s.imr_support == "spring") {
        MORSE_CALL(MatDuplicate(K, MAT_COPY_VALUES, Kspring.ptr()));
        for (auto g : res.boundary_dofs) {
          PetscInt rs, re;
          MORSE_CALL(MatGetOwnershipRange(Kspring.get(), &rs, &re));
          if (g >= rs && g < re) MORSE_CALL(MatSetValue(Kspring.get(), g, g, s.imr_stiffness, ADD_VALUES));
        }
        MORSE_CALL(MatAssemblyBegin(Kspring.get(), MAT_FINAL_ASSEMBLY));
        MORSE_CALL(MatAssemblyEnd(Kspring.get(), MAT_FINAL_ASSEMBLY));
        Ks = Kspring.get();
        eigen::EigenSettings es;
        es.prefix = "select_imr_";
        es.stage = "Imr";
        es.what = "IMR system modes";
        es.omega2_max = l_an;
        sys = eigen::solve_eigen(Ks, M, es, nullptr);
        use = &sys;
      }
      const PetscInt n_sys = static_cast<PetscInt>(use->omega2.size());
      // Rigid-body modes of a free system (omega = 0) have no resonance for a fixed-interface mode
      // to feed (IMR's fictitious force at (1 + shift) omega is 0; its eq. 22 is 0/0): by default
      // the flexible system modes are used, and naming a rigid one is an error.
      if (modes.empty())
        for (PetscInt i = use->zero_modes; i < n_sys; ++i) modes.push_back(i);
      for (auto m : modes)
        MORSE_CHECK(m < 0 || m >= use->zero_modes, "-select_imr_modes ", m + 1, ": system mode ", m + 1,
                    " is a rigid-body mode (0 Hz; the model has ", use->zero_modes,
                    "): IMR needs flexible system modes");
      for (auto m : modes)
        MORSE_CHECK(m >= 0 &&
                            m<n_sys, "-select_imr_modes ", m + 1, " is out of range (1..", n_sys, " system modes",
                              s.fom_modes> 0 &&
                            s.imr_support == "free"
                        ? ""
                        : cat(" below ", f_an, " Hz"),
                    ")");
      imr = std::make_unique<ImrData>(imr_data(comm, M, res, use->V.get(), use->omega2, modes, s.imr_shift));
    }
  }

  MacBasis mb;
  if (s.check) {
    StageTimer t(comm, "MacProjections");
    UMat MV;
    MORSE_CALL(MatMatMult(M, fom.V.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, MV.ptr()));
    mb = mac_basis(comm, fom.V.get(), MV.get(), res.T.get());
  }
  auto f_fom = [&](PetscInt j) { return hz(fom.omega2[j]); };
  // A model free in some rigid-body motions (no clamp, the interface left free): the superelement
  // has the same zero modes as the full model, put in the same basis before the MAC.
  const double zero_tau = s.check && fom.zero_modes > 0 ? eigen::zero_threshold(K, M) : 0.0;
  std::vector<double> zero_G;  // W^T M T for the zero modes' reference vectors
  PetscInt zero_G_k = 0;
  auto zero_refs = [&](PetscInt k) {
    if (k == zero_G_k || !w) return;
    const auto W = eigen::zero_mode_references(w, k);
    PetscInt m = 0, ng = 0;
    MORSE_CALL(VecGetLocalSize(w, &m));
    MORSE_CALL(VecGetSize(w, &ng));
    UMat MW;
    MORSE_CALL(MatCreateDense(comm, m, PETSC_DECIDE, ng, k, nullptr, MW.ptr()));
    for (PetscInt j = 0; j < k; ++j) {
      Vec col;
      MORSE_CALL(MatDenseGetColumnVecWrite(MW.get(), j, &col));
      MORSE_CALL(MatMult(M, W[static_cast<std::size_t>(j)].get(), col));
      MORSE_CALL(MatDenseRestoreColumnVecWrite(MW.get(), j, &col));
    }
    zero_G = cb::transpose_product(comm, MW.get(), res.T.get());
    zero_G_k = k;
  };
  for (std::size_t mi = 0; mi < s.methods.size(); ++mi) {
    MethodCheck mr;
    mr.name = s.names[mi];
    {
      // The ranking proper: scores, ranking, truncation.
      StageTimer ts(comm, cat("Select_", s.names[mi]));
      mr.score = scores(comm, s.methods[mi], ic, res, ex, imr.get());
      mr.sel = truncate(s.methods[mi], mr.score, s.num_modes, s.fraction);
    }
    // Its check: the restricted superelement's modes against the full model's.
    StageTimer t(comm, cat("Check_", s.names[mi]));
    mr.M = restrict_operator(res.M, nb, nr, mr.sel.selected);
    mr.K = restrict_operator(res.K, nb, nr, mr.sel.selected);
    const int n = static_cast<int>(nb + mr.sel.selected.size());
    std::vector<double> vec;
    auto lam = eigen::dense_eigenvalues(n, mr.K, mr.M, &vec, l_an);
    PetscInt zeros = 0;
    while (zero_tau > 0 && zeros < n && lam[zeros] < zero_tau) lam[zeros++] = 0.0;
    for (double l : lam) mr.rom_f.push_back(hz(l));
    while (mr.in_band < n && lam[mr.in_band] <= l_an) ++mr.in_band;
    if (!s.check) {
      out.methods.push_back(std::move(mr));
      continue;
    }
    // Expand the in-band superelement modes on the full CB basis and compare with the FOM.
    const PetscInt nq = std::max<PetscInt>(mr.in_band, 1);
    std::vector<double> Q(static_cast<std::size_t>(nr) * nq, 0.0);
    std::vector<PetscInt> idx(nb);
    std::iota(idx.begin(), idx.end(), 0);
    for (auto sidx : mr.sel.selected) idx.push_back(nb + sidx);
    if (zeros > 1 && w) {
      zero_refs(zeros);
      canonical_zero_modes(n, zeros, nr, idx, zero_G, &vec);
    }
    for (PetscInt k = 0; k < mr.in_band; ++k)
      for (int row = 0; row < n; ++row) Q[idx[row] * nq + k] = vec[static_cast<std::size_t>(row) * n + k];
    mr.mac = mac_matrix(mb, Q, nq);
    auto wmac = mac_matrix(mb, Q, nq, &res.M);
    mr.best_mac.assign(n_fom, 0.0);
    mr.subspace_mac.assign(n_fom, 0.0);
    for (PetscInt j = 0; j < n_fom; ++j) {
      // Near-repeated modes (cyclic parts) mix freely inside their cluster, which pairwise MAC
      // cannot follow: the mass-weighted MAC summed over the in-band superelement modes is the
      // squared projection of the full-model mode on the superelement's in-band modal space.
      for (PetscInt k = 0; k < mr.in_band; ++k) mr.subspace_mac[j] += wmac[j * nq + k];
      if (mr.subspace_mac[j] > s.mac_threshold) ++mr.subspace_matches;
      PetscInt best = -1;
      for (PetscInt k = 0; k < mr.in_band; ++k)
        if (mr.mac[j * nq + k] > mr.best_mac[j]) mr.best_mac[j] = mr.mac[j * nq + k], best = k;
      if (best >= 0 && mr.best_mac[j] > s.mac_threshold) {
        ++mr.matches;
        // Zero modes (f = 0 in both) have no relative frequency error.
        if (f_fom(j) > 0) mr.worst_err = std::max(mr.worst_err, std::abs(mr.rom_f[best] / f_fom(j) - 1.0));
      }
    }
    if (mr.in_band == 0) mr.mac.assign(n_fom, 0.0);
    out.methods.push_back(std::move(mr));
  }

  // Plain frequency-ordered Craig-Bampton for the same candidate set: reference row.
  {
    auto lam = eigen::dense_eigenvalues(static_cast<int>(nr), res.K, res.M);
    while (out.cb_in_band < nr && lam[out.cb_in_band] <= l_an) ++out.cb_in_band;
  }
  auto eim = scores(comm, Method::EIM, ic, res, ex, nullptr);
  double eim_total = 0;
  for (double v : eim) eim_total += v;
  for (double v : eim) out.eim_fractions.push_back(v / eim_total);
  return out;
}

void write_selection(io::H5Output& out, const VerifyResult& v, double mac_threshold, double total_mass) {
  std::vector<double> fom_hz;
  for (double l : v.fom_omega2) fom_hz.push_back(hz(l));
  const auto n_fom = static_cast<hsize_t>(fom_hz.size());
  if (v.checked) out.write("/select/fom/frequencies_hz", fom_hz);
  out.attribute("/select", "fmax_analysis_hz", v.fmax_analysis_hz);
  out.attribute("/select", "mac_threshold", mac_threshold);
  out.attribute_int("/select", "checked", v.checked ? 1 : 0);
  out.attribute_int("/select", "cb_modes_in_band", static_cast<std::int64_t>(v.cb_in_band));
  out.write("/select/effective_mass/directional_fractions", directional_mass_fractions(v.ic, total_mass),
            {static_cast<hsize_t>(v.ic.n_phi), 3});
  out.attribute("/select/effective_mass/directional_fractions", "description",
                "(P_i r_d)^2 / total mass for a rigid translation r_d of the interface in x, y, z");
  out.write("/select/effective_mass/trace_fractions", v.eim_fractions);
  for (const auto& mr : v.methods) {
    const std::string g = "/select/" + mr.name;
    const double total = std::accumulate(mr.score.begin(), mr.score.end(), 0.0);
    std::vector<double> frac;
    for (double x : mr.score) frac.push_back(total > 0 ? x / total : 0.0);
    std::vector<std::int64_t> rank(mr.sel.ranking.begin(), mr.sel.ranking.end()),
        sel(mr.sel.selected.begin(), mr.sel.selected.end());
    out.write(g + "/scores", mr.score);
    out.write(g + "/score_fractions", frac);
    out.write(g + "/ranking", rank);
    out.write(g + "/cumulative", mr.sel.cumulative);
    out.write(g + "/selected", sel);
    out.write(g + "/rom_frequencies_hz", mr.rom_f);
    if (v.checked) {  // -select_check false: no full-model modes, no MAC
      out.write(g + "/mac", mr.mac, {n_fom, static_cast<hsize_t>(std::max<PetscInt>(mr.in_band, 1))});
      out.write(g + "/best_mac", mr.best_mac);
      out.write(g + "/subspace_mac", mr.subspace_mac);
    }
    out.attribute(g, "retained_fraction", mr.sel.retained);
    out.attribute_int(g, "n_selected", static_cast<std::int64_t>(mr.sel.selected.size()));
    out.attribute_int(g, "n_rom_modes_in_band", static_cast<std::int64_t>(mr.in_band));
    out.attribute_int(g, "n_mac_matches", static_cast<std::int64_t>(mr.matches));
    out.attribute_int(g, "n_subspace_mac_matches", static_cast<std::int64_t>(mr.subspace_matches));
    out.attribute(g, "worst_frequency_error", mr.worst_err);
  }
}

}  // namespace morse::select
