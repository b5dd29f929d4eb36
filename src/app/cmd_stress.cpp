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
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

namespace {

struct StressOptions {
  std::string rom, sim, monitor = "LE", measure;
  double time = -1.0;
  PetscBool time_set = PETSC_FALSE, xdmf = PETSC_TRUE;
};

PetscErrorCode get_stress_options(MPI_Comm comm, StressOptions* o) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse stress options", "");
  PetscCall(MorseOptionsString("-rom", "Reduced model: the morse nlrom file of the simulation", "", buf, buf, sizeof buf,
                               &set));
  if (set) o->rom = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-sim", "A morse simulate file (/sim/time, /sim/q)", "", buf, buf, sizeof buf, &set));
  if (set) o->sim = buf;
  PetscCall(MorseOptionsReal("-stress_time", "Time [s] of the stress (the nearest stored step); default: the time of "
                             "the largest |radial displacement| at -stress_monitor",
                             "", o->time, &o->time, &o->time_set));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-stress_monitor", "Node set of one node whose largest radial displacement picks the time",
                               "", o->monitor.c_str(), buf, sizeof buf, &set));
  if (set) o->monitor = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-stress_measure",
                               "linear (small strain) | nonlinear (Cauchy stress of St Venant-Kirchhoff); default: "
                               "as the simulation (its /sim attribute linear)",
                               "", "", buf, sizeof buf, &set));
  if (set) o->measure = buf;
  PetscCall(MorseOptionsBool("-stress_xdmf", "Write an XDMF file for ParaView next to the HDF5 file", "", o->xdmf,
                             &o->xdmf, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

}  // namespace

void run_stress(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "stress.h5", &o));
  StressOptions so;
  MORSE_CALL(get_stress_options(comm, &so));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(!so.rom.empty(), "morse stress: no reduced model given: use -rom FILE.h5 (a morse nlrom file)");
  MORSE_CHECK(!so.sim.empty(), "morse stress: no simulation given: use -sim FILE.h5 (a morse simulate file)");
  MORSE_CHECK(so.measure.empty() || so.measure == "linear" || so.measure == "nonlinear",
              "-stress_measure ", so.measure, ": unknown (linear or nonlinear)");

  const auto sm = nlrom::read_stored_model(comm, so.rom, so.time_set ? std::vector<std::string>{}
                                                                     : std::vector<std::string>{so.monitor});
  const std::size_t r = sm.r();
  const std::vector<double> radial = so.time_set ? std::vector<double>{} : sm.radial_row(so.monitor, "-stress_monitor");

  // Rank 0 reads the simulation and picks the state: the stored time nearest -stress_time, or the
  // largest |u_r| at the monitor node. The others receive that state only.
  std::string err;
  double linear = 0.0, ur = 0.0, t_step = 0.0;
  std::int64_t step = 0, nt = 0;
  std::vector<double> q_step(r);
  if (rank_of(comm) == 0) {
    std::vector<double> time, q;
    std::vector<hsize_t> dt, dq;
    if (io::read_doubles(so.sim, "/sim/time", &time, &dt, &err) && io::read_doubles(so.sim, "/sim/q", &q, &dq, &err) &&
        so.measure.empty() && !io::read_attribute(so.sim, "/sim", "linear", &linear, &err))
      err = cat(err, " (give -stress_measure)");
    if (err.empty() && (dq.size() != 2 || dq[0] != time.size() || time.empty()))
      err = cat(so.sim, ": /sim/q and /sim/time disagree (a morse simulate file is expected)");
    else if (err.empty() && dq[1] != r)
      err = cat(so.sim, " has ", dq[1], " reduced coordinates; ", so.rom, " has r = ", r,
                " (not the model of this simulation)");
    else if (err.empty() && so.time_set &&
             !(so.time >= time.front() - 1e-12 && so.time <= time.back() + 1e-12))
      err = cat("-stress_time ", so.time, " s lies outside the simulation [", time.front(), ", ", time.back(), "] s");
    if (err.empty()) {
      nt = static_cast<std::int64_t>(time.size());
      for (std::int64_t i = 0; i < nt; ++i) {
        if (so.time_set) {
          if (std::abs(time[i] - so.time) < std::abs(time[step] - so.time)) step = i;
          continue;
        }
        double v = 0.0;
        for (std::size_t j = 0; j < r; ++j) v += radial[j] * q[static_cast<std::size_t>(i) * r + j];
        if (std::abs(v) > std::abs(ur)) ur = v, step = i;
      }
      t_step = time[step];
      std::copy_n(&q[static_cast<std::size_t>(step) * r], r, q_step.begin());
    }
  }
  collective_check(comm, err);
  double scalars[3] = {linear, ur, t_step};
  std::int64_t ints[2] = {step, nt};
  MPI_Bcast(scalars, 3, MPI_DOUBLE, 0, comm);
  MPI_Bcast(ints, 2, MPI_INT64_T, 0, comm);
  MPI_Bcast(q_step.data(), static_cast<int>(r), MPI_DOUBLE, 0, comm);
  linear = scalars[0], ur = scalars[1], t_step = scalars[2], step = ints[0], nt = ints[1];
  const auto measure = so.measure.empty() ? (linear != 0.0 ? sim::StressMeasure::Linear : sim::StressMeasure::Nonlinear)
                       : so.measure == "linear" ? sim::StressMeasure::Linear
                                                : sim::StressMeasure::Nonlinear;
  Model md = build_model(
      comm, o, "morse stress needs a mesh: stresses are recovered element by element");
  io::H5Output out(comm, o.out);  // early: a bad -out fails before the work
  const auto u = sm.field(q_step.data());
  sim::StressField f;
  {
    StageTimer t(comm, "Stress");
    f = sim::recover_stress(*md.mesh, o.mesh.material, sm.node_ids, u, measure);
  }
  check_options(comm, false);
  const char* mname = measure == sim::StressMeasure::Linear ? "linear" : "nonlinear";
  print0(comm, "\nmorse stress: %s stress at t = %.9g s (step %lld of %lld)%s\n", mname, t_step, (long long)step,
         (long long)nt,
         so.time_set ? "" : cat(", largest |u_r| at ", so.monitor, ": ", ur, " m").c_str());

  StageTimer t(comm, "Write");
  auto gm = mesh::gather_to_rank0(*md.mesh);
  io::write_provenance(out, "stress", md.units);
  io::write_mesh(out, gm);
  const auto nn = static_cast<hsize_t>(md.mesh->n_global_nodes);
  std::vector<double> ug;  // u in the mesh's global node order (rank 0)
  std::int64_t max_node = -1;
  double max_nodal = 0.0;
  if (rank_of(comm) == 0) {
    std::map<std::int64_t, std::size_t> row;
    for (std::size_t k = 0; k < sm.node_ids.size(); ++k) row[sm.node_ids[k]] = k;
    ug.resize(3 * nn);
    for (hsize_t g = 0; g < nn; ++g) {
      const std::size_t k = row.at(gm.node_ids[g]);  // recover_stress checked every node
      for (int c = 0; c < 3; ++c) ug[3 * g + c] = u[3 * k + c];
      if (f.nodal_mises[g] > max_nodal) max_nodal = f.nodal_mises[g], max_node = gm.node_ids[g];
    }
    print0(PETSC_COMM_SELF, "  max von Mises %.4g MPa (quadrature point, element %lld), %.4g MPa at nodes (node %lld)\n",
           f.max_mises / 1e6, (long long)f.max_element_id, max_nodal / 1e6, (long long)max_node);
  }
  sim::StressRecord rec;
  rec.n_nodes = md.mesh->n_global_nodes, rec.n_elements = md.mesh->n_global_elements;
  rec.displacement = std::move(ug);
  rec.time = t_step, rec.step = step, rec.measure = measure;
  rec.max_nodal_von_mises = max_nodal, rec.max_node_id = max_node;
  rec.rom = so.rom, rec.sim = so.sim;
  if (!so.time_set) rec.monitor = so.monitor, rec.monitor_radial_displacement = ur;
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
