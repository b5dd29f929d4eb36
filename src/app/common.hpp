// app/common.hpp (private): what several commands of the morse executable share: the model
// options (-mesh, -clamp, -material_*, -out) and the Craig-Bampton options, the unknown-option
// check, building the model, and the writers of mode shapes and XDMF. Each command is in
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
#include "morse/core/units.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/model.hpp"
#include "morse/io/h5.hpp"
#include "morse/io/matrix_model.hpp"
#include "morse/io/superelement.hpp"
#include "morse/mesh/mesh.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

struct CommonOptions {
  std::string mesh;
  std::string units;
  std::vector<std::string> clamp;
  mesh::Material material;
  std::vector<mesh::Material> set_materials;  ///< name = element set
  /// Node sets given on the command line (-mesh_node_sets): name, external node ids.
  std::vector<std::pair<std::string, std::vector<std::int64_t>>> node_sets;
  PetscBool skip_unsupported = PETSC_FALSE;  ///< -mesh_skip_unsupported (Nastran)
  std::string error;  ///< a bad option value, raised by build_model (after -help)
  std::string out;
  /// Assembled operators instead of a mesh (-matrices_K, -matrices_M, -matrices_C,
  /// -matrices_dofmap, -matrices_symmetry_tol); the commands that need only K and M.
  io::MatrixInput matrices;
  bool matrices_given() const { return !matrices.K.empty() || !matrices.M.empty() || !matrices.C.empty() || !matrices.dofmap.empty(); }
};

PetscErrorCode get_common(MPI_Comm comm, const char* default_out, CommonOptions* o);

// Unknown-option check (options::check_unknown, derived from the options registered so far).
// early, once the command has read its own options and registered the prefixes of the solvers it
// will run (options::add_prefix): the options not read that look like a misspelled morse option;
// final: every option nobody used. Collective.
void check_options(MPI_Comm comm, bool early);

bool help_requested();

using fe::Model;

/// The model of a mesh (-mesh) or of assembled operators (-matrices_*), built by the library
/// (fe::mesh_model, io::matrix_model) and described on rank 0. needs_mesh: why this command
/// needs a mesh (then matrix input is refused with that reason), or null if matrices will do.
Model build_model(MPI_Comm comm, const CommonOptions& o, const char* needs_mesh = nullptr);

int rank_of(MPI_Comm comm);

void write_xdmf_collective(MPI_Comm comm, const std::string& h5, const mesh::Mesh& gm,
                           const std::vector<io::XdmfField>& fields);

/// The superelement of a Craig-Bampton result as io::write_superelement writes it (/rom): the
/// reduced M, K, C (null: no /rom/C), the boundary labels of cb, the frequencies and the damping.
io::Superelement rom_superelement(const cb::CBResult& cb, const std::vector<double>& M, const std::vector<double>& K,
                                  const std::vector<double>* C, const std::vector<double>& freq_hz, double damping);

struct ReduceOptions {
  std::string boundary;
  PetscInt n_fixed = -1;
  PetscReal fmax = -1;
  PetscReal damping = 0;
  PetscBool write_basis = PETSC_FALSE;
  PetscBool xdmf = PETSC_TRUE;
  PetscBool xdmf_set = PETSC_FALSE;  ///< -cb_xdmf given explicitly
  std::string write_matrices;        ///< -matrices_write PREFIX: K, M and the DOF map of the model
  std::string write_format = "mtx";  ///< -matrices_write_format mtx|petsc
};

/// -boundary SET (unchanged if not given): the node set of the interface, read by reduce, select
/// (get_reduce_options) and nlrom.
PetscErrorCode get_boundary(MPI_Comm comm, std::string* boundary);

/// -boundary and the -cb_* and -matrices_write* options of reduce and select.
PetscErrorCode get_reduce_options(MPI_Comm comm, ReduceOptions* r);

/// The Craig-Bampton settings of the -boundary / -cb_* options (keep_basis as -cb_write_basis).
cb::CBSettings cb_settings(const ReduceOptions& r);

/// The nodal loads (-load_*): read by dyn::get_loads; this forwarding name keeps the callers in
/// cmd_static and cmd_simulate unchanged.
using dyn::get_loads;

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
void run_export(MPI_Comm comm);
void run_rampup(MPI_Comm comm);

}  // namespace morse::app::detail
