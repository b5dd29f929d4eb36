// The options of dyn's settings (see morse/dyn/dyn.hpp): the nodal loads (-load_*), the tabulated
// load history (-load_history*) and the full-order run (-fom_*).
#include "morse/core/options.hpp"

#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/dyn/dyn.hpp"

namespace morse::dyn {

PetscErrorCode get_loads(MPI_Comm comm, std::vector<NodalLoad>* loads, std::string* error, const char* prefix) {
  std::vector<std::string> sets;
  PetscCall(options::get_string_list(
      comm, "-load_sets", "Node sets carrying a nodal load (force per node), comma separated", &sets, prefix));
  const std::string pre = prefix ? cat("-", prefix) : std::string("-");
  PetscOptionsBegin(comm, prefix, "morse loads (F(t) = A sin(omega t + phase) per node; omega = 0: constant A)", "");
  for (const auto& name : sets) {
    NodalLoad l;
    l.set = name;
    const std::string p = "-load_" + name + "_";
    char buf[256] = "";
    PetscBool has_dir = PETSC_FALSE, has_amp = PETSC_FALSE;
    PetscCall(MorseOptionsString((p + "dir").c_str(), "Direction: x, y, z or vx,vy,vz (normalized)", "", buf, buf,
                                 sizeof buf, &has_dir));
    PetscCall(MorseOptionsReal((p + "amplitude").c_str(), "Force per node [N] (not a traction)", "", l.amplitude,
                               &l.amplitude, &has_amp));
    PetscCall(MorseOptionsReal((p + "omega").c_str(), "Angular frequency [rad/s]; 0 = constant load", "", l.omega,
                               &l.omega, nullptr));
    PetscCall(MorseOptionsReal((p + "phase").c_str(), "Phase [rad]", "", l.phase, &l.phase, nullptr));
    if (error->empty()) {
      if (!has_dir)
        *error = cat("load on set ", name, ": give its direction with ", pre, p.substr(1), "dir x|y|z|vx,vy,vz");
      else if (!has_amp)
        *error = cat("load on set ", name, ": give its force per node with ", pre, p.substr(1), "amplitude");
      else if (auto why = parse_direction(buf, l.dir); !why.empty())
        *error = cat(pre, p.substr(1), "dir: ", why);
      else if (l.omega < 0)  // non-finite values are refused by MorseOptionsReal
        *error = cat(pre, p.substr(1), "omega must be >= 0 (got ", l.omega, ")");
    }
    loads->push_back(l);
  }
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

PetscErrorCode LoadHistoryOptions::set_from_options(MPI_Comm comm) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE, outside_set = PETSC_FALSE;
  std::string text = "error";
  PetscOptionsBegin(comm, nullptr, "morse tabulated load history (linear interpolation in time)", "");
  PetscCall(MorseOptionsString("-load_history",
                               "FILE[:/GROUP]: nodal forces on a time grid, added to the -load_* loads: a CSV "
                               "(time,node_id,fx,fy,fz), an HDF5 table (/load_history: time, node_ids, forces) or the "
                               "contact forces of a morse simulate file (/sim/contact)",
                               "", buf, buf, sizeof buf, &set));
  if (set) spec = buf;
  buf[0] = 0;
  PetscCall(
      MorseOptionsString("-load_history_outside",
                         "Outside the table's time grid: error (checked before the run), zero or hold (end values)", "",
                         text.c_str(), buf, sizeof buf, &outside_set));
  if (outside_set) text = buf;
  PetscCall(MorseOptionsReal("-load_history_scale", "Factor on every force of the table", "", scale, &scale, nullptr));
  PetscOptionsEnd();
  if (auto why = parse_outside(text, &outside); !why.empty()) error = cat("-load_history_outside: ", why);
  if (error.empty() && !std::isfinite(scale)) error = "-load_history_scale must be finite";
  if (error.empty() && spec.empty() && outside_set) error = "-load_history_outside needs -load_history FILE";
  return PETSC_SUCCESS;
}

std::shared_ptr<const LoadHistory> make_load_history(MPI_Comm comm, const mesh::LocalMesh& lm,
                                                     const fe::DofLayout& dofs, const LoadHistoryOptions& o) {
  if (o.spec.empty()) return nullptr;
  StageTimer t(comm, "LoadHistory");
  LoadTable table;
  try {
    table = read_load_table(comm, o.spec);
  } catch (const Error& e) {
    throw Error(cat("-load_history ", e.what()));
  }
  auto h = std::make_shared<LoadHistory>(lm, dofs, table, o.outside, o.scale);
  double peak = 0.0;
  for (double f : table.forces) peak = std::max(peak, std::abs(f));
  print0(comm, "morse: load history %s: %zu nodes, %zu times in [%g, %g] s, max |force component| %.4g N (x %g)\n",
         table.source.c_str(), table.n_nodes(), table.n_times(), table.time.front(), table.time.back(), peak, o.scale);
  return h;
}

}  // namespace morse::dyn

