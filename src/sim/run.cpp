// sim/run.cpp: the options of the reduced runs and what `morse simulate` does around
// sim::integrate: case files, the snapshot plan, the records of a run, the cases round robin
// (sim/run.hpp).
#include "morse/sim/run.hpp"

#include <petscsys.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/detail/pack.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/io/h5.hpp"
#include "sim/contact.hpp"

namespace morse::sim {

PetscErrorCode ContactOptions::set_from_options(MPI_Comm comm) {
  ContactOptions* o = this;
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE, bump_set = PETSC_FALSE;
  auto bad = [&](const std::string& e) {
    if (o->error.empty()) o->error = e;
  };
  auto& c = o->casing;
  PetscOptionsBegin(comm, nullptr, "morse contact (seed 003 §3.4: blade tip against a rigid obstacle)", "");
  PetscCall(MorseOptionsString("-contact_set",
                               "Node set in contact (physical boundary nodes of the reduced model: its -boundary set "
                               "or a subset); no contact if not given",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->set = buf;
  const char* obstacles[] = {"plane", "casing", "Obstacle", "", nullptr};
  PetscEnum ob = static_cast<PetscEnum>(o->obstacle);
  PetscCall(MorseOptionsEnum("-contact_obstacle",
                             "casing (rigid, of revolution about z, two-lobe distortion growing in time: eq. 52-53) or "
                             "plane (-contact_plane_point, -contact_plane_normal)",
                             "", obstacles, ob, &ob, nullptr));
  o->obstacle = static_cast<Obstacle>(ob);
  PetscCall(MorseOptionsReal("-contact_mu", "Coulomb friction coefficient", "", o->mu, &o->mu, nullptr));
  if (!(o->mu >= 0)) bad(cat("-contact_mu must be >= 0 (got ", o->mu, ")"));
  const char* slidings[] = {"rotation", "relative", "Sliding", "", nullptr};  // the enum's order
  PetscEnum sl = static_cast<PetscEnum>(o->sliding);
  PetscCall(MorseOptionsEnum("-contact_sliding",
                             "Casing: the sliding direction of friction: relative (the tip's velocity relative to the "
                             "casing, omega e_z x x + u': the Coulomb law) or rotation (sign(omega) e_theta, the tip's "
                             "vibration speed neglected beside omega rho: seed 003 §3.4)",
                             "", slidings, sl, &sl, nullptr));
  o->sliding = static_cast<Sliding>(sl);
  PetscInt n = 3;
  PetscCall(
      MorseOptionsRealArray("-contact_plane_point", "A point of the plane x,y,z [m]", "", o->plane.point, &n, &set));
  if (set && n != 3) bad("-contact_plane_point needs 3 values x,y,z");
  o->plane_given = set;
  n = 3;
  PetscCall(MorseOptionsRealArray("-contact_plane_normal", "Normal of the plane x,y,z, pointing to the free side", "",
                                  o->plane.normal, &n, &set));
  if (set && n != 3) bad("-contact_plane_normal needs 3 values x,y,z");
  o->plane_given = o->plane_given || set;
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(o->plane.point[k]) || !std::isfinite(o->plane.normal[k]))
      bad("-contact_plane_point and -contact_plane_normal must be finite");
  const double nn = std::sqrt(o->plane.normal[0] * o->plane.normal[0] + o->plane.normal[1] * o->plane.normal[1] +
                              o->plane.normal[2] * o->plane.normal[2]);
  if (!(nn > 0))
    bad("-contact_plane_normal must not be zero");
  else
    for (double& x : o->plane.normal) x /= nn;
  PetscCall(MorseOptionsReal("-casing_clearance", "Casing: nominal radial clearance c0 [m] (seed: 0.356 mm)", "",
                             c.clearance, &c.clearance, nullptr));
  c.bump_height = 2.0 * c.clearance;
  PetscCall(MorseOptionsReal("-casing_bump_height", "Casing: height h_b of each lobe [m] (default 2 c0, as the seed)",
                             "", c.bump_height, &c.bump_height, &bump_set));
  if (!bump_set) c.bump_height = 2.0 * c.clearance;
  PetscInt lobes = c.lobes;
  PetscCall(MorseOptionsInt("-casing_lobes", "Casing: number of lobes of the distortion (seed: 2)", "", lobes, &lobes,
                            nullptr));
  c.lobes = static_cast<int>(lobes);
  PetscCall(MorseOptionsReal("-casing_width", "Casing: angular width of each lobe [rad] (eq. 52)", "", c.width,
                             &c.width, nullptr));
  PetscCall(MorseOptionsReal("-casing_alpha",
                             "Casing: growth rate of the distortion [1/s]; 0 = 99% of h_b at 20% of the run", "",
                             c.alpha, &c.alpha, nullptr));
  PetscBool omega_set = PETSC_FALSE;
  PetscCall(MorseOptionsReal("-sim_omega", "Rotation speed of the blade [rad/s] (casing contact)", "", c.omega,
                             &c.omega, &omega_set));
  o->omega_given = omega_set;
  PetscCall(MorseOptionsReal("-sim_revolutions", "Run length in revolutions at -sim_omega (instead of -sim_tfinal)", "",
                             o->revolutions, &o->revolutions, &set));
  if (set && !(o->revolutions > 0)) bad(cat("-sim_revolutions must be positive (got ", o->revolutions, ")"));
  PetscOptionsEnd();
  for (const auto& [name, v] : {std::pair<const char*, double>{"-contact_mu", o->mu},
                                {"-casing_clearance", c.clearance},
                                {"-casing_bump_height", c.bump_height},
                                {"-casing_width", c.width},
                                {"-casing_alpha", c.alpha},
                                {"-sim_omega", c.omega},
                                {"-sim_revolutions", o->revolutions}})
    if (!std::isfinite(v)) bad(cat(name, " must be finite (got ", v, ")"));
  if (!(c.clearance > 0)) bad(cat("-casing_clearance must be positive (got ", c.clearance, " m)"));
  if (!(c.bump_height >= 0)) bad(cat("-casing_bump_height must be >= 0 (got ", c.bump_height, " m)"));
  if (c.lobes < 1) bad(cat("-casing_lobes must be >= 1 (got ", c.lobes, ")"));
  if (!(c.width > 0)) bad(cat("-casing_width must be positive (got ", c.width, " rad)"));
  if (!(c.alpha >= 0)) bad(cat("-casing_alpha must be >= 0 (got ", c.alpha, " 1/s)"));
  return PETSC_SUCCESS;
}

PetscErrorCode SimOptions::set_from_options(MPI_Comm comm) {
  SimOptions* o = this;
  PetscCall(options::get_string_list(comm, "-sim_monitor",
                                     "Node sets whose reconstructed displacements u = Phi q are written", &o->monitor));
  PetscCall(
      options::get_string_list(comm, "-sim_cases",
                               "Independent load cases run one per rank; case c takes its loads from -c_load_sets, "
                               "-c_load_<SET>_* and writes <out>_c.h5",
                               &o->cases));
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  const char* names[2] = {"-sim_q0", "-sim_v0"};
  std::vector<double>* dest[2] = {&o->s.q0, &o->s.v0};
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
  const char* schemes[] = {"central", "trapezoidal", "energy", "Scheme", "", nullptr};
  PetscEnum scheme = static_cast<PetscEnum>(o->s.scheme);
  PetscCall(MorseOptionsEnum("-sim_scheme",
                             "central (explicit, eq. 40-41; dt below the critical step), trapezoidal (implicit, "
                             "Newton on the reduced model: morse fom's scheme, any dt) or energy (implicit, the "
                             "nonlinear force averaged over the step: exact energy conservation, any dt)",
                             "", schemes, scheme, &scheme, nullptr));
  o->s.scheme = static_cast<Scheme>(scheme);
  PetscCall(MorseOptionsReal("-sim_newton_rtol", "trapezoidal: Newton tolerance relative to the force scale", "",
                             o->s.newton_rtol, &o->s.newton_rtol, nullptr));
  PetscInt max_it = o->s.newton_max_it;
  PetscCall(MorseOptionsInt("-sim_newton_max_it", "trapezoidal: Newton iterations per step before the run stops", "",
                            max_it, &max_it, nullptr));
  o->s.newton_max_it = static_cast<int>(max_it);
  PetscBool flag = o->s.newton_line_search ? PETSC_TRUE : PETSC_FALSE;
  PetscCall(MorseOptionsBool("-sim_newton_line_search",
                             "trapezoidal: when the full Newton step does not lower the incremental potential, "
                             "step to its first minimum along the Newton direction (exact: a quartic; theory 9.1)",
                             "", flag, &flag, nullptr));
  o->s.newton_line_search = flag == PETSC_TRUE;
  flag = o->s.error_estimate ? PETSC_TRUE : PETSC_FALSE;
  PetscCall(MorseOptionsBool("-sim_error_estimate",
                             "trapezoidal: estimate the local time-discretization error of each step "
                             "(Zienkiewicz-Xie, theory 9.2), printed at the end and written to /sim",
                             "", flag, &flag, nullptr));
  o->s.error_estimate = flag == PETSC_TRUE;
  const char* layouts[] = {"auto", "folded", "potential", "KernelLayout", "", nullptr};
  PetscEnum layout = static_cast<PetscEnum>(o->s.kernel);
  PetscCall(MorseOptionsEnum("-sim_kernel",
                             "Nonlinear force in the time loop: folded (P3 [A;B] times the monomials), potential "
                             "(symmetric energy coefficients, ~4 times fewer bytes; exact or STEP tensors), auto "
                             "(potential when A, B derive from a potential and the folded matrix exceeds 12 MB)",
                             "", layouts, layout, &layout, nullptr));
  o->s.kernel = static_cast<KernelLayout>(layout);
  PetscCall(MorseOptionsBool("-sim_linear", "Linear reduced model (g~ = 0)", "", o->linear, &o->linear, nullptr));
  PetscCall(MorseOptionsBool("-sim_energy_balance",
                             "Track the energy balance (works of loads, contact, friction, damping; theory 10.6); "
                             "false saves up to half the time of a linear step",
                             "", o->energy_balance, &o->energy_balance, nullptr));
  PetscInt checks = static_cast<PetscInt>(o->s.tangent_checks);
  PetscCall(MorseOptionsInt("-sim_tangent_checks",
                            "central, nonlinear: the critical step of the tangent model K~ + dg~/dq at the initial "
                            "and at this many evenly spaced states (0: none), printed and written to /sim/tangent",
                            "", checks, &checks, nullptr));
  o->s.tangent_checks = static_cast<long>(checks);
  PetscCall(MorseOptionsReal("-sim_divergence_limit",
                             "Contact runs: a contact node displaced by more than this [m] stops the run with the "
                             "time reached (default: the largest radius of the contact nodes; 0: no limit)",
                             "", o->divergence_limit, &o->divergence_limit, nullptr));
  PetscCall(MorseOptionsInt("-sim_output_every", "Write every K-th step", "", o->every, &o->every, nullptr));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-sim_snapshots",
                               "A morse fom file: write the full field u = Phi q (and v) at its snapshot times and "
                               "on its DOF map (/sim/snapshots)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->snapshots = buf;
  std::vector<PetscReal> v(4096);
  const char* helps[2] = {"Initial reduced coordinates q(0), r values (default 0)",
                          "Initial reduced velocities dq/dt(0), r values (default 0)"};
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
  auto bad = [&](const std::string& e) {
    if (o->error.empty()) o->error = e;
  };
  if (o->s.tangent_checks < 0)
    bad(cat("-sim_tangent_checks must be >= 0 (got ", o->s.tangent_checks, "; 0: no tangent checks)"));
  // Every case writes <out stem>_<case><ext>: its name must keep the file beside -out, once.
  std::set<std::string> seen;
  for (const auto& c : o->cases) {
    if (c.empty() || c.find('/') != std::string::npos || c.find("..") != std::string::npos)
      bad(cat("-sim_cases: case name '", c, "' must not be empty nor contain '/' or '..' (case c writes ",
              case_path(o->out, "c"), ")"));
    else if (!seen.insert(c).second)
      bad(cat("-sim_cases: case ", c, " is given twice (each case writes its own file, ", case_path(o->out, c), ")"));
  }
  for (int i = 0; i < 2; ++i)
    for (std::size_t k = 0; k < dest[i]->size(); ++k)
      if (!std::isfinite((*dest[i])[k]))
        bad(cat(names[i], " must be finite (value ", k + 1, " is ", (*dest[i])[k], ")"));
  for (double x : o->v0_uniform)
    if (!std::isfinite(x)) bad(cat("-sim_v0_uniform must be finite (got ", x, ")"));
  for (const auto& [name, v] : {std::pair<const char*, double>{"-sim_dt", o->s.dt},
                                {"-sim_tfinal", o->s.t_final},
                                {"-sim_newton_rtol", o->s.newton_rtol},
                                {"-sim_divergence_limit", o->divergence_limit}})
    if (!std::isfinite(v)) bad(cat(name, " must be finite (got ", v, ")"));
  if (o->out.empty()) bad("-out is empty: give the name of the output file");
  PetscCall(o->contact.set_from_options(comm));
  o->s.linear = o->linear;
  o->s.energy_balance = o->energy_balance;
  return PETSC_SUCCESS;
}

void ContactOptions::apply(const nlrom::StoredModel& sm, ContactSettings* c) const {
  c->nodes = contact_nodes(sm, set);  // throws on every rank alike (same model)
  c->obstacle = obstacle, c->plane = plane, c->casing = casing, c->mu = mu, c->sliding = sliding;
}

void SimOptions::resolve(const nlrom::StoredModel& sm, double* v0_residual) {
  if (!contact.set.empty()) {
    contact.apply(sm, &s.contact);
    s.divergence_limit = divergence_limit < 0 ? divergence_radius(s.contact) : divergence_limit;
    MORSE_CHECK(s.scheme == Scheme::Central,
                "morse simulate: contact (-contact_set) needs -sim_scheme central "
                "(forward-increment Lagrange "
                "multipliers are explicit)");
  }
  if (contact.revolutions > 0) {
    const double w = contact.casing.omega;
    MORSE_CHECK(w != 0.0, "-sim_revolutions needs a rotation speed: give -sim_omega (rad/s)");
    MORSE_CHECK(!tfinal_set, "give either -sim_tfinal or -sim_revolutions, not both");
    s.t_final = contact.revolutions * 2.0 * M_PI / std::abs(w);
  }
  if (!v0_uniform.empty()) {
    MORSE_CHECK(s.v0.empty(), "give either -sim_v0 or -sim_v0_uniform, not both");
    std::vector<double> u(sm.node_ids.size() * 3);
    for (std::size_t k = 0; k < u.size(); ++k) u[k] = v0_uniform[k % 3];
    s.v0 = sm.fit(u, v0_residual);
  }
}

std::string case_path(const std::string& out, const std::string& c) {
  auto dot = out.rfind('.');
  auto slash = out.rfind('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return out + "_" + c + ".h5";
  return out.substr(0, dot) + "_" + c + out.substr(dot);
}

PetscErrorCode SweepOptions::set_from_options(MPI_Comm comm) {
  SweepOptions* o = this;
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscInt retries = o->retries;  // read as a PetscInt, range-checked below
  PetscOptionsBegin(comm, nullptr, "morse sweep options", "");
  PetscCall(MorseOptionsString("-rom", "Reduced model: a morse nlrom file whose boundary set holds the contact set", "",
                               buf, buf, sizeof buf, &set));
  if (set) o->rom = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-out", "Sweep file (HDF5), rewritten after every speed; resumed if it exists", "",
                               o->out.c_str(), buf, sizeof buf, &set));
  if (set) o->out = buf;
  PetscCall(
      MorseOptionsReal("-sweep_omega_min", "Lowest rotation speed [rad/s]", "", o->omega_min, &o->omega_min, nullptr));
  PetscCall(
      MorseOptionsReal("-sweep_omega_max", "Highest rotation speed [rad/s]", "", o->omega_max, &o->omega_max, nullptr));
  PetscCall(MorseOptionsReal("-sweep_omega_step", "Speed step [rad/s]", "", o->omega_step, &o->omega_step, nullptr));
  PetscCall(MorseOptionsReal("-sim_dt", "Time step [s] (at most the critical step)", "", o->dt, &o->dt, nullptr));
  PetscCall(MorseOptionsBool("-sim_linear", "Linear reduced model (g~ = 0)", "", o->linear, &o->linear, nullptr));
  PetscCall(MorseOptionsInt("-sim_tangent_checks",
                            "nonlinear: the critical step of the tangent model K~ + dg~/dq at the initial and at "
                            "this many evenly spaced states of each speed (0: none); its smallest per speed is "
                            "written to /sweep/tangent",
                            "", o->tangent_checks, &o->tangent_checks, nullptr));
  PetscCall(MorseOptionsBool("-sim_energy_balance",
                             "Track the energy balance (works of loads, contact, friction, damping; theory 10.6); "
                             "false saves up to half the time of a linear step",
                             "", o->energy_balance, &o->energy_balance, nullptr));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-sweep_monitor", "Node set of one node whose radial displacement is recorded", "",
                               o->monitor.c_str(), buf, sizeof buf, &set));
  if (set) o->monitor = buf;
  PetscCall(MorseOptionsReal("-sweep_spectrum_fmax", "Highest frequency of the spectrum [Hz]", "", o->fmax, &o->fmax,
                             nullptr));
  PetscCall(MorseOptionsInt("-sweep_spectrum_bins", "Frequencies of the spectrum (k fmax / bins, k = 0..bins)", "",
                            o->bins, &o->bins, nullptr));
  PetscCall(MorseOptionsInt("-sweep_batch",
                            "Speeds advanced together per rank (one pass of the cubic tensor); default 16 with the "
                            "AVX-512 build of the potential kernel, else 8",
                            "", o->batch, &o->batch, &o->batch_given));
  {
    const char* kernels[] = {"auto", "lane", "folded", "potential", "SweepKernel", "", nullptr};
    PetscEnum kernel = static_cast<PetscEnum>(o->kernel);
    PetscCall(MorseOptionsEnum("-sweep_kernel",
                               "Cubic force of a rank's speeds: potential (one pass over the potential coefficients "
                               "for all of them), folded (one pass of the folded tensor), lane (speed by speed), or "
                               "auto (potential when the force has one, else lane)",
                               "", kernels, kernel, &kernel, nullptr));
    o->kernel = static_cast<SweepKernel>(kernel);
  }
  {
    const char* isas[] = {"auto", "baseline", "avx2", "avx512", "KernelIsa", "", nullptr};
    PetscEnum isa = static_cast<PetscEnum>(o->isa + 1);
    PetscCall(MorseOptionsEnum("-sweep_isa",
                               "Build of the batched potential kernel: auto (the widest this processor runs), avx512 "
                               "(x86-64-v4), avx2 (x86-64-v3; the same bits as avx512) or baseline (no fused "
                               "multiply-adds: other bits)",
                               "", isas, isa, &isa, nullptr));
    o->isa = static_cast<int>(isa) - 1;
  }
  PetscCall(MorseOptionsBool("-sweep_float",
                             "Potential kernel: coefficients in float (half the bytes), arithmetic in double; check "
                             "its accuracy on your model (docs/user-guide.md)",
                             "", o->single, &o->single, nullptr));
  PetscCall(MorseOptionsBool("-sweep_restart", "Start again even if -out holds finished speeds", "", o->restart,
                             &o->restart, nullptr));
  PetscCall(MorseOptionsReal("-sweep_refine_step",
                             "Adaptive refinement down to this speed step [rad/s] (0: none); -sweep_omega_step must "
                             "be a power-of-two multiple of it",
                             "", o->refine_step, &o->refine_step, nullptr));
  PetscCall(MorseOptionsReal("-sweep_refine_rms", "Refine between two speeds whose RMS differ by this fraction", "",
                             o->refine_rms, &o->refine_rms, nullptr));
  PetscCall(MorseOptionsReal("-sweep_refine_frequency",
                             "Refine between two speeds whose dominant frequencies differ by this fraction", "",
                             o->refine_frequency, &o->refine_frequency, nullptr));
  {
    PetscInt ks[64], nk = 64;
    PetscBool given = PETSC_FALSE;
    PetscCall(MorseOptionsIntArray("-sweep_refine_orders",
                                   "Refine on these engine-order lines (their amplitudes' jumps and peaks) instead of "
                                   "the RMS and the dominant frequency, e.g. 6,8",
                                   "", ks, &nk, &given));
    if (given) {
      o->refine_orders.clear();
      for (PetscInt k = 0; k < nk; ++k) o->refine_orders.push_back(static_cast<int>(ks[k]));
      if (nk == 0) o->error = "-sweep_refine_orders: give one engine order or more, e.g. 6,8";
    }
  }
  PetscCall(MorseOptionsReal("-sweep_refine_order_jump",
                             "With -sweep_refine_orders: refine where a line's amplitudes differ by this fraction of "
                             "the larger",
                             "", o->refine_order_jump, &o->refine_order_jump, nullptr));
  PetscCall(MorseOptionsReal("-sweep_refine_order_floor",
                             "With -sweep_refine_orders: a line counts where it reaches this fraction of its largest "
                             "amplitude over the finished speeds",
                             "", o->refine_order_floor, &o->refine_order_floor, nullptr));
  PetscCall(MorseOptionsInt("-sweep_orders",
                            "Engine orders 1..K whose line amplitudes are written per speed (/sweep/order_amplitude)",
                            "", o->orders, &o->orders, nullptr));
  const char* senses[] = {"negative", "positive", "Rotation", "", nullptr};
  PetscEnum sense = o->rotation > 0 ? static_cast<PetscEnum>(1) : static_cast<PetscEnum>(0);
  PetscCall(MorseOptionsEnum("-sweep_rotation",
                             "positive: the blade turns at +omega about +z (the casing's lobes pass it towards -theta "
                             "and friction acts along -e_theta); negative: at -omega",
                             "", senses, sense, &sense, nullptr));
  o->rotation = sense == static_cast<PetscEnum>(1) ? 1 : -1;
  PetscCall(MorseOptionsInt("-sweep_retries",
                            "A speed that fails (non-finite state) runs again at half its step, up to this many times",
                            "", retries, &retries, nullptr));
  {
    const char* modes[] = {"none", "up", "down", "both", "Continuation", "", nullptr};
    const int values[] = {0, 1, -1, 2};
    PetscEnum mode = static_cast<PetscEnum>(0);
    for (int k = 0; k < 4; ++k)
      if (values[k] == o->continuation) mode = static_cast<PetscEnum>(k);
    PetscCall(MorseOptionsEnum("-sweep_continuation",
                               "Each speed starts from the final state of the one below it (up) or above it (down) on "
                               "the grown casing, to follow a branch of solutions; both: up and down in one sweep "
                               "(their speeds share the force kernel's passes); none: every speed from rest",
                               "", modes, mode, &mode, nullptr));
    o->continuation = values[static_cast<int>(mode)];
  }
  PetscCall(MorseOptionsInt("-sweep_chains",
                            "Continuation: the grid is cut into this many runs of neighbouring speeds, run in "
                            "parallel, each starting from rest",
                            "", o->chains, &o->chains, nullptr));
  PetscCall(MorseOptionsReal("-sweep_divergence_limit",
                             "A speed whose monitored displacement exceeds this [m] has diverged (default: the largest "
                             "radius of the contact nodes; 0: no limit)",
                             "", o->divergence_limit, &o->divergence_limit, nullptr));
  PetscOptionsEnd();
  auto bad = [&](const std::string& e) {
    if (o->error.empty()) o->error = e;
  };
  for (const auto& [name, v] : {std::pair<const char*, double>{"-sweep_omega_min", o->omega_min},
                                {"-sweep_omega_max", o->omega_max},
                                {"-sweep_omega_step", o->omega_step},
                                {"-sweep_refine_step", o->refine_step},
                                {"-sweep_refine_rms", o->refine_rms},
                                {"-sweep_refine_frequency", o->refine_frequency},
                                {"-sweep_refine_order_jump", o->refine_order_jump},
                                {"-sweep_refine_order_floor", o->refine_order_floor},
                                {"-sim_dt", o->dt},
                                {"-sweep_divergence_limit", o->divergence_limit},
                                {"-sweep_spectrum_fmax", o->fmax}})
    if (!std::isfinite(v)) bad(cat(name, " must be finite (got ", v, ")"));
  if (o->isa >= 0 && !kernel_isa_supported(static_cast<KernelIsa>(o->isa)))
    bad(cat("-sweep_isa: this processor has no ", kernel_isa_name(static_cast<KernelIsa>(o->isa)),
            " (use auto: ", kernel_isa_name(best_kernel_isa()), " here)"));
  if (o->tangent_checks < 0)
    bad(cat("-sim_tangent_checks must be >= 0 (got ", o->tangent_checks, "; 0: no tangent checks)"));
  if (!(retries >= 0 && retries <= 20))
    bad(cat("-sweep_retries must be in 0..20 (got ", retries, "; each retry halves the step of a failed speed)"));
  else
    o->retries = static_cast<int>(retries);
  if (o->error.empty() && o->refine_step != 0) {
    // The coarse step must be 2^k fine steps (k >= 1), so that bisection lands on the fine grid.
    const double ratio = o->omega_step / o->refine_step;
    const double k = std::log2(ratio);
    if (!(o->refine_step > 0))
      bad(cat("-sweep_refine_step must be > 0 (got ", o->refine_step, "; 0: no refinement)"));
    else if (!(o->omega_step > o->refine_step))
      bad(cat("-sweep_refine_step ", o->refine_step, " rad/s is not below the grid's step -sweep_omega_step ",
              o->omega_step, " rad/s: refinement goes from the grid's step down to it"));
    else if (!(k <= 30 && std::abs(k - std::round(k)) < 1e-9))
      bad(cat("-sweep_omega_step ", o->omega_step, " / -sweep_refine_step ", o->refine_step, " = ", ratio,
              " is not a power of two: refinement bisects the grid's step down to -sweep_refine_step"));
    else if (!(o->refine_rms > 0 && o->refine_frequency > 0))
      bad(cat("-sweep_refine_rms and -sweep_refine_frequency must be > 0 (got ", o->refine_rms, ", ",
              o->refine_frequency, ")"));
  }
  if (!(o->orders >= 0 && o->orders <= 1000)) bad(cat("-sweep_orders must be in 0..1000 (got ", o->orders, ")"));
  if (o->error.empty() && !o->refine_orders.empty()) {
    if (!(o->refine_step > 0)) bad("-sweep_refine_orders applies to a refined sweep: give -sweep_refine_step");
    for (int k : o->refine_orders)
      if (k < 1 || k > o->orders)
        bad(cat("-sweep_refine_orders: engine order ", k, " is not among those measured, 1..-sweep_orders ",
                o->orders));
    if (!(o->refine_order_jump > 0 && o->refine_order_jump < 1))
      bad(cat("-sweep_refine_order_jump must be in (0, 1) (got ", o->refine_order_jump,
              "; a fraction of the larger amplitude)"));
    if (!(o->refine_order_floor >= 0 && o->refine_order_floor < 1))
      bad(cat("-sweep_refine_order_floor must be in [0, 1) (got ", o->refine_order_floor,
              "; a fraction of the line's largest amplitude)"));
  }
  if (o->error.empty() && o->continuation != 0) {
    if (o->refine_step != 0)
      bad(
          cat("-sweep_continuation and -sweep_refine_step exclude each other: a continuation runs every speed of the "
              "grid in order (use -sweep_omega_step for its step)"));
    else if (o->chains < 1)
      bad(cat("-sweep_chains must be at least 1 (got ", o->chains, ")"));
    else if (o->omega_step > 0 && o->omega_max >= o->omega_min &&
             static_cast<double>(o->chains) > std::floor((o->omega_max - o->omega_min) / o->omega_step + 1e-9) + 1)
      bad(cat("-sweep_chains ", o->chains, " is more than the grid's ",
              std::floor((o->omega_max - o->omega_min) / o->omega_step + 1e-9) + 1, " speeds"));
  }
  if (o->error.empty() && o->omega_step > 0 && o->omega_max > o->omega_min) {
    // The count in floating point first: it may not fit any integer (with refinement, of the
    // fine grid).
    const double fine = o->refine_step > 0 ? o->refine_step : o->omega_step;
    const double n = (std::floor((o->omega_max - o->omega_min) / o->omega_step + 1e-9) * (o->omega_step / fine) + 1) *
                     o->directions();  // both ways: every speed twice
    if (n > static_cast<double>(kMaxSweepSpeeds)) {
      const double per_speed = 8.0 * (14 + static_cast<double>(std::max<PetscInt>(o->bins, 0)) + 1 +
                                      static_cast<double>(std::max<PetscInt>(o->orders, 0)));
      char b[512];
      std::snprintf(b, sizeof b,
                    "-sweep_omega_min %.10g, -sweep_omega_max %.10g and -sweep_omega_step %.10g give %.10g speeds; a "
                    "sweep takes at most %ld (its file would need about %.3g GB, %.0f bytes per speed): use a larger "
                    "-sweep_omega_step or a narrower range",
                    o->omega_min, o->omega_max, o->omega_step, n, kMaxSweepSpeeds, n * per_speed * 1e-9, per_speed);
      bad(b);
    }
  }
  return o->contact.set_from_options(comm);
}

