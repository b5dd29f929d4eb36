// app/cmd_compare.cpp: `morse compare FOM.h5 ROM.h5`, the performance indicator of seed 003
// (eq. 43–51; eval/indicator.hpp) of a `morse simulate` run against a `morse fom` run of the same
// case. Serial (rank 0). t_max comes from the load stored in the files (/fom/load, /sim/load;
// -load_* overrides it). Prints a table and writes /compare into ROM.h5 (atomically: a copy is
// modified, then renamed).
#include <hdf5.h>
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/eval/indicator.hpp"
#include "morse/io/h5.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

namespace {

struct CompareOptions {
  std::string tip = "tip";
  double tmax = -1;
  std::vector<double> w = {0.25, 0.25, 0.25, 0.25};
  std::string rom_model;
};

PetscErrorCode get_compare_options(MPI_Comm comm, CompareOptions* o) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscReal w[4];
  PetscInt nw = 4;
  PetscOptionsBegin(comm, nullptr, "morse compare options", "");
  PetscCall(MorseOptionsString("-compare_tip", "Node set of the blade tip (criteria e3, e4); monitored in both runs",
                               "", o->tip.c_str(), buf, sizeof buf, &set));
  if (set) o->tip = buf;
  PetscCall(MorseOptionsReal("-compare_tmax", "Time of e1 [s] (default: first maximum of the first harmonic -load_*)",
                             "", o->tmax, &o->tmax, nullptr));
  PetscCall(MorseOptionsRealArray("-compare_weights", "Weights w1,w2,w3,w4 of eq. 43 (sum 1)", "", w, &nw, &set));
  if (set) {
    MORSE_CHECK(nw == 4, "-compare_weights takes four values w1,w2,w3,w4");
    o->w.assign(w, w + 4);
  }
  buf[0] = 0;
  PetscCall(MorseOptionsString("-compare_rom_model", "The nlrom file of the reduced run (default: /sim's 'rom')", "",
                               buf, buf, sizeof buf, &set));
  if (set) o->rom_model = buf;
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

}  // namespace

