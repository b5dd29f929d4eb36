// app/cmd_static.cpp: `morse static`, the nonlinear (or linear) static solution under the nodal
// loads at one instant, by load stepping with Newton (dyn::solve_static).
#include <petscsys.h>

#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/io/h5.hpp"

namespace morse::app::detail {

namespace {

struct StaticOptions {
  dyn::StaticSettings s;
  std::vector<std::string> monitor;
  PetscBool linear = PETSC_FALSE;
  PetscBool xdmf = PETSC_TRUE;
};

PetscErrorCode get_static_options(MPI_Comm comm, StaticOptions* o) {
  PetscCall(options::get_string_list(comm, "-static_monitor", "Node sets whose displacements are printed and written",
                         &o->monitor));
  PetscOptionsBegin(comm, nullptr, "morse static options", "");
  PetscCall(MorseOptionsBool("-static_linear", "Linear solution K u = f (for comparison)", "", o->linear, &o->linear,
                             nullptr));
  PetscCall(MorseOptionsReal("-static_time", "Time at which the loads are evaluated [s]", "", o->s.time, &o->s.time,
                             nullptr));
  PetscCall(MorseOptionsReal("-static_load_factor", "Final load factor on the loads", "", o->s.load_factor,
                             &o->s.load_factor, nullptr));
  PetscCall(MorseOptionsInt("-static_steps", "Initial number of equal load increments", "", o->s.steps, &o->s.steps,
                            nullptr));
  PetscCall(MorseOptionsInt("-static_max_cutbacks", "Halvings of a failed increment before giving up", "",
                            o->s.max_cutbacks, &o->s.max_cutbacks, nullptr));
  PetscCall(MorseOptionsReal("-static_rtol", "Newton tolerance: ||R|| <= rtol max(||lambda f||, ||K u||)", "",
                             o->s.rtol, &o->s.rtol, nullptr));
  PetscCall(MorseOptionsInt("-static_max_it", "Newton iterations per increment", "", o->s.max_it, &o->s.max_it,
                            nullptr));
  PetscCall(MorseOptionsBool("-static_xdmf", "Write an XDMF file for ParaView next to the HDF5 file", "", o->xdmf,
                             &o->xdmf, nullptr));
  PetscOptionsEnd();
  o->s.linear = o->linear;
  return PETSC_SUCCESS;
}

}  // namespace

void run_static(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "static.h5", &o));
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(get_loads(comm, &load_list, &load_error));
  StaticOptions so;
  MORSE_CALL(get_static_options(comm, &so));
  if (help_requested()) return;
  options::add_prefix(so.s.prefix, options::Solver::Nonlinear);
  check_options(comm, true);
  collective_check(comm, load_error);
  MORSE_CHECK(!load_list.empty(), "morse static: no load; give -load_sets SET and -load_<SET>_dir/_amplitude");
  MORSE_CHECK(so.s.steps > 0, "-static_steps must be positive (got ", so.s.steps, ")");
  MORSE_CHECK(so.s.max_cutbacks >= 0, "-static_max_cutbacks must be >= 0 (got ", so.s.max_cutbacks, ")");
  MORSE_CHECK(so.s.rtol > 0 && so.s.max_it > 0, "-static_rtol and -static_max_it must be positive");

  Model md = build_model(
      comm, o, "morse static needs a mesh: its nonlinear (SVK) forces are computed element by element");
  dyn::Loads loads(*md.mesh, md.dofs, load_list);
  std::vector<dyn::SetProbe> probes;
  for (const auto& m : so.monitor) probes.emplace_back(*md.mesh, md.dofs, m);
  io::H5Output out(comm, o.out);  // early: a bad -out fails before the solve
  fe::Svk svk(*md.mesh, md.dofs, o.mesh.material, md.K.get());
  auto res = dyn::solve_static(svk, loads, so.s);
  check_options(comm, false);

  for (const auto& p : probes) {
    auto u = p.sample(res.u.get());
    print0(comm, "\n  set %s: displacement [m]\n  %-10s %14s %14s %14s\n", p.name().c_str(), "node", "u_x", "u_y", "u_z");
    for (std::size_t i = 0; i < p.node_ids().size(); ++i)
      print0(comm, "  %-10lld %14.6e %14.6e %14.6e\n", (long long)p.node_ids()[i], u[3 * i], u[3 * i + 1], u[3 * i + 2]);
  }

  StageTimer t(comm, "Write");
  io::write_provenance(out, "static", md.units);
  auto gm = mesh::gather_to_rank0(*md.mesh);
  io::write_mesh(out, gm);
  dyn::write_static(out, *md.mesh, md.dofs, res, probes, so.s);
  out.commit();
  if (so.xdmf) write_xdmf_collective(comm, o.out, gm, {{"/static/u", "displacement", 1}});
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
