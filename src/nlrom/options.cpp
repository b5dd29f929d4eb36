// The options of the offline stage (see morse/nlrom/nlrom.hpp: OfflineSettings) and the POD
// filter of the reduced force.
#include "morse/core/options.hpp"

#include <petscsys.h>

#include <cmath>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/nlrom/nlrom.hpp"

namespace morse::nlrom {

PetscErrorCode OfflineSettings::set_from_options(MPI_Comm comm) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE, tfinal_set = PETSC_FALSE, dt_set = PETSC_FALSE;
  auto& b = basis;
  PetscOptionsBegin(comm, nullptr, "morse nlrom options", "");
  PetscCall(MorseOptionsString("-nlrom_basis", "cb | cbmd (CB + modal derivatives) | pod (POD + constraint modes)", "",
                               basis_name.c_str(), buf, sizeof buf, &set));
  if (set) basis_name = buf;
  PetscCall(MorseOptionsInt("-nlrom_num_fixed_modes", "Fixed-interface modes (cb, cbmd)", "", b.n_fixed, &b.n_fixed,
                            nullptr));
  PetscCall(MorseOptionsInt("-nlrom_num_derivatives", "Modal derivatives kept (cbmd), by descending W_ij (eq. 24)", "",
                            b.n_derivatives, &b.n_derivatives, nullptr));
  PetscCall(MorseOptionsInt("-nlrom_num_pod", "POD vectors (pod)", "", b.n_pod, &b.n_pod, nullptr));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-nlrom_snapshots", "morse fom file with snapshots (pod; POD filtering)", "", buf, buf,
                               sizeof buf, &set));
  if (set) b.snapshots = buf;
  PetscCall(MorseOptionsReal("-nlrom_training_tfinal", "Length of the linear training run of cbmd [s]", "",
                             b.training_tfinal, &b.training_tfinal, &tfinal_set));
  PetscCall(MorseOptionsReal("-nlrom_training_dt",
                             "Time step of the training run [s] (default: 1/200 of the "
                             "fastest load period)",
                             "", b.training_dt, &b.training_dt, &dt_set));
  PetscCall(MorseOptionsReal("-nlrom_mgs_tol",
                             "Modified Gram-Schmidt: drop a vector whose M-norm falls below tol "
                             "times its norm before projection",
                             "", b.mgs_tol, &b.mgs_tol, nullptr));
  const char* sel[] = {"weight", "random", "DerivativeSelection", "", nullptr};
  PetscEnum e = b.random_derivatives ? static_cast<PetscEnum>(1) : static_cast<PetscEnum>(0);
  PetscCall(MorseOptionsEnum("-nlrom_derivative_selection",
                             "Order in which modal derivatives enter the basis: weight (descending W_ij, eq. 24) "
                             "or random (a seeded shuffle, the control of seed 003 Fig. 9)",
                             "", sel, e, &e, nullptr));
  b.random_derivatives = e == static_cast<PetscEnum>(1);
  PetscInt seed = static_cast<PetscInt>(b.derivative_seed);
  PetscCall(MorseOptionsInt("-nlrom_derivative_seed", "Seed of -nlrom_derivative_selection random", "", seed, &seed,
                            nullptr));
  b.derivative_seed = static_cast<unsigned>(seed);
  PetscCall(MorseOptionsString(
      "-nlrom_forces", "step (STEP, eq. 29-37) | exact (element-wise projection) | none (a linear model: no tensors)",
      "", forces.c_str(), buf, sizeof buf, &set));
  if (set) forces = buf;
  PetscCall(MorseOptionsReal("-step_displacement", "STEP: target displacement of the imposed fields [m]", "",
                             step_displacement, &step_displacement, nullptr));
  PetscCall(MorseOptionsInt("-nlrom_filter_pod",
                            "POD filtering of g_nl (eq. 38-39): number of filter vectors from the "
                            "snapshots' nonlinear forces (0: none)",
                            "", n_filter, &n_filter, nullptr));
  PetscCall(MorseOptionsReal("-nlrom_damping_modal",
                             "Modal damping ratio on the first -nlrom_damping_modes modes of "
                             "the reduced model",
                             "", damping_xi, &damping_xi, nullptr));
  PetscCall(MorseOptionsInt("-nlrom_damping_modes", "Reduced modes carrying -nlrom_damping_modal", "", damping_modes,
                            &damping_modes, nullptr));
  const char* masses[] = {"carrying", "massless", "BoundaryMass", "", nullptr};
  PetscEnum bm = massless ? static_cast<PetscEnum>(1) : static_cast<PetscEnum>(0);
  PetscCall(MorseOptionsEnum("-nlrom_boundary_mass",
                             "carrying (the boundary keeps its mass, seed 003) or massless (MacNeal: residual "
                             "flexibility without mass; a static boundary, the critical step of the dynamic modes)",
                             "", masses, bm, &bm, nullptr));
  massless = bm == static_cast<PetscEnum>(1);
  PetscCall(MorseOptionsReal("-nlrom_massless_fmax",
                             "Massless boundary: the modes of the reduced model (boundary free) above this frequency "
                             "[Hz] are residual, quasi-static (0: all but the n_b highest)",
                             "", massless_fmax, &massless_fmax, nullptr));
  PetscOptionsEnd();
  auto bad = [&](bool ok, const std::string& why) {
    if (!ok && error.empty()) error = why;
  };
  if (basis_name == "cb")
    b.kind = BasisKind::CB;
  else if (basis_name == "cbmd")
    b.kind = BasisKind::CBMD;
  else if (basis_name == "pod")
    b.kind = BasisKind::POD;
  else
    bad(false, cat("-nlrom_basis ", basis_name, ": unknown (cb, cbmd or pod)"));
  bad(forces == "step" || forces == "exact" || forces == "none",
      cat("-nlrom_forces ", forces, ": unknown (step, exact or none)"));
  bad(!(forces == "none" && n_filter > 0), "-nlrom_filter_pod applies to STEP (-nlrom_forces step), not to none");
  // Given, a length or step must be a finite positive time (not given: the defaults of cmd nlrom).
  bad(!tfinal_set || (std::isfinite(b.training_tfinal) && b.training_tfinal > 0),
      cat("-nlrom_training_tfinal must be a finite positive time [s] (got ", b.training_tfinal, ")"));
  bad(!dt_set || (std::isfinite(b.training_dt) && b.training_dt > 0),
      cat("-nlrom_training_dt must be a finite positive time step [s] (got ", b.training_dt, ")"));
  bad(!b.boundary_set.empty(), "morse nlrom: no boundary set given: use -boundary SET");
  bad(damping_xi >= 0 && damping_xi < 1 && damping_modes >= 0,
      "-nlrom_damping_modal must be in [0, 1) and -nlrom_damping_modes >= 0");
  bad(n_filter >= 0, "-nlrom_filter_pod must be >= 0");
  bad(std::isfinite(massless_fmax) && massless_fmax >= 0,
      cat("-nlrom_massless_fmax must be a finite frequency >= 0 [Hz] (got ", massless_fmax, ")"));
  bad(massless || massless_fmax == 0, "-nlrom_massless_fmax applies to -nlrom_boundary_mass massless");
  bad(!(n_filter > 0 && b.snapshots.empty()), "-nlrom_filter_pod needs -nlrom_snapshots FILE.h5");
  return PETSC_SUCCESS;
}

UMat force_filter(const fe::Model& md, const fe::Svk& svk, const std::string& file, PetscInt n) {
  StageTimer t(md.mesh->comm, "PodFilter");
  auto X = dyn::read_fom_snapshots(*md.mesh, md.dofs, file);
  PetscInt ns = 0;
  MORSE_CALL(MatGetSize(X.get(), nullptr, &ns));
  MORSE_CHECK(n <= ns, "-nlrom_filter_pod ", n, " exceeds the ", ns, " snapshots of ", file);
  UMat G;
  MORSE_CALL(MatDuplicate(X.get(), MAT_DO_NOT_COPY_VALUES, G.ptr()));
  svk.nonlinear_force_block(X.get(), G.get());
  std::vector<double> sigma;
  return pod(G.get(), n, &sigma);
}

}  // namespace morse::nlrom
