// app/cmd_nlrom.cpp: `morse nlrom`, the offline stage of seed 003: a reduction basis (CB, CB +
// modal derivatives, POD + constraint modes) and the reduced St Venant–Kirchhoff force (STEP or
// exact tensors, optionally POD-filtered), written to /nlrom with the reduced M, K, C and the
// basis as nodal fields (for reconstruction).
#include <petscsys.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/nlrom/nlrom.hpp"

namespace morse::app::detail {

namespace {

struct NlromOptions {
  nlrom::BasisSettings b;
  std::string basis = "cb", forces = "step", filter_file;
  PetscInt n_filter = 0;
  double step_displacement = 0.01;
  double damping_xi = 0.0;
  PetscInt damping_modes = 0;
  std::string error;
};

PetscErrorCode get_nlrom_options(MPI_Comm comm, NlromOptions* o) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscCall(cb::read_boundary_option(comm, &o->b.boundary_set));
  PetscOptionsBegin(comm, nullptr, "morse nlrom options", "");
  PetscCall(MorseOptionsString("-nlrom_basis", "cb | cbmd (CB + modal derivatives) | pod (POD + constraint modes)", "",
                               o->basis.c_str(), buf, sizeof buf, &set));
  if (set) o->basis = buf;
  PetscCall(MorseOptionsInt("-nlrom_num_fixed_modes", "Fixed-interface modes (cb, cbmd)", "", o->b.n_fixed,
                            &o->b.n_fixed, nullptr));
  PetscCall(MorseOptionsInt("-nlrom_num_derivatives", "Modal derivatives kept (cbmd), by descending W_ij (eq. 24)", "",
                            o->b.n_derivatives, &o->b.n_derivatives, nullptr));
  PetscCall(MorseOptionsInt("-nlrom_num_pod", "POD vectors (pod)", "", o->b.n_pod, &o->b.n_pod, nullptr));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-nlrom_snapshots", "morse fom file with snapshots (pod; POD filtering)", "", buf, buf,
                               sizeof buf, &set));
  if (set) o->b.snapshots = buf;
  PetscCall(MorseOptionsReal("-nlrom_training_tfinal", "Length of the linear training run of cbmd [s]", "",
                             o->b.training_tfinal, &o->b.training_tfinal, nullptr));
  PetscCall(MorseOptionsReal("-nlrom_training_dt", "Time step of the training run [s] (default: 1/200 of the "
                             "fastest load period)", "", o->b.training_dt, &o->b.training_dt, nullptr));
  PetscCall(MorseOptionsReal("-nlrom_mgs_tol", "Modified Gram-Schmidt: drop a vector whose M-norm falls below tol "
                             "times its norm before projection", "", o->b.mgs_tol, &o->b.mgs_tol, nullptr));
  {
    const char* sel[] = {"weight", "random", "DerivativeSelection", "", nullptr};
    PetscEnum e = o->b.random_derivatives ? static_cast<PetscEnum>(1) : static_cast<PetscEnum>(0);
    PetscCall(MorseOptionsEnum("-nlrom_derivative_selection",
                               "Order in which modal derivatives enter the basis: weight (descending W_ij, eq. 24) "
                               "or random (a seeded shuffle, the control of seed 003 Fig. 9)",
                               "", sel, e, &e, nullptr));
    o->b.random_derivatives = e == static_cast<PetscEnum>(1);
    PetscInt seed = static_cast<PetscInt>(o->b.derivative_seed);
    PetscCall(MorseOptionsInt("-nlrom_derivative_seed", "Seed of -nlrom_derivative_selection random", "", seed, &seed,
                              nullptr));
    o->b.derivative_seed = static_cast<unsigned>(seed);
  }
  PetscCall(MorseOptionsString("-nlrom_forces", "step (STEP, eq. 29-37) | exact (element-wise projection)", "",
                               o->forces.c_str(), buf, sizeof buf, &set));
  if (set) o->forces = buf;
  PetscCall(MorseOptionsReal("-step_displacement", "STEP: target displacement of the imposed fields [m]", "",
                             o->step_displacement, &o->step_displacement, nullptr));
  PetscCall(MorseOptionsInt("-nlrom_filter_pod", "POD filtering of g_nl (eq. 38-39): number of filter vectors from the "
                            "snapshots' nonlinear forces (0: none)", "", o->n_filter, &o->n_filter, nullptr));
  PetscCall(MorseOptionsReal("-nlrom_damping_modal", "Modal damping ratio on the first -nlrom_damping_modes modes of "
                             "the reduced model", "", o->damping_xi, &o->damping_xi, nullptr));
  PetscCall(MorseOptionsInt("-nlrom_damping_modes", "Reduced modes carrying -nlrom_damping_modal", "",
                            o->damping_modes, &o->damping_modes, nullptr));
  PetscOptionsEnd();
  if (o->basis == "cb")
    o->b.kind = nlrom::BasisKind::CB;
  else if (o->basis == "cbmd")
    o->b.kind = nlrom::BasisKind::CBMD;
  else if (o->basis == "pod")
    o->b.kind = nlrom::BasisKind::POD;
  else
    o->error = cat("-nlrom_basis ", o->basis, ": unknown (cb, cbmd or pod)");
  if (o->error.empty() && o->forces != "step" && o->forces != "exact")
    o->error = cat("-nlrom_forces ", o->forces, ": unknown (step or exact)");
  return PETSC_SUCCESS;
}