std::string settings_text(const SweepOptions& o, const SweepSettings& s, const nlrom::ReducedModel& m) {
  const std::size_t r = static_cast<std::size_t>(m.r);
  char b[2048];
  const auto& c = o.contact.casing;
  std::snprintf(
      b, sizeof b,
      "rom=%s\nr=%zu\nomega_min=%.17g\nomega_max=%.17g\nomega_step=%.17g\ndt=%.17g\nlinear=%d\n"
      "revolutions=%.17g\ncontact_set=%s\nmu=%.17g\nclearance=%.17g\nbump_height=%.17g\nlobes=%d\n"
      "width=%.17g\nalpha=%.17g\nmonitor=%s\nspectrum_fmax=%.17g\nspectrum_bins=%d\nkernel=%s\nfloat=%d\n"
      "spectrum_decimation=block_mean\nspectrum_bin_value=peak\nrotation=%d\nrefine_step=%.17g\nrefine_rms=%.17g\n"
      "refine_frequency=%.17g\nmodel=%s\nenergy_balance=%d\nretries=%d\ndivergence_limit=%.17g\n",
      files::absolute_path(o.rom).c_str(), r, o.omega_min, o.omega_max, o.omega_step, s.base.dt, s.base.linear ? 1 : 0,
      s.revolutions, o.contact.set.c_str(), o.contact.mu, c.clearance, c.bump_height, c.lobes, c.width, c.alpha,
      o.monitor.c_str(), s.spectrum_fmax, s.spectrum_bins, kernel_name(s.kernel), s.single ? 1 : 0, o.rotation,
      o.refine_step, o.refine_rms, o.refine_frequency, nlrom::fingerprint(m).c_str(), o.energy_balance ? 1 : 0,
      o.retries, s.divergence_limit);
  std::string text = b;
  text += cat("orders=", s.orders, "\n");
  // Always written: a file from before -contact_sliding (the rotation law) does not resume under the
  // relative default.
  text += cat("sliding=", o.contact.sliding == Sliding::Relative ? "relative" : "rotation", "\n");
  if (!o.refine_orders.empty()) {
    char c2[128];
    std::snprintf(c2, sizeof c2, "refine_order_jump=%.17g\nrefine_order_floor=%.17g\n", o.refine_order_jump,
                  o.refine_order_floor);
    text += "refine_orders=" + o.refine_orders_text() + "\n" + c2;
  }
  if (o.continuation != 0)  // only then: the files of sweeps without it stay resumable
    text += cat("continuation=",
                o.continuation == 2  ? "both"
                : o.continuation > 0 ? "up"
                                     : "down",
                "\nchains=", o.chains, "\n");
  return text;
}

