// app/cmd_static.cpp: `morse static`, the nonlinear (or linear) static solution under the nodal
// loads at one instant, by load stepping with Newton (dyn::solve_static).
#include <petscsys.h>

#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/constraints.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/io/h5.hpp"

namespace morse::app::detail {

void run_static(MPI_Comm comm) {
  io::ModelInput o;
  MORSE_CALL(o.set_from_options(comm, "static.h5"));
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(get_loads(comm, &load_list, &load_error));
  std::vector<std::string> monitor;
  MORSE_CALL(options::get_string_list(comm, "-static_monitor", "Node sets whose displacements are printed and written",
                                      &monitor));
  dyn::StaticSettings ss;
  MORSE_CALL(ss.set_from_options(comm));
  PetscBool xdmf = PETSC_TRUE;
  MORSE_CALL([&]() -> PetscErrorCode {
    PetscOptionsBegin(comm, nullptr, "morse static output", "");
    PetscCall(MorseOptionsBool("-static_xdmf", "Write an XDMF file for ParaView next to the HDF5 file", "", xdmf, &xdmf,
                               nullptr));
    PetscOptionsEnd();
    return PETSC_SUCCESS;
  }());
  if (help_requested()) return;
  options::add_prefix(ss.prefix, options::Solver::Nonlinear);
  check_options(comm, true);
  collective_check(comm, load_error);
  MORSE_CHECK(!load_list.empty(), "morse static: no load; give -load_sets SET and -load_<SET>_dir/_amplitude");
  MORSE_CHECK(ss.error.empty(), ss.error);
  const auto output_lock = files::prepare_outputs(comm, {{"-out", o.out}}, o.inputs());

  Model md = build_model(comm, o,
                         "morse static needs a mesh: its nonlinear (SVK) forces are computed element by element", true);
  // With rigid or interpolation elements or MPCs the solve is on the model's DOFs (loads T^T f,
  // forces through T) and the output on the nodes' (u = T u_bar).
  const auto& nodes = fe::node_layout(md);
  dyn::Loads loads(md, load_list);
  std::vector<dyn::SetProbe> probes;
  for (const auto& m : monitor) probes.emplace_back(*md.mesh, nodes, m);
  io::H5Output out(comm, o.out);  // early: a bad -out fails before the solve
  fe::Svk svk(md, o.mesh.material);
  auto res = dyn::solve_static(svk, loads, ss);
  if (md.constraints) res.u = fe::expand(md, res.u.get());
  check_options(comm, false);

  for (const auto& p : probes) {
    auto u = p.sample(res.u.get());
    print0(comm, "\n  set %s: displacement [m]\n  %-10s %14s %14s %14s\n", p.name().c_str(), "node", "u_x", "u_y",
           "u_z");
    for (std::size_t i = 0; i < p.node_ids().size(); ++i)
      print0(comm, "  %-10lld %14.6e %14.6e %14.6e\n", (long long)p.node_ids()[i], u[3 * i], u[3 * i + 1],
             u[3 * i + 2]);
  }

  StageTimer t(comm, "Write");
  io::write_provenance(out, "static", md.units);
  auto gm = mesh::gather_to_rank0(*md.mesh);
  io::write_mesh(out, gm);
  dyn::write_static(out, *md.mesh, nodes, res, probes, ss);
  out.commit();
  if (xdmf) write_xdmf_collective(comm, o.out, gm, {{"/static/u", "displacement", 1}});
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