// Nonlinear forces of the snapshots, POD-compressed (eq. 38): the filter basis Phi_f.
UMat force_filter(const Model& md, const fe::Svk& svk, const std::string& file, PetscInt n) {
  StageTimer t(md.mesh->comm, "PodFilter");
  auto X = dyn::read_fom_snapshots(*md.mesh, md.dofs, file);
  PetscInt ns = 0;
  MORSE_CALL(MatGetSize(X.get(), nullptr, &ns));
  MORSE_CHECK(n <= ns, "-nlrom_filter_pod ", n, " exceeds the ", ns, " snapshots of ", file);
  UMat G;
  MORSE_CALL(MatDuplicate(X.get(), MAT_DO_NOT_COPY_VALUES, G.ptr()));
  svk.nonlinear_force_block(X.get(), G.get());
  std::vector<double> sigma;
  return nlrom::pod(G.get(), n, &sigma);
}

}  // namespace

void run_nlrom(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "nlrom.h5", &o));
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(get_loads(comm, &load_list, &load_error));
  NlromOptions no;
  MORSE_CALL(get_nlrom_options(comm, &no));
  if (help_requested()) return;
  options::add_prefix(no.b.prefix, options::Solver::Eigen);
  check_options(comm, true);
  collective_check(comm, load_error);
  MORSE_CHECK(no.error.empty(), no.error);
  MORSE_CHECK(!no.b.boundary_set.empty(), "morse nlrom: no boundary set given: use -boundary SET");
  MORSE_CHECK(no.damping_xi >= 0 && no.damping_xi < 1 && no.damping_modes >= 0,
              "-nlrom_damping_modal must be in [0, 1) and -nlrom_damping_modes >= 0");
  MORSE_CHECK(no.n_filter >= 0, "-nlrom_filter_pod must be >= 0");
  MORSE_CHECK(!(no.n_filter > 0 && no.b.snapshots.empty()), "-nlrom_filter_pod needs -nlrom_snapshots FILE.h5");
  Model md = build_model(
      comm, o, "morse nlrom needs a mesh: its nonlinear (SVK) forces are computed element by element");
  io::H5Output out(comm, o.out);  // early: a bad -out fails before the work
  std::unique_ptr<dyn::Loads> training;
  if (!load_list.empty()) {
    training = std::make_unique<dyn::Loads>(*md.mesh, md.dofs, load_list);
    no.b.training = training.get();
    if (no.b.training_dt <= 0) {
      const double w = training->max_omega();
      no.b.training_dt = w > 0 ? 2 * M_PI / w / 200 : no.b.training_tfinal / 1000;
    }
  }
  fe::Svk svk(*md.mesh, md.dofs, o.mesh.material, md.K.get());
  auto basis = nlrom::build_basis(md, svk, no.b);
  const PetscInt r = basis.r();
  print0(comm, "morse nlrom: %s basis of %d vectors (%d boundary DOFs + %d fixed-interface modes + %d %s) in %.2f s\n",
         no.basis.c_str(), (int)r, (int)basis.n_b, (int)basis.n_fixed, (int)basis.n_extra,
         no.b.kind == nlrom::BasisKind::POD ? "POD vectors" : "modal derivatives", basis.seconds);

  auto t2a = std::chrono::steady_clock::now();
  UMat filter;
  if (no.n_filter > 0) filter = force_filter(md, svk, no.b.snapshots, no.n_filter);
  nlrom::CubicForce g;
  if (no.forces == "exact") {
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
  auto rm = nlrom::project_model(comm, basis.V.get(), md.K.get(), md.M.get(), no.damping_xi, no.damping_modes);
  const double t3 = std::chrono::duration<double>(std::chrono::steady_clock::now() - t3a).count();
  check_options(comm, false);
  print0(comm, "morse nlrom: offline times t1 (basis) %.2f s, t2 (forces) %.2f s, t3 (projection) %.2f s\n",
         basis.seconds, t2, t3);

  StageTimer t(comm, "Write");
  io::write_provenance(out, "nlrom", md.units);
  nlrom::StoredInfo info;
  info.basis = no.basis;
  info.forces = no.forces;
  info.boundary_set = no.b.boundary_set;
  info.derivative_selection = no.b.random_derivatives ? "random" : "weight";
  info.step_displacement = no.step_displacement;
  info.filter_pod = no.n_filter;
  info.modal_damping_ratio = no.damping_xi;
  info.t2_forces_seconds = t2;
  info.t3_projection_seconds = t3;
  rm.g = std::move(g);
  nlrom::write_stored_model(out, *md.mesh, md.dofs, basis, rm, info);
  out.commit();
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