namespace morse::dyn {

PetscErrorCode FomSettings::set_from_options(MPI_Comm comm) {
  PetscCall(
      options::get_string_list(comm, "-fom_monitor", "Node sets whose displacement histories are written", &monitor));
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE, lin = linear ? PETSC_TRUE : PETSC_FALSE;
  std::string scheme_name = scheme == Scheme::Energy ? "energy" : "trapezoidal";
  std::string newton_name = newton == Newton::Modified ? "modified" : "krylov";
  PetscOptionsBegin(comm, nullptr, "morse fom options", "");
  PetscCall(MorseOptionsReal("-fom_dt", "Time step [s] (fixed)", "", dt, &dt, nullptr));
  PetscCall(MorseOptionsReal("-fom_tfinal", "Final time [s]", "", t_final, &t_final, nullptr));
  PetscCall(MorseOptionsBool("-fom_linear", "Linear twin (g_nl = 0), same everything else", "", lin, &lin, nullptr));
  PetscCall(MorseOptionsString("-fom_scheme",
                               "energy: energy-conserving midpoint (Simo-Tarnow), trapezoidal: Newmark average "
                               "acceleration; identical for a linear model",
                               "", scheme_name.c_str(), buf, sizeof buf, &set));
  if (set) scheme_name = buf;
  PetscCall(MorseOptionsInt("-fom_snapshot_every", "Write full-field snapshots of u and v every K steps (0: none)", "",
                            snapshot_every, &snapshot_every, nullptr));
  PetscCall(MorseOptionsReal("-fom_damping_modal", "Modal damping ratio xi on the first -fom_damping_modes modes", "",
                             modal_xi, &modal_xi, nullptr));
  PetscCall(MorseOptionsInt("-fom_damping_modes", "Number of modes carrying -fom_damping_modal", "", damping_modes,
                            &damping_modes, nullptr));
  PetscCall(options::get_rayleigh(PetscOptionsObject, "-fom_rayleigh",
                                  "Rayleigh damping alpha,beta: C = alpha M + beta K", &rayleigh_alpha, &rayleigh_beta,
                                  &set, &error));
  PetscCall(MorseOptionsReal("-fom_newton_rtol", "Newton tolerance: ||R|| <= rtol * force scale + atol", "",
                             newton_rtol, &newton_rtol, nullptr));
  PetscCall(
      MorseOptionsReal("-fom_newton_atol", "Newton absolute tolerance [N]", "", newton_atol, &newton_atol, nullptr));
  PetscCall(
      MorseOptionsInt("-fom_newton_max_it", "Newton iterations per step", "", newton_max_it, &newton_max_it, nullptr));
  PetscCall(MorseOptionsInt("-fom_refactor_every",
                            "Refactor the iteration matrix every N iterations (1: full Newton); 0: modified Newton, "
                            "refactor only when the residual falls by less than -fom_refactor_ratio",
                            "", refactor_every, &refactor_every, nullptr));
  PetscCall(MorseOptionsReal("-fom_refactor_ratio", "Modified Newton: refactor when ||R_k+1|| > ratio ||R_k||", "",
                             refactor_ratio, &refactor_ratio, nullptr));
  PetscCall(MorseOptionsString("-fom_newton",
                               "krylov: exact Newton by CG on the matrix-free tangent, preconditioned by a reused "
                               "MUMPS factor (trapezoidal scheme); modified: the reused factor is the Newton matrix",
                               "", newton_name.c_str(), buf, sizeof buf, &set));
  if (set) newton_name = buf;
  PetscCall(MorseOptionsReal("-fom_krylov_rtol", "Newton-Krylov: smallest relative tolerance of a CG solve", "",
                             krylov_rtol, &krylov_rtol, nullptr));
  PetscCall(MorseOptionsInt("-fom_krylov_max_it", "Newton-Krylov: CG iterations before refactoring and retrying", "",
                            krylov_max_it, &krylov_max_it, nullptr));
  PetscCall(MorseOptionsInt("-fom_krylov_refactor_its",
                            "Newton-Krylov: refresh the factor when a CG solve needs more iterations than this", "",
                            krylov_refactor_its, &krylov_refactor_its, nullptr));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-fom_initial", "Initial displacement from a morse file (e.g. a morse static run)", "",
                               buf, buf, sizeof buf, &set));
  if (set) initial = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-fom_initial_dataset", "Nodal dataset read by -fom_initial", "",
                               initial_dataset.c_str(), buf, sizeof buf, &set));
  if (set) initial_dataset = buf;
  PetscOptionsEnd();
  linear = lin;
  auto bad = [&](bool ok, const std::string& why) {
    if (!ok && error.empty()) error = why;
  };
  if (scheme_name == "energy")
    scheme = Scheme::Energy;
  else if (scheme_name == "trapezoidal")
    scheme = Scheme::Trapezoidal;
  else
    bad(false, cat("-fom_scheme ", scheme_name, ": unknown (energy or trapezoidal)"));
  if (newton_name == "krylov")
    newton = Newton::Krylov;
  else if (newton_name == "modified")
    newton = Newton::Modified;
  else
    bad(false, cat("-fom_newton ", newton_name, ": unknown (krylov or modified)"));
  bad(dt > 0, cat("-fom_dt must be positive (got ", dt, ")"));
  bad(t_final > 0, cat("-fom_tfinal must be positive (got ", t_final, ")"));
  bad(t_final >= dt, cat("-fom_tfinal (", t_final, ") is shorter than one step -fom_dt (", dt, ")"));
  bad(snapshot_every >= 0, cat("-fom_snapshot_every must be >= 0 (got ", snapshot_every, ")"));
  bad(modal_xi >= 0 && modal_xi < 1, cat("-fom_damping_modal must be in [0, 1) (got ", modal_xi, ")"));
  bad(damping_modes >= 0, cat("-fom_damping_modes must be >= 0 (got ", damping_modes, ")"));
  bad(!(modal_xi > 0) || damping_modes > 0, "-fom_damping_modal needs -fom_damping_modes K > 0");
  bad(newton_rtol > 0 && newton_atol >= 0 && newton_max_it > 0,
      "-fom_newton_rtol, -fom_newton_max_it must be positive and -fom_newton_atol >= 0");
  bad(refactor_every >= 0, "-fom_refactor_every must be >= 0");
  bad(refactor_ratio > 0 && refactor_ratio < 1, "-fom_refactor_ratio must be in (0, 1)");
  bad(krylov_rtol > 0 && krylov_rtol < 1, cat("-fom_krylov_rtol must be in (0, 1) (got ", krylov_rtol, ")"));
  bad(krylov_max_it > 0 && krylov_refactor_its > 0, "-fom_krylov_max_it and -fom_krylov_refactor_its must be positive");
  return PETSC_SUCCESS;
}

}  // namespace morse::dyn
