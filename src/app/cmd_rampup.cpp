// app/cmd_rampup.cpp: `morse rampup`, seed 000 §3's benchmark load case: stator superelements
// (morse reduce / select files) in a rotor–stator assembly, unbalance speed ramp-up, bearing loads
// (morse::rampup). Options describe the engine (run/engine.opts documents every one); every rank
// reads and checks them and builds the model (small), rank 0 integrates and writes /rampup.
#include <petscsys.h>

#include <cstdio>
#include <string>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/io/h5.hpp"
#include "morse/rampup/engine.hpp"
#include "morse/rampup/rampup.hpp"

namespace morse::app::detail {

void run_rampup(MPI_Comm comm) {
  rampup::RampupOptions o;
  MORSE_CALL(o.set_from_options(comm));
  if (help_requested()) return;
  check_options(comm, true);
  o.check();
  const auto output_lock = files::prepare_outputs(comm, {{"-out", o.out}}, o.inputs());
  const rampup::LoadCase lc = o.load_case();
  const rampup::IntegratorSettings is = o.integrator();
  const double t_end = rampup::end_time(lc, is);
  MORSE_CHECK(t_end / o.dt < 5e8, "-rampup_dt ", o.dt, " s gives ", t_end / o.dt, " steps: too many");

  // Every rank builds the (small) model from the same options and files, so a bad input throws
  // the same error on every rank.
  rampup::Engine e = rampup::build_engine(comm, o, lc.omega_max);
  const rampup::Assembly a = [&] {
    StageTimer t(comm, "Assembly");
    return rampup::Assembly(e.rotors, e.stators, e.bearings, e.torsion);
  }();
  print0(comm,
         "morse rampup: %zu rotor(s), %zu stator(s), %zu bearing(s); %d DOFs (%d stator modes + %d "
         "rotor)\n",
         e.rotors.size(), e.stators.size(), e.bearings.size(), a.n(), a.n_stator(), a.n_rotor());
  for (std::size_t s = 0; s < e.stators.size(); ++s) {
    const auto& sm = e.stators[s];
    print0(comm,
           "  stator %s: %d modes below %.1f Hz kept of %d (clamped %zu nodes, %zu free boundary "
           "DOFs)%s\n",
           sm.name.c_str(), sm.n_modes, sm.f_cut_hz, sm.n_total, sm.clamped_nodes.size(), sm.dof_node.size(),
           sm.n_modes ? cat(", ", sm.omega.front() / kTwoPi, "..", sm.omega.back() / kTwoPi, " Hz").c_str() : "");
  }
  if (a.n_torsion() > 0) {
    const std::vector<double> wt = a.torsion_frequencies();
    print0(comm, "  torsion: %zu drive(s), %zu gearbox(es), %zu torque(s); %zu free twists, lowest %s Hz\n",
           e.torsion.drives.size(), e.torsion.gearboxes.size(), e.torsion.torques.size(), a.free_twists().size(),
           wt.empty() ? "-" : cat(wt.front() / kTwoPi).c_str());
  }
  print0(comm, "  %s to %.1f rpm in %g s, dt = %g s (%s%s)\n", o.constant ? "constant speed" : "ramp", o.rpm_max,
         o.constant ? o.t_final : o.ramp_time, o.dt, o.alpha == 0 ? "Newmark average acceleration" : "HHT-alpha",
         o.dense ? ", dense reference step" : "");

  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  rampup::History h;
  rampup::IntegratorStats st;
  std::string err;
  {
    StageTimer t(comm, "Integrate");
    if (rank == 0) try {
        Progress prog(PETSC_COMM_SELF, "rampup", 1.0);
        h = rampup::record(a, lc, is, &st, [&](double f) { prog.update(f); });
      } catch (const std::exception& ex) {
        err = message_of(ex);
      }
    collective_check(comm, err);
  }
  for (const auto& w : st.warnings) print0(comm, "morse: warning: %s\n", w.c_str());
  print0(comm, "  %ld steps in %.3f s (%.2f us per step)\n", st.steps, st.seconds,
         st.steps ? 1e6 * st.seconds / st.steps : 0.0);
  if (rank == 0 && h.n_out() > 0) {
    const std::size_t last = h.n_out() - 1;
    for (int k = 0; k < h.n_drives; ++k)
      std::printf("  drive %s: torque %.6g N m at the end (%.6g kW)\n", e.torsion.drives[k].name.c_str(),
                  h.drive_torque[last * h.n_drives + k],
                  1e-3 * h.drive_torque[last * h.n_drives + k] * h.omega[last] *
                      e.rotors[e.torsion.drives[k].rotor].speed_ratio);
    for (int k = 0; k < h.n_gearboxes; ++k)
      std::printf("  gearbox %s: mesh torque %.6g N m at the end\n", e.torsion.gearboxes[k].name.c_str(),
                  h.gearbox_torque[last * h.n_gearboxes + k]);
  }

  rampup::HistoryErrors he;
  if (!o.reference.empty()) {
    if (rank == 0) try {
        he = rampup::compare(h, rampup::read_history(o.reference));
      } catch (const std::exception& ex) {
        err = cat("-rampup_reference ", o.reference, ": ", message_of(ex));
      }
    collective_check(comm, err);
    print0(comm,
           "  against %s (seed 000 eq. 24): bearing loads worst %.3g %%, best %.3g %%, mean %.3g %%; "
           "displacements worst %.3g %%, best %.3g %%, mean %.3g %%\n",
           o.reference.c_str(), 100 * he.force_worst, 100 * he.force_best, 100 * he.force_mean,
           100 * he.displacement_worst, 100 * he.displacement_best, 100 * he.displacement_mean);
    print0(comm,
           "  against the largest range of any bearing (%.4g N, %.4g m): bearing loads worst %.3g %%, mean %.3g %%; "
           "displacements worst %.3g %%, mean %.3g %%; eq. 24's worst load is bearing %d %c\n",
           he.force_scale, he.displacement_scale, 100 * he.force_global_worst, 100 * he.force_global_mean,
           100 * he.displacement_global_worst, 100 * he.displacement_global_mean, he.force_dominant / 2 + 1,
           he.force_dominant % 2 ? 'y' : 'x');
  }

  StageTimer tw(comm, "Write");
  io::H5Output out(comm, o.out);
  if (rank == 0) {
    io::write_provenance(out, "rampup", "SI");
    rampup::write_history(out, "/rampup", h);
    rampup::write_run(out, "/rampup", o, e, a, st, he);
  }
  out.commit();
  print0(comm, "morse: wrote %s\n", o.out.c_str());
  check_options(comm, false);
}

}  // namespace morse::app::detail
