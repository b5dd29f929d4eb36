// eval/compare.cpp: the comparison of a `morse simulate` run with a `morse fom` run
// (eval/indicator.hpp): its options, t_max from the stored load, and the indicator of the files.
#include "morse/eval/compare.hpp"

#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/options.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/io/h5.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/sim.hpp"

namespace morse::eval {

PetscErrorCode CompareSettings::set_from_options(MPI_Comm comm) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscReal wv[4];
  PetscInt nw = 4;
  PetscOptionsBegin(comm, nullptr, "morse compare options", "");
  PetscCall(MorseOptionsString("-compare_tip", "Node set of the blade tip (criteria e3, e4); monitored in both runs",
                               "", tip.c_str(), buf, sizeof buf, &set));
  if (set) tip = buf;
  PetscBool tmax_set = PETSC_FALSE;
  PetscCall(MorseOptionsReal("-compare_tmax", "Time of e1 [s] (default: first maximum of the first harmonic -load_*)",
                             "", tmax, &tmax, &tmax_set));
  if (tmax_set && !(std::isfinite(tmax) && tmax >= 0) && error.empty())
    error = cat("-compare_tmax must be a finite time >= 0 [s] (got ", tmax, ")");
  PetscCall(MorseOptionsRealArray("-compare_weights", "Weights w1,w2,w3,w4 of eq. 43 (sum 1)", "", wv, &nw, &set));
  if (set) {
    if (nw == 4)
      w.assign(wv, wv + 4);
    else if (error.empty())
      error = "-compare_weights takes four values w1,w2,w3,w4";
  }
  buf[0] = 0;
  PetscCall(MorseOptionsString("-compare_rom_model", "The nlrom file of the reduced run (default: /sim's 'rom')", "",
                               buf, buf, sizeof buf, &set));
  if (set) rom_model = buf;
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

double load_tmax(const std::string& fom, const std::string& rom, const std::vector<dyn::NodalLoad>& loads,
                 std::string* stored) {
  dyn::LoadDescription ld;
  stored->clear();
  if (dyn::read_load_description(fom, "/fom/load", &ld))
    *stored = fom;
  else if (dyn::read_load_description(rom, "/sim/load", &ld))
    *stored = rom;
  return dyn::first_maximum(loads.empty() ? ld.loads : loads);
}

Indicator compare_runs(const std::string& fom, const std::string& rom, const CompareSettings& s, double* tsnap) {
  Indicator ind;
  std::string err;
  std::vector<hsize_t> d;
  auto need = [&](bool ok) {
    if (!ok) throw Error(err);
  };
  auto fh = dyn::read_fom(fom, {s.tip});
  auto sr = sim::read_sim(rom, {s.tip});
  const auto& tf = fh.time;
  const auto& tr = sr.time;
  const auto& tip_f = fh.sets[0].node_ids;
  const auto& tip_r = sr.sets[0].node_ids;
  auto& ur = sr.sets[0].u;
  const std::size_t r = sr.final_q.size();
  {  // Match the ROM's tip rows to the FOM's by node id (the two files may order them differently).
    auto a = tip_f, b = tip_r;
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    MORSE_CHECK(a == b, "compare: the tip set '", s.tip, "' has different nodes in ", fom, " and ", rom);
    std::map<std::int64_t, std::size_t> at;
    for (std::size_t k = 0; k < tip_r.size(); ++k) at[tip_r[k]] = k;
    const std::size_t nn = tip_r.size(), nt = nn ? ur.size() / (3 * nn) : 0;
    std::vector<double> v(ur.size());
    for (std::size_t t = 0; t < nt; ++t)
      for (std::size_t k = 0; k < nn; ++k)
        for (int c = 0; c < 3; ++c) v[(t * nn + k) * 3 + c] = ur[(t * nn + at[tip_f[k]]) * 3 + c];
    ur.swap(v);
  }
  MORSE_CHECK(tr.back() >= tf.back() - 1e-12 * tf.back(), "compare: ", rom, " ends at t = ", tr.back(), " before ", fom,
              " (t = ", tf.back(), ")");
  // Align on the FOM's time samples.
  const std::size_t ntip = 3 * tip_f.size();
  auto er_f = interpolate(tr, sr.energy, 1, tf);
  auto ur_f = interpolate(tr, ur, ntip, tf);
  ind.w = {s.w[0], s.w[1], s.w[2], s.w[3]};
  ind.e[1] = energy_criterion(fh.energy, er_f);
  ind.e[2] = peak_to_peak_criterion(fh.sets[0].u, ur_f, ntip);
  ind.e[3] = displacement_criterion(fh.sets[0].u, ur_f);
  // e1: full fields at the snapshot nearest to t_max.
  std::string model = s.rom_model.empty() ? files::resolve_stored_path(sr.rom, rom) : s.rom_model;
  MORSE_CHECK(!model.empty(), "compare: ", rom, " does not name its reduced model; give -compare_rom_model");
  MORSE_CHECK(s.tmax <= tf.back(), "compare: t_max = ", s.tmax, " s is after the end of ", fom, " (t = ", tf.back(),
              " s); give -compare_tmax");
  const dyn::SnapshotRow snap = dyn::read_fom_snapshot_row(fom, s.tmax);  // e1 needs one
  *tsnap = snap.time;
  // Only the basis is needed (not the tensors): fill the reconstruction part of a StoredModel.
  nlrom::StoredModel sm;
  sm.file = model;
  need(io::read_doubles(model, "/nlrom/basis", &sm.basis, &d, &err));
  need(io::read_ints(model, "/mesh/node_ids", &sm.node_ids, &d, &err));
  MORSE_CHECK(r > 0 && sm.basis.size() == r * sm.node_ids.size() * 3, "compare: ", model, "'s basis does not match ",
              rom, "'s q");
  sm.model.r = static_cast<PetscInt>(r);
  auto qt = interpolate(tr, sr.q, r, {*tsnap});
  std::vector<double> x2;
  sm.dof_values(sm.dof_rows(snap.node_ids, snap.components), qt.data(), &x2);
  ind.e[0] = covariance(snap.u, x2);
  return ind;
}

}  // namespace morse::eval