void run_compare(MPI_Comm comm, const std::vector<std::string>& args) {
  CompareOptions co;
  MORSE_CALL(get_compare_options(comm, &co));
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(get_loads(comm, &load_list, &load_error));
  if (help_requested()) return;
  check_options(comm, true);
  collective_check(comm, load_error);
  MORSE_CHECK(args.size() == 2, "usage: morse compare FOM.h5 ROM.h5 (a morse fom file, a morse simulate file)");
  const std::string fom = args[0], rom = args[1];
  double ws = 0;
  for (double x : co.w) ws += x;
  MORSE_CHECK(std::abs(ws - 1.0) < 1e-12 && *std::min_element(co.w.begin(), co.w.end()) >= 0,
              "-compare_weights must be >= 0 and sum to 1");
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  std::string err;
  if (co.tmax < 0) {
    // t_max from the load: the -load_* options if given (they override the load the files
    // store), else the load stored in the fom file (/fom/load), else in the simulate file.
    double tmax = -1;
    std::string stored;  // the file whose stored load is used or overridden
    if (rank == 0) try {
        dyn::LoadDescription ld;
        if (dyn::read_load_description(fom, "/fom/load", &ld))
          stored = fom;
        else if (dyn::read_load_description(rom, "/sim/load", &ld))
          stored = rom;
        tmax = dyn::first_maximum(load_list.empty() ? ld.loads : load_list);
      } catch (const std::exception& e) {
        err = e.what();
      }
    collective_check(comm, err);
    MPI_Bcast(&tmax, 1, MPI_DOUBLE, 0, comm);
    co.tmax = tmax;
    if (!load_list.empty() && !stored.empty())
      print0(comm, "morse compare: the -load_* options override the load stored in %s\n", stored.c_str());
    MORSE_CHECK(co.tmax >= 0, "compare: give -compare_tmax T or the harmonic load (-load_*) that defines t_max",
                load_list.empty() ? " (neither file stores a harmonic load: /fom/load, /sim/load)" : "");
  }
  eval::Indicator ind;
  double tsnap = 0;
  if (rank == 0) {
    try {
      std::vector<hsize_t> d;
      std::vector<double> tf, tr, ef, er, uf, ur, q, snap_t, row;
      std::vector<std::int64_t> tip_f, tip_r, ids, comps;
      auto need = [&](bool ok) {
        if (!ok) throw Error(err);
      };
      auto fh = dyn::read_fom(fom, {co.tip});
      auto sr = sim::read_sim(rom, {co.tip});
      tf = std::move(fh.time), ef = std::move(fh.energy), tip_f = std::move(fh.sets[0].node_ids);
      uf = std::move(fh.sets[0].u);
      tr = std::move(sr.time), er = std::move(sr.energy), tip_r = std::move(sr.sets[0].node_ids);
      ur = std::move(sr.sets[0].u);
      q = std::move(sr.q);
      const std::size_t r = sr.final_q.size();
      {  // Match the ROM's tip rows to the FOM's by node id (the two files may order them differently).
        auto a = tip_f, b = tip_r;
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        MORSE_CHECK(a == b, "compare: the tip set '", co.tip, "' has different nodes in ", fom, " and ", rom);
        std::map<std::int64_t, std::size_t> at;
        for (std::size_t k = 0; k < tip_r.size(); ++k) at[tip_r[k]] = k;
        const std::size_t nn = tip_r.size(), nt = nn ? ur.size() / (3 * nn) : 0;
        std::vector<double> v(ur.size());
        for (std::size_t t = 0; t < nt; ++t)
          for (std::size_t k = 0; k < nn; ++k)
            for (int c = 0; c < 3; ++c) v[(t * nn + k) * 3 + c] = ur[(t * nn + at[tip_f[k]]) * 3 + c];
        ur.swap(v);
      }
      MORSE_CHECK(tr.back() >= tf.back() - 1e-12 * tf.back(), "compare: ", rom, " ends at t = ", tr.back(),
                  " before ", fom, " (t = ", tf.back(), ")");
      // Align on the FOM's time samples.
      const std::size_t ntip = 3 * tip_f.size();
      auto er_f = eval::interpolate(tr, er, 1, tf);
      auto ur_f = eval::interpolate(tr, ur, ntip, tf);
      ind.w = {co.w[0], co.w[1], co.w[2], co.w[3]};
      ind.e[1] = eval::energy_criterion(ef, er_f);
      ind.e[2] = eval::peak_to_peak_criterion(uf, ur_f, ntip);
      ind.e[3] = eval::displacement_criterion(uf, ur_f);
      // e1: full fields at the snapshot nearest to t_max.
      std::string model = co.rom_model.empty() ? sr.rom : co.rom_model;
      MORSE_CHECK(!model.empty(), "compare: ", rom, " does not name its reduced model; give -compare_rom_model");
      if (!io::read_doubles(fom, "/fom/snapshots/time", &snap_t, &d, &err))
        throw Error(cat(fom, ": no full-field snapshots for e1 (run morse fom with -fom_snapshot_every K)"));
      need(io::read_ints(fom, "/fom/snapshots/dof_node_ids", &ids, &d, &err));
      need(io::read_ints(fom, "/fom/snapshots/dof_components", &comps, &d, &err));
      MORSE_CHECK(co.tmax <= tf.back(), "compare: t_max = ", co.tmax, " s is after the end of ", fom, " (t = ",
                  tf.back(), " s); give -compare_tmax");
      std::size_t k = 0;
      for (std::size_t j = 1; j < snap_t.size(); ++j)
        if (std::abs(snap_t[j] - co.tmax) < std::abs(snap_t[k] - co.tmax)) k = j;
      tsnap = snap_t[k];
      need(io::read_double_row(fom, "/fom/snapshots/u", static_cast<std::int64_t>(k), &row, &err));
      MORSE_CHECK(row.size() == ids.size(), "compare: ", fom, ": /fom/snapshots/u has ", row.size(),
                  " columns but the DOF map ", ids.size());
      // Only the basis is needed (not the tensors): fill the reconstruction part of a StoredModel.
      nlrom::StoredModel sm;
      sm.file = model;
      need(io::read_doubles(model, "/nlrom/basis", &sm.basis, &d, &err));
      need(io::read_ints(model, "/mesh/node_ids", &sm.node_ids, &d, &err));
      MORSE_CHECK(r > 0 && sm.basis.size() == r * sm.node_ids.size() * 3, "compare: ", model,
                  "'s basis does not match ", rom, "'s q");
      sm.model.r = static_cast<PetscInt>(r);
      auto qt = eval::interpolate(tr, q, r, {tsnap});
      std::vector<double> x2;
      sm.dof_values(sm.dof_rows(ids, comps), qt.data(), &x2);
      ind.e[0] = eval::covariance(row, x2);
    } catch (const std::exception& e) {
      err = e.what();
    }
  }
  collective_check(comm, rank == 0 && !err.empty() ? err : std::string());
  check_options(comm, false);
  print0(comm, "morse compare: %s against %s (seed 003 eq. 43-51)\n", rom.c_str(), fom.c_str());
  print0(comm, "  %-34s %8s %8s\n", "criterion", "e", "w");
  const char* names[4] = {"e1 covariance at t_max", "e2 energy (eq. 46)", "e3 tip peak-to-peak", "e4 tip displacement"};
  for (int i = 0; i < 4; ++i) print0(comm, "  %-34s %8.4f %8.3f\n", names[i], ind.e[i], ind.w[i]);
  print0(comm, "  %-34s %8.4f\n", "performance indicator I", ind.I());
  print0(comm, "  (t_max %.6g s, nearest snapshot %.6g s)\n", co.tmax, tsnap);
  std::string werr;
  if (rank == 0) try {
      eval::write_compare(rom, ind, co.tmax, tsnap, fom, co.tip);
    } catch (const std::exception& e) {
      werr = e.what();
    }
  collective_check(comm, werr);
  print0(comm, "\nmorse: wrote /compare into %s\n", rom.c_str());
}

}  // namespace morse::app::detail
