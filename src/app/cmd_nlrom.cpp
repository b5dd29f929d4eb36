// app/cmd_nlrom.cpp: `morse nlrom`, the offline stage of seed 003: a reduction basis (CB, CB +
// modal derivatives, POD + constraint modes) and the reduced St Venant–Kirchhoff force (STEP or
// exact tensors, optionally POD-filtered), written to /nlrom with the reduced M, K, C and the
// basis as nodal fields (for reconstruction).
#include <petscsys.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/fe/constraints.hpp"
#include "morse/io/h5.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

void run_nlrom(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "nlrom.h5", &o));
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(dyn::get_loads(comm, &load_list, &load_error));
  nlrom::OfflineSettings no;
  MORSE_CALL(cb::read_boundary_option(comm, &no.basis.boundary_set));
  MORSE_CALL(no.set_from_options(comm));
  if (help_requested()) return;
  options::add_prefix(no.basis.prefix, options::Solver::Eigen);
  check_options(comm, true);
  collective_check(comm, load_error);
  MORSE_CHECK(no.error.empty(), no.error);
  auto inputs = o.inputs();
  inputs.push_back({"-nlrom_snapshots", no.basis.snapshots});
  const auto output_lock = files::prepare_outputs(comm, {{"-out", o.out}}, inputs);
  Model md = build_model(comm, o,
                         "morse nlrom needs a mesh: its nonlinear (SVK) forces are computed element by element", true);
  io::H5Output out(comm, o.out);  // early: a bad -out fails before the work
  std::unique_ptr<dyn::Loads> training;
  if (!load_list.empty()) {
    training = std::make_unique<dyn::Loads>(md, load_list);  // through the constraints' T^T, if any
    no.basis.training = training.get();
    if (no.basis.training_dt <= 0) {
      const double w = training->max_omega();
      no.basis.training_dt = w > 0 ? 2 * M_PI / w / 200 : no.basis.training_tfinal / 1000;
    }
  }
  // The reduced force of r coordinates is O(r^4) on every rank: refused before the basis if it
  // cannot fit.
  if (no.forces != "none")
    nlrom::check_force_memory(comm, static_cast<std::size_t>(nlrom::basis_size(md, no.basis)), no.forces != "exact");
  fe::Svk svk(md, o.mesh.material);  // through the constraints' T, if any
  auto basis = nlrom::build_basis(md, svk, no.basis);
  const PetscInt r = basis.r();
  print0(comm, "morse nlrom: %s basis of %d vectors (%d boundary DOFs + %d fixed-interface modes + %d %s) in %.2f s\n",
         no.basis_name.c_str(), (int)r, (int)basis.n_b, (int)basis.n_fixed, (int)basis.n_extra,
         no.basis.kind == nlrom::BasisKind::POD ? "POD vectors" : "modal derivatives", basis.seconds);
  PetscInt n_static = 0;
  if (no.massless) {  // MacNeal on the reduced model: the same subspace, the residual modes' mass dropped
    const auto rm0 = nlrom::project_model(comm, basis.V.get(), md.K.get(), md.M.get(), 0.0, 0);
    basis.V = nlrom::transform_basis(
        basis.V.get(), nlrom::massless_transform(rm0.M, rm0.K, r, basis.n_b, no.massless_fmax, &n_static));
    nlrom::relabel_massless(&basis, n_static, no.massless_scaled);
    if (no.massless_scaled)
      print0(comm,
             "morse nlrom: massless boundary (MacNeal): %d dynamic modes, %d boundary coordinates quasi-static, %d "
             "residual combinations dynamic with their mass scaled to %g Hz at most\n",
             (int)(r - n_static), (int)basis.n_b, (int)(n_static - basis.n_b), no.massless_fmax);
    else
      print0(comm,
             "morse nlrom: massless boundary (MacNeal): %d dynamic modes, %d boundary coordinates and %d more "
             "residual combinations quasi-static\n",
             (int)(r - n_static), (int)basis.n_b, (int)(n_static - basis.n_b));
  }

  auto t2a = std::chrono::steady_clock::now();
  UMat filter;
  if (no.n_filter > 0) filter = nlrom::force_filter(md, svk, no.basis.snapshots, no.n_filter);
  nlrom::CubicForce g;
  if (no.forces == "none") {
    print0(comm, "morse nlrom: no nonlinear force (-nlrom_forces none): a linear reduced model\n");
  } else if (no.forces == "exact") {
    StageTimer t(comm, "ExactTensors");
    MORSE_CHECK(no.n_filter == 0, "-nlrom_filter_pod applies to STEP (-nlrom_forces step)");
    g = nlrom::exact_forces(svk, basis.V.get());
  } else {
    nlrom::StepSettings ss;
    ss.displacement = no.step_displacement;
    ss.filter = filter.get();
    print0(comm, "morse nlrom: STEP, %zu evaluations of g_nl (eq. 37)\n", nlrom::step_evaluations(r));
    g = nlrom::step_forces(svk, basis.V.get(), ss);
  }
  const double t2 = std::chrono::duration<double>(std::chrono::steady_clock::now() - t2a).count();
  auto t3a = std::chrono::steady_clock::now();
  // Modal damping after the mass scaling (each mode damped at its new frequency); a massless model
  // gets its own in make_massless.
  const bool damp_later = no.massless || no.mass_scaling_fmax > 0;
  auto rm = nlrom::project_model(comm, basis.V.get(), md.K.get(), md.M.get(), damp_later ? 0.0 : no.damping_xi,
                                 no.damping_modes);
  rm.n_b = basis.n_b;
  std::size_t mass_scaled = 0;
  if (no.mass_scaling_fmax > 0) {
    const double dt0 = sim::critical_step(rm);
    mass_scaled = nlrom::scale_modal_mass(&rm, no.mass_scaling_fmax);
    nlrom::modal_damping(&rm, no.damping_xi, no.damping_modes);
    print0(comm,
           "morse nlrom: mass scaling: %zu modes above %g Hz moved to it; critical step of central differences %.4g s "
           "(without scaling %.4g s)\n",
           mass_scaled, no.mass_scaling_fmax, sim::critical_step(rm), dt0);
  }
  if (no.rayleigh_given) nlrom::rayleigh_damping(&rm, no.rayleigh_alpha, no.rayleigh_beta);
  if (no.massless) {
    nlrom::make_massless(&rm, n_static, no.damping_xi, no.damping_modes, no.massless_scaled ? no.massless_fmax : 0.0);
    double free_dt = 0;
    const double held_dt = nlrom::massless_critical_step(rm, &free_dt);
    print0(comm, "morse nlrom: critical step of central differences %.4g s (static coordinates held; free: %.4g s)\n",
           held_dt, free_dt);
  }
  const double t3 = std::chrono::duration<double>(std::chrono::steady_clock::now() - t3a).count();
  check_options(comm, false);
  print0(comm, "morse nlrom: offline times t1 (basis) %.2f s, t2 (forces) %.2f s, t3 (projection) %.2f s\n",
         basis.seconds, t2, t3);

  StageTimer t(comm, "Write");
  io::write_provenance(out, "nlrom", md.units);
  nlrom::StoredInfo info;
  info.basis = no.basis_name;
  info.forces = no.forces;
  info.boundary_set = no.basis.boundary_set;
  info.derivative_selection = no.basis.random_derivatives ? "random" : "weight";
  info.step_displacement = no.step_displacement;
  info.filter_pod = no.n_filter;
  info.damping = no.damping();
  info.modal_damping_ratio = no.damping_xi;
  info.rayleigh_alpha = no.rayleigh_alpha;
  if (no.massless) info.massless_interior = no.massless_scaled ? "scaled" : "static";
  info.massless_fmax = no.massless_fmax;
  info.mass_scaling_fmax = no.mass_scaling_fmax;
  info.mass_scaled_modes = mass_scaled;
  info.rayleigh_beta = no.rayleigh_beta;
  info.t2_forces_seconds = t2;
  info.t3_projection_seconds = t3;
  rm.g = std::move(g);
  nlrom::write_stored_model(out, *md.mesh, fe::node_layout(md), basis, rm, info,
                            md.constraints ? md.constraints->T.get() : nullptr);
  out.commit();
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
