// The options of the offline stage (see morse/nlrom/nlrom.hpp: OfflineSettings) and the POD
// filter of the reduced force.
#include "morse/core/options.hpp"

#include <petscsys.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/nlrom/nlrom.hpp"

namespace morse::nlrom {

namespace {

// The value of -nlrom_damping_modes: `all` (kAllModes) or a count >= 0, the whole text an integer
// within PetscInt's range. Returns why not, naming the option and the text, or "".
std::string parse_damping_modes(const char* text, PetscInt* modes) {
  const std::string why = cat("-nlrom_damping_modes ", text, ": expected a number of modes >= 0 or all");
  if (std::string(text) == "all") {
    *modes = kAllModes;
    return {};
  }
  if (!options::value_error("-nlrom_damping_modes", text, options::Value::Int).empty()) return why;
  const long long k = std::strtoll(text, nullptr, 10);  // in range: value_error checked it
  if (k < 0) return why;
  *modes = static_cast<PetscInt>(k);
  return {};
}

}  // namespace

PetscErrorCode OfflineSettings::set_from_options(MPI_Comm comm) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE, tfinal_set = PETSC_FALSE, dt_set = PETSC_FALSE, rayleigh = PETSC_FALSE;
  std::string modes_error, rayleigh_error;
  auto& b = basis;
  PetscBool mi_set = PETSC_FALSE;  // -nlrom_massless_interior given
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
  // A count or `all`: read as text (PETSc's integer option cannot take a word) and parsed here.
  buf[0] = 0;
  PetscCall(MorseOptionsString("-nlrom_damping_modes",
                               "Reduced modes carrying -nlrom_damping_modal: a count K, or all (every mode; with a "
                               "massless boundary every dynamic mode)",
                               "", "0", buf, sizeof buf, &set));
  if (set) modes_error = parse_damping_modes(buf, &damping_modes);
  PetscCall(options::get_rayleigh(PetscOptionsObject, "-nlrom_rayleigh",
                                  "Rayleigh damping alpha,beta of the reduced model: C~ = alpha M~ + beta K~",
                                  &rayleigh_alpha, &rayleigh_beta, &rayleigh, &rayleigh_error));
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
  const char* interiors[] = {"static", "scaled", "MasslessInterior", "", nullptr};
  PetscEnum mi = massless_scaled ? static_cast<PetscEnum>(1) : static_cast<PetscEnum>(0);
  PetscCall(MorseOptionsEnum("-nlrom_massless_interior",
                             "Massless boundary: the residual combinations that vanish on the boundary are static "
                             "(MacNeal, solved with the boundary) or scaled (dynamic, their mass raised so that none "
                             "is above -nlrom_massless_fmax; only the boundary static)",
                             "", interiors, mi, &mi, &mi_set));
  massless_scaled = mi == static_cast<PetscEnum>(1);
  PetscCall(MorseOptionsReal("-nlrom_mass_scaling_fmax",
                             "Selective mass scaling of a mass-carrying model: the modes of the reduced model above "
                             "this frequency [Hz] keep their shapes at this frequency (0: none)",
                             "", mass_scaling_fmax, &mass_scaling_fmax, nullptr));
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
  bad(modes_error.empty(), modes_error);
  bad(damping_xi >= 0 && damping_xi < 1 && (damping_modes >= 0 || damping_modes == kAllModes),
      "-nlrom_damping_modal must be in [0, 1) and -nlrom_damping_modes >= 0");
  bad(rayleigh_error.empty(), rayleigh_error);
  rayleigh_given = rayleigh;
  bad(!(rayleigh_given && damping_xi > 0),
      "-nlrom_rayleigh and -nlrom_damping_modal are two damping models: give one of them");
  bad(!(rayleigh_given && massless),
      "-nlrom_rayleigh is not defined on the massless model (-nlrom_boundary_mass massless): on its zero-mass "
      "block (the quasi-static coordinates) alpha M~ vanishes and beta K~ would not; use -nlrom_damping_modal, "
      "which acts on its dynamic modes");
  bad(n_filter >= 0, "-nlrom_filter_pod must be >= 0");
  bad(std::isfinite(massless_fmax) && massless_fmax >= 0,
      cat("-nlrom_massless_fmax must be a finite frequency >= 0 [Hz] (got ", massless_fmax, ")"));
  bad(massless || massless_fmax == 0, "-nlrom_massless_fmax applies to -nlrom_boundary_mass massless");
  bad(massless || !mi_set, "-nlrom_massless_interior applies to -nlrom_boundary_mass massless");
  bad(std::isfinite(mass_scaling_fmax) && mass_scaling_fmax >= 0,
      cat("-nlrom_mass_scaling_fmax must be a finite frequency >= 0 [Hz] (got ", mass_scaling_fmax, ")"));
  bad(!(massless && mass_scaling_fmax > 0),
      "-nlrom_mass_scaling_fmax applies to a mass-carrying model; a massless boundary has no boundary mass to scale "
      "(its residual combinations: -nlrom_massless_interior scaled)");
  bad(!massless_scaled || massless_fmax > 0,
      "-nlrom_massless_interior scaled needs -nlrom_massless_fmax HZ > 0: the frequency that no scaled mode may "
      "exceed");
  bad(!(n_filter > 0 && b.snapshots.empty()), "-nlrom_filter_pod needs -nlrom_snapshots FILE.h5");
  return PETSC_SUCCESS;
}

std::string OfflineSettings::damping() const {
  if (rayleigh_given) return "rayleigh";
  return damping_xi > 0 && damping_modes != 0 ? "modal" : "none";
}

UMat force_filter(const fe::Model& md, const fe::Svk& svk, const std::string& file, PetscInt n) {
  StageTimer t(md.mesh->comm, "PodFilter");
  auto X = dyn::read_fom_snapshots(md, file);
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
