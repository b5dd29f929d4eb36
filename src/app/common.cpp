// app/common.cpp: the parts of the morse commands that several of them share (declared in
// common.hpp): option getters, the unknown-option check, model building and the output writers.
#include "app/common.hpp"

#include <petscsys.h>
#include <petscmat.h>

#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/fe/model.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/mesh.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::app::detail {

namespace {

std::string xdmf_path_of(const std::string& h5) {
  auto dot = h5.rfind('.');
  return (dot == std::string::npos ? h5 : h5.substr(0, dot)) + ".xdmf";
}

std::string base_name(const std::string& p) {
  auto s = p.rfind('/');
  return s == std::string::npos ? p : p.substr(s + 1);
}

}  // namespace

void check_options(MPI_Comm comm, bool early) { options::check_unknown(comm, early); }

bool help_requested() {
  PetscBool h = PETSC_FALSE;
  PetscOptionsHasHelp(nullptr, &h);
  return h;
}

Model build_model(MPI_Comm comm, const CommonOptions& o, const char* needs_mesh, bool constraints_ok) {
  o.check(needs_mesh);
  if (o.matrices_given()) {
    Model md;
    {
      StageTimer t(comm, "ReadMatrices");
      md = io::matrix_model(comm, o.matrices);
    }
    MatInfo ik, im;
    MORSE_CALL(MatGetInfo(md.K.get(), MAT_GLOBAL_SUM, &ik));
    MORSE_CALL(MatGetInfo(md.M.get(), MAT_GLOBAL_SUM, &im));
    print0(comm, "morse: matrices K %s (%.0f entries), M %s (%.0f entries)%s%s: %lld rows, %lld clamped, %lld free\n",
           o.matrices.K.c_str(), ik.nz_used, o.matrices.M.c_str(), im.nz_used, md.C ? ", C " : "",
           md.C ? o.matrices.C.c_str() : "", (long long)(md.dofs.n_global + md.dofs.n_clamped_global),
           (long long)md.dofs.n_clamped_global, (long long)md.dofs.n_global);
    print0(comm, "morse: symmetry: max|K - K^T| / max|K| = %.3g, max|M - M^T| / max|M| = %.3g (symmetrized)\n",
           md.asymmetry_K, md.asymmetry_M);
    return md;
  }
  // The stiffness on the nodes' layout of a constrained deck serves only the nonlinear forces (the
  // commands that take such a deck with constraints_ok); the linear ones do not keep it.
  Model md = fe::mesh_model(comm, o.mesh, constraints_ok);
  // Element-by-element commands see the nodes' displacements, which dependent nodes of rigid and
  // interpolation elements do not have as DOFs of the model.
  collective_check(comm, needs_mesh && md.constraints && !constraints_ok
                             ? cat(needs_mesh, "; the rigid elements, interpolation elements and MPCs of ", o.mesh.path,
                                   " are not supported by this command")
                             : std::string());
  int size = 1;
  MPI_Comm_size(comm, &size);
  print0(comm, "morse: mesh %s (%s units): %lld nodes, %lld elements on %d rank(s)\n", o.mesh.path.c_str(),
         md.units.c_str(), (long long)md.mesh->n_global_nodes, (long long)md.mesh->n_global_elements, size);
  print0(comm, "morse: %lld free DOFs, %lld clamped; volume %.6g, mass %.6g\n", (long long)md.dofs.n_global,
         (long long)md.dofs.n_clamped_global, md.volume, md.mass);
  if (md.constraints)
    print0(comm, "morse: %lld DOFs eliminated by constraints; %lld DOFs of six-DOF points\n",
           (long long)md.constraints->n_dependent, (long long)md.constraints->n_point_dofs);
  return md;
}

int rank_of(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

void write_xdmf_collective(MPI_Comm comm, const std::string& h5, const mesh::Mesh& gm,
                           const std::vector<io::XdmfField>& fields) {
  std::string err;
  if (rank_of(comm) == 0) try {
      io::write_xdmf(xdmf_path_of(h5), base_name(h5), gm, fields);
    } catch (const Error& e) {
      err = e.what();
    }
  collective_check(comm, err);
}

io::Superelement rom_superelement(const cb::CBResult& cb, const std::vector<double>& M, const std::vector<double>& K,
                                  const std::vector<double>* C, const std::vector<double>& freq_hz, double damping) {
  io::Superelement se;
  se.n = static_cast<int>(freq_hz.size());
  se.n_b = static_cast<int>(cb.n_b);
  se.M = M;
  se.K = K;
  if (C) se.C = *C;
  se.boundary_nodes = cb.boundary_node_ids;
  se.dof_node.assign(cb.boundary_dof_node.begin(), cb.boundary_dof_node.begin() + cb.n_b);
  se.dof_component.assign(cb.boundary_dof_component.begin(), cb.boundary_dof_component.begin() + cb.n_b);
  se.frequencies_hz = freq_hz;
  se.damping_ratio = damping;
  return se;
}

PetscErrorCode get_reduce_options(MPI_Comm comm, ReduceOptions* r) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse reduce output options", "");
  PetscCall(MorseOptionsBool("-cb_xdmf", "Write an XDMF file for ParaView (with -cb_write_basis)", "", r->xdmf,
                             &r->xdmf, &r->xdmf_set));
  PetscCall(MorseOptionsString("-matrices_write",
                               "Also write the model's free-DOF K and M and its DOF map as PREFIX_K.EXT, PREFIX_M.EXT, "
                               "PREFIX_dofmap.txt (mesh input)",
                               "", buf, buf, sizeof buf, &set));
  if (set) r->write_matrices = buf;
  PetscCall(PetscStrncpy(buf, r->write_format.c_str(), sizeof buf));
  PetscCall(MorseOptionsString("-matrices_write_format",
                               "Format of -matrices_write: mtx (MatrixMarket) or petsc (binary)", "", buf, buf,
                               sizeof buf, nullptr));
  r->write_format = buf;
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

}  // namespace morse::app::detail
