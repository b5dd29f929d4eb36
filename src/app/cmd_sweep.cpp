// app/cmd_sweep.cpp: `morse sweep`, interaction maps of seed 003 §5: constant-speed runs of a
// `morse nlrom` model against the rotating casing for Omega = min, min + step, ..., max, spread
// over all ranks (sim::sweep). Every finished speed is written to -out at once (atomic rewrite);
// a killed sweep run again with the same options resumes from the file.
#include <petscsys.h>

#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

namespace {

struct SweepOptions {
  std::string rom, out = "sweep.h5", monitor = "LE";
  double omega_min = 0, omega_max = 0, omega_step = 0, dt = 0, fmax = 10000.0;
  PetscInt bins = 500, batch = 8;
  PetscBool linear = PETSC_FALSE, restart = PETSC_FALSE, batched = PETSC_FALSE;
  ContactOptions contact;
};

PetscErrorCode get_sweep_options(MPI_Comm comm, SweepOptions* o) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse sweep options", "");
  PetscCall(MorseOptionsString("-rom", "Reduced model: a morse nlrom file whose boundary set holds the contact set", "",
                               buf, buf, sizeof buf, &set));
  if (set) o->rom = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-out", "Sweep file (HDF5), rewritten after every speed; resumed if it exists", "",
                               o->out.c_str(), buf, sizeof buf, &set));
  if (set) o->out = buf;
  PetscCall(MorseOptionsReal("-sweep_omega_min", "Lowest rotation speed [rad/s]", "", o->omega_min, &o->omega_min, nullptr));
  PetscCall(MorseOptionsReal("-sweep_omega_max", "Highest rotation speed [rad/s]", "", o->omega_max, &o->omega_max, nullptr));
  PetscCall(MorseOptionsReal("-sweep_omega_step", "Speed step [rad/s]", "", o->omega_step, &o->omega_step, nullptr));
  PetscCall(MorseOptionsReal("-sim_dt", "Time step [s] (at most the critical step)", "", o->dt, &o->dt, nullptr));
  PetscCall(MorseOptionsBool("-sim_linear", "Linear reduced model (g~ = 0)", "", o->linear, &o->linear, nullptr));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-sweep_monitor", "Node set of one node whose radial displacement is recorded", "",
                               o->monitor.c_str(), buf, sizeof buf, &set));
  if (set) o->monitor = buf;
  PetscCall(MorseOptionsReal("-sweep_spectrum_fmax", "Highest frequency of the spectrum [Hz]", "", o->fmax, &o->fmax, nullptr));
  PetscCall(MorseOptionsInt("-sweep_spectrum_bins", "Frequencies of the spectrum (k fmax / bins, k = 0..bins)", "",
                            o->bins, &o->bins, nullptr));
  PetscCall(MorseOptionsInt("-sweep_batch", "Speeds advanced together per rank (one pass of the cubic tensor)", "",
                            o->batch, &o->batch, nullptr));
  PetscCall(MorseOptionsBool("-sweep_batched",
                             "Cubic force of a rank's speeds as one batched pass of the folded tensor (else the "
                             "auto kernel speed by speed, faster on the machines measured: bench/sweep_bench.py)",
                             "", o->batched, &o->batched, nullptr));
  PetscCall(MorseOptionsBool("-sweep_restart", "Start again even if -out holds finished speeds", "", o->restart,
                             &o->restart, nullptr));
  PetscOptionsEnd();
  return get_contact_options(comm, &o->contact);
}