void SweepOptions::check() const {
  MORSE_CHECK(error.empty(), error);
  MORSE_CHECK(!rom.empty(), "morse sweep: no reduced model given: use -rom FILE.h5 (a morse nlrom file)");
  MORSE_CHECK(!contact.set.empty(), "morse sweep: give the contact nodes with -contact_set SET");
  MORSE_CHECK(contact.obstacle == sim::Obstacle::Casing && !contact.plane_given,
              "morse sweep: the obstacle is the casing (-contact_obstacle casing; -contact_plane_* "
              "do not apply)");
  MORSE_CHECK(!contact.omega_given,
              "morse sweep: the speeds are -sweep_omega_min/_max/_step; -sim_omega does not apply");
  MORSE_CHECK(omega_min > 0 && omega_max >= omega_min,
              "morse sweep: give 0 < -sweep_omega_min <= -sweep_omega_max (got ", omega_min, ", ", omega_max, ")");
  MORSE_CHECK(omega_step > 0 || omega_max == omega_min, "morse sweep: -sweep_omega_step must be positive");
  MORSE_CHECK(batch > 0, "-sweep_batch must be positive (got ", batch, ")");
  MORSE_CHECK(fmax > 0 && bins > 0, "-sweep_spectrum_fmax and -sweep_spectrum_bins must be positive");
  MORSE_CHECK(bins < std::numeric_limits<int>::max(), "-sweep_spectrum_bins ", bins, " is too large");
}

