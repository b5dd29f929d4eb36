// app/cmd_fom.cpp: `morse fom`, the full-order nonlinear implicit dynamics under the nodal loads
// (harmonic -load_* and tabulated -load_history; dyn::integrate), the reference of every reduced model. Writes /fom: time, monitored set
// histories, energies, Newton statistics and full-field snapshots (written in parallel).
#include <petscsys.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/io/h5.hpp"

namespace morse::app::detail {

namespace {

struct FomOptions {
  dyn::FomSettings s;
  std::vector<std::string> monitor;
  PetscInt snapshot_every = 0;
  PetscBool linear = PETSC_FALSE;
  std::string initial;
  std::string initial_dataset = "/static/u";
  std::string scheme = "trapezoidal";
  std::string newton = "krylov";
  bool rayleigh_set = false;
  std::string error;
};

PetscErrorCode get_fom_options(MPI_Comm comm, FomOptions* o) {
  PetscCall(options::get_string_list(comm, "-fom_monitor", "Node sets whose displacement histories are written", &o->monitor));
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscReal ray[2] = {0, 0};
  PetscInt n_ray = 2;
  PetscOptionsBegin(comm, nullptr, "morse fom options", "");
  PetscCall(MorseOptionsReal("-fom_dt", "Time step [s] (fixed)", "", o->s.dt, &o->s.dt, nullptr));
  PetscCall(MorseOptionsReal("-fom_tfinal", "Final time [s]", "", o->s.t_final, &o->s.t_final, nullptr));
  PetscCall(MorseOptionsBool("-fom_linear", "Linear twin (g_nl = 0), same everything else", "", o->linear, &o->linear,
                             nullptr));
  PetscCall(MorseOptionsString("-fom_scheme",
                               "energy: energy-conserving midpoint (Simo-Tarnow), trapezoidal: Newmark average "
                               "acceleration; identical for a linear model",
                               "", o->scheme.c_str(), buf, sizeof buf, &set));
  if (set) o->scheme = buf;
  PetscCall(MorseOptionsInt("-fom_snapshot_every", "Write full-field snapshots of u and v every K steps (0: none)", "",
                            o->snapshot_every, &o->snapshot_every, nullptr));
  PetscCall(MorseOptionsReal("-fom_damping_modal", "Modal damping ratio xi on the first -fom_damping_modes modes", "",
                             o->s.modal_xi, &o->s.modal_xi, nullptr));
  PetscCall(MorseOptionsInt("-fom_damping_modes", "Number of modes carrying -fom_damping_modal", "",
                            o->s.damping_modes, &o->s.damping_modes, nullptr));
  PetscCall(MorseOptionsRealArray("-fom_rayleigh", "Rayleigh damping alpha,beta: C = alpha M + beta K", "", ray,
                                  &n_ray, &set));
  if (set) {
    o->rayleigh_set = true;
    if (n_ray != 2) o->error = "-fom_rayleigh takes two values: alpha,beta";
    o->s.rayleigh_alpha = ray[0];
    o->s.rayleigh_beta = ray[1];
  }
  PetscCall(MorseOptionsReal("-fom_newton_rtol", "Newton tolerance: ||R|| <= rtol * force scale + atol", "",
                             o->s.newton_rtol, &o->s.newton_rtol, nullptr));
  PetscCall(MorseOptionsReal("-fom_newton_atol", "Newton absolute tolerance [N]", "", o->s.newton_atol,
                             &o->s.newton_atol, nullptr));
  PetscCall(MorseOptionsInt("-fom_newton_max_it", "Newton iterations per step", "", o->s.newton_max_it,
                            &o->s.newton_max_it, nullptr));
  PetscCall(MorseOptionsInt("-fom_refactor_every",
                            "Refactor the iteration matrix every N iterations (1: full Newton); 0: modified Newton, "
                            "refactor only when the residual falls by less than -fom_refactor_ratio",
                            "", o->s.refactor_every, &o->s.refactor_every, nullptr));
  PetscCall(MorseOptionsReal("-fom_refactor_ratio", "Modified Newton: refactor when ||R_k+1|| > ratio ||R_k||", "",
                             o->s.refactor_ratio, &o->s.refactor_ratio, nullptr));
  PetscCall(MorseOptionsString("-fom_newton",
                               "krylov: exact Newton by CG on the matrix-free tangent, preconditioned by a reused "
                               "MUMPS factor (trapezoidal scheme); modified: the reused factor is the Newton matrix",
                               "", o->newton.c_str(), buf, sizeof buf, &set));
  if (set) o->newton = buf;
  PetscCall(MorseOptionsReal("-fom_krylov_rtol", "Newton-Krylov: smallest relative tolerance of a CG solve", "",
                             o->s.krylov_rtol, &o->s.krylov_rtol, nullptr));
  PetscCall(MorseOptionsInt("-fom_krylov_max_it", "Newton-Krylov: CG iterations before refactoring and retrying", "",
                            o->s.krylov_max_it, &o->s.krylov_max_it, nullptr));
  PetscCall(MorseOptionsInt("-fom_krylov_refactor_its",
                            "Newton-Krylov: refresh the factor when a CG solve needs more iterations than this", "",
                            o->s.krylov_refactor_its, &o->s.krylov_refactor_its, nullptr));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-fom_initial", "Initial displacement from a morse file (e.g. a morse static run)", "",
                               buf, buf, sizeof buf, &set));
  if (set) o->initial = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-fom_initial_dataset", "Nodal dataset read by -fom_initial", "",
                               o->initial_dataset.c_str(), buf, sizeof buf, &set));
  if (set) o->initial_dataset = buf;
  PetscOptionsEnd();
  o->s.linear = o->linear;
  if (o->scheme == "energy")
    o->s.scheme = dyn::Scheme::Energy;
  else if (o->scheme == "trapezoidal")
    o->s.scheme = dyn::Scheme::Trapezoidal;
  else if (o->error.empty())
    o->error = cat("-fom_scheme ", o->scheme, ": unknown (energy or trapezoidal)");
  if (o->newton == "krylov")
    o->s.newton = dyn::Newton::Krylov;
  else if (o->newton == "modified")
    o->s.newton = dyn::Newton::Modified;
  else if (o->error.empty())
    o->error = cat("-fom_newton ", o->newton, ": unknown (krylov or modified)");
  return PETSC_SUCCESS;
}

