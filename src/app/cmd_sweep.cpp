// app/cmd_sweep.cpp: `morse sweep`, interaction maps of seed 003 §5: constant-speed runs of a
// `morse nlrom` model against the rotating casing for Omega = min, min + step, ..., max, spread
// over all ranks (sim::sweep). Every finished speed is written to -out at once (atomic rewrite);
// a killed sweep run again with the same options resumes from the file.
#include <petscsys.h>
#include <dlfcn.h>

#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/sim/run.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

namespace {
// One BLAS thread per rank. The step operators are made with BLAS/LAPACK, whose threaded kernels
// round differently from the sequential ones; where solutions coexist, a last-bit difference can
// put a speed on the other branch (docs/contact.md, "Coexisting solutions": 1,144 rad/s went from
// 3.26 to 0.65 mm with threaded OpenBLAS). The sweep's parallelism is over speeds, not threads.
void single_blas_thread(MPI_Comm comm) {
  using SetThreads = void (*)(int);
  using GetThreads = int (*)();
  auto set = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  auto get = reinterpret_cast<GetThreads>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  if (!set || !get) return;  // another BLAS
  const int before = get();
  if (before == 1) return;
  set(1);
  print0(comm,
         "morse sweep: OpenBLAS set to 1 thread per rank (it had %d): a speed's result is then the same on any "
         "machine (set OPENBLAS_NUM_THREADS=1 to silence this)\n",
         before);
}
}  // namespace