void SweepOptions::check_memory(MPI_Comm comm) const {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const double speeds = static_cast<double>(n_speeds()), mine = rank == 0 ? speeds : std::ceil(speeds / size);
  // The grid, a spectrum per speed held (+ its lane's and the checkpoint's copies), the task list;
  // the block means of the analysed second half in each lane of a rank (the slowest speed's run is
  // the longest), and the spectrum's zero-padded FFT of one lane at a time (binned_spectrum: at
  // most 8 n complex values and their twiddles, 192 n bytes).
  const double revs = contact.revolutions > 0 ? contact.revolutions : 200.0;
  const double every = static_cast<double>(spectrum_block(fmax, dt));
  const double window = 0.5 * revs * 2.0 * M_PI / omega_min / (every * dt);
  const double lanes = std::min(static_cast<double>(batch), std::max(1.0, mine));
  const double bytes =
      8.0 * static_cast<double>(bins + 1) * (mine + 3.0) + 64.0 * speeds + (8.0 * lanes + 192.0) * window;
  morse::check_memory(
      comm,
      cat("morse sweep: ", static_cast<long long>(speeds), " speeds of ", bins + 1,
          " spectrum frequencies (-sweep_spectrum_bins ", bins, "), windows of ", static_cast<long long>(window),
          " samples (-sim_revolutions ", revs, " at -sweep_omega_min ", omega_min, ")"),
      bytes, "the spectra");
}

