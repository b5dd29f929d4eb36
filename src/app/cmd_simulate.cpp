// app/cmd_simulate.cpp: `morse simulate`, the online stage of seed 003: a `morse nlrom` reduced
// model integrated by explicit central differences (sim::integrate) under the shared -load_*
// loads, on rank 0. Outputs mirror `morse fom` (/sim/time, /sim/sets/<SET>/u, /sim/energy) plus
// /sim/q.
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/io/h5.hpp"
#include "morse/sim/sim.hpp"

namespace morse::app::detail {

namespace {

struct SimOptions {
  std::string rom, out = "simulate.h5";
  sim::Settings s;
  PetscBool linear = PETSC_FALSE;
  PetscInt every = 1;
  std::vector<std::string> monitor;
};

PetscErrorCode get_sim_options(MPI_Comm comm, SimOptions* o) {
  PetscCall(get_set_list(comm, "-sim_monitor", "Node sets whose reconstructed displacements u = Phi q are written",
                         &o->monitor));
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse simulate options", "");
  PetscCall(PetscOptionsString("-rom", "Reduced model: a morse nlrom file", "", buf, buf, sizeof buf, &set));
  if (set) o->rom = buf;
  buf[0] = 0;
  PetscCall(PetscOptionsString("-out", "Output HDF5 file", "", o->out.c_str(), buf, sizeof buf, &set));
  if (set) o->out = buf;
  PetscCall(PetscOptionsReal("-sim_dt", "Time step [s] (at most the critical step, printed)", "", o->s.dt, &o->s.dt,
                             nullptr));
  PetscCall(PetscOptionsReal("-sim_tfinal", "Final time [s]", "", o->s.t_final, &o->s.t_final, nullptr));
  PetscCall(PetscOptionsBool("-sim_linear", "Linear reduced model (g~ = 0)", "", o->linear, &o->linear, nullptr));
  PetscCall(PetscOptionsInt("-sim_output_every", "Write every K-th step", "", o->every, &o->every, nullptr));
  PetscOptionsEnd();
  o->s.linear = o->linear;
  return PETSC_SUCCESS;
}

}  // namespace

void run_simulate(MPI_Comm comm) {
  SimOptions so;
  MORSE_CALL(get_sim_options(comm, &so));
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(get_loads(comm, &load_list, &load_error));
  if (help_requested()) return;
  check_options(comm, true);
  collective_check(comm, load_error);
  MORSE_CHECK(!so.rom.empty(), "morse simulate: no reduced model given: use -rom FILE.h5 (a morse nlrom file)");
  MORSE_CHECK(so.every > 0, "-sim_output_every must be positive (got ", so.every, ")");
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  // Rank 0 reads the reduced model, the basis and the sets; errors are collective.
  nlrom::ReducedModel rm;
  std::vector<double> basis;  // [r][node][3]
  std::vector<std::int64_t> node_ids;
  std::vector<sim::ReducedLoad> loads;
  std::map<std::string, std::vector<std::size_t>> set_rows;  // set -> node rows of the basis
  std::string err;
  if (rank == 0) {
    std::vector<hsize_t> d;
    std::vector<std::int64_t> ids;
    bool ok = io::read_doubles(so.rom, "/nlrom/M", &rm.M, &d, &err) && d.size() == 2 && d[0] == d[1];
    if (ok) rm.r = static_cast<PetscInt>(d[0]);
    ok = ok && io::read_doubles(so.rom, "/nlrom/K", &rm.K, &d, &err) && io::read_doubles(so.rom, "/nlrom/C", &rm.C, &d, &err) &&
         io::read_doubles(so.rom, "/nlrom/A", &rm.g.A, &d, &err) && io::read_doubles(so.rom, "/nlrom/B", &rm.g.B, &d, &err) &&
         io::read_doubles(so.rom, "/nlrom/basis", &basis, &d, &err) && io::read_ints(so.rom, "/mesh/node_ids", &node_ids, &d, &err);
    const std::size_t r = static_cast<std::size_t>(rm.r);
    rm.g.r = r;
    if (ok && (rm.K.size() != r * r || rm.C.size() != r * r || rm.g.A.size() != nlrom::n_quadratic(r) * r ||
               rm.g.B.size() != nlrom::n_cubic(r) * r || basis.size() != r * node_ids.size() * 3))
      err = cat(so.rom, ": inconsistent /nlrom datasets (r = ", r, ")"), ok = false;
    if (ok) {
      std::map<std::int64_t, std::size_t> row;
      for (std::size_t k = 0; k < node_ids.size(); ++k) row[node_ids[k]] = k;
      auto rows_of = [&](const std::string& set) {
        std::vector<std::int64_t> s;
        if (!io::read_ints(so.rom, "/nlrom/node_sets/" + set, &s, &d, &err)) {
          err = cat(so.rom, ": no node set '", set, "' in /nlrom/node_sets");
          return false;
        }
        auto& v = set_rows[set];
        for (auto id : s) v.push_back(row.at(id));
        return true;
      };
      for (const auto& l : load_list) {
        if (!set_rows.count(l.set) && !rows_of(l.set)) break;
        const double n = std::sqrt(l.dir[0] * l.dir[0] + l.dir[1] * l.dir[1] + l.dir[2] * l.dir[2]);
        sim::ReducedLoad rl;
        rl.amplitude = l.amplitude, rl.omega = l.omega, rl.phase = l.phase;
        rl.p.assign(r, 0.0);
        for (std::size_t j = 0; j < r; ++j)
          for (auto k : set_rows[l.set])
            for (int c = 0; c < 3; ++c) rl.p[j] += l.dir[c] / n * basis[(j * node_ids.size() + k) * 3 + c];
        loads.push_back(std::move(rl));
      }
      for (const auto& m : so.monitor)
        if (err.empty() && !set_rows.count(m)) rows_of(m);
    }
  }
  collective_check(comm, err);
  io::H5Output out(comm, so.out);

  std::vector<double> time, energy, qh;
  std::map<std::string, std::vector<double>> hist;
  sim::Stats st;
  if (rank == 0) {
    try {
      const double hc = sim::critical_step(rm);
      print0(PETSC_COMM_SELF, "morse simulate: r = %d, critical step %.4e s, dt = %.4e s, %s\n", (int)rm.r, hc, so.s.dt,
             so.s.linear ? "linear" : "nonlinear");
      const std::size_t r = static_cast<std::size_t>(rm.r), nn = node_ids.size();
      st = sim::integrate(rm, loads, so.s, [&](const sim::StepState& x) {
        if (x.step % so.every != 0) return;
        time.push_back(x.t);
        energy.push_back(x.energy);
        qh.insert(qh.end(), x.q, x.q + r);
        for (const auto& m : so.monitor) {
          auto& h = hist[m];
          for (auto k : set_rows[m])
            for (int c = 0; c < 3; ++c) {
              double u = 0.0;
              for (std::size_t j = 0; j < r; ++j) u += basis[(j * nn + k) * 3 + c] * x.q[j];
              h.push_back(u);
            }
        }
      });
    } catch (const std::exception& e) {
      err = e.what();
    }
  }
  collective_check(comm, err);
  check_options(comm, false);
  print0(comm, "  %ld steps in %.4f s (%.3g steps/s, with output)\n", st.steps, st.seconds,
         st.seconds > 0 ? st.steps / st.seconds : 0.0);

  StageTimer t(comm, "Write");
  io::write_provenance(out, "simulate", "SI");
  out.write("/sim/time", time);
  out.write("/sim/energy", energy);
  out.attribute("/sim/energy", "description", "seed 003 eq. 46: kinetic + linear strain energy of the reduced model [J]");
  out.write("/sim/q", qh, {static_cast<hsize_t>(time.size()), static_cast<hsize_t>(rm.r)});
  for (const auto& m : so.monitor) {
    std::vector<std::int64_t> ids;
    for (auto k : set_rows[m]) ids.push_back(node_ids[k]);
    out.write("/sim/sets/" + m + "/node_ids", ids);
    out.write("/sim/sets/" + m + "/u", hist[m], {static_cast<hsize_t>(time.size()), ids.size(), 3});
    out.attribute("/sim/sets/" + m + "/u", "description", "[time][node][x,y,z] displacement u = Phi q [m]");
  }
  out.attribute("/sim", "rom", so.rom);
  out.attribute_int("/sim", "linear", so.s.linear ? 1 : 0);
  out.attribute("/sim", "dt", so.s.dt);
  out.attribute_int("/sim", "steps", st.steps);
  out.attribute("/sim", "seconds", st.seconds);
  out.attribute("/sim", "critical_dt", st.critical_dt);
  out.commit();
  print0(comm, "\nmorse: wrote %s\n", so.out.c_str());
}

}  // namespace morse::app::detail
