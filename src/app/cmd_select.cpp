// app/cmd_select.cpp: `morse select`, the ranking of the fixed-interface modes by one or more
// methods, their truncated superelements checked against the full model (MAC), and the
// superelement of one method written to /rom.
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/cb/eigen.hpp"
#include "morse/core/error.hpp"
#include "morse/core/handle.hpp"
#include "morse/core/log.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/select/select.hpp"

namespace morse::app::detail {

namespace {

struct SelectOptions {
  std::string from;
  std::vector<std::string> methods;
  PetscInt num_modes = -1;
  PetscReal fraction = -1;
  PetscBool num_modes_set = PETSC_FALSE, fraction_set = PETSC_FALSE;
  PetscReal fmax_analysis = -1;
  PetscInt fom_modes = -1;
  PetscReal mac_threshold = 0.98;
  std::string rom_method;
  std::vector<double> ebr_freq, ebr_amp, ebr_phase;
  bool ebr_given = false;
  std::string ebr_load;
  std::string imr_support = "free";
  PetscReal imr_stiffness = -1;
  std::vector<PetscInt> imr_modes;
  PetscReal imr_shift = 0.01;
};

PetscErrorCode get_select_options(MPI_Comm comm, SelectOptions* o) {
  char* names[16];
  PetscInt n = 16;
  PetscBool set = PETSC_FALSE;
  char buf[256] = "";
  PetscReal vals[256];
  PetscInt ivals[256];
  PetscOptionsBegin(comm, nullptr, "morse select options", "");
  PetscCall(PetscOptionsString("-select_from",
                               "Start from a `morse reduce -cb_write_basis` file of the same mesh and boundary instead "
                               "of computing the modes",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->from = buf;
  buf[0] = 0;
  PetscCall(PetscOptionsStringArray("-select_method",
                                    "Ranking methods, comma separated: frequency lpf eim veim deim omr cmschi ebr imr",
                                    "", names, &n, &set));
  if (set)
    for (PetscInt i = 0; i < n; ++i) {
      o->methods.emplace_back(names[i]);
      PetscCall(PetscFree(names[i]));
    }
  else
    o->methods = {"eim"};
  PetscCall(PetscOptionsInt("-select_num_modes", "Keep this many fixed-interface modes (best first)", "",
                            o->num_modes, &o->num_modes, &o->num_modes_set));
  PetscCall(PetscOptionsReal("-select_fraction",
                             "Keep the best modes up to this cumulative fraction of the method's total score "
                             "(default 0.95 when -select_num_modes is not given)",
                             "", o->fraction, &o->fraction, &o->fraction_set));
  PetscCall(PetscOptionsReal("-select_fmax_analysis",
                             "Analysis cutoff [Hz] for superelement modes in band and the MAC check "
                             "(default: -cb_fmax / 2, seed 000's 2.5x vs 5x; or half the top candidate frequency)",
                             "", o->fmax_analysis, &o->fmax_analysis, nullptr));
  PetscCall(PetscOptionsInt("-select_fom_modes",
                            "Number of full-model modes for the MAC check (default: all below the analysis cutoff)",
                            "", o->fom_modes, &o->fom_modes, nullptr));
  PetscCall(PetscOptionsReal("-select_mac_threshold", "MAC above which a full-model mode counts as matched", "",
                             o->mac_threshold, &o->mac_threshold, nullptr));
  PetscCall(PetscOptionsString("-select_rom_method", "Method whose superelement is written to /rom (default: the first)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->rom_method = buf;
  PetscInt nv = 256;
  PetscCall(PetscOptionsRealArray("-select_ebr_freq",
                                  "EBR harmonic frequencies [Hz] (default: every boundary DOF loaded alone at 8 "
                                  "frequencies across the analysis band)",
                                  "", vals, &nv, &set));
  if (set) o->ebr_freq.assign(vals, vals + nv), o->ebr_given = true;
  nv = 256;
  PetscCall(PetscOptionsRealArray("-select_ebr_amp", "EBR force amplitude per harmonic (on every boundary DOF)", "",
                                  vals, &nv, &set));
  if (set) o->ebr_amp.assign(vals, vals + nv), o->ebr_given = true;
  nv = 256;
  PetscCall(PetscOptionsRealArray("-select_ebr_phase", "EBR phase per harmonic [deg] (uniform: no effect on the scores)",
                                  "", vals, &nv, &set));
  if (set) o->ebr_phase.assign(vals, vals + nv), o->ebr_given = true;
  buf[0] = 0;
  PetscCall(PetscOptionsString("-select_ebr_load",
                               "EBR load table: lines 'freq_hz node component amplitude [phase_deg]' on boundary "
                               "nodes, one harmonic per frequency (instead of -select_ebr_freq/amp/phase)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->ebr_load = buf;
  buf[0] = 0;
  PetscCall(PetscStrncpy(buf, o->imr_support.c_str(), sizeof buf));
  PetscCall(PetscOptionsString("-select_imr_support",
                               "IMR: full-system modes with the interface free, spring (-select_imr_support_stiffness) or "
                               "clamped",
                               "", buf, buf, sizeof buf, nullptr));
  o->imr_support = buf;
  PetscCall(PetscOptionsReal("-select_imr_support_stiffness", "IMR: spring stiffness on every boundary DOF", "",
                             o->imr_stiffness, &o->imr_stiffness, nullptr));
  nv = 256;
  PetscCall(PetscOptionsIntArray("-select_imr_modes",
                                 "IMR: full-system modes of interest, 1-based (default: all below the analysis cutoff)",
                                 "", ivals, &nv, &set));
  if (set) o->imr_modes.assign(ivals, ivals + nv);
  PetscCall(PetscOptionsReal("-select_imr_shift", "IMR: relative frequency shift of the fictitious force", "",
                             o->imr_shift, &o->imr_shift, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

std::string hz_of(double lambda) { return cat(hz(lambda)); }

}  // namespace

void run_select(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "select.h5", &o));
  ReduceOptions r;
  MORSE_CALL(get_reduce_options(comm, &r));
  SelectOptions so;
  MORSE_CALL(get_select_options(comm, &so));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(!r.boundary.empty(), "no boundary set given: use -boundary SET");
  MORSE_CHECK(!so.from.empty() || r.n_fixed >= 0 || r.fmax > 0,
              "give the candidate modes: -cb_num_fixed_modes N or -cb_fmax HZ (or -select_from FILE.h5)");
  MORSE_CHECK(so.from.empty() || (r.n_fixed < 0 && r.fmax < 0),
              "-select_from reads the candidate modes from its file: drop -cb_num_fixed_modes / -cb_fmax");
  MORSE_CHECK(!(r.n_fixed >= 0 && r.fmax > 0), "give only one of -cb_num_fixed_modes and -cb_fmax");
  std::vector<select::Method> methods;
  for (const auto& name : so.methods) {
    select::Method m;
    MORSE_CHECK(select::parse_method(name, &m), "-select_method ", name,
                ": unknown method (frequency lpf eim veim deim omr cmschi ebr imr)");
    methods.push_back(m);
  }
  for (std::size_t i = 0; i < methods.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      MORSE_CHECK(methods[i] != methods[j], "-select_method lists ", so.methods[i], " twice");
  MORSE_CHECK(!(so.num_modes_set && so.fraction_set), "give only one of -select_num_modes and -select_fraction");
  MORSE_CHECK(!so.num_modes_set || so.num_modes >= 0, "-select_num_modes ", so.num_modes, " must be >= 0");
  if (!so.num_modes_set && !so.fraction_set) so.fraction = 0.95;
  MORSE_CHECK(so.num_modes_set || (so.fraction > 0 && so.fraction <= 1), "-select_fraction ", so.fraction,
              " must be in (0, 1]");
  MORSE_CHECK(so.ebr_load.empty() || !so.ebr_given,
              "give the EBR excitation either as -select_ebr_load FILE or as -select_ebr_freq/-select_ebr_amp/"
              "-select_ebr_phase, not both");
  MORSE_CHECK(!r.write_basis, "-cb_write_basis is a reduce option: select writes the selected superelement only");
  MORSE_CHECK(!r.xdmf_set, "-cb_xdmf is a reduce option (the mode shapes of -cb_write_basis): select writes no mode "
                           "shapes");
  MORSE_CHECK(so.imr_support == "free" || so.imr_support == "spring" || so.imr_support == "clamped",
              "-select_imr_support ", so.imr_support, ": expected free, spring or clamped");
  MORSE_CHECK(so.imr_support != "spring" || so.imr_stiffness > 0,
              "-select_imr_support spring needs -select_imr_support_stiffness > 0");
  std::string rom_name = so.rom_method.empty() ? so.methods[0] : so.rom_method;
  MORSE_CHECK(std::find(so.methods.begin(), so.methods.end(), rom_name) != so.methods.end(), "-select_rom_method ",
              rom_name, " is not one of -select_method");

  Model md = build_model(comm, o, true);
  MORSE_CHECK(!(md.from_matrices && !so.from.empty()),
              "-select_from reads nodal mode shapes of a mesh: not available with -matrices_K/-matrices_M");
  MORSE_CHECK(!(md.mm.C && r.damping > 0), "give either -matrices_C (projected on the selected superelement) or "
                                           "-cb_damping (modal damping of the fixed-interface modes), not both");
  cb::CBSettings cs = cb_settings(r);
  cs.keep_basis = true;
  auto res = so.from.empty() ? craig_bampton(md, cs)
                             : cb::load_basis(md.lm, md.dofs, md.ops.K.get(), md.ops.M.get(), so.from, r.boundary,
                                              r.damping);
  MORSE_CHECK(res.n_phi > 0, "no candidate fixed-interface mode to select from");
  if (md.mm.C) res.C = cb::project_symmetric(comm, md.mm.C.get(), res.T.get());  // T^T C T, restricted below
  const PetscInt nb = res.n_b, nr = res.n(), nphi = res.n_phi;
  double f_an = so.fmax_analysis > 0 ? so.fmax_analysis
                : r.fmax > 0       ? 0.5 * r.fmax
                                   : 0.5 * std::sqrt(res.fixed_omega2.back()) / kTwoPi;
  const double l_an = std::pow(kTwoPi * f_an, 2);

  select::InterfaceCoupling ic;
  {
    StageTimer t(comm, "InterfaceCoupling");
    ic = select::interface_coupling(comm, md.ops.K.get(), md.ops.M.get(), res);
  }
  // Full-model modes with the real boundary conditions (clamp only): MAC reference and IMR.
  cb::Eigenpairs fom;
  {
    cb::EigenSettings es;
    es.prefix = "select_fom_";
    es.stage = "Fom";
    es.what = "full-model modes";
    if (so.fom_modes > 0)
      es.nev = so.fom_modes;
    else
      es.omega2_max = l_an;
    auto w = sign_reference(md);
    fom = cb::solve_eigen(md.ops.K.get(), md.ops.M.get(), es, w.get());
  }
  const PetscInt n_fom = static_cast<PetscInt>(fom.omega2.size());

  select::Excitation ex;
  if (!so.ebr_load.empty()) {
    ex = select::read_ebr_load(comm, so.ebr_load, res);
  } else if (so.ebr_given) {
    ex.freq_hz = so.ebr_freq;
    ex.amplitude = so.ebr_amp.empty() ? std::vector<double>(ex.freq_hz.size(), 1.0) : so.ebr_amp;
    ex.phase_deg = so.ebr_phase.empty() ? std::vector<double>(ex.freq_hz.size(), 0.0) : so.ebr_phase;
    ex.all_components = false;
  } else {
    for (int k = 1; k <= 8; ++k) ex.freq_hz.push_back(f_an * (k - 0.5) / 8.0);
    ex.amplitude.assign(8, 1.0);
    ex.phase_deg.assign(8, 0.0);
  }
  std::unique_ptr<select::ImrData> imr;
  if (std::find(methods.begin(), methods.end(), select::Method::IMR) != methods.end()) {
    StageTimer t(comm, "ImrSystemModes");
    std::vector<PetscInt> modes;
    for (auto m1 : so.imr_modes) modes.push_back(m1 - 1);
    if (so.imr_support == "clamped") {
      imr = std::make_unique<select::ImrData>();
      imr->clamped = true;
      if (modes.empty())
        for (PetscInt i = 0; i < nphi && res.fixed_omega2[i] <= l_an; ++i) modes.push_back(i);
      for (auto m : modes)
        MORSE_CHECK(m >= 0 && m < nphi, "-select_imr_modes ", m + 1, " is out of range (1..", nphi,
                    " fixed-interface modes)");
      imr->clamped_modes = modes;
    } else {
      cb::Eigenpairs sys;
      Mat Ks = md.ops.K.get();
      UMat Kspring;
      cb::Eigenpairs* use = &fom;
      if (so.imr_support == "spring") {
        MORSE_CALL(MatDuplicate(md.ops.K.get(), MAT_COPY_VALUES, Kspring.ptr()));
        for (auto g : res.boundary_dofs) {
          PetscInt rs, re;
          MORSE_CALL(MatGetOwnershipRange(Kspring.get(), &rs, &re));
          if (g >= rs && g < re) MORSE_CALL(MatSetValue(Kspring.get(), g, g, so.imr_stiffness, ADD_VALUES));
        }
        MORSE_CALL(MatAssemblyBegin(Kspring.get(), MAT_FINAL_ASSEMBLY));
        MORSE_CALL(MatAssemblyEnd(Kspring.get(), MAT_FINAL_ASSEMBLY));
        Ks = Kspring.get();
        cb::EigenSettings es;
        es.prefix = "select_imr_";
        es.stage = "Imr";
        es.what = "IMR system modes";
        es.omega2_max = l_an;
        sys = cb::solve_eigen(Ks, md.ops.M.get(), es, nullptr);
        use = &sys;
      }
      const PetscInt n_sys = static_cast<PetscInt>(use->omega2.size());
      if (modes.empty())
        for (PetscInt i = 0; i < n_sys; ++i) modes.push_back(i);
      for (auto m : modes)
        MORSE_CHECK(m >= 0 && m < n_sys, "-select_imr_modes ", m + 1, " is out of range (1..", n_sys,
                    " system modes", so.fom_modes > 0 && so.imr_support == "free" ? "" : cat(" below ", f_an, " Hz"),
                    ")");
      imr = std::make_unique<select::ImrData>(
          select::imr_data(comm, md.ops.M.get(), res, use->V.get(), use->omega2, modes, so.imr_shift));
    }
  }
  check_options(comm, false);

  struct MethodResult {
    std::string name;
    std::vector<double> score;
    select::Selection sel;
    std::vector<double> rom_f;
    PetscInt in_band = 0, matches = 0, subspace_matches = 0;
    double worst_err = 0;
    std::vector<double> mac, best_mac, subspace_mac;
    std::vector<double> M, K;
  };
  std::vector<MethodResult> results;
  select::MacBasis mac_basis;
  {
    StageTimer t(comm, "MacProjections");
    UMat MV;
    MORSE_CALL(MatMatMult(md.ops.M.get(), fom.V.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, MV.ptr()));
    mac_basis = select::mac_basis(comm, fom.V.get(), MV.get(), res.T.get());
  }
  auto f_fom = [&](PetscInt j) { return hz(fom.omega2[j]); };
  for (std::size_t mi = 0; mi < methods.size(); ++mi) {
    MethodResult mr;
    mr.name = so.methods[mi];
    {
      // The ranking proper: scores, ranking, truncation.
      StageTimer ts(comm, cat("Select_", so.methods[mi]));
      mr.score = select::scores(comm, methods[mi], ic, res, ex, imr.get());
      mr.sel = select::truncate(methods[mi], mr.score, so.num_modes, so.fraction);
    }
    // Its check: the restricted superelement's modes against the full model's.
    StageTimer t(comm, cat("Check_", so.methods[mi]));
    mr.M = select::restrict_operator(res.M, nb, nr, mr.sel.selected);
    mr.K = select::restrict_operator(res.K, nb, nr, mr.sel.selected);
    const int n = static_cast<int>(nb + mr.sel.selected.size());
    std::vector<double> vec;
    auto lam = cb::dense_eigenvalues(n, mr.K, mr.M, &vec, l_an);
    mr.rom_f = hz(lam);
    while (mr.in_band < n && lam[mr.in_band] <= l_an) ++mr.in_band;
    // Expand the in-band superelement modes on the full CB basis and compare with the FOM.
    const PetscInt nq = std::max<PetscInt>(mr.in_band, 1);
    std::vector<double> Q(static_cast<std::size_t>(nr) * nq, 0.0);
    std::vector<PetscInt> idx(nb);
    std::iota(idx.begin(), idx.end(), 0);
    for (auto sidx : mr.sel.selected) idx.push_back(nb + sidx);
    for (PetscInt k = 0; k < mr.in_band; ++k)
      for (int row = 0; row < n; ++row) Q[idx[row] * nq + k] = vec[static_cast<std::size_t>(row) * n + k];
    mr.mac = select::mac_matrix(mac_basis, Q, nq);
    auto wmac = select::mac_matrix(mac_basis, Q, nq, &res.M);
    mr.best_mac.assign(n_fom, 0.0);
    mr.subspace_mac.assign(n_fom, 0.0);
    for (PetscInt j = 0; j < n_fom; ++j) {
      // Near-repeated modes (cyclic parts) mix freely inside their cluster, which pairwise MAC
      // cannot follow: the mass-weighted MAC summed over the in-band superelement modes is the
      // squared projection of the full-model mode on the superelement's in-band modal space.
      for (PetscInt k = 0; k < mr.in_band; ++k) mr.subspace_mac[j] += wmac[j * nq + k];
      if (mr.subspace_mac[j] > so.mac_threshold) ++mr.subspace_matches;
      PetscInt best = -1;
      for (PetscInt k = 0; k < mr.in_band; ++k)
        if (mr.mac[j * nq + k] > mr.best_mac[j]) mr.best_mac[j] = mr.mac[j * nq + k], best = k;
      if (best >= 0 && mr.best_mac[j] > so.mac_threshold) {
        ++mr.matches;
        mr.worst_err = std::max(mr.worst_err, std::abs(mr.rom_f[best] / f_fom(j) - 1.0));
      }
    }
    if (mr.in_band == 0) mr.mac.assign(n_fom, 0.0);
    results.push_back(std::move(mr));
  }

  // Plain frequency-ordered Craig-Bampton for the same candidate set: reference row.
  PetscInt cb_in_band = 0;
  {
    auto lam = cb::dense_eigenvalues(static_cast<int>(nr), res.K, res.M);
    while (cb_in_band < nr && lam[cb_in_band] <= l_an) ++cb_in_band;
  }
  print0(comm, "\nmorse select: %d candidate fixed-interface modes (%s .. %s Hz), %d boundary DOFs; analysis band "
               "%.6g Hz: %d full-model modes\n",
         (int)nphi, hz_of(res.fixed_omega2.front()).c_str(), hz_of(res.fixed_omega2.back()).c_str(), (int)nb, f_an,
         (int)n_fom);
  print0(comm, "  all candidates (plain Craig-Bampton): %d superelement modes in band\n", (int)cb_in_band);
  print0(comm, "\n  %-10s %6s %10s %14s %12s %14s %14s\n", "method", "N", "retained%", "SE modes<fan", "MAC>thr",
         "subspace MAC", "worst df [%]");
  for (const auto& mr : results)
    print0(comm, "  %-10s %6d %10.2f %14d %7d/%-4d %9d/%-4d %14.4f\n", mr.name.c_str(), (int)mr.sel.selected.size(),
           100 * mr.sel.retained, (int)mr.in_band, (int)mr.matches, (int)n_fom, (int)mr.subspace_matches, (int)n_fom,
           100 * mr.worst_err);

  StageTimer t(comm, "Write");
  io::H5Output out(comm, o.out);
  io::write_provenance(out, "select", md.lm.mesh.units);
  write_model(out, md);
  const std::vector<double> fom_hz = hz(fom.omega2);
  out.write("/cb/fixed_interface/frequencies_hz", hz(res.fixed_omega2));
  out.write("/cb/fixed_interface/eigenvalues", res.fixed_omega2);
  out.write("/select/fom/frequencies_hz", fom_hz);
  out.attribute("/select", "fmax_analysis_hz", f_an);
  out.attribute("/select", "mac_threshold", so.mac_threshold);
  out.attribute_int("/select", "cb_modes_in_band", static_cast<std::int64_t>(cb_in_band));
  out.write("/select/effective_mass/directional_fractions", select::directional_mass_fractions(ic, md.ops.mass),
            {static_cast<hsize_t>(nphi), 3});
  out.attribute("/select/effective_mass/directional_fractions", "description",
                "(P_i r_d)^2 / total mass for a rigid translation r_d of the interface in x, y, z");
  auto eim = select::scores(comm, select::Method::EIM, ic, res, ex, nullptr);
  double eim_total = 0;
  for (double v : eim) eim_total += v;
  std::vector<double> eim_frac;
  for (double v : eim) eim_frac.push_back(v / eim_total);
  out.write("/select/effective_mass/trace_fractions", eim_frac);
  for (const auto& mr : results) {
    const std::string g = "/select/" + mr.name;
    const double total = std::accumulate(mr.score.begin(), mr.score.end(), 0.0);
    std::vector<double> frac;
    for (double v : mr.score) frac.push_back(total > 0 ? v / total : 0.0);
    std::vector<std::int64_t> rank(mr.sel.ranking.begin(), mr.sel.ranking.end()),
        sel(mr.sel.selected.begin(), mr.sel.selected.end());
    out.write(g + "/scores", mr.score);
    out.write(g + "/score_fractions", frac);
    out.write(g + "/ranking", rank);
    out.write(g + "/cumulative", mr.sel.cumulative);
    out.write(g + "/selected", sel);
    out.write(g + "/rom_frequencies_hz", mr.rom_f);
    out.write(g + "/mac", mr.mac, {static_cast<hsize_t>(n_fom), static_cast<hsize_t>(std::max<PetscInt>(mr.in_band, 1))});
    out.write(g + "/best_mac", mr.best_mac);
    out.write(g + "/subspace_mac", mr.subspace_mac);
    out.attribute(g, "retained_fraction", mr.sel.retained);
    out.attribute_int(g, "n_selected", static_cast<std::int64_t>(mr.sel.selected.size()));
    out.attribute_int(g, "n_rom_modes_in_band", static_cast<std::int64_t>(mr.in_band));
    out.attribute_int(g, "n_mac_matches", static_cast<std::int64_t>(mr.matches));
    out.attribute_int(g, "n_subspace_mac_matches", static_cast<std::int64_t>(mr.subspace_matches));
    out.attribute(g, "worst_frequency_error", mr.worst_err);
    if (mr.name == rom_name) {
      auto C = select::restrict_operator(res.C, nb, nr, mr.sel.selected);
      auto se = rom_superelement(res, mr.M, mr.K, r.damping > 0 || md.mm.C ? &C : nullptr, mr.rom_f, r.damping);
      se.selected_modes = sel;
      se.selection_method = mr.name;
      io::write_superelement(out, se);
    }
  }
  out.attribute("/cb", "boundary_set", r.boundary);
  out.commit();
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
