// app/common.hpp (private): what several commands of the morse executable share: the model
// options (-mesh, -clamp, -material_*, -out) and the Craig-Bampton options, the unknown-option
// check, building the model, and the writers of mode shapes, XDMF and /rom. Each command is in
// cmd_<name>.cpp; run_command (commands.cpp) dispatches to them.
#pragma once

#include <mpi.h>
#include <petscmat.h>
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "morse/cb/craig_bampton.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/model.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/mesh.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

constexpr double kTwoPi = 6.283185307179586;

/// Frequency [Hz] of an eigenvalue omega^2 (negative round-off of rigid modes clipped to 0).
inline double hz(double omega2) { return std::sqrt(std::max(0.0, omega2)) / kTwoPi; }
inline std::vector<double> hz(const std::vector<double>& omega2) {
  std::vector<double> f;
  f.reserve(omega2.size());
  for (double l : omega2) f.push_back(hz(l));
  return f;
}

struct CommonOptions {
  std::string mesh;
  std::string units;
  std::vector<std::string> clamp;
  mesh::Material material;
  std::vector<mesh::Material> set_materials;  ///< name = element set
  /// Node sets given on the command line (-mesh_node_sets): name, external node ids.
  std::vector<std::pair<std::string, std::vector<std::int64_t>>> node_sets;
  std::string error;  ///< a bad option value, raised by build_model (after -help)
  std::string out;
};

PetscErrorCode get_common(MPI_Comm comm, const char* default_out, CommonOptions* o);

// Unknown-option check. early: only options with a morse prefix that no command option matched
// (a typo of a morse option); final: every option nobody used.
void check_options(MPI_Comm comm, bool early);

bool help_requested();

struct Model {
  mesh::LocalMesh lm;
  fe::DofMap dofs;
  fe::Operators ops;
};

Model build_model(MPI_Comm comm, const CommonOptions& o);

void write_modes_dataset(io::H5Output& out, const std::string& name, const Model& md, Mat V, PetscInt first,
                         PetscInt count);

int rank_of(MPI_Comm comm);

void write_xdmf_collective(MPI_Comm comm, const std::string& h5, const mesh::Mesh& gm,
                           const std::vector<io::XdmfField>& fields);

// /rom as every superelement-writing command writes it (docs/hdf5-schema.md).
void write_rom(io::H5Output& out, const std::vector<double>& M, const std::vector<double>& K,
               const std::vector<double>* C, const std::vector<std::int64_t>& boundary_nodes,
               const std::vector<double>& freq_hz, PetscInt n_b, double damping);

struct ReduceOptions {
  std::string boundary;
  PetscInt n_fixed = -1;
  PetscReal fmax = -1;
  PetscReal damping = 0;
  PetscBool write_basis = PETSC_FALSE;
  PetscBool xdmf = PETSC_TRUE;
  PetscBool xdmf_set = PETSC_FALSE;  ///< -cb_xdmf given explicitly
};

PetscErrorCode get_reduce_options(MPI_Comm comm, ReduceOptions* r);

/// The Craig-Bampton settings of the -boundary / -cb_* options (keep_basis as -cb_write_basis).
cb::CBSettings cb_settings(const ReduceOptions& r);

/// The shared nodal loads: -load_sets SET[,SET...] and, per set, -load_<SET>_dir x|y|z|vx,vy,vz,
/// -load_<SET>_amplitude (newtons per node, required), -load_<SET>_omega (rad/s, 0 = constant)
/// and -load_<SET>_phase (rad). A missing direction or amplitude, or a bad direction, is an
/// error that names the option.
PetscErrorCode get_loads(MPI_Comm comm, std::vector<dyn::NodalLoad>* loads, std::string* error,
                         const char* prefix = nullptr);

/// A comma-separated list of node sets from option `name` (empty if not given).
PetscErrorCode get_set_list(MPI_Comm comm, const char* name, const char* help, std::vector<std::string>* sets,
                            const char* prefix = nullptr);

/// Contact and rotation options shared by simulate and sweep (docs/user-guide.md):
/// -contact_set SET, -contact_obstacle casing|plane, -contact_mu, -contact_plane_point x,y,z,
/// -contact_plane_normal x,y,z (normalized here), -casing_clearance, -casing_bump_height (default
/// 2 x clearance), -casing_lobes, -casing_width, -casing_alpha, -sim_omega, -sim_revolutions.
struct ContactOptions {
  std::string set;
  sim::Obstacle obstacle = sim::Obstacle::Casing;
  sim::Plane plane;
  sim::Casing casing;
  double mu = 0.15;
  double revolutions = 0.0;  ///< 0: not given
  bool plane_given = false;  ///< -contact_plane_point or -contact_plane_normal given
  bool omega_given = false;  ///< -sim_omega given
  std::string error;         ///< a bad value, naming the option
};
PetscErrorCode get_contact_options(MPI_Comm comm, ContactOptions* o);

// The commands, one file each (cmd_<name>.cpp).
void run_modes(MPI_Comm comm);
void run_reduce(MPI_Comm comm);
void run_select(MPI_Comm comm);
void run_mesh(MPI_Comm comm, const std::vector<std::string>& args);
void run_static(MPI_Comm comm);
void run_fom(MPI_Comm comm);
void run_nlrom(MPI_Comm comm);
void run_simulate(MPI_Comm comm);
void run_compare(MPI_Comm comm, const std::vector<std::string>& args);
void run_sweep(MPI_Comm comm);
void run_stress(MPI_Comm comm);

}  // namespace morse::app::detail
