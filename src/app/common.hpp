// app/common.hpp (private): what several commands of the morse executable share: the model
// options (-mesh, -clamp, -material_*, -out) and the Craig-Bampton options, the unknown-option
// check, building the model, and the writers of mode shapes and XDMF. Each command is in
// cmd_<name>.cpp; run_command (commands.cpp) dispatches to them.
#pragma once

#include <petscsys.h>
#include <mpi.h>
#include <petscmat.h>

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

/// The model options (-mesh, -clamp, -material_*, -matrices_*, ...) and -out: io::ModelInput.
using CommonOptions = io::ModelInput;
inline PetscErrorCode get_common(MPI_Comm comm, const char* default_out, CommonOptions* o) {
  return o->set_from_options(comm, default_out);
}

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
/// A command that needs a mesh refuses rigid and interpolation elements and MPCs unless
/// `constraints_ok` (its element-by-element work goes through the constraints: fe::Svk(Model)).
Model build_model(MPI_Comm comm, const CommonOptions& o, const char* needs_mesh = nullptr, bool constraints_ok = false);

int rank_of(MPI_Comm comm);

void write_xdmf_collective(MPI_Comm comm, const std::string& h5, const mesh::Mesh& gm,
                           const std::vector<io::XdmfField>& fields);

/// The superelement of a Craig-Bampton result as io::write_superelement writes it (/rom): the
/// reduced M, K, C (null: no /rom/C), the boundary labels of cb, the frequencies and the damping.
io::Superelement rom_superelement(const cb::CBResult& cb, const std::vector<double>& M, const std::vector<double>& K,
                                  const std::vector<double>* C, const std::vector<double>& freq_hz, double damping);

/// The output options of reduce and select beside cb::CBSettings: -cb_xdmf, -matrices_write,
/// -matrices_write_format.
struct ReduceOptions {
  PetscBool xdmf = PETSC_TRUE;
  PetscBool xdmf_set = PETSC_FALSE;  ///< -cb_xdmf given explicitly
  std::string write_matrices;        ///< -matrices_write PREFIX: K, M and the DOF map of the model
  std::string write_format = "mtx";  ///< -matrices_write_format mtx|petsc
};
PetscErrorCode get_reduce_options(MPI_Comm comm, ReduceOptions* r);

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
