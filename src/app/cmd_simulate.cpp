// app/cmd_simulate.cpp: `morse simulate`, the online stage of seed 003: a `morse nlrom` reduced
// model integrated by explicit central differences (sim::integrate) under the shared -load_*
// loads. One case runs on rank 0; several cases (-sim_cases a,b,...: loads -a_load_*, -b_load_*)
// run one per rank, round robin, each writing its own file. The reduced model is read once by
// rank 0 and broadcast. Outputs mirror `morse fom` (/sim/time, /sim/sets/<SET>/u, /sim/energy,
// /sim/snapshots) plus /sim/q and /sim/final.
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/io/h5.hpp"
#include "morse/sim/run.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

namespace {

struct Case {
  std::string name, out;
  std::vector<dyn::NodalLoad> loads;
};

// Integrates one case and writes its file (serial: comm = PETSC_COMM_SELF of the rank that runs
// it).
void run_case(const sim::SimOptions& so, const nlrom::StoredModel& sm, const sim::SnapshotPlan& plan, const Case& c) {
  const std::size_t r = sm.r();
  const double hc = sim::critical_step(sm.model, &so.s.contact);
  const char* label = c.name.empty() ? "" : " case ";
  const bool implicit = so.s.scheme != sim::Scheme::Central;
  print0(PETSC_COMM_SELF, "morse simulate%s%s: r = %d, critical step %.4e s%s, dt = %.4e s, %s, %s\n", label,
         c.name.c_str(), (int)r, hc, implicit ? " (not a limit: implicit)" : "", so.s.dt,
         so.s.linear ? "linear" : "nonlinear",
         so.s.scheme == sim::Scheme::Energy ? "energy (average vector field)"
                                            : (implicit ? "trapezoidal" : "central differences"));
  sim::SimRecord rec;
  auto stats = sim::simulate(sm, c.loads, so.s, so.every, so.monitor, so.contact.set, plan, &rec);
  const double sps = stats.seconds > 0 ? stats.steps / stats.seconds : 0.0;
  print0(PETSC_COMM_SELF, "  %s%s%ld steps in %.4f s (%.3g steps/s, with output)\n", c.name.c_str(),
         c.name.empty() ? "" : ": ", stats.steps, stats.seconds, sps);
  if (implicit)
    print0(PETSC_COMM_SELF, "  Newton: %ld iterations (%.2f per step), %ld shortened by the line search\n",
           stats.newton_iterations, stats.steps ? static_cast<double>(stats.newton_iterations) / stats.steps : 0.0,
           stats.line_searches);
  if (implicit && stats.newton_floor_steps > 0)
    print0(PETSC_COMM_SELF,
           "  Newton: %ld steps stopped at the round-off floor of the residual (a correction below 1e-8 |q| in "
           "the quadratic phase), ||R|| up to %.3g times the tolerance\n",
           stats.newton_floor_steps, stats.newton_floor_ratio);
  if (stats.error_estimated && stats.error_q_max > 0)
    print0(PETSC_COMM_SELF,
           "  time-discretization error estimate (local, per step, |.|_M relative to max |q|_M = %.3e): largest "
           "%.2e at t = %.6g s, rms %.2e; sum over the steps %.2e (the order of the drift accumulated over the "
           "run: 2/pi of an oscillator's phase drift). Halving -sim_dt divides the local error by about 8 and the "
           "sum by 4\n",
           stats.error_q_max, stats.error_local_max / stats.error_q_max, stats.error_time,
           stats.error_local_rms / stats.error_q_max, stats.error_sum / stats.error_q_max);
  else if (stats.kernel != "linear")
    print0(PETSC_COMM_SELF, "  nonlinear force kernel: %s, %.3g flop and %.3g MB per step (%.2f GFLOP/s, %.2f GB/s)\n",
           stats.kernel.c_str(), stats.kernel_flops, stats.kernel_bytes * 1e-6, sps * stats.kernel_flops * 1e-9,
           sps * stats.kernel_bytes * 1e-9);
  if (!stats.tangent.empty()) {
    const double h = so.s.dt, m = stats.tangent_dt_min;
    print0(PETSC_COMM_SELF,
           "  tangent critical step (K~ + dg~/dq at %zu states): smallest %.4e s at t = %.6g s (dt / smallest = %.3g), "
           "%ld states with negative tangent stiffness\n",
           stats.tangent.size(), m, stats.tangent_dt_min_time, h / m, stats.tangent_negative_checks);
    if (h > 0.5 * m)
      print0(PETSC_COMM_SELF,
             "  WARNING: -sim_dt %.4e s was above half the smallest tangent critical step; runs of the blade have "
             "diverged from 0.7 of it (docs/contact.md): check this one against a run at dt <= %.4e s\n",
             h, 0.5 * m);
  }
  if (sm.model.massless && !so.s.linear)
    print0(PETSC_COMM_SELF, "  massless boundary: %ld equilibrium iterations (%.2f per step), %ld tangents\n",
           stats.boundary_iterations,
           stats.steps ? static_cast<double>(stats.boundary_iterations) / static_cast<double>(stats.steps) : 0.0,
           stats.tangent_updates);
  io::H5Output out(PETSC_COMM_SELF, c.out);
  io::write_provenance(out, "simulate", sm.units);
  const auto& cr = rec.contact;
  if (!cr.node_ids.empty())
    print0(PETSC_COMM_SELF, "  contact: %zu nodes, max normal force %.4g N at t = %.6g s\n", cr.node_ids.size(),
           cr.max_normal_force, cr.time_of_max_normal_force);
  if (const auto& b = rec.balance; b.time.size() > 1) {
    const std::size_t e = b.time.size() - 1;
    print0(PETSC_COMM_SELF,
           "  energy balance to t = %.6g s: energy %+.4g J = load %+.4g + normal contact %+.4g + friction %+.4g - "
           "damping %.4g J (residual %.2g J)\n",
           b.time[e], b.energy[e] - b.energy[0], b.external[e], b.normal[e], b.friction[e], b.damping[e],
           b.energy[e] - b.energy[0] - (b.external[e] + b.normal[e] + b.friction[e] - b.damping[e]));
  }
  rec.rom = files::absolute_path(so.rom);  // valid from any directory (morse compare)
  rec.case_name = c.name;
  sim::write_sim(out, rec, so.s, stats);
  out.commit();
  print0(PETSC_COMM_SELF, "morse: wrote %s\n", c.out.c_str());
}

}  // namespace

