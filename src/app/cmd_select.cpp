// app/cmd_select.cpp: `morse select`, the ranking of the fixed-interface modes by one or more
// methods, their truncated superelements checked against the full model (MAC; select::verify),
// and the superelement of one method written to /rom.
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
#include "morse/core/error.hpp"
#include "morse/core/handle.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/select/select.hpp"

namespace morse::app::detail {

namespace {

// Options prefixes of the eigen solvers of the full-model check and of the IMR modes.
const char* const kFomPrefix = "select_fom_";
const char* const kImrPrefix = "select_imr_";

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
  PetscCall(MorseOptionsString("-select_from",
                               "Start from a `morse reduce -cb_write_basis` file of the same mesh and boundary instead "
                               "of computing the modes",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->from = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsStringArray("-select_method",
                                    "Ranking methods, comma separated: frequency lpf eim veim deim omr cmschi ebr imr",
                                    "", names, &n, &set));
  if (set)
    for (PetscInt i = 0; i < n; ++i) {
      o->methods.emplace_back(names[i]);
      PetscCall(PetscFree(names[i]));
    }
  else
    o->methods = {"eim"};
  PetscCall(MorseOptionsInt("-select_num_modes", "Keep this many fixed-interface modes (best first)", "",
                            o->num_modes, &o->num_modes, &o->num_modes_set));
  PetscCall(MorseOptionsReal("-select_fraction",
                             "Keep the best modes up to this cumulative fraction of the method's total score "
                             "(default 0.95 when -select_num_modes is not given)",
                             "", o->fraction, &o->fraction, &o->fraction_set));
  PetscCall(MorseOptionsReal("-select_fmax_analysis",
                             "Analysis cutoff [Hz] for superelement modes in band and the MAC check "
                             "(default: -cb_fmax / 2, seed 000's 2.5x vs 5x; or half the top candidate frequency)",
                             "", o->fmax_analysis, &o->fmax_analysis, nullptr));
  PetscCall(MorseOptionsInt("-select_fom_modes",
                            "Number of full-model modes for the MAC check (default: all below the analysis cutoff)",
                            "", o->fom_modes, &o->fom_modes, nullptr));
  PetscCall(MorseOptionsReal("-select_mac_threshold", "MAC above which a full-model mode counts as matched", "",
                             o->mac_threshold, &o->mac_threshold, nullptr));
  PetscCall(MorseOptionsString("-select_rom_method", "Method whose superelement is written to /rom (default: the first)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->rom_method = buf;
  PetscInt nv = 256;
  PetscCall(MorseOptionsRealArray("-select_ebr_freq",
                                  "EBR harmonic frequencies [Hz] (default: every boundary DOF loaded alone at 8 "
                                  "frequencies across the analysis band)",
                                  "", vals, &nv, &set));
  if (set) o->ebr_freq.assign(vals, vals + nv), o->ebr_given = true;
  nv = 256;
  PetscCall(MorseOptionsRealArray("-select_ebr_amp", "EBR force amplitude per harmonic (on every boundary DOF)", "",
                                  vals, &nv, &set));
  if (set) o->ebr_amp.assign(vals, vals + nv), o->ebr_given = true;
  nv = 256;
  PetscCall(MorseOptionsRealArray("-select_ebr_phase", "EBR phase per harmonic [deg] (uniform: no effect on the scores)",
                                  "", vals, &nv, &set));
  if (set) o->ebr_phase.assign(vals, vals + nv), o->ebr_given = true;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-select_ebr_load",
                               "EBR load table: lines 'freq_hz node component amplitude [phase_deg]' on boundary "
                               "nodes, one harmonic per frequency (instead of -select_ebr_freq/amp/phase)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->ebr_load = buf;
  buf[0] = 0;
  PetscCall(PetscStrncpy(buf, o->imr_support.c_str(), sizeof buf));
  PetscCall(MorseOptionsString("-select_imr_support",
                               "IMR: full-system modes with the interface free, spring (-select_imr_support_stiffness) or "
                               "clamped",
                               "", buf, buf, sizeof buf, nullptr));
  o->imr_support = buf;
  PetscCall(MorseOptionsReal("-select_imr_support_stiffness", "IMR: spring stiffness on every boundary DOF", "",
                             o->imr_stiffness, &o->imr_stiffness, nullptr));
  nv = 256;
  PetscCall(MorseOptionsIntArray("-select_imr_modes",
                                 "IMR: full-system modes of interest, 1-based (default: all below the analysis cutoff)",
                                 "", ivals, &nv, &set));
  if (set) o->imr_modes.assign(ivals, ivals + nv);
  PetscCall(MorseOptionsReal("-select_imr_shift", "IMR: relative frequency shift of the fictitious force", "",
                             o->imr_shift, &o->imr_shift, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

std::string hz_of(double lambda) { return cat(hz(lambda)); }

}  // namespace

void run_select(MPI_Comm comm) {
  io::ModelInput o;
  MORSE_CALL(o.set_from_options(comm, "select.h5"));
  cb::CBSettings cs;
  MORSE_CALL(cs.set_from_options(comm));
  ReduceOptions r;
  MORSE_CALL(get_reduce_options(comm, &r));
  SelectOptions so;
  MORSE_CALL(get_select_options(comm, &so));
  if (help_requested()) return;
  for (const std::string& p : {cs.prefix, std::string(kFomPrefix), std::string(kImrPrefix)})
    options::add_prefix(p, options::Solver::Eigen);
  check_options(comm, true);
  MORSE_CHECK(!cs.boundary_set.empty(), "no boundary set given: use -boundary SET");
  MORSE_CHECK(!so.from.empty() || cs.n_fixed >= 0 || cs.fmax_hz > 0,
              "give the candidate modes: -cb_num_fixed_modes N or -cb_fmax HZ (or -select_from FILE.h5)");
  MORSE_CHECK(so.from.empty() || (cs.n_fixed < 0 && cs.fmax_hz < 0),
              "-select_from reads the candidate modes from its file: drop -cb_num_fixed_modes / -cb_fmax");
  MORSE_CHECK(!(cs.n_fixed >= 0 && cs.fmax_hz > 0), "give only one of -cb_num_fixed_modes and -cb_fmax");
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
  MORSE_CHECK(!cs.keep_basis, "-cb_write_basis is a reduce option: select writes the selected superelement only");
  MORSE_CHECK(!r.xdmf_set, "-cb_xdmf is a reduce option (the mode shapes of -cb_write_basis): select writes no mode "
                           "shapes");
  MORSE_CHECK(so.imr_support == "free" || so.imr_support == "spring" || so.imr_support == "clamped",
              "-select_imr_support ", so.imr_support, ": expected free, spring or clamped");
  MORSE_CHECK(so.imr_support != "spring" || so.imr_stiffness > 0,
              "-select_imr_support spring needs -select_imr_support_stiffness > 0");
  std::string rom_name = so.rom_method.empty() ? so.methods[0] : so.rom_method;
  MORSE_CHECK(std::find(so.methods.begin(), so.methods.end(), rom_name) != so.methods.end(), "-select_rom_method ",
              rom_name, " is not one of -select_method");

  Model md = build_model(comm, o);
  MORSE_CHECK(!(!md.mesh && !so.from.empty()),
              "-select_from reads nodal mode shapes of a mesh: not available with -matrices_K/-matrices_M");
  MORSE_CHECK(!(md.C && cs.damping > 0), "give either -matrices_C (projected on the selected superelement) or "
                                           "-cb_damping (modal damping of the fixed-interface modes), not both");
  cs.keep_basis = true;
  auto res = so.from.empty() ? cb::craig_bampton(md, cs) : cb::load_basis(md, so.from, cs.boundary_set, cs.damping);
  MORSE_CHECK(res.n_phi > 0, "no candidate fixed-interface mode to select from");
  if (md.C) res.C = cb::project_symmetric(comm, md.C.get(), res.T.get());  // T^T C T, restricted below
  const PetscInt nb = res.n_b, nr = res.n(), nphi = res.n_phi;
  double f_an = so.fmax_analysis > 0 ? so.fmax_analysis
                : cs.fmax_hz > 0       ? 0.5 * cs.fmax_hz
                                   : 0.5 * std::sqrt(res.fixed_omega2.back()) / kTwoPi;

  select::VerifySettings vs;
  vs.methods = methods;
  vs.names = so.methods;
  vs.num_modes = so.num_modes;
  vs.fraction = so.fraction;
  vs.fmax_analysis_hz = f_an;
  vs.fom_modes = so.fom_modes;
  vs.mac_threshold = so.mac_threshold;
  vs.ebr_load = so.ebr_load;
  vs.ebr_given = so.ebr_given;
  vs.ebr_freq = so.ebr_freq, vs.ebr_amp = so.ebr_amp, vs.ebr_phase = so.ebr_phase;
  vs.imr_support = so.imr_support;
  vs.imr_stiffness = so.imr_stiffness;
  vs.imr_modes = so.imr_modes;
  vs.imr_shift = so.imr_shift;
  auto w = cb::sign_reference(md);
  const auto vr = select::verify(comm, md.K.get(), md.M.get(), res, w.get(), vs);
  check_options(comm, false);
  const auto& results = vr.methods;
  const PetscInt n_fom = static_cast<PetscInt>(vr.fom_omega2.size()), cb_in_band = vr.cb_in_band;
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
  io::write_provenance(out, "select", md.units);
  write_model(out, md);
  io::write_fixed_interface(out, res.fixed_omega2);
  select::write_selection(out, vr, so.mac_threshold, md.mass);
  for (const auto& mr : results)
    if (mr.name == rom_name) {
      auto C = select::restrict_operator(res.C, nb, nr, mr.sel.selected);
      auto se = rom_superelement(res, mr.M, mr.K, cs.damping > 0 || md.C ? &C : nullptr, mr.rom_f, cs.damping);
      se.selected_modes.assign(mr.sel.selected.begin(), mr.sel.selected.end());
      se.selection_method = mr.name;
      io::write_superelement(out, se);
    }
  out.attribute("/cb", "boundary_set", cs.boundary_set);
  out.commit();
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
