// app/cmd_stress.cpp: `morse stress`, stress recovery from a reduced simulation (seed 003 Figs. 11
// and 25): u = Phi q at one stored time of a `morse simulate` file (by default the time of the
// largest radial displacement at the monitor node), then the von Mises stress of every element
// (sim::recover_stress), written as HDF5 + XDMF for ParaView.
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/sim/run.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

void run_stress(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "stress.h5", &o));
  sim::StressOptions so;
  MORSE_CALL(so.set_from_options(comm));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(!so.rom.empty(), "morse stress: no reduced model given: use -rom FILE.h5 (a morse nlrom file)");
  MORSE_CHECK(!so.sim.empty(), "morse stress: no simulation given: use -sim FILE.h5 (a morse simulate file)");
  collective_check(comm, so.error);
  auto inputs = o.inputs();
  inputs.push_back({"-rom", so.rom});
  inputs.push_back({"-sim", so.sim});
  const auto output_lock = files::prepare_outputs(comm, {{"-out", o.out}}, inputs);

  const auto sm = nlrom::read_stored_model(
      comm, so.rom, so.time_set ? std::vector<std::string>{} : std::vector<std::string>{so.monitor});
  const auto st = sim::stress_state(comm, so, sm);
  Model md = build_model(comm, o, "morse stress needs a mesh: stresses are recovered element by element");
  sim::check_stress_mesh(*md.mesh, sm.node_ids, sm.coords, o.mesh.path, so.rom);
  io::H5Output out(comm, o.out);  // early: a bad -out fails before the work
  const auto u = sm.field(st.q.data());
  sim::StressField f;
  {
    StageTimer t(comm, "Stress");
    f = sim::recover_stress(*md.mesh, o.mesh.material, sm.node_ids, u, st.measure);
  }
  check_options(comm, false);
  const char* mname = st.measure == sim::StressMeasure::Linear ? "linear" : "nonlinear";
  print0(comm, "\nmorse stress: %s stress at t = %.9g s (step %lld of %lld)%s\n", mname, st.time, (long long)st.step,
         (long long)st.n_steps,
         so.time_set ? "" : cat(", largest |u_r| at ", so.monitor, ": ", st.radial, " m").c_str());

  StageTimer t(comm, "Write");
  auto gm = mesh::gather_to_rank0(*md.mesh);
  io::write_provenance(out, "stress", md.units);
  io::write_mesh(out, gm);
  sim::StressRecord rec;
  if (rank_of(comm) == 0) {
    sim::nodal_fields(sm.node_ids, u, gm, f, &rec);
    print0(PETSC_COMM_SELF,
           "  max von Mises %.4g MPa (quadrature point, element %lld), %.4g MPa at nodes (node "
           "%lld)\n",
           f.max_mises / 1e6, (long long)f.max_element_id, rec.max_nodal_von_mises / 1e6, (long long)rec.max_node_id);
  }
  rec.n_nodes = md.mesh->n_global_nodes, rec.n_elements = md.mesh->n_global_elements;
  rec.time = st.time, rec.step = st.step, rec.measure = st.measure;
  rec.rom = files::absolute_path(so.rom), rec.sim = files::absolute_path(so.sim);
  if (!so.time_set) rec.monitor = so.monitor, rec.monitor_radial_displacement = st.radial;
  sim::write_stress(out, f, rec);
  out.commit();
  if (so.xdmf)
    write_xdmf_collective(comm, o.out, gm,
                          {{"/stress/displacement", "displacement", 1, 3, false},
                           {"/stress/von_mises", "von_mises", 1, 1, false},
                           {"/stress/stress", "stress", 1, 6, false},
                           {"/stress/von_mises_element", "von_mises_element", 1, 1, true}});
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

}  // namespace morse::app::detail
