// app/cmd_modes.cpp: `morse modes`, the lowest eigenpairs of the clamped full model, written
// with the mesh (and an XDMF file for ParaView).
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/cb/eigen.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::app::detail {

namespace {

PetscErrorCode get_modes_options(MPI_Comm comm, PetscInt* nev, PetscReal* shift, PetscBool* xdmf) {
  PetscOptionsBegin(comm, nullptr, "morse modes options", "");
  PetscCall(PetscOptionsInt("-modes_nev", "Number of lowest eigenpairs of the clamped model", "", *nev, nev, nullptr));
  PetscCall(PetscOptionsReal("-modes_shift", "Shift-invert target (rad/s)^2; negative for free-free models", "",
                             *shift, shift, nullptr));
  PetscCall(PetscOptionsBool("-modes_xdmf", "Write an XDMF file for ParaView next to the HDF5 file", "", *xdmf, xdmf,
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
  check_options(comm, true);
  MORSE_CHECK(nev > 0, "-modes_nev must be positive (got ", nev, ")");
  Model md = build_model(comm, o);
  cb::EigenSettings es;
  es.nev = nev;
  es.shift = shift;
  es.prefix = "modes_";
  es.what = "full-model modes";
  es.keep_factor = false;  // nothing solves with it afterwards: the Sylvester check reuses it
  auto w = cb::sign_reference(md.lm, md.dofs);
  auto eig = cb::solve_eigen(md.ops.K.get(), md.ops.M.get(), es, w.get());
  check_options(comm, false);

  const std::vector<double> f_hz = hz(eig.omega2);
  print0(comm, "\n  %-6s %16s %16s\n", "mode", "frequency [Hz]", "omega [rad/s]");
  for (std::size_t i = 0; i < f_hz.size(); ++i)
    print0(comm, "  %-6zu %16.6f %16.6f\n", i + 1, f_hz[i], kTwoPi * f_hz[i]);

  StageTimer t(comm, "Write");
  io::H5Output out(comm, o.out);
  io::write_provenance(out, "modes", md.lm.mesh.units);
  auto gm = mesh::gather_to_rank0(md.lm);
  io::write_mesh(out, gm);
  io::write_modes(out, "/fom", md.lm, md.dofs, eig.omega2, eig.V.get());
  out.attribute("/fom", "clamp", [&] {
    std::string s;
    for (auto& c : o.clamp) s += (s.empty() ? "" : ",") + c;
    return s;
  }());
  out.commit();
  if (xdmf) write_xdmf_collective(comm, o.out, gm, {{"/fom/mode_shapes", "mode", (int)f_hz.size()}});
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