SweepSettings SweepOptions::settings(const nlrom::StoredModel& sm) const {
  SweepSettings s;
  s.base.dt = dt;
  s.base.linear = linear;
  s.base.energy_balance = energy_balance;
  s.base.tangent_checks = static_cast<long>(tangent_checks);
  contact.apply(sm, &s.base.contact);  // the casing (check())
  s.revolutions = contact.revolutions > 0 ? contact.revolutions : 200.0;
  s.spectrum_fmax = fmax;
  s.spectrum_bins = static_cast<int>(bins);
  s.orders = static_cast<int>(orders);
  s.batch = batch_given ? static_cast<int>(batch) : default_sweep_batch(isa);
  s.kernel = kernel;
  s.single = single;
  s.isa = isa;
  s.monitor = sm.radial_row(monitor, "-sweep_monitor");
  s.divergence_limit = divergence_limit;
  if (divergence_limit < 0) s.divergence_limit = divergence_radius(s.base.contact);
  return s;
}

std::string SweepOptions::refine_orders_text() const {
  std::string ks;
  for (int k : refine_orders) ks += cat(ks.empty() ? "" : ",", k);
  return ks;
}

long SweepOptions::stride() const { return refine_step > 0 ? std::lround(omega_step / refine_step) : 1; }

long SweepOptions::grid_speeds() const {
  if (omega_max == omega_min) return 1;
  return static_cast<long>(std::floor((omega_max - omega_min) / omega_step + 1e-9)) * stride() + 1;
}

long SweepOptions::n_speeds() const { return directions() * grid_speeds(); }

double SweepOptions::omega_of(long index) const {
  const double step = refine_step > 0 ? refine_step : omega_step;
  return rotation * (omega_min + static_cast<double>(index % grid_speeds()) * step);
}

std::vector<SpeedTask> SweepOptions::todo(const std::vector<std::int64_t>& done_idx) const {
  const std::set<std::int64_t> done(done_idx.begin(), done_idx.end());
  std::vector<SpeedTask> todo;
  for (long i = 0; i < n_speeds(); i += stride())
    if (!done.count(i)) todo.push_back({i, omega_of(i)});
  return todo;
}

bool speeds_differ(const SpeedResult& a, const SpeedResult& b, const std::vector<double>& freqs, double rms_jump,
                   double frequency_jump) {
  if ((a.status != 0) != (b.status != 0)) return true;
  if (a.status != 0) return false;  // both failed: nothing to locate between them
  if (std::abs(a.rms - b.rms) > rms_jump * std::max(a.rms, b.rms)) return true;
  auto dominant = [&](const SpeedResult& x) {  // the largest amplitude above f = 0
    std::size_t k = 0;
    for (std::size_t j = 1; j < x.spectrum.size() && j < freqs.size(); ++j)
      if (freqs[j] > 0 && (k == 0 || x.spectrum[j] > x.spectrum[k])) k = j;
    return k;
  };
  const std::size_t ka = dominant(a), kb = dominant(b);
  if (ka == 0 || kb == 0 || freqs.size() < 2) return false;
  const double fa = freqs[ka], fb = freqs[kb], bin = freqs[1] - freqs[0];
  return std::abs(fa - fb) > frequency_jump * std::max(fa, fb) && std::abs(fa - fb) > 2.0 * bin;
}

int default_sweep_batch(int isa) { return kernel_isa_or_best(isa) == KernelIsa::Avx512 ? 16 : 8; }

SweepCost predict_sweep_cost(MPI_Comm comm, const nlrom::ReducedModel& m, const SweepSettings& s,
                             const SweepOptions& so, const std::vector<SpeedTask>& todo,
                             const std::vector<std::int64_t>& done_idx, double seconds) {
  SweepCost c;
  if (todo.empty() && !(so.refine_step > 0)) return c;
  auto steps_of = [&](double omega) {
    return static_cast<double>(detail::step_count(s.revolutions * 2.0 * M_PI / std::abs(omega), s.base.dt));
  };
  std::set<std::int64_t> planned(done_idx.begin(), done_idx.end());
  double slowest = 0.0;
  const bool checked = !s.base.linear && !m.massless && s.base.tangent_checks > 0;
  for (const auto& t : todo) {
    c.steps += steps_of(t.omega), planned.insert(t.index);
    if (checked)
      c.checks +=
          static_cast<double>(sweep_tangent_checks(static_cast<long>(steps_of(t.omega)), s.base.tangent_checks));
    if (slowest == 0.0 || std::abs(t.omega) < std::abs(slowest)) slowest = t.omega;
  }
  if (so.refine_step > 0)
    for (long i = 0; i < so.n_speeds(); ++i)
      if (!planned.count(i)) c.refine_steps += steps_of(so.omega_min + static_cast<double>(i) * so.refine_step);
  if (slowest == 0.0) slowest = so.rotation * so.omega_min;
  int size = 1;
  MPI_Comm_size(comm, &size);
  // As many lanes as a rank will advance together: the batched kernels' rate per lane grows with them.
  // A continuation advances one speed per chain at a time.
  const std::size_t at_once =
      so.continuation != 0 ? static_cast<std::size_t>(std::max<PetscInt>(1, so.chains) * so.directions()) : todo.size();
  const int lanes = static_cast<int>(sweep_lanes_per_rank(s.batch, at_once, size));
  double rate = measure_step_rate(m, s, slowest, seconds, lanes);
  MPI_Allreduce(MPI_IN_PLACE, &rate, 1, MPI_DOUBLE, MPI_SUM, comm);
  c.rate = rate / size;
  if (c.checks > 0) {  // one tangent check at rest, timed until 3 calls and 0.02 s
    const std::vector<double> q(static_cast<std::size_t>(m.r), 0.0);
    const auto t0 = std::chrono::steady_clock::now();
    double dt = 0.0;
    int calls = 0;
    do {
      (void)tangent_step(m, q.data());
      ++calls;
      dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    } while (calls < 3 || dt < 0.02);
    c.check_seconds = dt / calls;
    MPI_Allreduce(MPI_IN_PLACE, &c.check_seconds, 1, MPI_DOUBLE, MPI_SUM, comm);
    c.check_seconds /= size;
  }
  if (c.rate > 0) {
    c.core_hours = (c.steps / c.rate + c.checks * c.check_seconds) / 3600.0;
    c.wall_seconds = c.core_hours * 3600.0 / static_cast<double>(std::min<std::size_t>(size, at_once));
    c.refine_core_hours = c.refine_steps / c.rate / 3600.0;
  }
  return c;
}

namespace {
// A list of speeds decided on rank 0, shared with every rank (with the initial states of continued
// speeds).
std::vector<SpeedTask> share_tasks(MPI_Comm comm, const std::vector<SpeedTask>& tasks) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  morse::detail::Packer pk;
  if (rank == 0) {
    pk.put(static_cast<std::uint64_t>(tasks.size()));
    for (const auto& t : tasks) {
      pk.put(t.index), pk.put(t.omega), pk.put(t.halvings), pk.put(t.from), pk.put(t.phase);
      pk.put_vec(t.q0), pk.put_vec(t.qm0);
    }
  }
  long len = static_cast<long>(pk.buffer().size());
  MPI_Bcast(&len, 1, MPI_LONG, 0, comm);
  std::vector<char> buf = pk.buffer();
  buf.resize(static_cast<std::size_t>(len));
  MPI_Bcast(buf.data(), static_cast<int>(len), MPI_CHAR, 0, comm);
  morse::detail::Unpacker up(buf);
  const auto n = up.get<std::uint64_t>();
  std::vector<SpeedTask> out(n);
  for (auto& t : out) {
    t.index = up.get<long>(), t.omega = up.get<double>(), t.halvings = up.get<int>(), t.from = up.get<long>();
    t.phase = up.get<double>(), t.q0 = up.get_vec<double>(), t.qm0 = up.get_vec<double>();
  }
  return out;
}
}  // namespace