std::string settings_text(const SweepOptions& o, const sim::SweepSettings& s, std::size_t r) {
  char b[2048];
  const auto& c = o.contact.casing;
  std::snprintf(b, sizeof b,
                "rom=%s\nr=%zu\nomega_min=%.17g\nomega_max=%.17g\nomega_step=%.17g\ndt=%.17g\nlinear=%d\n"
                "revolutions=%.17g\ncontact_set=%s\nmu=%.17g\nclearance=%.17g\nbump_height=%.17g\nlobes=%d\n"
                "width=%.17g\nalpha=%.17g\nmonitor=%s\nspectrum_fmax=%.17g\nspectrum_bins=%d\nbatched=%d\n"
                "spectrum_decimation=block_mean\n",
                o.rom.c_str(), r, o.omega_min, o.omega_max, o.omega_step, s.base.dt, s.base.linear ? 1 : 0,
                s.revolutions, o.contact.set.c_str(), o.contact.mu, c.clearance, c.bump_height, c.lobes, c.width,
                c.alpha, o.monitor.c_str(), s.spectrum_fmax, s.spectrum_bins, s.batched ? 1 : 0);
  return b;
}

}  // namespace

void run_sweep(MPI_Comm comm) {
  SweepOptions so;
  MORSE_CALL(get_sweep_options(comm, &so));
  if (help_requested()) return;
  check_options(comm, true);
  collective_check(comm, so.contact.error);
  MORSE_CHECK(!so.rom.empty(), "morse sweep: no reduced model given: use -rom FILE.h5 (a morse nlrom file)");
  MORSE_CHECK(!so.contact.set.empty(), "morse sweep: give the contact nodes with -contact_set SET");
  MORSE_CHECK(so.contact.obstacle == sim::Obstacle::Casing && !so.contact.plane_given,
              "morse sweep: the obstacle is the casing (-contact_obstacle casing; -contact_plane_* do not apply)");
  MORSE_CHECK(!so.contact.omega_given, "morse sweep: the speeds are -sweep_omega_min/_max/_step; -sim_omega does not apply");
  MORSE_CHECK(so.omega_min > 0 && so.omega_max >= so.omega_min,
              "morse sweep: give 0 < -sweep_omega_min <= -sweep_omega_max (got ", so.omega_min, ", ", so.omega_max, ")");
  MORSE_CHECK(so.omega_step > 0 || so.omega_max == so.omega_min, "morse sweep: -sweep_omega_step must be positive");
  MORSE_CHECK(so.batch > 0, "-sweep_batch must be positive (got ", so.batch, ")");
  MORSE_CHECK(so.fmax > 0 && so.bins > 0, "-sweep_spectrum_fmax and -sweep_spectrum_bins must be positive");
  const double revolutions = so.contact.revolutions > 0 ? so.contact.revolutions : 200.0;
  const auto sm = nlrom::read_stored_model(comm, so.rom, {so.contact.set, so.monitor});
  const std::size_t r = sm.r();
  sim::SweepSettings s;
  s.base.dt = so.dt;
  s.base.linear = so.linear;
  s.base.contact.nodes = sim::contact_nodes(sm, so.contact.set);
  s.base.contact.obstacle = sim::Obstacle::Casing;
  s.base.contact.casing = so.contact.casing;
  s.base.contact.mu = so.contact.mu;
  s.revolutions = revolutions;
  s.spectrum_fmax = so.fmax;
  s.spectrum_bins = static_cast<int>(so.bins);
  s.batch = static_cast<int>(so.batch);
  s.batched = so.batched;
  s.monitor = sm.radial_row(so.monitor, "-sweep_monitor");
  const double hc = sim::critical_step(sm.model);
  MORSE_CHECK(so.dt > 0, "morse sweep: give the time step with -sim_dt (the critical step is ", hc, " s)");
  MORSE_CHECK(so.dt <= hc, "morse sweep: -sim_dt ", so.dt, " s is above the critical step of central differences, ", hc,
              " s (2 / omega_max of the reduced model); use -sim_dt <= ", hc);
  const long n_speeds =
      so.omega_max == so.omega_min ? 1 : static_cast<long>(std::floor((so.omega_max - so.omega_min) / so.omega_step + 1e-9)) + 1;
  sim::SweepRecord rec;
  rec.settings = settings_text(so, s, r);
  rec.units = sm.units;
  rec.rom = so.rom;
  rec.n_speeds = n_speeds;
  rec.frequencies = s.frequencies();
  for (double w2 : eigen::dense_eigenvalues(static_cast<int>(r), sm.model.K, sm.model.M, nullptr))
    rec.eigenfrequencies_hz.push_back(hz(w2));
  // Resume: rank 0 reads the file; the speeds it holds are skipped on every rank.
  const int rank = rank_of(comm);
  std::string err;
  std::vector<std::int64_t> done_idx;
  if (rank == 0 && !so.restart) {
    sim::SweepRecord old;
    std::string why;
    if (sim::read_sweep(so.out, &old, &why)) {
      if (old.settings != rec.settings)
        err = cat(so.out, " holds a sweep with other settings; give another -out, or -sweep_restart to overwrite it");
      else {
        rec.results = old.results;
        for (const auto& R : old.results) done_idx.push_back(R.index);
      }
    } else if (why.find("no such file") == std::string::npos) {
      err = cat(why, "; give another -out, or -sweep_restart to overwrite it");
    }
  }
  // The first checkpoint also proves that -out is writable before any speed runs.
  if (rank == 0 && err.empty()) {
    try {
      sim::write_sweep(so.out, rec);
    } catch (const std::exception& e) {
      err = cat("morse sweep: cannot write -out ", so.out, ": ", e.what());
    }
  }
  collective_check(comm, err);
  long nd = static_cast<long>(done_idx.size());
  MPI_Bcast(&nd, 1, MPI_LONG, 0, comm);
  done_idx.resize(static_cast<std::size_t>(nd));
  MPI_Bcast(done_idx.data(), static_cast<int>(nd), MPI_INT64_T, 0, comm);
  const std::set<std::int64_t> done(done_idx.begin(), done_idx.end());
  std::vector<sim::SpeedTask> todo;
  for (long i = 0; i < n_speeds; ++i)
    if (!done.count(i)) todo.push_back({i, so.omega_min + static_cast<double>(i) * so.omega_step});
  int size = 1;
  MPI_Comm_size(comm, &size);
  print0(comm,
         "morse sweep: %ld speeds %.6g..%.6g rad/s (%ld already in %s), %.6g revolutions each, dt %.4g s (critical %.4g s), "
         "r = %zu, %s, %d lanes per rank (%s kernel) on %d rank(s)\n",
         n_speeds, so.omega_min, so.omega_min + (n_speeds - 1) * so.omega_step, nd, so.out.c_str(), revolutions, so.dt,
         hc, r, so.linear ? "linear" : "nonlinear", s.batch, so.batched ? "batched" : "per-lane", size);
  sim::SweepStats st;
  {
    StageTimer timer(comm, "Sweep");
    st = sim::sweep(comm, sm.model, s, todo, [&](const sim::SpeedResult& R) {
      rec.results.push_back(R);
      sim::write_sweep(so.out, rec);  // rank 0: atomic checkpoint
    });
  }
  double lane_steps = static_cast<double>(st.lane_steps), kernel = st.kernel_seconds, wall = st.seconds;
  MPI_Allreduce(MPI_IN_PLACE, &lane_steps, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &kernel, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &wall, 1, MPI_DOUBLE, MPI_MAX, comm);
  print0(comm, "morse sweep: %zu speeds in %.2f s, %.4g steps/s over all ranks (%.4g per rank), %.0f%% in the force kernels\n",
         todo.size(), wall, wall > 0 ? lane_steps / wall : 0.0, wall > 0 ? lane_steps / wall / size : 0.0,
         wall > 0 ? 100.0 * kernel / (wall * size) : 0.0);
  std::string failed;
  if (rank == 0)
    for (const auto& R : rec.results)
      if (R.status != 0) failed += cat(failed.empty() ? "" : "; ", "omega ", R.omega, ": ", R.error);
  print0(comm, "morse: wrote %s\n", so.out.c_str());
  collective_check(comm, failed.empty() ? "" : cat("morse sweep: speeds failed (recorded with status 1): ", failed));
  check_options(comm, false);
}

}  // namespace morse::app::detail