void run_sweep(MPI_Comm comm) {
  sim::SweepOptions so;
  MORSE_CALL(so.set_from_options(comm));
  if (help_requested()) return;
  check_options(comm, true);
  collective_check(comm, so.contact.error);
  so.check();
  const auto output_lock = files::prepare_outputs(comm, {{"-out", so.out}}, {{"-rom", so.rom}});
  so.check_memory(comm);
  single_blas_thread(comm);
  const auto sm = nlrom::read_stored_model(comm, so.rom, {so.contact.set, so.monitor});
  const std::size_t r = sm.r();
  const sim::SweepSettings s = so.settings(sm);
  sim::ContactSettings casing = s.base.contact;  // every speed's obstacle is the casing
  casing.obstacle = sim::Obstacle::Casing;
  const double hc = sim::critical_step(sm.model, &casing);
  MORSE_CHECK(so.dt > 0, "morse sweep: give the time step with -sim_dt (the critical step is ", hc, " s)");
  MORSE_CHECK(so.dt <= hc, "morse sweep: -sim_dt ", so.dt, " s is above the critical step of central differences, ", hc,
              " s (2 / omega_max of the reduced model); use -sim_dt <= ", hc);
  const long n_speeds = so.n_speeds();
  sim::SweepRecord rec;
  rec.settings = sim::settings_text(so, s, sm.model);
  rec.units = sm.units;
  rec.rom = files::absolute_path(so.rom);  // valid from any directory
  rec.n_speeds = n_speeds;
  rec.frequencies = s.frequencies();
  rec.orders = s.orders;
  for (double w2 : nlrom::free_eigenvalues(sm.model))  // a massless M is singular: its condensed model
    rec.eigenfrequencies_hz.push_back(hz(w2));
  const int rank = rank_of(comm);
  const std::vector<std::int64_t> done_idx = sim::resume_sweep(comm, so.out, so.restart, &rec);
  const long nd = static_cast<long>(done_idx.size());
  std::vector<sim::SpeedTask> todo = so.todo(done_idx);
  int size = 1;
  MPI_Comm_size(comm, &size);
  const long coarse = (so.grid_speeds() - 1) / so.stride() + 1;
  const double last = so.omega_min + static_cast<double>(coarse - 1) * so.omega_step;
  print0(comm,
         "morse sweep: %ld speeds %.6g..%.6g rad/s%s (%ld already in %s), %.6g revolutions each, dt "
         "%.4g s (critical %.4g s), "
         "r = %zu, %s, %d lanes per rank (-sweep_kernel %s) on %d rank(s)\n",
         coarse, so.omega_min, last, so.rotation > 0 ? "" : " turning negatively about z", nd, so.out.c_str(),
         s.revolutions, so.dt, hc, r, so.linear ? "linear" : "nonlinear", s.batch, sim::kernel_name(so.kernel), size);
  if (so.continuation != 0) {
    print0(comm,
           "morse sweep: continuation %s: each speed starts from the final state of the speed %s it, on the grown "
           "casing; %ld chain(s) of neighbouring speeds, the first of each from rest (-sweep_chains)%s\n",
           so.continuation == 2  ? "both ways"
           : so.continuation > 0 ? "up"
                                 : "down",
           so.continuation == 2  ? "below (up: indices 0..n-1 of the file) or above (down: n..2n-1)"
           : so.continuation > 0 ? "below"
                                 : "above",
           static_cast<long>(so.chains) * so.directions(),
           so.chains * so.directions() < size ? "; fewer chains than ranks: some ranks idle" : "");
  } else if (so.retries > 0) {
    print0(comm, "morse sweep: a speed that fails runs again at half its step, up to %d time(s) (-sweep_retries)\n",
           so.retries);
  }
  if (so.refine_step > 0 && !so.refine_orders.empty()) {
    print0(comm,
           "morse sweep: then refined where the engine-order lines %s jump by %.3g or peak (above %.3g of their "
           "largest) down to %.6g rad/s (a grid of %ld speeds)\n",
           so.refine_orders_text().c_str(), so.refine_order_jump, so.refine_order_floor, so.refine_step, n_speeds);
  } else if (so.refine_step > 0)
    print0(comm,
           "morse sweep: then refined where neighbouring speeds differ (RMS by %.3g, dominant frequency by %.3g) "
           "down to %.6g rad/s (a grid of %ld speeds)\n",
           so.refine_rms, so.refine_frequency, so.refine_step, n_speeds);
  const auto cost = sim::predict_sweep_cost(comm, sm.model, s, so, todo, done_idx);
  if (cost.rate > 0) {
    print0(comm,
           "morse sweep: predicted cost: %.4g steps, %.3g core-hours at %.4g steps/s per rank (measured), about %s "
           "on %d rank(s)\n",
           cost.steps, cost.core_hours, cost.rate, duration_text(cost.wall_seconds).c_str(), size);
    if (cost.checks > 0)
      print0(comm,
             "morse sweep: of which %.4g tangent checks (-sim_tangent_checks per speed) at %.3g ms each (measured): "
             "%.0f%% of the cost\n",
             cost.checks, 1e3 * cost.check_seconds,
             100.0 * cost.checks * cost.check_seconds / (cost.core_hours * 3600.0));
    if (so.refine_step > 0)
      print0(
          comm,
          "morse sweep: refinement: at most %.4g more steps, %.3g core-hours (if every speed of the fine grid ran)\n",
          cost.refine_steps, cost.refine_core_hours);
    if (so.retries > 0 && so.continuation == 0)
      print0(
          comm,
          "morse sweep: not counted: the retries of failed speeds (a speed retried k times costs at most 2^(k+1) - 1 "
          "times its run)\n");
  }
  sim::SweepStats st;
  std::size_t n_run = 0;
  {
    StageTimer timer(comm, "Sweep");
    st = sim::sweep_rounds(
        comm, sm.model, s, so, todo, &rec.results, rec.frequencies,
        [&](const sim::SpeedResult&) { sim::write_sweep(so.out, rec); },  // rank 0: checkpoint
        &n_run);
  }
  double lane_steps = static_cast<double>(st.lane_steps), kernel = st.kernel_seconds, wall = st.seconds,
         idle = st.idle_seconds;
  MPI_Allreduce(MPI_IN_PLACE, &lane_steps, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &kernel, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &idle, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &wall, 1, MPI_DOUBLE, MPI_MAX, comm);
  print0(comm,
         "morse sweep: %zu speeds in %.2f s (%.3g core-hours), %.4g steps/s over all ranks (%.4g per rank), %.0f%% "
         "in the force kernels (%s%s%s%s), %.0f%% idle (no speed to advance: the load-balance loss)\n",
         n_run, wall, wall * size / 3600.0, wall > 0 ? lane_steps / wall : 0.0,
         wall > 0 ? lane_steps / wall / size : 0.0, wall > 0 ? 100.0 * kernel / (wall * size) : 0.0,
         so.linear ? "linear" : sim::kernel_name(st.kernel), so.single ? ", float coefficients" : "",
         !so.linear && st.kernel == sim::SweepKernel::Potential ? ", " : "",
         !so.linear && st.kernel == sim::SweepKernel::Potential ? sim::kernel_isa_name(sim::kernel_isa_or_best(so.isa))
                                                                : "",
         wall > 0 ? 100.0 * idle / (wall * size) : 0.0);
  if (size > 1) {  // the load balance, rank by rank
    std::vector<double> idles(static_cast<std::size_t>(size), 0.0);
    MPI_Gather(&st.idle_seconds, 1, MPI_DOUBLE, idles.data(), 1, MPI_DOUBLE, 0, comm);
    std::string per_rank;
    for (int k = 0; k < size; ++k) {
      char b[64];
      std::snprintf(b, sizeof b, "%s%d: %.0f%%", k ? ", " : "", k,
                    wall > 0 ? 100.0 * idles[static_cast<std::size_t>(k)] / wall : 0.0);
      per_rank += b;
    }
    print0(comm, "morse sweep: idle per rank: %s\n", per_rank.c_str());
  }
  if (rank == 0) {  // the tangent checks: how close the speeds came to the stiffened model's step
    const sim::SpeedResult* worst = nullptr;
    long close = 0, checked = 0;
    for (const auto& R : rec.results) {
      if (R.tangent_checks == 0) continue;
      ++checked;
      close += R.dt > 0.5 * R.tangent_dt_min ? 1 : 0;
      if (!worst || R.tangent_dt_min < worst->tangent_dt_min) worst = &R;
    }
    if (worst)
      print0(PETSC_COMM_SELF,
             "morse sweep: tangent critical step 2/omega_max(K~ + dg~/dq): smallest %.4e s (omega %g rad/s, t = %.6g "
             "s); %ld of %ld speeds ran above half of their smallest (/sweep/tangent; docs/contact.md: runs have "
             "diverged from 0.7 of it)\n",
             worst->tangent_dt_min, worst->omega, worst->tangent_dt_min_time, close, checked);
  }
  std::string failed;
  if (rank == 0)
    for (const auto& R : rec.results)
      if (R.status != 0) failed += cat(failed.empty() ? "" : "; ", "omega ", R.omega, " at dt ", R.dt, " s: ", R.error);
  print0(comm, "morse: wrote %s\n", so.out.c_str());
  collective_check(comm, failed.empty()
                             ? ""
                             : cat("morse sweep: speeds failed (recorded with status 1",
                                   so.retries > 0 && so.continuation == 0
                                       ? cat(" after ", so.retries, " halving(s) of the step; -sweep_retries")
                                       : std::string(),
                                   "): ", failed));
  check_options(comm, false);
}

}  // namespace morse::app::detail
