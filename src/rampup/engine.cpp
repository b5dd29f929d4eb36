// rampup/engine.cpp: the options of `morse rampup` and the engine they describe
// (rampup/engine.hpp).
#include "morse/rampup/engine.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/io/h5.hpp"

namespace morse::rampup {

namespace {

PetscErrorCode get_list(PetscOptionItems* PetscOptionsObject, const std::string& name, const char* help,
                        std::vector<std::string>* out) {
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

PetscErrorCode get_reals(PetscOptionItems* PetscOptionsObject, const std::string& name, const char* help,
                         std::vector<double>* out, PetscBool* set) {
  std::vector<PetscReal> v(4096);
  PetscInt n = static_cast<PetscInt>(v.size());
  PetscCall(MorseOptionsRealArray(name.c_str(), help, "", v.data(), &n, set));
  if (*set) out->assign(v.begin(), v.begin() + n);
  return PETSC_SUCCESS;
}

PetscErrorCode get_string(PetscOptionItems* PetscOptionsObject, const std::string& name, const char* help,
                          std::string* out, PetscBool* set) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscCall(MorseOptionsString(name.c_str(), help, "", out->c_str(), buf, sizeof buf, set));
  if (*set) *out = buf;
  return PETSC_SUCCESS;
}

// Index of station z of a rotor (within 1e-9 of the rotor's length), or throws naming `who`.
int station_of(const RotorSpec& r, double z, const std::string& who) {
  const double tol = 1e-9 * std::max(1.0, std::abs(r.z.back() - r.z.front()));
  for (std::size_t i = 0; i < r.z.size(); ++i)
    if (std::abs(r.z[i] - z) <= tol) return static_cast<int>(i);
  std::string list;
  for (double v : r.z) list += cat(list.empty() ? "" : ",", v);
  throw Error(cat(who, " z = ", z, " is not a station of rotor '", r.name, "' (stations: ", list, ")"));
}

}  // namespace

PetscErrorCode RampupOptions::set_from_options(MPI_Comm comm) {
  RampupOptions* o = this;
  PetscBool set = PETSC_FALSE;
  auto fail = [&](const std::string& msg) {
    if (o->error.empty()) o->error = msg;
  };
  std::vector<std::string> stators, rotors, bearings, drives, gearboxes, torques;
  PetscOptionsBegin(comm, nullptr, "morse rampup options (run/engine.opts documents every one)", "");
  PetscCall(get_string(PetscOptionsObject, "-out", "Output HDF5 file", &o->out, &set));
  PetscCall(get_list(PetscOptionsObject, "-rampup_stators",
                     "Stator superelements, by name (each: -rampup_stator_<name>_*)", &stators));
  PetscCall(get_list(PetscOptionsObject, "-rampup_rotors", "Rotors, by name (each: -rampup_rotor_<name>_*)", &rotors));
  PetscCall(get_list(PetscOptionsObject, "-rampup_bearings", "Bearings, by name (each: -rampup_bearing_<name>_*)",
                     &bearings));
  PetscCall(get_list(PetscOptionsObject, "-rampup_drives",
                     "Stations where the speed law is imposed, by name (each: -rampup_drive_<name>_*); with "
                     "drives, gearboxes or torques the rotors' torsion is modelled",
                     &drives));
  PetscCall(get_list(PetscOptionsObject, "-rampup_gearboxes", "Gear stages, by name (each: -rampup_gearbox_<name>_*)",
                     &gearboxes));
  PetscCall(get_list(PetscOptionsObject, "-rampup_torques",
                     "Resistive torques -c Omega_r |Omega_r|, by name (each: -rampup_torque_<name>_*)", &torques));
  for (const auto& s : stators) {
    StatorOptions so;
    so.name = s;
    const std::string p = "-rampup_stator_" + s + "_";
    PetscCall(get_string(PetscOptionsObject, p + "file", "Superelement file (/rom of morse reduce or select)", &so.file,
                         &set));
    if (!set) fail(cat("stator ", s, ": give its superelement file with ", p, "file"));
    PetscCall(get_list(PetscOptionsObject, p + "clamp",
                       "Interface nodes clamped in the assembly: node ids or node sets", &so.clamp));
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
    RotorOptions ro;
    ro.name = r;
    const std::string p = "-rampup_rotor_" + r + "_";
    PetscCall(
        get_reals(PetscOptionsObject, p + "z", "Station positions along the axis z [m], increasing", &ro.z, &set));
    if (!set) fail(cat("rotor ", r, ": give its stations with ", p, "z z0,z1,..."));
    PetscCall(get_reals(PetscOptionsObject, p + "d_outer", "Outer diameter [m]: one value, or one per element",
                        &ro.d_outer, &set));
    if (!set && ro.z.size() > 1) fail(cat("rotor ", r, ": give its shaft diameter with ", p, "d_outer"));
    PetscCall(get_reals(PetscOptionsObject, p + "d_inner",
                        "Inner diameter [m] (hollow shaft): one value or one per element", &ro.d_inner, &set));
    PetscCall(MorseOptionsReal((p + "E").c_str(), "Young's modulus [Pa]", "", ro.mat.E, &ro.mat.E, &set));
    if (set) fail(options::magnitude_error(p + "E", ro.mat.E));
    PetscCall(MorseOptionsReal((p + "nu").c_str(), "Poisson ratio", "", ro.mat.nu, &ro.mat.nu, nullptr));
    PetscCall(MorseOptionsReal((p + "rho").c_str(), "Density [kg/m^3]", "", ro.mat.rho, &ro.mat.rho, &set));
    if (set) fail(options::magnitude_error(p + "rho", ro.mat.rho));
    PetscCall(MorseOptionsReal((p + "speed_ratio").c_str(), "Spin speed / driving speed (negative: counter-rotating)",
                               "", ro.speed_ratio, &ro.speed_ratio, nullptr));
    std::vector<double> ab;
    PetscCall(
        get_reals(PetscOptionsObject, p + "rayleigh", "Rayleigh damping alpha [1/s],beta [s] of the rotor", &ab, &set));
    if (set) {
      if (ab.size() != 2)
        fail(cat(p, "rayleigh needs two values alpha,beta"));
      else
        ro.alpha = ab[0], ro.beta = ab[1];
    }
    PetscCall(get_list(PetscOptionsObject, p + "disks",
                       "Rigid disks on this rotor, by name (each: -rampup_disk_<name>_*)", &ro.disks));
    for (const auto& d : ro.disks) {
      if (o->disks.count(d)) fail(cat("disk ", d, " is listed twice (disk names are unique across rotors)"));
      DiskOptions dk;
      dk.name = d;
      const std::string q = "-rampup_disk_" + d + "_";
      PetscCall(
          MorseOptionsReal((q + "z").c_str(), "Axial position [m] (a station of its rotor)", "", dk.z, &dk.z, &set));
      if (!set) fail(cat("disk ", d, ": give its position with ", q, "z"));
      PetscCall(MorseOptionsReal((q + "mass").c_str(), "Mass [kg]", "", dk.mass, &dk.mass, nullptr));
      PetscCall(MorseOptionsReal((q + "Ip").c_str(), "Polar moment of inertia [kg m^2]", "", dk.Ip, &dk.Ip, nullptr));
      PetscCall(
          MorseOptionsReal((q + "Id").c_str(), "Diametral moment of inertia [kg m^2]", "", dk.Id, &dk.Id, nullptr));
      if (!(dk.mass >= 0 && dk.Ip >= 0 && dk.Id >= 0))
        fail(cat("disk ", d, ": ", q, "mass, ", q, "Ip and ", q, "Id must be >= 0"));
      o->disks[d] = dk;
    }
    o->rotors.push_back(ro);
  }
  PetscCall(get_list(PetscOptionsObject, "-rampup_unbalance", "Disks carrying an unbalance", &o->unbalance_disks));
  PetscCall(get_reals(PetscOptionsObject, "-rampup_unbalance_me", "Unbalance mass x eccentricity [kg m], one per disk",
                      &o->unbalance_me, &set));
  PetscCall(get_reals(PetscOptionsObject, "-rampup_unbalance_phase_deg",
                      "Unbalance angle from +x at t = 0 [deg], one per disk", &o->unbalance_phase_deg, &set));
  for (const auto& b : bearings) {
    BearingOptions bo;
    bo.name = b;
    const std::string p = "-rampup_bearing_" + b + "_";
    PetscCall(get_string(PetscOptionsObject, p + "rotor", "Rotor", &bo.rotor, &set));
    if (!set) fail(cat("bearing ", b, ": give its rotor with ", p, "rotor"));
    PetscCall(
        MorseOptionsReal((p + "z").c_str(), "Axial position [m] (a station of the rotor)", "", bo.z, &bo.z, &set));
    if (!set) fail(cat("bearing ", b, ": give its position with ", p, "z"));
    PetscCall(get_string(PetscOptionsObject, p + "stator", "Stator it sits in, or ground", &bo.stator, &set));
    const bool stator_set = set;
    PetscCall(get_string(PetscOptionsObject, p + "rotor2", "Intershaft bearing: the other rotor", &bo.rotor2, &set));
    if (set && stator_set) fail(cat("bearing ", b, ": give ", p, "stator or ", p, "rotor2 (intershaft), not both"));
    PetscCall(MorseOptionsReal((p + "z2").c_str(), "Intershaft bearing: axial position on the other rotor [m]", "",
                               bo.z2, &bo.z2, &set));
    if (set != !bo.rotor2.empty())
      fail(cat("bearing ", b, ": an intershaft bearing needs both ", p, "rotor2 and ", p, "z2"));
    PetscCall(get_list(PetscOptionsObject, p + "nodes",
                       "Housing nodes of the stator (ids or node sets; several: their mean)", &bo.nodes));
    PetscCall(get_reals(PetscOptionsObject, p + "k", "Stiffness kxx[,kyy] [N/m]", &bo.k, &set));
    if (!set) fail(cat("bearing ", b, ": give its stiffness with ", p, "k kxx[,kyy]"));
    PetscCall(get_reals(PetscOptionsObject, p + "c", "Damping cxx[,cyy] [N s/m]", &bo.c, &set));
    if (bo.k.size() > 2 || bo.c.size() > 2) fail(cat("bearing ", b, ": ", p, "k and ", p, "c take 1 or 2 values"));
    o->bearings.push_back(bo);
  }
  for (const auto& d : drives) {
    DriveOptions dr;
    dr.name = d;
    const std::string p = "-rampup_drive_" + d + "_";
    PetscCall(get_string(PetscOptionsObject, p + "rotor", "Rotor whose station is driven", &dr.rotor, &set));
    if (!set) fail(cat("drive ", d, ": give its rotor with ", p, "rotor"));
    PetscCall(MorseOptionsReal((p + "z").c_str(), "Driven station [m]", "", dr.z, &dr.z, &set));
    if (!set) fail(cat("drive ", d, ": give its station with ", p, "z"));
    o->drives.push_back(dr);
  }
  for (const auto& g : gearboxes) {
    GearboxOptions go;
    go.name = g;
    const std::string p = "-rampup_gearbox_" + g + "_";
    const char* need[] = {"input", "input_z", "output", "output_z", "ratio", "k"};
    bool have[6] = {};
    PetscCall(get_string(PetscOptionsObject, p + "input", "Input rotor (the faster side: the sun)", &go.input, &set));
    have[0] = set;
    PetscCall(MorseOptionsReal((p + "input_z").c_str(), "Input station [m]", "", go.input_z, &go.input_z, &set));
    have[1] = set;
    PetscCall(get_string(PetscOptionsObject, p + "output", "Output rotor (the carrier)", &go.output, &set));
    have[2] = set;
    PetscCall(MorseOptionsReal((p + "output_z").c_str(), "Output station [m]", "", go.output_z, &go.output_z, &set));
    have[3] = set;
    PetscCall(MorseOptionsReal((p + "ratio").c_str(), "Speed ratio input / output", "", go.ratio, &go.ratio, &set));
    have[4] = set;
    PetscCall(MorseOptionsReal((p + "k").c_str(), "Mesh torsional stiffness at the input, output held [N m/rad]", "",
                               go.k, &go.k, &set));
    have[5] = set;
    PetscCall(MorseOptionsReal((p + "c").c_str(), "Mesh torsional damping at the input [N m s/rad]", "", go.c, &go.c,
                               nullptr));
    for (int k = 0; k < 6; ++k)
      if (!have[k]) fail(cat("gearbox ", g, ": give ", p, need[k]));
    o->gearboxes.push_back(go);
  }
  for (const auto& t : torques) {
    TorqueOptions to;
    to.name = t;
    const std::string p = "-rampup_torque_" + t + "_";
    PetscCall(get_string(PetscOptionsObject, p + "rotor", "Rotor it acts on", &to.rotor, &set));
    if (!set) fail(cat("torque ", t, ": give its rotor with ", p, "rotor"));
    PetscCall(MorseOptionsReal((p + "z").c_str(), "Station [m]", "", to.z, &to.z, &set));
    if (!set) fail(cat("torque ", t, ": give its station with ", p, "z"));
    PetscCall(MorseOptionsReal((p + "coefficient").c_str(),
                               "c of the resistive torque -c Omega_r |Omega_r| [N m s^2] (Omega_r: the rotor's spin)",
                               "", to.coefficient, &to.coefficient, &set));
    if (!set) fail(cat("torque ", t, ": give its coefficient with ", p, "coefficient"));
    o->torques.push_back(to);
  }
  PetscCall(MorseOptionsReal("-rampup_rpm_max", "Top driving speed [rpm]", "", o->rpm_max, &o->rpm_max, nullptr));
  PetscCall(MorseOptionsReal("-rampup_ramp_time", "Ramp duration 0 -> top speed [s]", "", o->ramp_time, &o->ramp_time,
                             nullptr));
  PetscCall(MorseOptionsBool("-rampup_constant_speed", "Constant top speed from t = 0 instead of the ramp", "",
                             o->constant, &o->constant, nullptr));
  PetscCall(MorseOptionsReal("-rampup_dt", "Time step [s]", "", o->dt, &o->dt, nullptr));
  PetscCall(MorseOptionsReal("-rampup_t_final", "End time [s] (default: the ramp time)", "", o->t_final, &o->t_final,
                             nullptr));
  PetscCall(MorseOptionsReal("-rampup_alpha", "HHT alpha in [-1/3, 0] (0: Newmark average acceleration)", "", o->alpha,
                             &o->alpha, nullptr));
  PetscCall(
      MorseOptionsInt("-rampup_output_every", "Write every K-th step", "", o->output_every, &o->output_every, nullptr));
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

std::vector<files::Named> RampupOptions::inputs() const {
  std::vector<files::Named> in;
  for (const auto& so : stators) in.push_back({cat("-rampup_stator_", so.name, "_file"), so.file});
  in.push_back({"-rampup_reference", reference});
  return in;
}

void RampupOptions::check() const {
  MORSE_CHECK(error.empty(), error);
  MORSE_CHECK(rpm_max > 0, "-rampup_rpm_max must be > 0 (got ", rpm_max, ")");
  MORSE_CHECK(constant || ramp_time > 0, "-rampup_ramp_time must be > 0 (got ", ramp_time,
              "), or use -rampup_constant_speed");
  MORSE_CHECK(dt > 0, "-rampup_dt must be > 0 (got ", dt, ")");
  MORSE_CHECK(!constant || t_final > 0, "-rampup_constant_speed needs -rampup_t_final");
  MORSE_CHECK(output_every > 0, "-rampup_output_every must be positive (got ", output_every, ")");
  MORSE_CHECK(cut_factor > 0, "-rampup_cut_factor must be > 0 (got ", cut_factor, ")");
}

LoadCase RampupOptions::load_case() const {
  LoadCase lc;
  lc.kind = constant ? LoadCase::Kind::Constant : LoadCase::Kind::Ramp;
  lc.omega_max = rpm_max * kRpm;
  lc.ramp_time = ramp_time;
  return lc;
}

IntegratorSettings RampupOptions::integrator() const {
  IntegratorSettings is;
  is.dt = dt;
  is.t_final = t_final;
  is.alpha = alpha;
  is.output_every = static_cast<int>(output_every);
  is.dense = dense;
  return is;
}

Engine build_engine(MPI_Comm comm, const RampupOptions& o, double omega_max) {
  Engine e;
  MORSE_CHECK(!o.rotors.empty(), "morse rampup: no rotor: give -rampup_rotors NAME[,NAME] (see run/engine.opts)");
  for (const auto& ro : o.rotors) {
    RotorSpec r;
    r.name = ro.name;
    r.z = ro.z;
    const std::size_t ne = r.z.size() > 1 ? r.z.size() - 1 : 0;
    const std::string p = "-rampup_rotor_" + ro.name + "_";
    MORSE_CHECK(ro.d_outer.size() <= 1 || ro.d_outer.size() == ne, p, "d_outer has ", ro.d_outer.size(),
                " values: give 1 or one per element (", ne, ")");
    MORSE_CHECK(ro.d_inner.size() <= 1 || ro.d_inner.size() == ro.d_outer.size(), p, "d_inner has ", ro.d_inner.size(),
                " values: give 1 or as many as ", p, "d_outer");
    for (std::size_t k = 0; k < ro.d_outer.size(); ++k)
      r.sections.push_back(
          {ro.d_outer[k], ro.d_inner.empty() ? 0.0 : ro.d_inner[ro.d_inner.size() == 1 ? 0 : k], ro.mat});
    r.speed_ratio = ro.speed_ratio;
    r.rayleigh_alpha = ro.alpha;
    r.rayleigh_beta = ro.beta;
    for (const auto& dn : ro.disks) {
      const DiskOptions& d = o.disks.at(dn);
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
    auto it = std::find_if(o.rotors.begin(), o.rotors.end(), [&](const RotorOptions& r) {
      return std::find(r.disks.begin(), r.disks.end(), dn) != r.disks.end();
    });
    std::string all;
    for (const auto& kv : o.disks) all += (all.empty() ? "" : ", ") + kv.first;
    MORSE_CHECK(it != o.rotors.end(), "-rampup_unbalance ", dn, ": no such disk (disks: ", all.empty() ? "none" : all,
                ")");
    MORSE_CHECK(o.unbalance_me[u] >= 0, "-rampup_unbalance_me ", o.unbalance_me[u], " must be >= 0");
    const double ph = o.unbalance_phase_deg.empty() ? 0.0 : o.unbalance_phase_deg[u] * M_PI / 180.0;
    e.rotors[it - o.rotors.begin()].unbalances.push_back({dn, o.unbalance_me[u], ph});
  }
  for (const auto& r : e.rotors) rotor_matrices(r);  // validates each rotor, naming it
  const double cut_default = default_cut_hz(e.rotors, omega_max, o.cut_factor);
  {
    StageTimer t(comm, "StatorModes");
    for (const auto& so : o.stators) {
      MORSE_CHECK(std::ifstream(so.file).good(), "-rampup_stator_", so.name, "_file ", so.file,
                  ": no such file (make the superelement with morse reduce or morse select; for "
                  "run/engine.opts, "
                  "run/rampup makes it)");
      auto se = read_superelement(so.file);
      const auto clamp = resolve_nodes(so.file, so.clamp, cat("-rampup_stator_", so.name, "_clamp"));
      auto sm = stator_modes(se, clamp, so.cut_hz > 0 ? so.cut_hz : cut_default, so.damping_ratio);
      sm.name = so.name;
      e.stators.push_back(std::move(sm));
      e.stator_n_b.push_back(se.n_b);
    }
  }
  auto rotor_index = [&](const std::string& name, const std::string& who) {
    auto it = std::find_if(e.rotors.begin(), e.rotors.end(), [&](const auto& r) { return r.name == name; });
    MORSE_CHECK(it != e.rotors.end(), who, " ", name, ": no such rotor (-rampup_rotors)");
    return static_cast<int>(it - e.rotors.begin());
  };
  for (const auto& bo : o.bearings) {
    Bearing b;
    b.name = bo.name;
    const std::string p = "-rampup_bearing_" + bo.name + "_";
    auto rit = std::find_if(e.rotors.begin(), e.rotors.end(), [&](const auto& r) { return r.name == bo.rotor; });
    MORSE_CHECK(rit != e.rotors.end(), p, "rotor ", bo.rotor, ": no such rotor (-rampup_rotors)");
    b.rotor = static_cast<int>(rit - e.rotors.begin());
    b.station = station_of(*rit, bo.z, p + "z:");
    if (!bo.rotor2.empty()) {
      const int r2 = rotor_index(bo.rotor2, p + "rotor2");
      MORSE_CHECK(r2 != b.rotor, p, "rotor2 ", bo.rotor2, ": an intershaft bearing joins two different rotors");
      MORSE_CHECK(bo.nodes.empty(), p, "nodes: an intershaft bearing has no housing nodes");
      b.rotor2 = r2;
      b.station2 = station_of(e.rotors[r2], bo.z2, p + "z2:");
    } else if (bo.stator == "ground") {
      b.stator = -1;
      MORSE_CHECK(bo.nodes.empty(), p, "nodes: a bearing on the ground has no housing nodes");
    } else {
      auto sit = std::find_if(o.stators.begin(), o.stators.end(), [&](const auto& s) { return s.name == bo.stator; });
      MORSE_CHECK(sit != o.stators.end(), p, "stator ", bo.stator, ": no such stator (-rampup_stators) or ground");
      b.stator = static_cast<int>(sit - o.stators.begin());
      MORSE_CHECK(!bo.nodes.empty(), p, "nodes: give the housing nodes of the bearing in stator ", bo.stator);
      b.nodes = resolve_nodes(sit->file, bo.nodes, p + "nodes");
    }
    b.kxx = bo.k.empty() ? 0.0 : bo.k[0];
    b.kyy = bo.k.size() > 1 ? bo.k[1] : b.kxx;
    b.cxx = bo.c.empty() ? 0.0 : bo.c[0];
    b.cyy = bo.c.size() > 1 ? bo.c[1] : b.cxx;
    e.bearings.push_back(std::move(b));
  }
  for (const auto& d : o.drives) {
    const std::string p = "-rampup_drive_" + d.name + "_";
    const int r = rotor_index(d.rotor, p + "rotor");
    e.torsion.drives.push_back({d.name, r, station_of(e.rotors[r], d.z, p + "z:")});
  }
  for (const auto& g : o.gearboxes) {
    const std::string p = "-rampup_gearbox_" + g.name + "_";
    Gearbox gb;
    gb.name = g.name;
    gb.input = rotor_index(g.input, p + "input");
    gb.input_station = station_of(e.rotors[gb.input], g.input_z, p + "input_z:");
    gb.output = rotor_index(g.output, p + "output");
    gb.output_station = station_of(e.rotors[gb.output], g.output_z, p + "output_z:");
    gb.ratio = g.ratio;
    gb.k = g.k;
    gb.c = g.c;
    e.torsion.gearboxes.push_back(gb);
  }
  for (const auto& t : o.torques) {
    const std::string p = "-rampup_torque_" + t.name + "_";
    const int r = rotor_index(t.rotor, p + "rotor");
    e.torsion.torques.push_back({t.name, r, station_of(e.rotors[r], t.z, p + "z:"), t.coefficient});
  }
  return e;
}

void write_run(io::H5Output& out, const std::string& group, const RampupOptions& o, const Engine& e, const Assembly& a,
               const IntegratorStats& st, const HistoryErrors& he) {
  std::string names;
  for (const auto& b : e.bearings) names += (names.empty() ? "" : ",") + b.name;
  out.attribute(group, "bearings", names);
  out.attribute(group, "dt", o.dt);
  out.attribute(group, "rpm_max", o.rpm_max);
  out.attribute(group, "ramp_time", o.ramp_time);
  out.attribute(group, "load_case", o.constant ? "constant" : "ramp");
  out.attribute(group, "alpha", o.alpha);
  out.attribute(group, "step_solver", o.dense ? "dense" : "condensed");
  out.attribute_int(group, "steps", st.steps);
  out.attribute(group, "seconds", st.seconds);
  out.attribute_int(group, "n_dofs", a.n());
  out.attribute_int(group, "n_stator_modes", a.n_stator());
  out.attribute_int(group, "n_rotor_dofs", a.n_rotor());
  if (a.n_torsion() > 0) {
    auto names_of = [](const auto& v) {
      std::string s;
      for (const auto& x : v) s += (s.empty() ? "" : ",") + x.name;
      return s;
    };
    out.attribute(group, "drives", names_of(e.torsion.drives));
    out.attribute(group, "gearboxes", names_of(e.torsion.gearboxes));
    out.attribute(group, "torques", names_of(e.torsion.torques));
    std::vector<double> f = a.torsion_frequencies();
    for (double& v : f) v /= 2.0 * M_PI;
    out.write(group + "/torsion_frequencies", f);
    out.attribute(group + "/torsion_frequencies", "description",
                  "natural frequencies of the torsion with the drives held [Hz]");
  }
  for (std::size_t s = 0; s < e.stators.size(); ++s)
    write_stator(out, group, e.stators[s], o.stators[s].file, e.stator_n_b[s]);
  if (o.write_matrices) write_matrices(out, group, a.dense());
  if (!o.reference.empty()) write_errors(out, group, he, o.reference);
}

}  // namespace morse::rampup
