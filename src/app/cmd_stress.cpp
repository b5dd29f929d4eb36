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
#include "morse/dyn/dyn.hpp"
#include "morse/io/h5.hpp"
#include "morse/sim/run.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

namespace {

// gm: the mesh gathered on rank 0 (mesh::gather_to_rank0).
void write_stress_file(MPI_Comm comm, const CommonOptions& o, const sim::StressOptions& so, const Model& md,
                       const mesh::Mesh& gm, io::H5Output& out, const std::vector<std::int64_t>& node_ids,
                       const std::vector<double>& u, const sim::StressField& f, sim::StressRecord rec) {
  StageTimer t(comm, "Write");
  io::write_provenance(out, "stress", md.units);
  io::write_mesh(out, gm);
  if (rank_of(comm) == 0) {
    sim::nodal_fields(node_ids, u, gm, f, &rec);
    print0(PETSC_COMM_SELF,
           "  max von Mises %.4g MPa (quadrature point, element %lld), %.4g MPa at nodes (node "
           "%lld)\n",
           f.max_mises / 1e6, (long long)f.max_element_id, rec.max_nodal_von_mises / 1e6, (long long)rec.max_node_id);
  }
  rec.n_nodes = md.mesh->n_global_nodes, rec.n_elements = md.mesh->n_global_elements;
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

// The stress of a full-model snapshot (seed 003 Fig. 11's reference): the snapshot of -fom
// nearest -stress_time, the mesh's other nodes (fully clamped) at rest.
void run_stress_fom(MPI_Comm comm, const CommonOptions& o, const sim::StressOptions& so) {
  MORSE_CHECK(so.rom.empty() && so.sim.empty(), "morse stress: give either -fom, or -rom and -sim, not both");
  MORSE_CHECK(so.time_set, "morse stress -fom: give -stress_time (the snapshot nearest it is used)");
  collective_check(comm, so.error);
  auto inputs = o.inputs();
  inputs.push_back({"-fom", so.fom});
  const auto output_lock = files::prepare_outputs(comm, {{"-out", o.out}}, inputs);
  // A fom file holds every node's displacement (dependent nodes of rigid and interpolation
  // elements included): only the mesh is used, as for -rom.
  Model md = build_model(comm, o, "morse stress needs a mesh: stresses are recovered element by element", true);
  io::H5Output out(comm, o.out);  // early: a bad -out fails before the work
  // Rank 0 reads the snapshot and completes it with the mesh's nodes; every rank receives it.
  auto gm = mesh::gather_to_rank0(*md.mesh);
  dyn::SnapshotField snap;
  std::vector<std::int64_t> ids;
  std::vector<double> u;
  std::string err;
  if (rank_of(comm) == 0) {
    try {
      snap = dyn::read_fom_snapshot(so.fom, so.time);
      std::map<std::int64_t, std::size_t> at;
      for (std::size_t k = 0; k < snap.node_ids.size(); ++k) at[snap.node_ids[k]] = k;
      std::size_t found = 0;
      for (auto id : gm.node_ids) {
        ids.push_back(id);
        const auto it = at.find(id);
        for (int c = 0; c < 3; ++c) u.push_back(it == at.end() ? 0.0 : snap.u[3 * it->second + c]);
        found += it != at.end();
      }
      MORSE_CHECK(found == snap.node_ids.size(), so.fom, ": ", snap.node_ids.size() - found,
                  " node(s) of its snapshots are not in the mesh ", o.mesh.path, " (another mesh?)");
    } catch (const std::exception& e) {
      err = e.what();
    }
  }
  collective_check(comm, err);
  double hdr[2] = {snap.time, static_cast<double>(snap.index)};
  MPI_Bcast(hdr, 2, MPI_DOUBLE, 0, comm);
  long n = static_cast<long>(ids.size());
  MPI_Bcast(&n, 1, MPI_LONG, 0, comm);
  ids.resize(static_cast<std::size_t>(n));
  u.resize(3 * static_cast<std::size_t>(n));
  MPI_Bcast(ids.data(), static_cast<int>(n), MPI_INT64_T, 0, comm);
  MPI_Bcast(u.data(), static_cast<int>(3 * n), MPI_DOUBLE, 0, comm);
  const auto measure = so.measure == "linear" ? sim::StressMeasure::Linear : sim::StressMeasure::Nonlinear;
  sim::StressField f;
  {
    StageTimer t(comm, "Stress");
    f = sim::recover_stress(*md.mesh, o.mesh.material, ids, u, measure);
  }
  check_options(comm, false);
  print0(comm, "\nmorse stress: %s stress of the full model at t = %.9g s (snapshot %lld of %s)\n",
         measure == sim::StressMeasure::Linear ? "linear" : "nonlinear", hdr[0], (long long)hdr[1], so.fom.c_str());
  sim::StressRecord rec;
  rec.time = hdr[0], rec.step = static_cast<std::int64_t>(hdr[1]), rec.measure = measure;
  rec.sim = files::absolute_path(so.fom);
  write_stress_file(comm, o, so, md, gm, out, ids, u, f, rec);
}

}  // namespace

void run_stress(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "stress.h5", &o));
  sim::StressOptions so;
  MORSE_CALL(so.set_from_options(comm));
  if (help_requested()) return;
  check_options(comm, true);
  if (!so.fom.empty()) {
    run_stress_fom(comm, o, so);
    return;
  }
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
  // The stored basis is expanded at every node (constraints included): only the mesh is used.
  Model md = build_model(comm, o, "morse stress needs a mesh: stresses are recovered element by element", true);
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

  sim::StressRecord rec;
  rec.time = st.time, rec.step = st.step, rec.measure = st.measure;
  rec.rom = files::absolute_path(so.rom), rec.sim = files::absolute_path(so.sim);
  if (!so.time_set) rec.monitor = so.monitor, rec.monitor_radial_displacement = st.radial;
  write_stress_file(comm, o, so, md, mesh::gather_to_rank0(*md.mesh), out, sm.node_ids, u, f, rec);
}

}  // namespace morse::app::detail
