// app/cmd_rampup.cpp: `morse rampup`, seed 000 §3's benchmark load case: stator superelements
// (morse reduce / select files) in a rotor–stator assembly, unbalance speed ramp-up, bearing loads
// (morse::rampup). Options describe the engine (run/engine.opts documents every one); every rank
// reads and checks them and builds the model (small), rank 0 integrates and writes /rampup.
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/io/h5.hpp"
#include "morse/rampup/rampup.hpp"

namespace morse::app::detail {

namespace {

constexpr double kRpm = 2.0 * M_PI / 60.0;  // rad/s per rpm

// The engine as the options give it, names unresolved (resolved and checked in build()).
struct StatorOpt {
  std::string name, file;
  std::vector<std::string> clamp;
  double cut_hz = -1, damping_ratio = -1;
};
struct DiskOpt {
  std::string name;
  double z = 0, mass = 0, Ip = 0, Id = 0;
};
struct RotorOpt {
  std::string name;
  std::vector<double> z, d_outer, d_inner;
  rampup::Material mat;
  double speed_ratio = 1, alpha = 0, beta = 0;
  std::vector<std::string> disks;
};
struct BearingOpt {
  std::string name, rotor, stator = "ground";
  double z = 0;
  std::vector<std::string> nodes;
  std::vector<double> k, c;
};
struct RampupOptions {
  std::string out = "rampup.h5", reference;
  std::vector<StatorOpt> stators;
  std::vector<RotorOpt> rotors;
  std::map<std::string, DiskOpt> disks;
  std::vector<BearingOpt> bearings;
  std::vector<std::string> unbalance_disks;
  std::vector<double> unbalance_me, unbalance_phase_deg;
  double rpm_max = 0, ramp_time = 0, dt = 0, t_final = 0, alpha = 0, cut_factor = 2.5;
  double matrices_rpm = -1;
  PetscInt output_every = 1;
  PetscBool constant = PETSC_FALSE, dense = PETSC_FALSE, write_matrices = PETSC_TRUE;
  std::string error;  ///< first bad value, naming the option
};

PetscErrorCode get_list(PetscOptionItems* PetscOptionsObject, const std::string& name, const char* help, std::vector<std::string>* out) {
  char* v[256];
  PetscInt n = 256;
  PetscBool set = PETSC_FALSE;
  PetscCall(MorseOptionsStringArray(name.c_str(), help, "", v, &n, &set));
  if (set)
    for (PetscInt i = 0; i < n; ++i) {
      out->emplace_back(v[i]);
      PetscCall(PetscFree(v[i]));
    }
  return PETSC_SUCCESS;
}

PetscErrorCode get_reals(PetscOptionItems* PetscOptionsObject, const std::string& name, const char* help, std::vector<double>* out, PetscBool* set) {
  std::vector<PetscReal> v(4096);
  PetscInt n = static_cast<PetscInt>(v.size());
  PetscCall(MorseOptionsRealArray(name.c_str(), help, "", v.data(), &n, set));
  if (*set) out->assign(v.begin(), v.begin() + n);
  return PETSC_SUCCESS;
}

PetscErrorCode get_string(PetscOptionItems* PetscOptionsObject, const std::string& name, const char* help, std::string* out, PetscBool* set) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscCall(MorseOptionsString(name.c_str(), help, "", out->c_str(), buf, sizeof buf, set));
  if (*set) *out = buf;
  return PETSC_SUCCESS;
}

PetscErrorCode get_rampup_options(MPI_Comm comm, RampupOptions* o) {
  PetscBool set = PETSC_FALSE;
  auto fail = [&](const std::string& msg) {
    if (o->error.empty()) o->error = msg;
  };
  std::vector<std::string> stators, rotors, bearings;
  PetscOptionsBegin(comm, nullptr, "morse rampup options (run/engine.opts documents every one)", "");
  PetscCall(get_string(PetscOptionsObject, "-out", "Output HDF5 file", &o->out, &set));
  PetscCall(get_list(PetscOptionsObject, "-rampup_stators", "Stator superelements, by name (each: -rampup_stator_<name>_*)", &stators));
  PetscCall(get_list(PetscOptionsObject, "-rampup_rotors", "Rotors, by name (each: -rampup_rotor_<name>_*)", &rotors));
  PetscCall(get_list(PetscOptionsObject, "-rampup_bearings", "Bearings, by name (each: -rampup_bearing_<name>_*)", &bearings));
  for (const auto& s : stators) {
    StatorOpt so;
    so.name = s;
    const std::string p = "-rampup_stator_" + s + "_";
    PetscCall(get_string(PetscOptionsObject, p + "file", "Superelement file (/rom of morse reduce or select)", &so.file, &set));
    if (!set) fail(cat("stator ", s, ": give its superelement file with ", p, "file"));
    PetscCall(get_list(PetscOptionsObject, p + "clamp", "Interface nodes clamped in the assembly: node ids or node sets", &so.clamp));
    PetscCall(MorseOptionsReal((p + "cut_hz").c_str(),
                               "Truncation frequency of its modal basis [Hz] (default: -rampup_cut_factor x the top "
                               "spin frequency)",
                               "", so.cut_hz, &so.cut_hz, &set));
    if (set && !(so.cut_hz > 0)) fail(cat(p, "cut_hz ", so.cut_hz, " must be > 0"));
    PetscCall(MorseOptionsReal((p + "damping_ratio").c_str(),
                               "Modal damping ratio of its modes (default: the superelement's C, 0 without)", "",
                               so.damping_ratio, &so.damping_ratio, &set));
    if (set && !(so.damping_ratio >= 0 && so.damping_ratio < 1))
      fail(cat(p, "damping_ratio ", so.damping_ratio, " must be in [0, 1)"));
    o->stators.push_back(so);
  }
  for (const auto& r : rotors) {
    RotorOpt ro;
    ro.name = r;
    const std::string p = "-rampup_rotor_" + r + "_";
    PetscCall(get_reals(PetscOptionsObject, p + "z", "Station positions along the axis z [m], increasing", &ro.z, &set));
    if (!set) fail(cat("rotor ", r, ": give its stations with ", p, "z z0,z1,..."));
    PetscCall(get_reals(PetscOptionsObject, p + "d_outer", "Outer diameter [m]: one value, or one per element", &ro.d_outer, &set));
    if (!set && ro.z.size() > 1) fail(cat("rotor ", r, ": give its shaft diameter with ", p, "d_outer"));
    PetscCall(get_reals(PetscOptionsObject, p + "d_inner", "Inner diameter [m] (hollow shaft): one value or one per element",
                        &ro.d_inner, &set));
    PetscCall(MorseOptionsReal((p + "E").c_str(), "Young's modulus [Pa]", "", ro.mat.E, &ro.mat.E, nullptr));
    PetscCall(MorseOptionsReal((p + "nu").c_str(), "Poisson ratio", "", ro.mat.nu, &ro.mat.nu, nullptr));
    PetscCall(MorseOptionsReal((p + "rho").c_str(), "Density [kg/m^3]", "", ro.mat.rho, &ro.mat.rho, nullptr));
    PetscCall(MorseOptionsReal((p + "speed_ratio").c_str(), "Spin speed / driving speed (negative: counter-rotating)",
                               "", ro.speed_ratio, &ro.speed_ratio, nullptr));
    std::vector<double> ab;
    PetscCall(get_reals(PetscOptionsObject, p + "rayleigh", "Rayleigh damping alpha [1/s],beta [s] of the rotor", &ab, &set));
    if (set) {
      if (ab.size() != 2)
        fail(cat(p, "rayleigh needs two values alpha,beta"));
      else
        ro.alpha = ab[0], ro.beta = ab[1];
    }
    PetscCall(get_list(PetscOptionsObject, p + "disks", "Rigid disks on this rotor, by name (each: -rampup_disk_<name>_*)", &ro.disks));
    for (const auto& d : ro.disks) {
      if (o->disks.count(d)) fail(cat("disk ", d, " is listed twice (disk names are unique across rotors)"));
      DiskOpt dk;
      dk.name = d;
      const std::string q = "-rampup_disk_" + d + "_";
      PetscCall(MorseOptionsReal((q + "z").c_str(), "Axial position [m] (a station of its rotor)", "", dk.z, &dk.z,
                                 &set));
      if (!set) fail(cat("disk ", d, ": give its position with ", q, "z"));
      PetscCall(MorseOptionsReal((q + "mass").c_str(), "Mass [kg]", "", dk.mass, &dk.mass, nullptr));
      PetscCall(MorseOptionsReal((q + "Ip").c_str(), "Polar moment of inertia [kg m^2]", "", dk.Ip, &dk.Ip, nullptr));
      PetscCall(MorseOptionsReal((q + "Id").c_str(), "Diametral moment of inertia [kg m^2]", "", dk.Id, &dk.Id,
                                 nullptr));
      if (!(dk.mass >= 0 && dk.Ip >= 0 && dk.Id >= 0))
        fail(cat("disk ", d, ": ", q, "mass, ", q, "Ip and ", q, "Id must be >= 0"));
      o->disks[d] = dk;
    }
    o->rotors.push_back(ro);
  }
  PetscCall(get_list(PetscOptionsObject, "-rampup_unbalance", "Disks carrying an unbalance", &o->unbalance_disks));
  PetscCall(get_reals(PetscOptionsObject, "-rampup_unbalance_me", "Unbalance mass x eccentricity [kg m], one per disk", &o->unbalance_me,
                      &set));
  PetscCall(get_reals(PetscOptionsObject, "-rampup_unbalance_phase_deg", "Unbalance angle from +x at t = 0 [deg], one per disk",
                      &o->unbalance_phase_deg, &set));
  for (const auto& b : bearings) {
    BearingOpt bo;
    bo.name = b;
    const std::string p = "-rampup_bearing_" + b + "_";
    PetscCall(get_string(PetscOptionsObject, p + "rotor", "Rotor", &bo.rotor, &set));
    if (!set) fail(cat("bearing ", b, ": give its rotor with ", p, "rotor"));
    PetscCall(MorseOptionsReal((p + "z").c_str(), "Axial position [m] (a station of the rotor)", "", bo.z, &bo.z,
                               &set));
    if (!set) fail(cat("bearing ", b, ": give its position with ", p, "z"));
    PetscCall(get_string(PetscOptionsObject, p + "stator", "Stator it sits in, or ground", &bo.stator, &set));
    PetscCall(get_list(PetscOptionsObject, p + "nodes", "Housing nodes of the stator (ids or node sets; several: their mean)", &bo.nodes));
    PetscCall(get_reals(PetscOptionsObject, p + "k", "Stiffness kxx[,kyy] [N/m]", &bo.k, &set));
    if (!set) fail(cat("bearing ", b, ": give its stiffness with ", p, "k kxx[,kyy]"));
    PetscCall(get_reals(PetscOptionsObject, p + "c", "Damping cxx[,cyy] [N s/m]", &bo.c, &set));
    if (bo.k.size() > 2 || bo.c.size() > 2) fail(cat("bearing ", b, ": ", p, "k and ", p, "c take 1 or 2 values"));
    o->bearings.push_back(bo);
  }
  PetscCall(MorseOptionsReal("-rampup_rpm_max", "Top driving speed [rpm]", "", o->rpm_max, &o->rpm_max, nullptr));
  PetscCall(MorseOptionsReal("-rampup_ramp_time", "Ramp duration 0 -> top speed [s]", "", o->ramp_time, &o->ramp_time,
                             nullptr));
  PetscCall(MorseOptionsBool("-rampup_constant_speed", "Constant top speed from t = 0 instead of the ramp", "",
                             o->constant, &o->constant, nullptr));
  PetscCall(MorseOptionsReal("-rampup_dt", "Time step [s]", "", o->dt, &o->dt, nullptr));
  PetscCall(MorseOptionsReal("-rampup_t_final", "End time [s] (default: the ramp time)", "", o->t_final, &o->t_final,
                             nullptr));
  PetscCall(MorseOptionsReal("-rampup_alpha", "HHT alpha in [-1/3, 0] (0: Newmark average acceleration)", "",
                             o->alpha, &o->alpha, nullptr));
  PetscCall(MorseOptionsInt("-rampup_output_every", "Write every K-th step", "", o->output_every, &o->output_every,
                            nullptr));
  PetscCall(MorseOptionsReal("-rampup_cut_factor",
                             "Stator modal bases keep the modes below this factor x the top spin frequency", "",
                             o->cut_factor, &o->cut_factor, nullptr));
  PetscCall(MorseOptionsBool("-rampup_dense", "Dense LU of the whole effective matrix every step (reference, O(n^3))",
                             "", o->dense, &o->dense, nullptr));
  PetscCall(MorseOptionsBool("-rampup_write_matrices", "Write the assembled M, C, K, G to /rampup/matrices", "",
                             o->write_matrices, &o->write_matrices, nullptr));
  PetscCall(get_string(PetscOptionsObject, "-rampup_reference",
                       "A morse rampup file of the same engine: report seed 000's eq. 24 errors against it",
                       &o->reference, &set));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

// Index of station z of a rotor (within 1e-9 of the rotor's length), or throws naming `who`.
int station_of(const rampup::RotorSpec& r, double z, const std::string& who) {
  const double tol = 1e-9 * std::max(1.0, std::abs(r.z.back() - r.z.front()));
  for (std::size_t i = 0; i < r.z.size(); ++i)
    if (std::abs(r.z[i] - z) <= tol) return static_cast<int>(i);
  std::string list;
  for (double v : r.z) list += cat(list.empty() ? "" : ",", v);
  throw Error(cat(who, " z = ", z, " is not a station of rotor '", r.name, "' (stations: ", list, ")"));
}

struct Engine {
  std::vector<rampup::RotorSpec> rotors;
  std::vector<rampup::StatorModes> stators;
  std::vector<rampup::Bearing> bearings;
  std::vector<int> stator_n_b;  ///< boundary DOFs of each superelement
};

Engine build(MPI_Comm comm, const RampupOptions& o, double omega_max) {
  Engine e;
  MORSE_CHECK(!o.rotors.empty(), "morse rampup: no rotor: give -rampup_rotors NAME[,NAME] (see run/engine.opts)");
  for (const auto& ro : o.rotors) {
    rampup::RotorSpec r;
    r.name = ro.name;
    r.z = ro.z;
    const std::size_t ne = r.z.size() > 1 ? r.z.size() - 1 : 0;
    const std::string p = "-rampup_rotor_" + ro.name + "_";
    MORSE_CHECK(ro.d_outer.size() <= 1 || ro.d_outer.size() == ne, p, "d_outer has ", ro.d_outer.size(),
                " values: give 1 or one per element (", ne, ")");
    MORSE_CHECK(ro.d_inner.size() <= 1 || ro.d_inner.size() == ro.d_outer.size(), p, "d_inner has ",
                ro.d_inner.size(), " values: give 1 or as many as ", p, "d_outer");
    for (std::size_t k = 0; k < ro.d_outer.size(); ++k)
      r.sections.push_back({ro.d_outer[k], ro.d_inner.empty() ? 0.0 : ro.d_inner[ro.d_inner.size() == 1 ? 0 : k],
                            ro.mat});
    r.speed_ratio = ro.speed_ratio;
    r.rayleigh_alpha = ro.alpha;
    r.rayleigh_beta = ro.beta;
    for (const auto& dn : ro.disks) {
      const DiskOpt& d = o.disks.at(dn);
      r.disks.push_back({dn, station_of(r, d.z, cat("-rampup_disk_", dn, "_z:")), d.mass, d.Ip, d.Id});
    }
    e.rotors.push_back(std::move(r));
  }
  MORSE_CHECK(o.unbalance_me.size() == o.unbalance_disks.size(), "-rampup_unbalance_me has ", o.unbalance_me.size(),
              " values for ", o.unbalance_disks.size(), " disks of -rampup_unbalance");
  MORSE_CHECK(o.unbalance_phase_deg.empty() || o.unbalance_phase_deg.size() == o.unbalance_disks.size(),
              "-rampup_unbalance_phase_deg has ", o.unbalance_phase_deg.size(), " values for ",
              o.unbalance_disks.size(), " disks of -rampup_unbalance");
  for (std::size_t u = 0; u < o.unbalance_disks.size(); ++u) {
    const std::string& dn = o.unbalance_disks[u];
    auto it = std::find_if(o.rotors.begin(), o.rotors.end(), [&](const RotorOpt& r) {
      return std::find(r.disks.begin(), r.disks.end(), dn) != r.disks.end();
    });
    std::string all;
    for (const auto& kv : o.disks) all += (all.empty() ? "" : ", ") + kv.first;
    MORSE_CHECK(it != o.rotors.end(), "-rampup_unbalance ", dn, ": no such disk (disks: ",
                all.empty() ? "none" : all, ")");
    MORSE_CHECK(o.unbalance_me[u] >= 0, "-rampup_unbalance_me ", o.unbalance_me[u], " must be >= 0");
    const double ph = o.unbalance_phase_deg.empty() ? 0.0 : o.unbalance_phase_deg[u] * M_PI / 180.0;
    e.rotors[it - o.rotors.begin()].unbalances.push_back({dn, o.unbalance_me[u], ph});
  }
  for (const auto& r : e.rotors) rampup::rotor_matrices(r);  // validates each rotor, naming it
  const double cut_default = rampup::default_cut_hz(e.rotors, omega_max, o.cut_factor);
  {
    StageTimer t(comm, "StatorModes");
    for (const auto& so : o.stators) {
      MORSE_CHECK(std::ifstream(so.file).good(), "-rampup_stator_", so.name, "_file ", so.file,
                  ": no such file (make the superelement with morse reduce or morse select; for run/engine.opts, "
                  "run/rampup makes it)");
      auto se = rampup::read_superelement(so.file);
      const auto clamp = rampup::resolve_nodes(so.file, so.clamp, cat("-rampup_stator_", so.name, "_clamp"));
      auto sm = rampup::stator_modes(se, clamp, so.cut_hz > 0 ? so.cut_hz : cut_default, so.damping_ratio);
      sm.name = so.name;
      e.stators.push_back(std::move(sm));
      e.stator_n_b.push_back(se.n_b);
    }
  }
  for (const auto& bo : o.bearings) {
    rampup::Bearing b;
    b.name = bo.name;
    const std::string p = "-rampup_bearing_" + bo.name + "_";
    auto rit = std::find_if(e.rotors.begin(), e.rotors.end(), [&](const auto& r) { return r.name == bo.rotor; });
    MORSE_CHECK(rit != e.rotors.end(), p, "rotor ", bo.rotor, ": no such rotor (-rampup_rotors)");
    b.rotor = static_cast<int>(rit - e.rotors.begin());
    b.station = station_of(*rit, bo.z, p + "z:");
    if (bo.stator == "ground") {
      b.stator = -1;
      MORSE_CHECK(bo.nodes.empty(), p, "nodes: a bearing on the ground has no housing nodes");
    } else {
      auto sit = std::find_if(o.stators.begin(), o.stators.end(), [&](const auto& s) { return s.name == bo.stator; });
      MORSE_CHECK(sit != o.stators.end(), p, "stator ", bo.stator, ": no such stator (-rampup_stators) or ground");
      b.stator = static_cast<int>(sit - o.stators.begin());
      MORSE_CHECK(!bo.nodes.empty(), p, "nodes: give the housing nodes of the bearing in stator ", bo.stator);
      b.nodes = rampup::resolve_nodes(sit->file, bo.nodes, p + "nodes");
    }
    b.kxx = bo.k.empty() ? 0.0 : bo.k[0];
    b.kyy = bo.k.size() > 1 ? bo.k[1] : b.kxx;
    b.cxx = bo.c.empty() ? 0.0 : bo.c[0];
    b.cyy = bo.c.size() > 1 ? bo.c[1] : b.cxx;
    e.bearings.push_back(std::move(b));
  }
  return e;
}

}  // namespace

void run_rampup(MPI_Comm comm) {
  RampupOptions o;
  MORSE_CALL(get_rampup_options(comm, &o));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(o.error.empty(), o.error);
  MORSE_CHECK(o.rpm_max > 0, "-rampup_rpm_max must be > 0 (got ", o.rpm_max, ")");
  MORSE_CHECK(o.constant || o.ramp_time > 0, "-rampup_ramp_time must be > 0 (got ", o.ramp_time,
              "), or use -rampup_constant_speed");
  MORSE_CHECK(o.dt > 0, "-rampup_dt must be > 0 (got ", o.dt, ")");
  MORSE_CHECK(!o.constant || o.t_final > 0, "-rampup_constant_speed needs -rampup_t_final");
  MORSE_CHECK(o.output_every > 0, "-rampup_output_every must be positive (got ", o.output_every, ")");
  MORSE_CHECK(o.cut_factor > 0, "-rampup_cut_factor must be > 0 (got ", o.cut_factor, ")");

  rampup::LoadCase lc;
  lc.kind = o.constant ? rampup::LoadCase::Kind::Constant : rampup::LoadCase::Kind::Ramp;
  lc.omega_max = o.rpm_max * kRpm;
  lc.ramp_time = o.ramp_time;
  rampup::IntegratorSettings is;
  is.dt = o.dt;
  is.t_final = o.t_final;
  is.alpha = o.alpha;
  is.output_every = static_cast<int>(o.output_every);
  is.dense = o.dense;
  const double t_end = rampup::end_time(lc, is);
  MORSE_CHECK(t_end / o.dt < 5e8, "-rampup_dt ", o.dt, " s gives ", t_end / o.dt, " steps: too many");

  // Every rank builds the (small) model from the same options and files, so a bad input throws
  // the same error on every rank.
  Engine e = build(comm, o, lc.omega_max);
  const rampup::Assembly a = [&] {
    StageTimer t(comm, "Assembly");
    return rampup::Assembly(e.rotors, e.stators, e.bearings);
  }();
  print0(comm, "morse rampup: %zu rotor(s), %zu stator(s), %zu bearing(s); %d DOFs (%d stator modes + %d rotor)\n",
         e.rotors.size(), e.stators.size(), e.bearings.size(), a.n(), a.n_stator(), a.n_rotor());
  for (std::size_t s = 0; s < e.stators.size(); ++s) {
    const auto& sm = e.stators[s];
    print0(comm, "  stator %s: %d modes below %.1f Hz kept of %d (clamped %zu nodes, %zu free boundary DOFs)%s\n",
           sm.name.c_str(), sm.n_modes, sm.f_cut_hz, sm.n_total, sm.clamped_nodes.size(), sm.dof_node.size(),
           sm.n_modes ? cat(", ", sm.omega.front() / kTwoPi, "..", sm.omega.back() / kTwoPi, " Hz").c_str() : "");
  }
  print0(comm, "  %s to %.1f rpm in %g s, dt = %g s (%s%s)\n", o.constant ? "constant speed" : "ramp", o.rpm_max,
         o.constant ? o.t_final : o.ramp_time, o.dt, o.alpha == 0 ? "Newmark average acceleration" : "HHT-alpha",
         o.dense ? ", dense reference step" : "");

  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  rampup::History h;
  rampup::IntegratorStats st;
  std::string err;
  {
    StageTimer t(comm, "Integrate");
    if (rank == 0) try {
        Progress prog(PETSC_COMM_SELF, "rampup", 1.0);
        h = rampup::record(a, lc, is, &st, [&](double f) { prog.update(f); });
      } catch (const std::exception& ex) {
        err = ex.what();
      }
    collective_check(comm, err);
  }
  for (const auto& w : st.warnings) print0(comm, "morse: warning: %s\n", w.c_str());
  print0(comm, "  %ld steps in %.3f s (%.2f us per step)\n", st.steps, st.seconds,
         st.steps ? 1e6 * st.seconds / st.steps : 0.0);

  rampup::HistoryErrors he;
  if (!o.reference.empty()) {
    if (rank == 0) try {
        he = rampup::compare(h, rampup::read_history(o.reference));
      } catch (const std::exception& ex) {
        err = cat("-rampup_reference ", o.reference, ": ", ex.what());
      }
    collective_check(comm, err);
    print0(comm,
           "  against %s (seed 000 eq. 24): bearing loads worst %.3g %%, best %.3g %%, mean %.3g %%; "
           "displacements worst %.3g %%, best %.3g %%, mean %.3g %%\n",
           o.reference.c_str(), 100 * he.force_worst, 100 * he.force_best, 100 * he.force_mean,
           100 * he.displacement_worst, 100 * he.displacement_best, 100 * he.displacement_mean);
  }

  StageTimer tw(comm, "Write");
  io::H5Output out(comm, o.out);
  if (rank == 0) {
    io::write_provenance(out, "rampup", "SI");
    rampup::write_history(out, "/rampup", h);
    std::string names;
    for (const auto& b : e.bearings) names += (names.empty() ? "" : ",") + b.name;
    out.attribute("/rampup", "bearings", names);
    out.attribute("/rampup", "dt", o.dt);
    out.attribute("/rampup", "rpm_max", o.rpm_max);
    out.attribute("/rampup", "ramp_time", o.ramp_time);
    out.attribute("/rampup", "load_case", o.constant ? "constant" : "ramp");
    out.attribute("/rampup", "alpha", o.alpha);
    out.attribute("/rampup", "step_solver", o.dense ? "dense" : "condensed");
    out.attribute_int("/rampup", "steps", st.steps);
    out.attribute("/rampup", "seconds", st.seconds);
    out.attribute_int("/rampup", "n_dofs", a.n());
    out.attribute_int("/rampup", "n_stator_modes", a.n_stator());
    out.attribute_int("/rampup", "n_rotor_dofs", a.n_rotor());
    for (std::size_t s = 0; s < e.stators.size(); ++s)
      rampup::write_stator(out, "/rampup", e.stators[s], o.stators[s].file, e.stator_n_b[s]);
    if (o.write_matrices) rampup::write_matrices(out, "/rampup", a.dense());
    if (!o.reference.empty()) rampup::write_errors(out, "/rampup", he, o.reference);
  }
  out.commit();
  print0(comm, "morse: wrote %s\n", o.out.c_str());
  check_options(comm, false);
}

}  // namespace morse::app::detail