std::vector<SpeedTask> SweepOptions::retry(const std::vector<SpeedResult>& done) const {
  std::vector<SpeedTask> out;
  for (const auto& R : done)
    if (R.status != 0 && R.halvings < retries) out.push_back({R.index, R.omega, R.halvings + 1});
  std::sort(out.begin(), out.end(), [](const SpeedTask& a, const SpeedTask& b) { return a.index < b.index; });
  return out;
}

SweepStats sweep_rounds(MPI_Comm comm, const nlrom::ReducedModel& m, const SweepSettings& s, const SweepOptions& so,
                        std::vector<SpeedTask> todo, std::vector<SpeedResult>* done, const std::vector<double>& freqs,
                        const std::function<void(const SpeedResult&)>& on_result, std::size_t* n_run) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  SweepStats st;
  *n_run = 0;
  // A result replaces the earlier one of its speed (a retry's failed run) or joins done.
  auto keep = [&](const SpeedResult& R) {
    auto old = std::find_if(done->begin(), done->end(), [&](const SpeedResult& x) { return x.index == R.index; });
    if (old != done->end())
      *old = R;
    else
      done->push_back(R);
  };
  auto count = [&](const SweepStats& rs, std::size_t tasks) {
    st.lane_steps += rs.lane_steps, st.speeds += rs.speeds, st.seconds += rs.seconds,
        st.kernel_seconds += rs.kernel_seconds, st.idle_seconds += rs.idle_seconds;
    st.kernel = rs.kernel;
    *n_run += tasks;
  };
  if (so.continuation != 0) {
    // Rounds of one speed per chain, decided on rank 0 (which holds the results and their final
    // states) and shared; every speed keeps its final state for the next.
    SweepSettings sk = s;
    sk.keep_state = true;
    for (;;) {
      std::vector<SpeedTask> next;
      if (rank == 0) next = so.next_in_chains(*done);
      next = share_tasks(comm, next);
      if (next.empty()) break;
      count(sweep(comm, m, sk, next,
                  [&](const SpeedResult& R) {
                    keep(R);
                    if (R.status != 0)
                      print0(PETSC_COMM_SELF,
                             "morse sweep: omega %.10g rad/s failed (%s); its chain goes on from rest at the next "
                             "speed\n",
                             R.omega, R.error.c_str());
                    on_result(R);
                  }),
            next.size());
    }
    return st;
  }
  std::vector<SpeedTask> again;  // rank 0: the failures of the current pass that may retry
  auto run = [&](const std::vector<SpeedTask>& tasks, int halvings) {
    SweepSettings sh = s;
    sh.base.dt = std::ldexp(s.base.dt, -halvings);
    count(sweep(comm, m, sh, tasks,
                [&](const SpeedResult& R) {
                  keep(R);
                  if (R.status != 0 && R.halvings < so.retries) {
                    print0(PETSC_COMM_SELF,
                           "morse sweep: omega %.10g rad/s failed at dt %.4g s (%s); it runs again at dt %.4g s\n",
                           R.omega, R.dt, R.error.c_str(), 0.5 * R.dt);
                    again.push_back({R.index, R.omega, R.halvings + 1});
                  }
                  on_result(R);
                }),
          tasks.size());
  };
  // The retries a resumed file still owes run first, with the grid's speeds not yet run.
  {
    std::vector<SpeedTask> owed;
    if (rank == 0) owed = so.retry(*done);
    owed = share_tasks(comm, owed);
    todo.insert(todo.end(), owed.begin(), owed.end());
  }
  for (int round = 0;; ++round) {
    if (!todo.empty() && round > 0) print0(comm, "morse sweep: refinement round %d: %zu speeds\n", round, todo.size());
    // The tasks by step (halvings), the largest step first; the failures of each pass join the
    // next one at half their step.
    while (!todo.empty()) {
      int level = todo.front().halvings;
      for (const auto& t : todo) level = std::min(level, t.halvings);
      std::vector<SpeedTask> now, later;
      for (const auto& t : todo) (t.halvings == level ? now : later).push_back(t);
      if (level > 0)
        print0(comm, "morse sweep: %zu speed(s) at dt %.4g s (the step halved %d time(s))\n", now.size(),
               std::ldexp(s.base.dt, -level), level);
      again.clear();
      run(now, level);
      std::sort(again.begin(), again.end(), [](const SpeedTask& a, const SpeedTask& b) { return a.index < b.index; });
      const auto retried = share_tasks(comm, again);
      later.insert(later.end(), retried.begin(), retried.end());
      todo = std::move(later);
    }
    // The next round, decided on rank 0 (which holds the results) and shared.
    std::vector<SpeedTask> next;
    if (rank == 0) next = so.refine(*done, freqs);
    todo = share_tasks(comm, next);
    if (todo.empty()) break;
  }
  return st;
}

std::vector<std::vector<long>> SweepOptions::chain_order() const {
  // Both: the up chains on indices 0..n-1, the down chains on n..2n-1 (the same speeds).
  const long n = grid_speeds(), k = std::max<long>(1, std::min<long>(chains, n));
  std::vector<std::vector<long>> out;
  for (int d : continuation == 2 ? std::vector<int>{1, -1} : std::vector<int>{continuation}) {
    const long offset = continuation == 2 && d < 0 ? n : 0;
    for (long c = 0; c < k; ++c) {
      std::vector<long> o;
      for (long i = c * n / k; i < (c + 1) * n / k; ++i) o.push_back(offset + i);
      if (d < 0) std::reverse(o.begin(), o.end());
      out.push_back(std::move(o));
    }
  }
  return out;
}