void check(const FomOptions& o) {
  const auto& s = o.s;
  MORSE_CHECK(o.error.empty(), o.error);
  MORSE_CHECK(s.dt > 0, "-fom_dt must be positive (got ", s.dt, ")");
  MORSE_CHECK(s.t_final > 0, "-fom_tfinal must be positive (got ", s.t_final, ")");
  MORSE_CHECK(s.t_final >= s.dt, "-fom_tfinal (", s.t_final, ") is shorter than one step -fom_dt (", s.dt, ")");
  MORSE_CHECK(o.snapshot_every >= 0, "-fom_snapshot_every must be >= 0 (got ", o.snapshot_every, ")");
  MORSE_CHECK(s.modal_xi >= 0 && s.modal_xi < 1, "-fom_damping_modal must be in [0, 1) (got ", s.modal_xi, ")");
  MORSE_CHECK(s.damping_modes >= 0, "-fom_damping_modes must be >= 0 (got ", s.damping_modes, ")");
  MORSE_CHECK(!(s.modal_xi > 0) || s.damping_modes > 0, "-fom_damping_modal needs -fom_damping_modes K > 0");
  MORSE_CHECK(s.rayleigh_alpha >= 0 && s.rayleigh_beta >= 0, "-fom_rayleigh: alpha and beta must be >= 0");
  MORSE_CHECK(s.newton_rtol > 0 && s.newton_atol >= 0 && s.newton_max_it > 0,
              "-fom_newton_rtol, -fom_newton_max_it must be positive and -fom_newton_atol >= 0");
  MORSE_CHECK(s.refactor_every >= 0, "-fom_refactor_every must be >= 0");
  MORSE_CHECK(s.refactor_ratio > 0 && s.refactor_ratio < 1, "-fom_refactor_ratio must be in (0, 1)");
  MORSE_CHECK(s.krylov_rtol > 0 && s.krylov_rtol < 1, "-fom_krylov_rtol must be in (0, 1) (got ", s.krylov_rtol, ")");
  MORSE_CHECK(s.krylov_max_it > 0 && s.krylov_refactor_its > 0,
              "-fom_krylov_max_it and -fom_krylov_refactor_its must be positive");
}

}  // namespace

