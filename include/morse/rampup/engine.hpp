// morse/rampup/engine.hpp: the engine of `morse rampup` as its options describe it (run/engine.opts
// documents every option), read by RampupOptions::set_from_options, and its resolution into the
// rotors, stator modal bases and bearings of rampup.hpp (build_engine), and the attributes of a
// run's /rampup group.
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "morse/core/files.hpp"
#include "morse/rampup/rampup.hpp"

namespace morse::rampup {

/// rad/s per rpm.
constexpr double kRpm = 2.0 * M_PI / 60.0;

// The engine as the options give it, names unresolved (resolved and checked by build_engine()).
struct StatorOptions {
  std::string name, file;
  std::vector<std::string> clamp;
  double cut_hz = -1, damping_ratio = -1;
};
struct DiskOptions {
  std::string name;
  double z = 0, mass = 0, Ip = 0, Id = 0;
};
struct RotorOptions {
  std::string name;
  std::vector<double> z, d_outer, d_inner;
  Material mat;
  double speed_ratio = 1, alpha = 0, beta = 0;
  std::vector<std::string> disks;
};
struct BearingOptions {
  std::string name, rotor, stator = "ground", rotor2;  ///< rotor2: intershaft bearing
  double z = 0, z2 = 0;
  std::vector<std::string> nodes;
  std::vector<double> k, c;
};
struct DriveOptions {
  std::string name, rotor;
  double z = 0;
};
struct GearboxOptions {
  std::string name, input, output;
  double input_z = 0, output_z = 0, ratio = 0, k = 0, c = 0;
};
struct TorqueOptions {
  std::string name, rotor;
  double z = 0, coefficient = 0;
};
struct RampupOptions {
  std::string out = "rampup.h5", reference;
  std::vector<StatorOptions> stators;
  std::vector<RotorOptions> rotors;
  std::map<std::string, DiskOptions> disks;
  std::vector<BearingOptions> bearings;
  std::vector<DriveOptions> drives;
  std::vector<GearboxOptions> gearboxes;
  std::vector<TorqueOptions> torques;
  std::vector<std::string> unbalance_disks;
  std::vector<double> unbalance_me, unbalance_phase_deg;
  double rpm_max = 0, ramp_time = 0, dt = 0, t_final = 0, alpha = 0, cut_factor = 2.5;
  double matrices_rpm = -1;
  PetscInt output_every = 1;
  PetscBool constant = PETSC_FALSE, dense = PETSC_FALSE, write_matrices = PETSC_TRUE;
  std::string error;  ///< first bad value, naming the option

  /// Reads -out, -rampup_stators, -rampup_rotors, -rampup_bearings, -rampup_drives,
  /// -rampup_gearboxes, -rampup_torques and, per name, the -rampup_stator_<name>_*,
  /// -rampup_rotor_<name>_*, -rampup_disk_<name>_*, -rampup_bearing_<name>_*,
  /// -rampup_drive_<name>_*, -rampup_gearbox_<name>_* and -rampup_torque_<name>_* options, -rampup_unbalance,
  /// -rampup_unbalance_me, -rampup_unbalance_phase_deg, -rampup_rpm_max, -rampup_ramp_time, -rampup_constant_speed,
  /// -rampup_dt, -rampup_t_final, -rampup_alpha, -rampup_output_every, -rampup_cut_factor,
  /// -rampup_dense, -rampup_write_matrices and -rampup_reference (run/engine.opts documents every
  /// one). A missing or bad value of a named part is recorded in `error`. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
  /// Throws (the same on every rank) on the first bad value: `error`, then the speeds, times and
  /// factors out of range, naming the option. Not collective.
  void check() const;
  /// The input files of these options: every -rampup_stator_<name>_file and -rampup_reference,
  /// for files::prepare_outputs. Not collective.
  std::vector<files::Named> inputs() const;
  /// The speed law of the options (-rampup_rpm_max, -rampup_ramp_time, -rampup_constant_speed).
  LoadCase load_case() const;
  /// The time scheme of the options (-rampup_dt, -rampup_t_final, -rampup_alpha,
  /// -rampup_output_every, -rampup_dense).
  IntegratorSettings integrator() const;
};

/// The engine of the options, resolved: rotors, stator modal bases and bearings.
struct Engine {
  std::vector<RotorSpec> rotors;
  std::vector<StatorModes> stators;
  std::vector<Bearing> bearings;
  Torsion torsion;              ///< drives, gearboxes, torques (empty: no torsion)
  std::vector<int> stator_n_b;  ///< boundary DOFs of each superelement
};

/// Resolves the options into the engine: each rotor's sections, disks and unbalances (checked),
/// each stator's modal basis (its superelement file read, clamped nodes resolved, cut at its
/// -rampup_stator_<name>_cut_hz or the default cut of omega_max [rad/s]) and each bearing's
/// rotor station and stator nodes (or the other rotor's station for an intershaft bearing), each
/// drive's, gearbox's and torque's stations. Throws naming the option on bad input; every rank builds the
/// same (small) model from the same options and files, so every rank throws alike. Collective
/// only through its stage timer (StatorModes).
Engine build_engine(MPI_Comm comm, const RampupOptions& o, double omega_max);

/// Writes the attributes of a run on group (bearings, dt, rpm_max, ramp_time, load_case, alpha,
/// step_solver, steps, seconds, n_dofs, n_stator_modes, n_rotor_dofs), the stators
/// (write_stator), the assembled matrices (-rampup_write_matrices) and the errors against
/// -rampup_reference (he). Rank 0 data; not collective.
void write_run(io::H5Output& out, const std::string& group, const RampupOptions& o, const Engine& e, const Assembly& a,
               const IntegratorStats& st, const HistoryErrors& he);

}  // namespace morse::rampup