std::vector<SpeedTask> SweepOptions::next_in_chains(const std::vector<SpeedResult>& done) const {
  std::map<long, const SpeedResult*> by_index;
  for (const auto& R : done) by_index[R.index] = &R;
  std::vector<SpeedTask> out;
  for (const auto& order : chain_order()) {
    std::size_t p = 0;
    while (p < order.size() && by_index.count(order[p])) ++p;
    if (p == order.size()) continue;
    SpeedTask t;
    t.index = order[p];
    t.omega = omega_of(t.index);
    if (p > 0) {
      const SpeedResult& prev = *by_index[order[p - 1]];
      if (prev.status == 0 && !prev.q_end.empty())
        t.q0 = prev.q_end, t.qm0 = prev.qm_end, t.phase = prev.phase_end, t.from = prev.index;
    }
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<SpeedTask> SweepOptions::refine(const std::vector<SpeedResult>& done,
                                            const std::vector<double>& freqs) const {
  std::vector<SpeedTask> out;
  if (!(refine_step > 0)) return out;
  std::vector<const SpeedResult*> by_index;
  for (const auto& R : done) by_index.push_back(&R);
  std::sort(by_index.begin(), by_index.end(),
            [](const SpeedResult* x, const SpeedResult* y) { return x->index < y->index; });
  // A local maximum of the RMS (an interaction) is located to the fine step: both intervals
  // beside it are bisected even if its neighbours are alike.
  const std::size_t n = by_index.size();
  auto peak = [&](std::size_t k) {
    const SpeedResult& x = *by_index[k];
    if (x.status != 0) return false;
    const bool left = k == 0 || by_index[k - 1]->status != 0 || by_index[k - 1]->rms < x.rms;
    const bool right = k + 1 == n || by_index[k + 1]->status != 0 || by_index[k + 1]->rms < x.rms;
    return left && right && n > 1;
  };
  // -sweep_refine_orders: each listed line's amplitude (NaN: not measured), its floor, its peaks.
  std::vector<double> floor_of(refine_orders.size(), 0.0);
  auto line = [&](std::size_t k, std::size_t j) {
    const SpeedResult& x = *by_index[k];
    const auto o = static_cast<std::size_t>(refine_orders[j] - 1);
    return x.status == 0 && o < x.orders.size() && std::isfinite(x.orders[o]) ? x.orders[o] : std::nan("");
  };
  for (std::size_t j = 0; j < refine_orders.size(); ++j) {
    for (std::size_t k = 0; k < n; ++k)
      if (std::isfinite(line(k, j))) floor_of[j] = std::max(floor_of[j], line(k, j));
    floor_of[j] *= refine_order_floor;
  }
  auto line_peak = [&](std::size_t k) {
    for (std::size_t j = 0; j < refine_orders.size(); ++j) {
      const double x = line(k, j);
      if (!(x > 0 && x >= floor_of[j]) || n < 2) continue;
      const bool left = k == 0 || !(line(k - 1, j) >= x);  // a failed or unmeasured neighbour is lower
      const bool right = k + 1 == n || !(line(k + 1, j) >= x);
      if (left && right) return true;
    }
    return false;
  };
  auto lines_differ = [&](std::size_t k) {
    const SpeedResult &a = *by_index[k], &b = *by_index[k + 1];
    if ((a.status != 0) != (b.status != 0)) return true;
    for (std::size_t j = 0; j < refine_orders.size(); ++j) {
      const double x = line(k, j), y = line(k + 1, j);
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      const double big = std::max(x, y);
      if (big > 0 && big >= floor_of[j] && std::abs(x - y) > refine_order_jump * big) return true;
    }
    return false;
  };
  const bool by_lines = !refine_orders.empty();
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const SpeedResult &a = *by_index[k], &b = *by_index[k + 1];
    if (b.index - a.index < 2) continue;
    if (by_lines ? !line_peak(k) && !line_peak(k + 1) && !lines_differ(k)
                 : !peak(k) && !peak(k + 1) && !speeds_differ(a, b, freqs, refine_rms, refine_frequency))
      continue;
    const long mid = (a.index + b.index) / 2;
    out.push_back({mid, rotation * (omega_min + static_cast<double>(mid) * refine_step)});
  }
  return out;
}

std::string settings_difference(const std::string& stored, const std::string& now) {
  // key=value lines; the reduced model compared as the same file (a checkpoint written with a
  // relative -rom resumes with the absolute path of the same file, and the reverse).
  auto parse = [](const std::string& t) {
    std::map<std::string, std::string> kv;
    std::istringstream in(t);
    std::string line;
    while (std::getline(in, line)) {
      const auto eq = line.find('=');
      if (eq != std::string::npos) kv[line.substr(0, eq)] = line.substr(eq + 1);
    }
    return kv;
  };
  const auto a = parse(stored), b = parse(now);
  std::set<std::string> keys;
  for (const auto& [k, v] : a) keys.insert(k);
  for (const auto& [k, v] : b) keys.insert(k);
  std::string diff;
  for (const auto& k : keys) {
    const auto ia = a.find(k), ib = b.find(k);
    const std::string va = ia == a.end() ? "(none)" : ia->second, vb = ib == b.end() ? "(none)" : ib->second;
    if (va == vb || (k == "rom" && ia != a.end() && ib != b.end() && files::same_file(va, vb))) continue;
    diff += cat(diff.empty() ? "" : "; ", k, ": ", va, " in the file, ", vb, " now");
  }
  return diff;
}

std::vector<std::int64_t> resume_sweep(MPI_Comm comm, const std::string& out, bool restart, SweepRecord* rec) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  std::string err;
  std::vector<std::int64_t> done_idx;
  if (rank == 0 && !restart) {
    SweepRecord old;
    std::string why;
    if (read_sweep(out, &old, &why)) {
      const std::string differ = settings_difference(old.settings, rec->settings);
      if (!differ.empty())
        err = cat(out, " holds a sweep with other settings (", differ,
                  "); give another -out, or -sweep_restart to overwrite it");
      else if (old.n_speeds != rec->n_speeds)
        err = cat(out, ": /sweep@n_speeds is ", old.n_speeds, " but the options give ", rec->n_speeds,
                  " speeds: the sweep checkpoint is corrupt; give another -out, or -sweep_restart to overwrite it");
      else {
        rec->results = old.results;
        for (const auto& R : old.results) done_idx.push_back(R.index);
      }
    } else if (why.find("no such file") == std::string::npos) {
      err = cat(why, "; give another -out, or -sweep_restart to overwrite it");
    }
  }
  // The first checkpoint also proves that -out is writable before any speed runs.
  if (rank == 0 && err.empty()) {
    try {
      write_sweep(out, *rec);
    } catch (const std::exception& e) {
      err = cat("morse sweep: cannot write -out ", out, ": ", message_of(e));
    }
  }
  collective_check(comm, err);
  long nd = static_cast<long>(done_idx.size());
  MPI_Bcast(&nd, 1, MPI_LONG, 0, comm);
  done_idx.resize(static_cast<std::size_t>(nd));
  MPI_Bcast(done_idx.data(), static_cast<int>(nd), MPI_INT64_T, 0, comm);
  return done_idx;
}

PetscErrorCode StressOptions::set_from_options(MPI_Comm comm) {
  StressOptions* o = this;
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse stress options", "");
  PetscCall(MorseOptionsString("-rom", "Reduced model: the morse nlrom file of the simulation", "", buf, buf,
                               sizeof buf, &set));
  if (set) o->rom = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-sim", "A morse simulate file (/sim/time, /sim/q)", "", buf, buf, sizeof buf, &set));
  if (set) o->sim = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-fom",
                               "A morse fom file with snapshots (-fom_snapshot_every): the stress of its snapshot "
                               "nearest -stress_time, instead of -rom and -sim",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->fom = buf;
  PetscCall(MorseOptionsReal("-stress_time",
                             "Time [s] of the stress (the nearest stored step); default: the time of "
                             "the largest |radial displacement| at -stress_monitor",
                             "", o->time, &o->time, &o->time_set));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-stress_monitor",
                               "Node set of one node whose largest radial displacement picks the time", "",
                               o->monitor.c_str(), buf, sizeof buf, &set));
  if (set) o->monitor = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-stress_measure",
                               "linear (small strain) | nonlinear (Cauchy stress of St Venant-Kirchhoff); default: "
                               "as the simulation (its /sim attribute linear)",
                               "", "", buf, sizeof buf, &set));
  if (set) o->measure = buf;
  PetscCall(MorseOptionsBool("-stress_xdmf", "Write an XDMF file for ParaView next to the HDF5 file", "", o->xdmf,
                             &o->xdmf, nullptr));
  PetscOptionsEnd();
  if (!(o->measure.empty() || o->measure == "linear" || o->measure == "nonlinear"))
    o->error = cat("-stress_measure ", o->measure, ": unknown (linear or nonlinear)");
  return PETSC_SUCCESS;
}

StressState stress_state(MPI_Comm comm, const StressOptions& so, const nlrom::StoredModel& sm) {
  StressState st;
  const std::size_t r = sm.r();
  const std::vector<double> radial = so.time_set ? std::vector<double>{} : sm.radial_row(so.monitor, "-stress_monitor");

  // Rank 0 reads the simulation and picks the state: the stored time nearest -stress_time, or the
  // largest |u_r| at the monitor node. The others receive that state only.
  std::string err;
  double linear = 0.0, ur = 0.0, t_step = 0.0;
  std::int64_t step = 0, nt = 0;
  std::vector<double> q_step(r);
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0) {
    std::vector<double> time, q;
    std::vector<hsize_t> dt, dq;
    if (io::read_doubles(so.sim, "/sim/time", &time, &dt, &err) && io::read_doubles(so.sim, "/sim/q", &q, &dq, &err) &&
        so.measure.empty() && !io::read_attribute(so.sim, "/sim", "linear", &linear, &err))
      err = cat(err, " (give -stress_measure)");
    if (err.empty() && (dq.size() != 2 || dq[0] != time.size() || time.empty()))
      err = cat(so.sim, ": /sim/q and /sim/time disagree (a morse simulate file is expected)");
    else if (err.empty() && dq[1] != r)
      err = cat(so.sim, " has ", dq[1], " reduced coordinates; ", so.rom, " has r = ", r,
                " (not the model of this simulation)");
    else if (err.empty() && so.time_set && !(so.time >= time.front() - 1e-12 && so.time <= time.back() + 1e-12))
      err = cat("-stress_time ", so.time, " s lies outside the simulation [", time.front(), ", ", time.back(), "] s");
    if (err.empty()) {
      nt = static_cast<std::int64_t>(time.size());
      for (std::int64_t i = 0; i < nt; ++i) {
        if (so.time_set) {
          if (std::abs(time[i] - so.time) < std::abs(time[step] - so.time)) step = i;
          continue;
        }
        double v = 0.0;
        for (std::size_t j = 0; j < r; ++j) v += radial[j] * q[static_cast<std::size_t>(i) * r + j];
        if (std::abs(v) > std::abs(ur)) ur = v, step = i;
      }
      t_step = time[step];
      std::copy_n(&q[static_cast<std::size_t>(step) * r], r, q_step.begin());
    }
  }
  collective_check(comm, err);
  double scalars[3] = {linear, ur, t_step};
  std::int64_t ints[2] = {step, nt};
  MPI_Bcast(scalars, 3, MPI_DOUBLE, 0, comm);
  MPI_Bcast(ints, 2, MPI_INT64_T, 0, comm);
  MPI_Bcast(q_step.data(), static_cast<int>(r), MPI_DOUBLE, 0, comm);
  st.radial = scalars[1], st.time = scalars[2], st.step = ints[0], st.n_steps = ints[1];
  st.measure = so.measure.empty()       ? (scalars[0] != 0.0 ? StressMeasure::Linear : StressMeasure::Nonlinear)
               : so.measure == "linear" ? StressMeasure::Linear
                                        : StressMeasure::Nonlinear;
  st.q = std::move(q_step);
  return st;
}

