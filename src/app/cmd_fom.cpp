// app/cmd_fom.cpp: `morse fom`, the full-order nonlinear implicit dynamics under the nodal loads
// (harmonic -load_* and tabulated -load_history; dyn::integrate), the reference of every reduced model. Writes /fom:
// time, monitored set histories, energies, Newton statistics and full-field snapshots (written in parallel).
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/constraints.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/io/h5.hpp"

namespace morse::app::detail {

void run_fom(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "fom.h5", &o));
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(dyn::get_loads(comm, &load_list, &load_error));
  dyn::LoadHistoryOptions ho;
  MORSE_CALL(ho.set_from_options(comm));
  dyn::FomSettings fs;
  MORSE_CALL(fs.set_from_options(comm));
  if (help_requested()) return;
  dyn::add_option_prefixes(fs);
  check_options(comm, true);
  collective_check(comm, load_error);
  collective_check(comm, ho.error);
  MORSE_CHECK(fs.error.empty(), fs.error);
  auto inputs = o.inputs();
  inputs.push_back({"-load_history", ho.file()});
  inputs.push_back({"-fom_initial", fs.initial});
  const auto output_lock = files::prepare_outputs(comm, {{"-out", o.out}}, inputs);

  Model md =
      build_model(comm, o, "morse fom needs a mesh: its nonlinear (SVK) forces are computed element by element", true);
  // With rigid or interpolation elements or MPCs the run is on the model's DOFs (loads T^T f, a
  // load history included; forces through T, M_bar), the output on the nodes' (u = T u_bar), and
  // an initial displacement is restricted to the model's DOFs (fe::restrict_vector).
  const auto& nodes = fe::node_layout(md);
  dyn::Loads loads(md, load_list);
  const PetscInt n_steps = static_cast<PetscInt>(std::ceil(fs.t_final / fs.dt - 1e-9));
  if (auto h = dyn::make_load_history(comm, *md.mesh, nodes, ho)) {
    h->check_covers(0.0, n_steps * fs.dt);
    loads.set_history(std::move(h));
  }
  std::vector<dyn::SetProbe> probes;
  for (const auto& m : fs.monitor) probes.emplace_back(*md.mesh, nodes, m);
  fe::Svk svk(md, o.mesh.material);
  UVec u0;
  if (!fs.initial.empty()) {
    UVec x;
    if (md.constraints)
      MORSE_CALL(MatCreateVecs(md.constraints->T.get(), nullptr, x.ptr()));
    else
      MORSE_CALL(MatCreateVecs(md.K.get(), x.ptr(), nullptr));
    MORSE_CALL(VecSet(x.get(), 0.0));
    io::read_nodal_field(*md.mesh, nodes, fs.initial, fs.initial_dataset, x.get());
    u0 = md.constraints ? fe::restrict_vector(md, x.get()) : std::move(x);
  }
  if (std::abs(n_steps * fs.dt - fs.t_final) > 1e-9 * fs.t_final)
    print0(comm, "morse fom: -fom_tfinal is not a multiple of -fom_dt: the run ends at t = %g (%lld steps)\n",
           n_steps * fs.dt, (long long)n_steps);
  print0(comm, "morse fom: %s, %s scheme, dt = %g s, %lld steps to t = %g s\n", fs.linear ? "linear twin" : "nonlinear",
         fs.scheme == dyn::Scheme::Energy ? "energy" : "trapezoidal", fs.dt, (long long)n_steps, n_steps * fs.dt);

  io::H5Output out(comm, o.out);  // early: a bad -out fails before the run; removed if the run fails
  std::unique_ptr<dyn::FomSnapshotWriter> snaps;
  if (fs.snapshot_every > 0)
    snaps = std::make_unique<dyn::FomSnapshotWriter>(out, *md.mesh, nodes, n_steps / fs.snapshot_every + 1);

  dyn::FomHistory hist;
  for (const auto& p : probes) hist.sets.push_back({p.name(), p.node_ids(), {}});
  UVec uf, vf;  // constraints: the state on the nodes
  if (md.constraints) {
    MORSE_CALL(MatCreateVecs(md.constraints->T.get(), nullptr, uf.ptr()));
    MORSE_CALL(VecDuplicate(uf.get(), vf.ptr()));
  }
  auto stats = dyn::integrate(svk, md.M.get(), loads, fs, u0.get(), nullptr, [&](const dyn::StepInfo& step) {
    dyn::StepInfo i = step;
    if (md.constraints) {
      MORSE_CALL(MatMult(md.constraints->T.get(), step.u, uf.get()));
      MORSE_CALL(MatMult(md.constraints->T.get(), step.v, vf.get()));
      i.u = uf.get(), i.v = vf.get();
    }
    hist.record(i);
    for (std::size_t p = 0; p < probes.size(); ++p) {
      auto u = probes[p].sample(i.u);
      hist.sets[p].u.insert(hist.sets[p].u.end(), u.begin(), u.end());
    }
    if (snaps && i.step % fs.snapshot_every == 0) snaps->write(i);
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
  // The energy diagnostics of docs/nlrom.md ("On the 60k-DOF blade"): the drift of the balance
  // (an exact scheme keeps it constant; the trapezoidal rule can gain energy from a stiff
  // nonlinear force), and how far eq. 46's linear strain energy exceeds the true one.
  if (!hist.balance.empty()) {
    double drift = 0.0, total = 0.0, linear = 0.0, strain = 0.0;
    for (std::size_t k = 0; k < hist.balance.size(); ++k) {
      drift = std::max(drift, std::abs(hist.balance[k] - hist.balance[0]));
      total = std::max(total, hist.kinetic[k] + hist.strain_linear[k] + hist.strain_nonlinear[k]);
      linear = std::max(linear, hist.strain_linear[k]);
      strain = std::max(strain, hist.strain_linear[k] + hist.strain_nonlinear[k]);
    }
    print0(comm,
           "  energy: balance drift %.3g J (largest total energy %.4g J); largest strain energy %.4g J, of which "
           "linear (seed 003 eq. 46) %.4g J\n",
           drift, total, strain, linear);
    if (total > 0 && drift > 0.01 * total)
      print0(comm,
             "  warning: the energy balance drifts by %.1f %% of the largest total energy: the scheme gains or loses "
             "energy; try -fom_scheme energy or a smaller -fom_dt\n",
             100.0 * drift / total);
    if (!fs.linear && strain > 0 && linear > 10.0 * strain)
      print0(comm,
             "  note: the linear strain energy of eq. 46 reaches %.0f times the true strain energy: a local large "
             "deformation (under a point load?) dominates it, and seed 003's energy criterion e2 measures that\n",
             linear / strain);
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
  dyn::write_fom(out, hist, snap_times, fs.snapshot_every, fs, stats, ld);
  out.commit();
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