void run_simulate(MPI_Comm comm) {
  sim::SimOptions so;
  MORSE_CALL(so.set_from_options(comm));
  std::vector<Case> cases;
  std::string load_error;
  if (so.cases.empty()) {
    cases.push_back({"", so.out, {}});
    MORSE_CALL(get_loads(comm, &cases.back().loads, &load_error));
  } else {
    for (const auto& name : so.cases) {
      cases.push_back({name, sim::case_path(so.out, name), {}});
      const std::string prefix = name + "_";
      MORSE_CALL(get_loads(comm, &cases.back().loads, &load_error, prefix.c_str()));
    }
  }
  if (help_requested()) return;
  check_options(comm, true);
  collective_check(comm, load_error);
  collective_check(comm, so.contact.error);
  collective_check(comm, so.error);
  MORSE_CHECK(!so.rom.empty(), "morse simulate: no reduced model given: use -rom FILE.h5 (a morse nlrom file)");
  MORSE_CHECK(so.every > 0, "-sim_output_every must be positive (got ", so.every, ")");
  std::vector<files::Named> outputs;
  for (const auto& c : cases) outputs.push_back({c.name.empty() ? "-out" : cat("-out (case ", c.name, ")"), c.out});
  const auto output_lock = files::prepare_outputs(comm, outputs, {{"-rom", so.rom}, {"-sim_snapshots", so.snapshots}});
  std::vector<std::string> sets(so.monitor);
  for (const auto& c : cases)
    for (const auto& l : c.loads) sets.push_back(l.set);
  if (!so.contact.set.empty()) sets.push_back(so.contact.set);
  const auto sm = nlrom::read_stored_model(comm, so.rom, sets);
  const std::size_t r = sm.r();
  double residual = 0.0;
  so.resolve(sm, &residual);
  if (!so.v0_uniform.empty())
    print0(comm,
           "morse simulate: uniform initial velocity (%g, %g, %g) m/s fitted on the basis, "
           "relative residual %.2e\n",
           so.v0_uniform[0], so.v0_uniform[1], so.v0_uniform[2], residual);
  MORSE_CHECK(so.s.q0.empty() || so.s.q0.size() == r, "-sim_q0 has ", so.s.q0.size(), " values; the model has r = ", r);
  MORSE_CHECK(so.s.v0.empty() || so.s.v0.size() == r, "-sim_v0 has ", so.s.v0.size(), " values; the model has r = ", r);
  sim::SnapshotPlan plan;
  if (!so.snapshots.empty()) plan = sim::read_snapshot_plan(comm, so.snapshots, sm);
  int size = 1;
  MPI_Comm_size(comm, &size);
  if (cases.size() > 1)
    print0(comm, "morse simulate: %zu cases on %d rank(s), reduced model read once (r = %zu)\n", cases.size(), size, r);
  // A failed case (NaN, Newton) does not stop the others; the command fails at the end, naming
  // every failed case, and those cases leave no file.
  std::vector<std::string> names;
  for (const auto& c : cases) names.push_back(c.name);
  sim::run_cases(comm, names, [&](std::size_t i) { run_case(so, sm, plan, cases[i]); });
  check_options(comm, false);
}

}  // namespace morse::app::detail