void nodal_fields(const std::vector<std::int64_t>& node_ids, const std::vector<double>& u, const mesh::Mesh& gm,
                  const StressField& f, StressRecord* rec) {
  std::map<std::int64_t, std::size_t> row;
  for (std::size_t k = 0; k < node_ids.size(); ++k) row[node_ids[k]] = k;
  const std::size_t nn = gm.node_ids.size();
  rec->displacement.assign(3 * nn, 0.0);
  rec->max_node_id = -1;
  rec->max_nodal_von_mises = 0.0;
  for (std::size_t g = 0; g < nn; ++g) {
    const std::size_t k = row.at(gm.node_ids[g]);  // recover_stress checked every node
    for (int c = 0; c < 3; ++c) rec->displacement[3 * g + c] = u[3 * k + c];
    if (f.nodal_mises[g] > rec->max_nodal_von_mises)
      rec->max_nodal_von_mises = f.nodal_mises[g], rec->max_node_id = gm.node_ids[g];
  }
}

SnapshotPlan read_snapshot_plan(MPI_Comm comm, const std::string& fom, const nlrom::StoredModel& sm) {
  SnapshotPlan plan;
  plan.fom = fom;
  std::string err;
  try {
    std::vector<hsize_t> d;
    if (!io::read_doubles(fom, "/fom/snapshots/time", &plan.time, &d, &err) ||
        !io::read_ints(fom, "/fom/snapshots/dof_node_ids", &plan.ids, &d, &err) ||
        !io::read_ints(fom, "/fom/snapshots/dof_components", &plan.comps, &d, &err))
      err = cat("-sim_snapshots: ", err, " (a morse fom file run with -fom_snapshot_every K is expected)");
    else
      plan.rows = sm.dof_rows(plan.ids, plan.comps);
  } catch (const std::exception& e) {
    err = cat("-sim_snapshots ", fom, ": ", message_of(e));
  }
  collective_check(comm, err);
  return plan;
}

Stats simulate(const nlrom::StoredModel& sm, const std::vector<dyn::NodalLoad>& nodal, const Settings& s, long every,
               const std::vector<std::string>& monitor, const std::string& contact_set, const SnapshotPlan& plan,
               SimRecord* out) {
  const std::size_t r = sm.r();
  {
    // The histories grow with the output rows: refuse a run whose record cannot fit before it
    // starts (10^9 steps written every step ended in std::bad_alloc hours into the run). A row:
    // time, energy, q, the monitored displacements, the contact quantities, the snapshots.
    MORSE_CHECK(s.dt > 0 && std::isfinite(s.t_final / s.dt), "simulate: -sim_dt ", s.dt, " s must be > 0");
    const double steps = std::ceil(s.t_final / s.dt - 1e-9), rows = std::floor(steps / every) + 1;
    double per_row = 2.0 + static_cast<double>(r);
    for (const auto& m : monitor) per_row += 3.0 * static_cast<double>(sm.sets.at(m).size());
    per_row += 10.0 * static_cast<double>(s.contact.nodes.size());
    const double bytes = 8.0 * (rows * per_row + 2.0 * static_cast<double>(plan.time.size() * plan.rows.size()));
    const std::string err = memory_error(cat("simulate: writing ", static_cast<long long>(rows), " output rows (",
                                             static_cast<long long>(steps), " steps, -sim_output_every ", every, ")"),
                                         bytes, cat("the histories (r = ", r, ")"));
    MORSE_CHECK(err.empty(), err, ": raise -sim_output_every or shorten -sim_tfinal");
  }
  std::vector<ReducedLoad> loads;
  for (const auto& l : nodal) {
    ReducedLoad rl;
    rl.amplitude = l.amplitude, rl.omega = l.omega, rl.phase = l.phase;
    rl.p = sm.nodal_pattern(l.set, l.dir);
    loads.push_back(std::move(rl));
  }
  std::vector<long> snap_step;
  for (double t : plan.time)
    if (t <= s.t_final * (1 + 1e-12)) snap_step.push_back(std::lround(t / s.dt));
  SimRecord& rec = *out;
  std::map<std::string, std::vector<double>> hist;
  // Contact at the output steps: normal force, friction vector, gap, radial displacement e_r . u.
  const auto& cn = s.contact.nodes;
  const std::size_t nc = cn.size();
  auto& cr = rec.contact;
  std::vector<double> e_r(3 * nc, 0.0);
  // The contact forces act for one step each: the mean force of every output interval (its
  // impulse over its length) keeps what the output samples alone would miss, so that the
  // history can drive another model (-load_history).
  if (nc) cr.normals = contact_normals(s.contact);
  const std::vector<double>& c_normal = cr.normals;
  std::vector<double> c_sum(3 * nc, 0.0);
  long c_count = 0;
  double t_prev_out = 0.0;
  for (std::size_t k = 0; k < nc; ++k) {
    const double rho = std::hypot(cn[k].x[0], cn[k].x[1]);
    if (rho > 0) e_r[3 * k] = cn[k].x[0] / rho, e_r[3 * k + 1] = cn[k].x[1] / rho;
  }
  // The energy balance, per revolution of the casing (t_final / 100 without one), from t = 0.
  auto& bal = rec.balance;
  const bool balance = s.scheme == Scheme::Central && s.energy_balance;
  const long last_step = detail::step_count(s.t_final, s.dt);
  bal.period = s.contact.obstacle == Obstacle::Casing && !s.contact.nodes.empty() && s.contact.casing.omega != 0
                   ? 2.0 * M_PI / std::abs(s.contact.casing.omega)
                   : s.t_final / 100.0;
  double next_balance = 0.0;
  std::size_t next_snap = 0;
  auto stats = integrate(sm.model, loads, s, [&](const StepState& x) {
    // (A boundary within a step of the end gives way to the end's row.)
    if (balance && x.work && (x.step == last_step || (x.t >= next_balance - 0.5 * s.dt && x.step + 1 < last_step))) {
      bal.time.push_back(x.t);
      bal.energy.push_back(x.balance_energy());
      bal.external.push_back(x.work->external);
      bal.normal.push_back(x.work->normal);
      bal.friction.push_back(x.work->friction);
      bal.damping.push_back(x.work->damping);
      while (next_balance <= x.t + 0.5 * s.dt) next_balance += bal.period;
    }
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
      if (x.contact_normal[k] > cr.max_normal_force)
        cr.max_normal_force = x.contact_normal[k], cr.time_of_max_normal_force = x.t;
    if (nc && x.step > 0) {
      for (std::size_t k = 0; k < nc; ++k)
        for (int d = 0; d < 3; ++d)
          c_sum[3 * k + d] += x.contact_normal[k] * c_normal[3 * k + d] + x.contact_friction[3 * k + d];
      ++c_count;
    }
    if (x.step % every != 0) return;
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
    for (const auto& m : monitor) sm.displacements(m, x.q, &hist[m]);
  });
  for (const auto& m : monitor) {
    std::vector<std::int64_t> ids;
    for (auto k : sm.sets.at(m)) ids.push_back(sm.node_ids[k]);
    rec.sets.push_back({m, std::move(ids), hist[m]});
  }
  if (!plan.fom.empty()) {
    rec.snapshots_fom = plan.fom;
    rec.snapshot_node_ids = plan.ids;
    rec.snapshot_components = plan.comps;
  }
  if (nc)
    for (auto k : sm.sets.at(contact_set)) cr.node_ids.push_back(sm.node_ids[k]);
  rec.load.loads = nodal;
  return stats;
}

void run_cases(MPI_Comm comm, const std::vector<std::string>& names, const std::function<void(std::size_t)>& task) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  std::string err;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (static_cast<int>(i % size) != rank) continue;
    try {
      task(i);
    } catch (const std::exception& e) {
      err +=
          (err.empty() ? "" : "; ") + (names[i].empty() ? message_of(e) : cat("case ", names[i], ": ", message_of(e)));
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
}

}  // namespace morse::sim