void run_fom(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "fom.h5", &o));
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(get_loads(comm, &load_list, &load_error));
  LoadHistoryOptions ho;
  MORSE_CALL(get_load_history(comm, &ho));
  FomOptions fo;
  MORSE_CALL(get_fom_options(comm, &fo));
  if (help_requested()) return;
  dyn::add_option_prefixes(fo.s);
  check_options(comm, true);
  collective_check(comm, load_error);
  collective_check(comm, ho.error);
  check(fo);

  Model md = build_model(
      comm, o, "morse fom needs a mesh: its nonlinear (SVK) forces are computed element by element");
  dyn::Loads loads(*md.mesh, md.dofs, load_list);
  const PetscInt n_steps = static_cast<PetscInt>(std::ceil(fo.s.t_final / fo.s.dt - 1e-9));
  if (auto h = make_load_history(comm, *md.mesh, md.dofs, ho)) {
    h->check_covers(0.0, n_steps * fo.s.dt);
    loads.set_history(std::move(h));
  }
  std::vector<dyn::SetProbe> probes;
  for (const auto& m : fo.monitor) probes.emplace_back(*md.mesh, md.dofs, m);
  fe::Svk svk(*md.mesh, md.dofs, o.mesh.material, md.K.get());
  UVec u0;
  if (!fo.initial.empty()) {
    MORSE_CALL(MatCreateVecs(md.K.get(), u0.ptr(), nullptr));
    MORSE_CALL(VecSet(u0.get(), 0.0));
    io::read_nodal_field(*md.mesh, md.dofs, fo.initial, fo.initial_dataset, u0.get());
  }
  if (std::abs(n_steps * fo.s.dt - fo.s.t_final) > 1e-9 * fo.s.t_final)
    print0(comm, "morse fom: -fom_tfinal is not a multiple of -fom_dt: the run ends at t = %g (%lld steps)\n",
           n_steps * fo.s.dt, (long long)n_steps);
  print0(comm, "morse fom: %s, %s scheme, dt = %g s, %lld steps to t = %g s\n", fo.linear ? "linear twin" : "nonlinear",
         fo.scheme.c_str(), fo.s.dt, (long long)n_steps, n_steps * fo.s.dt);

  io::H5Output out(comm, o.out);  // early: a bad -out fails before the run; removed if the run fails
  std::unique_ptr<dyn::FomSnapshotWriter> snaps;
  if (fo.snapshot_every > 0)
    snaps = std::make_unique<dyn::FomSnapshotWriter>(out, *md.mesh, md.dofs, n_steps / fo.snapshot_every + 1);

  dyn::FomHistory hist;
  for (const auto& p : probes) hist.sets.push_back({p.name(), p.node_ids(), {}});
  auto stats = dyn::integrate(svk, md.M.get(), loads, fo.s, u0.get(), nullptr, [&](const dyn::StepInfo& i) {
    hist.record(i);
    for (std::size_t p = 0; p < probes.size(); ++p) {
      auto u = probes[p].sample(i.u);
      hist.sets[p].u.insert(hist.sets[p].u.end(), u.begin(), u.end());
    }
    if (snaps && i.step % fo.snapshot_every == 0) snaps->write(i);
  });
  check_options(comm, false);
  std::vector<double> snap_times;
  if (snaps) {
    snaps->close();
    snap_times = snaps->times();
    snaps.reset();
  }

  const double per_step = stats.seconds_total / std::max<PetscInt>(1, stats.steps);
  print0(comm, "\n  steps %lld, Newton iterations %lld (%.2f per step), factorizations %lld, CG iterations %lld\n",
         (long long)stats.steps, (long long)stats.newton_iterations,
         double(stats.newton_iterations) / std::max<PetscInt>(1, stats.steps), (long long)stats.factorizations,
         (long long)stats.krylov_iterations);
  print0(comm, "  time per step %.4f s: forces %.1f s, tangent %.1f s, factor %.1f s, solves %.1f s (total %.1f s)\n",
         per_step, stats.seconds_force, stats.seconds_tangent, stats.seconds_factor, stats.seconds_solve,
         stats.seconds_total);
  for (std::size_t p = 0; p < probes.size(); ++p) {
    double peak = 0;
    for (double v : hist.sets[p].u) peak = std::max(peak, std::abs(v));
    print0(comm, "  set %s: max |u| component %.6e m\n", probes[p].name().c_str(), peak);
  }

  StageTimer t(comm, "Write");
  io::write_provenance(out, "fom", md.units);
  auto gm = mesh::gather_to_rank0(*md.mesh);
  io::write_mesh(out, gm);
  dyn::LoadDescription ld;
  ld.loads = load_list;
  if (const auto* h = loads.history()) {
    ld.history = h->source();
    ld.history_scale = ho.scale;
    ld.history_outside = ho.outside;
  }
  dyn::write_fom(out, hist, snap_times, fo.snapshot_every, fo.s, stats, ld);
  out.commit();
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
