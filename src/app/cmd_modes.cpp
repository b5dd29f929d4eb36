// app/cmd_modes.cpp: `morse modes`, the lowest eigenpairs of the clamped full model (a mesh or
// assembled matrices), written with the mesh (and an XDMF file for ParaView) or with the row
// labels of the matrices (/dofs).
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/mesh.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::app::detail {

namespace {

const char* const kSolverPrefix = "modes_";  // options prefix of the eigen solver

PetscErrorCode get_modes_options(MPI_Comm comm, PetscInt* nev, PetscReal* shift, PetscBool* xdmf) {
  PetscOptionsBegin(comm, nullptr, "morse modes options", "");
  PetscCall(MorseOptionsInt("-modes_nev", "Number of lowest eigenpairs of the clamped model", "", *nev, nev, nullptr));
  PetscCall(MorseOptionsReal("-modes_shift",
                             "Shift-invert target (rad/s)^2 (a singular K, a free model, is shifted below 0 by itself)",
                             "", *shift, shift, nullptr));
  PetscCall(MorseOptionsBool("-modes_xdmf", "Write an XDMF file for ParaView next to the HDF5 file", "", *xdmf, xdmf,
                             nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

}  // namespace

void run_modes(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "modes.h5", &o));
  PetscInt nev = 10;
  PetscReal shift = 0;
  PetscBool xdmf = PETSC_TRUE;
  MORSE_CALL(get_modes_options(comm, &nev, &shift, &xdmf));
  if (help_requested()) return;
  options::add_prefix(kSolverPrefix, options::Solver::Eigen);
  check_options(comm, true);
  MORSE_CHECK(nev > 0, "-modes_nev must be positive (got ", nev, ")");
  const auto output_lock = files::prepare_outputs(comm, {{"-out", o.out}}, o.inputs());
  Model md = build_model(comm, o);
  eigen::EigenSettings es;
  es.nev = nev;
  es.shift = shift;
  es.prefix = kSolverPrefix;
  es.what = "full-model modes";
  es.keep_factor = false;  // nothing solves with it afterwards: the Sylvester check reuses it
  auto w = cb::sign_reference(md);
  auto eig = eigen::solve_eigen(md.K.get(), md.M.get(), es, w.get());
  check_options(comm, false);

  const std::vector<double> f_hz = hz(eig.omega2);
  print0(comm, "\n  %-6s %16s %16s\n", "mode", "frequency [Hz]", "omega [rad/s]");
  for (std::size_t i = 0; i < f_hz.size(); ++i)
    print0(comm, "  %-6zu %16.6f %16.6f\n", i + 1, f_hz[i], kTwoPi * f_hz[i]);

  StageTimer t(comm, "Write");
  io::H5Output out(comm, o.out);
  io::write_provenance(out, "modes", md.units);
  mesh::Mesh gm;
  if (md.mesh) {
    gm = mesh::gather_to_rank0(*md.mesh);
    io::write_mesh(out, gm);
  } else {
    io::write_model(out, md);
  }
  io::write_modes(out, "/fom", md, eig.omega2, eig.V.get());
  out.attribute("/fom", "clamp", [&] {
    std::string s;
    for (auto& c : o.mesh.clamp) s += (s.empty() ? "" : ",") + c;
    return s;
  }());
  out.commit();
  if (xdmf && md.mesh) write_xdmf_collective(comm, o.out, gm, {{"/fom/mode_shapes", "mode", (int)f_hz.size()}});
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
