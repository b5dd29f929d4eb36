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
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/io/h5.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

namespace {

struct SimOptions {
  std::string rom, out = "simulate.h5", snapshots;
  sim::Settings s;
  PetscBool linear = PETSC_FALSE;
  PetscInt every = 1;
  std::vector<std::string> monitor, cases;
  ContactOptions contact;
  std::vector<double> v0_uniform;  ///< 3 values, or empty
  bool tfinal_set = false;
};

PetscErrorCode get_sim_options(MPI_Comm comm, SimOptions* o) {
  PetscCall(options::get_string_list(comm, "-sim_monitor", "Node sets whose reconstructed displacements u = Phi q are written",
                         &o->monitor));
  PetscCall(options::get_string_list(comm, "-sim_cases",
                         "Independent load cases run one per rank; case c takes its loads from -c_load_sets, "
                         "-c_load_<SET>_* and writes <out>_c.h5",
                         &o->cases));
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse simulate options", "");
  PetscCall(MorseOptionsString("-rom", "Reduced model: a morse nlrom file", "", buf, buf, sizeof buf, &set));
  if (set) o->rom = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-out", "Output HDF5 file", "", o->out.c_str(), buf, sizeof buf, &set));
  if (set) o->out = buf;
  PetscCall(MorseOptionsReal("-sim_dt", "Time step [s] (at most the critical step, printed)", "", o->s.dt, &o->s.dt,
                             nullptr));
  PetscCall(MorseOptionsReal("-sim_tfinal", "Final time [s]", "", o->s.t_final, &o->s.t_final, &set));
  o->tfinal_set = set;
  const char* schemes[] = {"central", "trapezoidal", "Scheme", "", nullptr};
  PetscEnum scheme = static_cast<PetscEnum>(o->s.scheme);
  PetscCall(MorseOptionsEnum("-sim_scheme",
                             "central (explicit, eq. 40-41; dt below the critical step) or trapezoidal (implicit, "
                             "Newton on the reduced model: morse fom's scheme, any dt)",
                             "", schemes, scheme, &scheme, nullptr));
  o->s.scheme = static_cast<sim::Scheme>(scheme);
  PetscCall(MorseOptionsReal("-sim_newton_rtol", "trapezoidal: Newton tolerance relative to the force scale", "",
                             o->s.newton_rtol, &o->s.newton_rtol, nullptr));
  PetscInt max_it = o->s.newton_max_it;
  PetscCall(MorseOptionsInt("-sim_newton_max_it", "trapezoidal: Newton iterations per step before the run stops", "",
                            max_it, &max_it, nullptr));
  o->s.newton_max_it = static_cast<int>(max_it);
  const char* layouts[] = {"auto", "folded", "potential", "KernelLayout", "", nullptr};
  PetscEnum layout = static_cast<PetscEnum>(o->s.kernel);
  PetscCall(MorseOptionsEnum("-sim_kernel",
                             "Nonlinear force in the time loop: folded (P3 [A;B] times the monomials), potential "
                             "(symmetric energy coefficients, ~4 times fewer bytes; exact or STEP tensors), auto "
                             "(potential when A, B derive from a potential and the folded matrix exceeds 12 MB)",
                             "", layouts, layout, &layout, nullptr));
  o->s.kernel = static_cast<sim::KernelLayout>(layout);
  PetscCall(MorseOptionsBool("-sim_linear", "Linear reduced model (g~ = 0)", "", o->linear, &o->linear, nullptr));
  PetscCall(MorseOptionsInt("-sim_output_every", "Write every K-th step", "", o->every, &o->every, nullptr));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-sim_snapshots",
                               "A morse fom file: write the full field u = Phi q (and v) at its snapshot times and "
                               "on its DOF map (/sim/snapshots)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->snapshots = buf;
  std::vector<PetscReal> v(4096);
  const char* names[2] = {"-sim_q0", "-sim_v0"};
  const char* helps[2] = {"Initial reduced coordinates q(0), r values (default 0)",
                          "Initial reduced velocities dq/dt(0), r values (default 0)"};
  std::vector<double>* dest[2] = {&o->s.q0, &o->s.v0};
  for (int i = 0; i < 2; ++i) {
    PetscInt n = static_cast<PetscInt>(v.size());
    PetscCall(MorseOptionsRealArray(names[i], helps[i], "", v.data(), &n, &set));
    if (set) dest[i]->assign(v.begin(), v.begin() + n);
  }
  PetscInt n3 = 3;
  PetscReal u3[3] = {0, 0, 0};
  PetscCall(MorseOptionsRealArray("-sim_v0_uniform",
                                  "Initial velocity vx,vy,vz of every node [m/s], fitted on the basis by least squares "
                                  "(for impact tests; the fit residual is printed)",
                                  "", u3, &n3, &set));
  if (set) {
    if (n3 != 3 && o->contact.error.empty()) o->contact.error = "-sim_v0_uniform needs 3 values vx,vy,vz";
    o->v0_uniform.assign(u3, u3 + 3);
  }
  PetscOptionsEnd();
  PetscCall(get_contact_options(comm, &o->contact));
  o->s.linear = o->linear;
  return PETSC_SUCCESS;
}

// <out stem>_<case>.h5
std::string case_path(const std::string& out, const std::string& c) {
  auto dot = out.rfind('.');
  auto slash = out.rfind('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return out + "_" + c + ".h5";
  return out.substr(0, dot) + "_" + c + out.substr(dot);
}

// The fom file's snapshot times and DOF map.
struct SnapshotPlan {
  std::vector<double> time;
  std::vector<std::int64_t> ids, comps;
  std::vector<std::size_t> rows;
};

struct Case {
  std::string name, out;
  std::vector<dyn::NodalLoad> loads;
};

// Integrates one case and writes its file (serial: comm = PETSC_COMM_SELF of the rank that runs it).
void run_case(const SimOptions& so, const nlrom::StoredModel& sm, const SnapshotPlan& plan, const Case& c) {
  const std::size_t r = sm.r();
  std::vector<sim::ReducedLoad> loads;
  for (const auto& l : c.loads) {
    sim::ReducedLoad rl;
    rl.amplitude = l.amplitude, rl.omega = l.omega, rl.phase = l.phase;
    rl.p = sm.nodal_pattern(l.set, l.dir);
    loads.push_back(std::move(rl));
  }
  const double hc = sim::critical_step(sm.model);
  const char* label = c.name.empty() ? "" : " case ";
  const bool implicit = so.s.scheme == sim::Scheme::Trapezoidal;
  print0(PETSC_COMM_SELF, "morse simulate%s%s: r = %d, critical step %.4e s%s, dt = %.4e s, %s, %s\n", label,
         c.name.c_str(), (int)r, hc, implicit ? " (not a limit: implicit)" : "", so.s.dt,
         so.s.linear ? "linear" : "nonlinear", implicit ? "trapezoidal" : "central differences");
  // Snapshot steps: the step nearest each fom snapshot time within [0, t_final].
  std::vector<long> snap_step;
  for (double t : plan.time)
    if (t <= so.s.t_final * (1 + 1e-12)) snap_step.push_back(std::lround(t / so.s.dt));
  sim::SimRecord rec;
  std::map<std::string, std::vector<double>> hist;
  // Contact at the output steps: normal force, friction vector, gap, radial displacement e_r . u.
  const auto& cn = so.s.contact.nodes;
  const std::size_t nc = cn.size();
  auto& cr = rec.contact;
  std::vector<double> e_r(3 * nc, 0.0);
  // The contact forces act for one step each: the mean force of every output interval (its
  // impulse over its length) keeps what the output samples alone would miss, so that the
  // history can drive another model (-load_history).
  if (nc) cr.normals = sim::contact_normals(so.s.contact);
  const std::vector<double>& c_normal = cr.normals;
  std::vector<double> c_sum(3 * nc, 0.0);
  long c_count = 0;
  double t_prev_out = 0.0;
  for (std::size_t k = 0; k < nc; ++k) {
    const double rho = std::hypot(cn[k].x[0], cn[k].x[1]);
    if (rho > 0) e_r[3 * k] = cn[k].x[0] / rho, e_r[3 * k + 1] = cn[k].x[1] / rho;
  }
  std::size_t next_snap = 0;
  auto stats = sim::integrate(sm.model, loads, so.s, [&](const sim::StepState& x) {
    while (next_snap < snap_step.size() && snap_step[next_snap] == x.step) {
      rec.snapshot_time.push_back(x.t);
      sm.dof_values(plan.rows, x.q, &rec.snapshot_u);
      sm.dof_values(plan.rows, x.v, &rec.snapshot_v);
      ++next_snap;
    }
    rec.final_q.assign(x.q, x.q + r);
    rec.final_v.assign(x.v, x.v + r);
    rec.final_time = x.t;
    for (std::size_t k = 0; k < nc; ++k)
      if (x.contact_normal[k] > cr.max_normal_force) cr.max_normal_force = x.contact_normal[k], cr.time_of_max_normal_force = x.t;
    if (nc && x.step > 0) {
      for (std::size_t k = 0; k < nc; ++k)
        for (int d = 0; d < 3; ++d)
          c_sum[3 * k + d] += x.contact_normal[k] * c_normal[3 * k + d] + x.contact_friction[3 * k + d];
      ++c_count;
    }
    if (x.step % so.every != 0) return;
    if (nc) {
      // Row 0 (the initial state) has no force; row i the mean over the steps since row i - 1.
      for (std::size_t j = 0; j < 3 * nc; ++j) cr.mean_force.push_back(c_count ? c_sum[j] / c_count : 0.0);
      cr.mean_force_time.push_back(x.step == 0 ? 0.0 : 0.5 * (t_prev_out + x.t));
      std::fill(c_sum.begin(), c_sum.end(), 0.0);
      c_count = 0;
      t_prev_out = x.t;
      cr.normal.insert(cr.normal.end(), x.contact_normal, x.contact_normal + nc);
      cr.tangential.insert(cr.tangential.end(), x.contact_friction, x.contact_friction + 3 * nc);
      cr.gap.insert(cr.gap.end(), x.gap, x.gap + nc);
      cr.active.push_back(x.active);
      for (std::size_t k = 0; k < nc; ++k) {
        const double* u = x.q + cn[k].dof;
        cr.radial_displacement.push_back(e_r[3 * k] * u[0] + e_r[3 * k + 1] * u[1]);
      }
    }
    rec.time.push_back(x.t);
    rec.energy.push_back(x.energy());
    rec.q.insert(rec.q.end(), x.q, x.q + r);
    for (const auto& m : so.monitor) sm.displacements(m, x.q, &hist[m]);
  });
  const double sps = stats.seconds > 0 ? stats.steps / stats.seconds : 0.0;
  print0(PETSC_COMM_SELF, "  %s%s%ld steps in %.4f s (%.3g steps/s, with output)\n", c.name.c_str(),
         c.name.empty() ? "" : ": ", stats.steps, stats.seconds, sps);
  if (implicit)
    print0(PETSC_COMM_SELF, "  Newton: %ld iterations (%.2f per step)\n", stats.newton_iterations,
           stats.steps ? static_cast<double>(stats.newton_iterations) / stats.steps : 0.0);
  else if (stats.kernel != "linear")
    print0(PETSC_COMM_SELF, "  nonlinear force kernel: %s, %.3g flop and %.3g MB per step (%.2f GFLOP/s, %.2f GB/s)\n",
           stats.kernel.c_str(), stats.kernel_flops, stats.kernel_bytes * 1e-6, sps * stats.kernel_flops * 1e-9,
           sps * stats.kernel_bytes * 1e-9);
  io::H5Output out(PETSC_COMM_SELF, c.out);
  io::write_provenance(out, "simulate", sm.units);
  for (const auto& m : so.monitor) {
    std::vector<std::int64_t> ids;
    for (auto k : sm.sets.at(m)) ids.push_back(sm.node_ids[k]);
    rec.sets.push_back({m, std::move(ids), hist[m]});
  }
  if (!so.snapshots.empty()) {
    rec.snapshots_fom = so.snapshots;
    rec.snapshot_node_ids = plan.ids;
    rec.snapshot_components = plan.comps;
  }
  if (nc) {
    for (auto k : sm.sets.at(so.contact.set)) cr.node_ids.push_back(sm.node_ids[k]);
    print0(PETSC_COMM_SELF, "  contact: %zu nodes, max normal force %.4g N at t = %.6g s\n", nc, cr.max_normal_force,
           cr.time_of_max_normal_force);
  }
  rec.rom = so.rom;
  rec.case_name = c.name;
  rec.load.loads = c.loads;
  sim::write_sim(out, rec, so.s, stats);
  out.commit();
  print0(PETSC_COMM_SELF, "morse: wrote %s\n", c.out.c_str());
}

}  // namespace

void run_simulate(MPI_Comm comm) {
  SimOptions so;
  MORSE_CALL(get_sim_options(comm, &so));
  std::vector<Case> cases;
  std::string load_error;
  if (so.cases.empty()) {
    cases.push_back({"", so.out, {}});
    MORSE_CALL(get_loads(comm, &cases.back().loads, &load_error));
  } else {
    for (const auto& name : so.cases) {
      cases.push_back({name, case_path(so.out, name), {}});
      const std::string prefix = name + "_";
      MORSE_CALL(get_loads(comm, &cases.back().loads, &load_error, prefix.c_str()));
    }
  }
  if (help_requested()) return;
  check_options(comm, true);
  collective_check(comm, load_error);
  collective_check(comm, so.contact.error);
  MORSE_CHECK(!so.rom.empty(), "morse simulate: no reduced model given: use -rom FILE.h5 (a morse nlrom file)");
  MORSE_CHECK(so.every > 0, "-sim_output_every must be positive (got ", so.every, ")");
  std::vector<std::string> sets(so.monitor);
  for (const auto& c : cases)
    for (const auto& l : c.loads) sets.push_back(l.set);
  if (!so.contact.set.empty()) sets.push_back(so.contact.set);
  const auto sm = nlrom::read_stored_model(comm, so.rom, sets);
  const std::size_t r = sm.r();
  if (!so.contact.set.empty()) {
    auto& c = so.s.contact;
    c.nodes = sim::contact_nodes(sm, so.contact.set);  // throws on every rank alike (same model)
    c.obstacle = so.contact.obstacle, c.plane = so.contact.plane, c.casing = so.contact.casing, c.mu = so.contact.mu;
    MORSE_CHECK(so.s.scheme == sim::Scheme::Central,
                "morse simulate: contact (-contact_set) needs -sim_scheme central (forward-increment Lagrange "
                "multipliers are explicit)");
  }
  if (so.contact.revolutions > 0) {
    const double w = so.contact.casing.omega;
    MORSE_CHECK(w != 0.0, "-sim_revolutions needs a rotation speed: give -sim_omega (rad/s)");
    MORSE_CHECK(!so.tfinal_set, "give either -sim_tfinal or -sim_revolutions, not both");
    so.s.t_final = so.contact.revolutions * 2.0 * M_PI / std::abs(w);
  }
  if (!so.v0_uniform.empty()) {
    MORSE_CHECK(so.s.v0.empty(), "give either -sim_v0 or -sim_v0_uniform, not both");
    std::vector<double> u(sm.node_ids.size() * 3);
    for (std::size_t k = 0; k < u.size(); ++k) u[k] = so.v0_uniform[k % 3];
    double res = 0.0;
    so.s.v0 = sm.fit(u, &res);
    print0(comm, "morse simulate: uniform initial velocity (%g, %g, %g) m/s fitted on the basis, relative residual %.2e\n",
           u[0], u[1], u[2], res);
  }
  MORSE_CHECK(so.s.q0.empty() || so.s.q0.size() == r, "-sim_q0 has ", so.s.q0.size(), " values; the model has r = ", r);
  MORSE_CHECK(so.s.v0.empty() || so.s.v0.size() == r, "-sim_v0 has ", so.s.v0.size(), " values; the model has r = ", r);
  SnapshotPlan plan;
  if (!so.snapshots.empty()) {
    std::string err;
    try {
      std::vector<hsize_t> d;
      if (!io::read_doubles(so.snapshots, "/fom/snapshots/time", &plan.time, &d, &err) ||
          !io::read_ints(so.snapshots, "/fom/snapshots/dof_node_ids", &plan.ids, &d, &err) ||
          !io::read_ints(so.snapshots, "/fom/snapshots/dof_components", &plan.comps, &d, &err))
        err = cat("-sim_snapshots: ", err, " (a morse fom file run with -fom_snapshot_every K is expected)");
      else
        plan.rows = sm.dof_rows(plan.ids, plan.comps);
    } catch (const std::exception& e) {
      err = cat("-sim_snapshots ", so.snapshots, ": ", e.what());
    }
    collective_check(comm, err);
  }
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (cases.size() > 1)
    print0(comm, "morse simulate: %zu cases on %d rank(s), reduced model read once (r = %zu)\n", cases.size(), size, r);
  // A failed case (NaN, Newton) does not stop the others; the command fails at the end, naming
  // every failed case, and those cases leave no file.
  std::string err;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    if (static_cast<int>(i % size) != rank) continue;
    try {
      run_case(so, sm, plan, cases[i]);
    } catch (const std::exception& e) {
      err += (err.empty() ? "" : "; ") +
             (cases[i].name.empty() ? std::string(e.what()) : cat("case ", cases[i].name, ": ", e.what()));
    }
  }
  // Every rank's failures, joined in rank order, on every rank.
  int len = static_cast<int>(err.size());
  std::vector<int> lens(size), offs(size, 0);
  MPI_Allgather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, comm);
  for (int i = 1; i < size; ++i) offs[i] = offs[i - 1] + lens[i - 1];
  std::string all(static_cast<std::size_t>(offs[size - 1] + lens[size - 1]), ' ');
  MPI_Allgatherv(err.data(), len, MPI_CHAR, all.data(), lens.data(), offs.data(), MPI_CHAR, comm);
  std::string joined;
  for (int i = 0; i < size; ++i)
    if (lens[i] > 0) joined += (joined.empty() ? "" : "; ") + all.substr(offs[i], lens[i]);
  collective_check(comm, joined);
  check_options(comm, false);
}

}  // namespace morse::app::detail
