// The sweep file: one HDF5 file rewritten atomically after every finished speed (see
// morse/sim/sim.hpp, write_sweep; docs/hdf5-schema.md, /sweep).
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>

#include "morse/core/error.hpp"
#include "morse/io/h5.hpp"
#include "morse/sim/sim.hpp"

namespace morse::sim {

namespace {
template <class F>
std::vector<double> column(const std::vector<SpeedResult>& rs, F f) {
  std::vector<double> v;
  for (const auto& r : rs) v.push_back(f(r));
  return v;
}
// A [speed][N] table: the N values f(r) returns for each speed, row by row.
template <std::size_t N, class F>
std::vector<double> table(const std::vector<SpeedResult>& rs, F f) {
  std::vector<double> v;
  for (const auto& r : rs) {
    const std::array<double, N> row = f(r);
    v.insert(v.end(), row.begin(), row.end());
  }
  return v;
}
template <class F>
std::vector<std::int64_t> icolumn(const std::vector<SpeedResult>& rs, F f) {
  std::vector<std::int64_t> v;
  for (const auto& r : rs) v.push_back(static_cast<std::int64_t>(f(r)));
  return v;
}
}  // namespace

void write_sweep(const std::string& path, SweepRecord rec) {
  auto& rs = rec.results;
  std::sort(rs.begin(), rs.end(), [](const SpeedResult& a, const SpeedResult& b) { return a.index < b.index; });
  io::H5Output out(PETSC_COMM_SELF, path);
  io::write_provenance(out, "sweep", rec.units);
  out.write_string("/sweep/settings", rec.settings);
  out.attribute("/sweep", "rom", rec.rom);
  out.attribute_int("/sweep", "n_speeds", rec.n_speeds);
  out.attribute_int("/sweep", "n_done", static_cast<std::int64_t>(rs.size()));
  out.write("/sweep/frequency", rec.frequencies);
  out.attribute("/sweep/frequency", "description", "[Hz] frequencies of /sweep/spectrum");
  out.write("/sweep/eigenfrequencies", rec.eigenfrequencies_hz);
  out.attribute("/sweep/eigenfrequencies", "description",
                "[Hz] natural frequencies of the reduced model without contact");
  out.write("/sweep/index", icolumn(rs, [](const SpeedResult& r) { return r.index; }));
  out.write("/sweep/omega", column(rs, [](const SpeedResult& r) { return r.omega; }));
  out.write("/sweep/status", icolumn(rs, [](const SpeedResult& r) { return r.status; }));
  out.write("/sweep/steps", icolumn(rs, [](const SpeedResult& r) { return r.steps; }));
  out.write("/sweep/dt", column(rs, [](const SpeedResult& r) { return r.dt; }));
  out.attribute("/sweep/dt", "description", "[s] the time step of each speed's run (smaller after a retry)");
  out.write("/sweep/halvings", icolumn(rs, [](const SpeedResult& r) { return r.halvings; }));
  out.attribute("/sweep/halvings", "description",
                "times the step was halved for the speed after a failure (-sweep_retries): dt = -sim_dt / 2^halvings");
  out.write("/sweep/t_final", column(rs, [](const SpeedResult& r) { return r.t_final; }));
  out.write("/sweep/rms", column(rs, [](const SpeedResult& r) { return r.rms; }));
  out.write("/sweep/mean", column(rs, [](const SpeedResult& r) { return r.mean; }));
  out.write("/sweep/max_displacement", column(rs, [](const SpeedResult& r) { return r.max_displacement; }));
  out.write("/sweep/time_of_max", column(rs, [](const SpeedResult& r) { return r.time_of_max; }));
  out.write("/sweep/max_contact_force", column(rs, [](const SpeedResult& r) { return r.max_force; }));
  out.write("/sweep/time_of_max_contact_force", column(rs, [](const SpeedResult& r) { return r.time_of_max_force; }));
  out.write("/sweep/max_node_force", column(rs, [](const SpeedResult& r) { return r.max_node_force; }));
  out.write("/sweep/max_active", icolumn(rs, [](const SpeedResult& r) { return r.max_active; }));
  out.write("/sweep/seconds", column(rs, [](const SpeedResult& r) { return r.seconds; }));
  out.write("/sweep/tangent",
            table<4>(rs,
                     [](const SpeedResult& r) {
                       return std::array<double, 4>{r.tangent_dt_min, r.tangent_dt_min_time,
                                                    static_cast<double>(r.tangent_checks),
                                                    static_cast<double>(r.tangent_negative_checks)};
                     }),
            {static_cast<hsize_t>(rs.size()), 4});
  out.attribute("/sweep/tangent", "description",
                "[speed][4] the smallest tangent critical step 2 / omega_max(K~ + dg~/dq, M~) over the checked states "
                "[s] (inf: none checked), its time [s], the number of checks and of checked states with negative "
                "tangent stiffness (-sim_tangent_checks; theory 9)");
  std::vector<double> spec;
  for (const auto& r : rs) {
    MORSE_CHECK(r.spectrum.size() == rec.frequencies.size(), "sweep: speed ", r.index, " has ", r.spectrum.size(),
                " spectrum values for ", rec.frequencies.size(), " frequencies");
    spec.insert(spec.end(), r.spectrum.begin(), r.spectrum.end());
  }
  out.write("/sweep/spectrum", spec, {static_cast<hsize_t>(rs.size()), static_cast<hsize_t>(rec.frequencies.size())});
  out.attribute("/sweep/spectrum", "description",
                "[speed][frequency] amplitude of the monitored displacement [m]: the largest over each frequency's "
                "bin (half-way to its neighbours), sampled finer than a quarter of the resolution");
  if (rec.orders > 0) {
    std::vector<double> ord;
    for (const auto& r : rs) {
      MORSE_CHECK(r.orders.size() == static_cast<std::size_t>(rec.orders), "sweep: speed ", r.index, " has ",
                  r.orders.size(), " engine-order amplitudes for ", rec.orders, " orders");
      ord.insert(ord.end(), r.orders.begin(), r.orders.end());
    }
    out.write("/sweep/order_amplitude", ord, {static_cast<hsize_t>(rs.size()), static_cast<hsize_t>(rec.orders)});
    out.attribute("/sweep/order_amplitude", "description",
                  "[speed][k - 1] amplitude of engine order k = 1..orders of the monitored displacement at its exact "
                  "frequency k |omega| / 2 pi [m] (NaN: above the spectrum's fmax, or a failed speed)");
  }
  out.write("/sweep/energy_balance",
            table<10>(rs,
                      [](const SpeedResult& r) {
                        const auto &h = r.work_half, &e = r.work_end;
                        return std::array<double, 10>{r.energy_half, h.external, h.normal, h.friction, h.damping,
                                                      r.energy_end,  e.external, e.normal, e.friction, e.damping};
                      }),
            {static_cast<hsize_t>(rs.size()), 10});
  out.attribute("/sweep/energy_balance", "description",
                "[speed][10] energy balance from rest (theory 10.6), at t_final / 2 then at t_final: discrete energy, "
                "work of the loads, of the normal contact forces, of friction, damping dissipation [J]; energy = "
                "load + normal + friction - damping (exact for a linear model)");
  std::vector<double> cont;
  std::size_t r_state = 0;
  for (const auto& r : rs) {
    cont.push_back(static_cast<double>(r.from)), cont.push_back(r.phase), cont.push_back(r.energy_start);
    r_state = std::max(r_state, r.q_end.size());
  }
  out.write("/sweep/continuation", cont, {static_cast<hsize_t>(rs.size()), 3});
  out.attribute("/sweep/continuation", "description",
                "[speed][3] the speed (index) whose final state this speed started from (-1: from rest on the "
                "growing casing), the casing lobes' angle at its start [rad], its discrete energy there [J] "
                "(-sweep_continuation)");
  if (r_state > 0) {  // a continuation sweep: every speed's final state, for the next one and a resume
    std::vector<double> fs;
    for (const auto& r : rs) {
      const bool has = r.q_end.size() == r_state && r.qm_end.size() == r_state;
      for (std::size_t j = 0; j < r_state; ++j) fs.push_back(has ? r.q_end[j] : std::nan(""));
      for (std::size_t j = 0; j < r_state; ++j) fs.push_back(has ? r.qm_end[j] : std::nan(""));
      fs.push_back(has ? r.phase_end : std::nan(""));
    }
    out.write("/sweep/final_state", fs, {static_cast<hsize_t>(rs.size()), static_cast<hsize_t>(2 * r_state + 1)});
    out.attribute("/sweep/final_state", "description",
                  "[speed][2r + 1] the final state q_N, q_{N-1} and the casing lobes' angle at t_N [rad] (NaN: none, "
                  "a failed speed)");
  }
  std::string errors;
  for (const auto& r : rs)
    if (r.status != 0) errors += cat(r.index, "\t", r.error, "\n");
  out.write_string("/sweep/errors", errors);
  out.commit();
}

bool read_sweep(const std::string& path, SweepRecord* rec, std::string* error) {
  struct stat sb;
  if (stat(path.c_str(), &sb) != 0) {
    *error = cat(path, ": no such file");
    return false;
  }
  // Every dataset with its shape: a resumed file is validated whole before any value is used.
  std::map<std::string, std::vector<hsize_t>> dims;
  std::vector<double> omega, dt, tf, rms, mean, umax, tmax, fmax, tfmax, fnode, secs, spec, eb;
  std::vector<std::int64_t> index, status, steps, halvings, act;
  auto dbl = [&](const char* name, std::vector<double>* v) {
    return io::read_doubles(path, cat("/sweep/", name), v, &dims[name], error);
  };
  auto ints = [&](const char* name, std::vector<std::int64_t>* v) {
    return io::read_ints(path, cat("/sweep/", name), v, &dims[name], error);
  };
  std::string errors;
  double n_speeds = -1, n_done = -1;
  bool ok = io::read_string(path, "/sweep/settings", &rec->settings, error) && dbl("frequency", &rec->frequencies) &&
            dbl("eigenfrequencies", &rec->eigenfrequencies_hz) && ints("index", &index) && dbl("omega", &omega) &&
            ints("status", &status) && ints("steps", &steps) && dbl("dt", &dt) && ints("halvings", &halvings) &&
            dbl("t_final", &tf) && dbl("rms", &rms) && dbl("mean", &mean) && dbl("max_displacement", &umax) &&
            dbl("time_of_max", &tmax) && dbl("max_contact_force", &fmax) && dbl("time_of_max_contact_force", &tfmax) &&
            dbl("max_node_force", &fnode) && ints("max_active", &act) && dbl("seconds", &secs) &&
            dbl("spectrum", &spec) && dbl("energy_balance", &eb) &&
            io::read_string(path, "/sweep/errors", &errors, error) &&
            io::read_attribute(path, "/sweep", "n_speeds", &n_speeds, error) &&
            io::read_attribute(path, "/sweep", "n_done", &n_done, error);
  // Continuation data: in the files of a version that had it (optional: older files resume).
  std::vector<double> cont, fs, tan;
  if (ok && io::has_object(path, "/sweep/continuation")) ok = dbl("continuation", &cont);
  if (ok && io::has_object(path, "/sweep/tangent")) ok = dbl("tangent", &tan);
  if (ok && io::has_object(path, "/sweep/final_state")) ok = dbl("final_state", &fs);
  std::vector<double> ord;
  if (ok && io::has_object(path, "/sweep/order_amplitude")) ok = dbl("order_amplitude", &ord);
  if (!ok) {
    *error = cat(path, " is not a complete morse sweep file: ", *error);
    return false;
  }
  auto corrupt = [&](const std::string& what) {
    *error = cat(path, ": ", what, ": the sweep checkpoint is corrupt");
    return false;
  };
  const std::size_t n = index.size(), nf = rec->frequencies.size();
  if (!(n_speeds >= 1 && n_speeds <= 1e15 && n_speeds == std::floor(n_speeds)))
    return corrupt(cat("/sweep@n_speeds is ", n_speeds));
  if (dims["index"].size() != 1 || static_cast<double>(n) > n_speeds)
    return corrupt(cat("/sweep/index holds ", n, " finished speeds of a grid of ", n_speeds));
  if (n_done != static_cast<double>(n))
    return corrupt(cat("/sweep@n_done is ", n_done, " but /sweep/index holds ", n, " finished speeds"));
  if (dims["frequency"].size() != 1 || nf == 0) return corrupt("/sweep/frequency is not a list of frequencies");
  for (const auto& [name, d] : dims) {
    if (name == "frequency" || name == "eigenfrequencies") continue;
    const hsize_t cols = name == "spectrum"          ? nf
                         : name == "energy_balance"  ? 10
                         : name == "continuation"    ? 3
                         : name == "tangent"         ? 4
                         : name == "order_amplitude" ? (d.size() == 2 && d[1] >= 1 ? d[1] : 0)
                         : name == "final_state"     ? (d.size() == 2 && d[1] % 2 == 1 && d[1] >= 3 ? d[1] : 0)
                                                     : 0;
    const std::vector<hsize_t> want = cols ? std::vector<hsize_t>{n, cols} : std::vector<hsize_t>{n};
    if (d != want) {
      std::string shape;
      for (auto x : d) shape += cat(shape.empty() ? "" : " x ", x);
      return corrupt(cat("/sweep/", name, " has shape [", shape, "], expected [", n,
                         cols ? cat(" x ", cols) : std::string(), "] for the ", n, " finished speeds of /sweep/index"));
    }
  }
  std::set<std::int64_t> seen;
  for (std::size_t i = 0; i < n; ++i) {
    if (index[i] < 0 || static_cast<double>(index[i]) >= n_speeds)
      return corrupt(cat("/sweep/index[", i, "] = ", index[i], " is outside the speed grid 0..", n_speeds - 1));
    if (!seen.insert(index[i]).second) return corrupt(cat("/sweep/index holds speed ", index[i], " twice"));
    if (!(dt[i] > 0 && std::isfinite(dt[i])) || halvings[i] < 0 || halvings[i] > 64)
      return corrupt(
          cat("speed ", index[i], " has the step /sweep/dt ", dt[i], " s and /sweep/halvings ", halvings[i]));
  }
  // "<index>\t<message>" per failed speed; a line that does not start so continues the message
  // before it (a message of several lines).
  std::map<long, std::string> msg;
  std::istringstream is(errors);
  std::string* last = nullptr;
  for (std::string line; std::getline(is, line);) {
    const auto tab = line.find('\t');
    char* end = nullptr;
    const long k = tab == std::string::npos || tab == 0 ? 0 : std::strtol(line.c_str(), &end, 10);
    if (end && end == line.c_str() + tab) {
      last = &msg[k];
      *last = line.substr(tab + 1);
    } else if (last) {
      *last += "\n" + line;
    }
  }
  rec->n_speeds = static_cast<long>(n_speeds);
  rec->orders = n > 0 && !ord.empty() ? static_cast<int>(ord.size() / n) : 0;
  rec->results.clear();
  for (std::size_t i = 0; i < n; ++i) {
    SpeedResult r;
    r.index = index[i], r.omega = omega[i], r.status = static_cast<int>(status[i]), r.steps = steps[i];
    r.dt = dt[i], r.halvings = static_cast<int>(halvings[i]);
    r.t_final = tf[i], r.rms = rms[i], r.mean = mean[i], r.max_displacement = umax[i], r.time_of_max = tmax[i];
    r.max_force = fmax[i], r.time_of_max_force = tfmax[i], r.max_node_force = fnode[i];
    r.max_active = static_cast<int>(act[i]), r.seconds = secs[i];
    r.spectrum.assign(spec.begin() + static_cast<std::ptrdiff_t>(i * nf),
                      spec.begin() + static_cast<std::ptrdiff_t>((i + 1) * nf));
    if (rec->orders > 0) {
      const auto k = static_cast<std::ptrdiff_t>(rec->orders), ii = static_cast<std::ptrdiff_t>(i);
      r.orders.assign(ord.begin() + ii * k, ord.begin() + (ii + 1) * k);
    }
    const double* e = &eb[10 * i];
    r.energy_half = e[0], r.work_half = {e[1], e[2], e[3], e[4]};
    r.energy_end = e[5], r.work_end = {e[6], e[7], e[8], e[9]};
    if (r.status != 0) r.error = msg[r.index];
    if (!tan.empty()) {
      const double* x = &tan[4 * i];
      r.tangent_dt_min = x[0], r.tangent_dt_min_time = x[1];
      r.tangent_checks = static_cast<long>(x[2]), r.tangent_negative_checks = static_cast<long>(x[3]);
    }
    if (!cont.empty()) {
      r.from = static_cast<long>(cont[3 * i]), r.phase = cont[3 * i + 1], r.energy_start = cont[3 * i + 2];
      if (r.from < -1 || static_cast<double>(r.from) >= n_speeds)
        return corrupt(cat("speed ", r.index, " continues from speed ", r.from, ", outside the grid"));
    }
    if (!fs.empty()) {
      const std::size_t w = fs.size() / n, rr = (w - 1) / 2;
      const double* row = &fs[w * i];
      if (std::isfinite(row[0])) {
        r.q_end.assign(row, row + rr), r.qm_end.assign(row + rr, row + 2 * rr), r.phase_end = row[2 * rr];
        for (std::size_t j = 0; j < w; ++j)
          if (!std::isfinite(row[j])) return corrupt(cat("speed ", r.index, " has a non-finite final state"));
      }
    }
    rec->results.push_back(std::move(r));
  }
  return true;
}

}  // namespace morse::sim
