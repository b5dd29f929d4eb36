// select/settings.cpp: the options of `morse select` (select::Settings::set_from_options).
#include <petscsys.h>

#include <algorithm>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/options.hpp"
#include "morse/select/select.hpp"

namespace morse::select {

PetscErrorCode Settings::set_from_options(MPI_Comm comm) {
  auto& v = verify;
  char* names[16];
  PetscInt n = 16;
  PetscBool set = PETSC_FALSE, num_modes_set = PETSC_FALSE, fraction_set = PETSC_FALSE;
  char buf[256] = "";
  PetscReal vals[256];
  PetscInt ivals[256];
  std::vector<std::string> methods;
  v.fraction = -1;
  v.fmax_analysis_hz = -1;
  PetscOptionsBegin(comm, nullptr, "morse select options", "");
  PetscCall(MorseOptionsString("-select_from",
                               "Start from a `morse reduce -cb_write_basis` file of the same mesh and boundary instead "
                               "of computing the modes",
                               "", buf, buf, sizeof buf, &set));
  if (set) from = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsStringArray("-select_method",
                                    "Ranking methods, comma separated: frequency lpf eim veim deim omr cmschi ebr imr",
                                    "", names, &n, &set));
  if (set)
    for (PetscInt i = 0; i < n; ++i) {
      methods.emplace_back(names[i]);
      PetscCall(PetscFree(names[i]));
    }
  else
    methods = {"eim"};
  PetscCall(MorseOptionsInt("-select_num_modes", "Keep this many fixed-interface modes (best first)", "", v.num_modes,
                            &v.num_modes, &num_modes_set));
  PetscCall(MorseOptionsReal("-select_fraction",
                             "Keep the best modes up to this cumulative fraction of the method's total score "
                             "(default 0.95 when -select_num_modes is not given)",
                             "", v.fraction, &v.fraction, &fraction_set));
  PetscCall(MorseOptionsReal("-select_fmax_analysis",
                             "Analysis cutoff [Hz] for superelement modes in band and the MAC check "
                             "(default: -cb_fmax / 2, seed 000's 2.5x vs 5x; or half the top candidate frequency)",
                             "", v.fmax_analysis_hz, &v.fmax_analysis_hz, nullptr));
  PetscCall(MorseOptionsInt("-select_fom_modes",
                            "Number of full-model modes for the MAC check (default: all below the analysis cutoff)", "",
                            v.fom_modes, &v.fom_modes, nullptr));
  PetscCall(MorseOptionsReal("-select_mac_threshold", "MAC above which a full-model mode counts as matched", "",
                             v.mac_threshold, &v.mac_threshold, nullptr));
  PetscBool check = v.check ? PETSC_TRUE : PETSC_FALSE;
  PetscCall(MorseOptionsBool("-select_check",
                             "Check every method's superelement against the full model's modes (MAC); false skips "
                             "the full model's eigen solve",
                             "", check, &check, nullptr));
  v.check = check == PETSC_TRUE;
  PetscCall(MorseOptionsString("-select_rom_method",
                               "Method whose superelement is written to /rom (default: the first)", "", buf, buf,
                               sizeof buf, &set));
  if (set) rom_method = buf;
  PetscInt nv = 256;
  PetscCall(MorseOptionsRealArray("-select_ebr_freq",
                                  "EBR harmonic frequencies [Hz] (default: every boundary DOF loaded alone at 8 "
                                  "frequencies across the analysis band)",
                                  "", vals, &nv, &set));
  if (set) v.ebr_freq.assign(vals, vals + nv), v.ebr_given = true;
  nv = 256;
  PetscCall(MorseOptionsRealArray("-select_ebr_amp", "EBR force amplitude per harmonic (on every boundary DOF)", "",
                                  vals, &nv, &set));
  if (set) v.ebr_amp.assign(vals, vals + nv), v.ebr_given = true;
  nv = 256;
  PetscCall(MorseOptionsRealArray(
      "-select_ebr_phase", "EBR phase per harmonic [deg] (uniform: no effect on the scores)", "", vals, &nv, &set));
  if (set) v.ebr_phase.assign(vals, vals + nv), v.ebr_given = true;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-select_ebr_load",
                               "EBR load table: lines 'freq_hz node component amplitude [phase_deg]' on boundary "
                               "nodes, one harmonic per frequency (instead of -select_ebr_freq/amp/phase)",
                               "", buf, buf, sizeof buf, &set));
  if (set) v.ebr_load = buf;
  buf[0] = 0;
  PetscCall(PetscStrncpy(buf, v.imr_support.c_str(), sizeof buf));
  PetscCall(
      MorseOptionsString("-select_imr_support",
                         "IMR: full-system modes with the interface free, spring (-select_imr_support_stiffness) or "
                         "clamped",
                         "", buf, buf, sizeof buf, nullptr));
  v.imr_support = buf;
  PetscCall(MorseOptionsReal("-select_imr_support_stiffness", "IMR: spring stiffness on every boundary DOF", "",
                             v.imr_stiffness, &v.imr_stiffness, nullptr));
  nv = 256;
  PetscCall(MorseOptionsIntArray("-select_imr_modes",
                                 "IMR: full-system modes of interest, 1-based (default: all below the analysis cutoff)",
                                 "", ivals, &nv, &set));
  if (set) v.imr_modes.assign(ivals, ivals + nv);
  PetscCall(MorseOptionsReal("-select_imr_shift", "IMR: relative frequency shift of the fictitious force", "",
                             v.imr_shift, &v.imr_shift, nullptr));
  PetscOptionsEnd();

  auto bad = [&](const std::string& e) {
    if (error.empty()) error = e;
  };
  v.names = methods;
  for (const auto& name : methods) {
    Method m;
    if (!parse_method(name, &m))
      bad(cat("-select_method ", name, ": unknown method (frequency lpf eim veim deim omr cmschi ebr imr)"));
    else
      v.methods.push_back(m);
  }
  for (std::size_t i = 0; i < v.methods.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (v.methods[i] == v.methods[j]) bad(cat("-select_method lists ", methods[i], " twice"));
  if (num_modes_set && fraction_set) bad("give only one of -select_num_modes and -select_fraction");
  if (num_modes_set && v.num_modes < 0) bad(cat("-select_num_modes ", v.num_modes, " must be >= 0"));
  if (!num_modes_set && !fraction_set) v.fraction = 0.95;
  if (!num_modes_set && !(v.fraction > 0 && v.fraction <= 1))
    bad(cat("-select_fraction ", v.fraction, " must be in (0, 1]"));
  if (!v.ebr_load.empty() && v.ebr_given)
    bad("give the EBR excitation either as -select_ebr_load FILE or as -select_ebr_freq/-select_ebr_amp/"
        "-select_ebr_phase, not both");
  if (v.imr_support != "free" && v.imr_support != "spring" && v.imr_support != "clamped")
    bad(cat("-select_imr_support ", v.imr_support, ": expected free, spring or clamped"));
  if (v.imr_support == "spring" && !(v.imr_stiffness > 0))
    bad("-select_imr_support spring needs -select_imr_support_stiffness > 0");
  if (rom_method.empty()) rom_method = methods[0];
  if (std::find(methods.begin(), methods.end(), rom_method) == methods.end())
    bad(cat("-select_rom_method ", rom_method, " is not one of -select_method"));
  return PETSC_SUCCESS;
}

}  // namespace morse::select
