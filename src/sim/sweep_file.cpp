// The sweep file: one HDF5 file rewritten atomically after every finished speed (see
// morse/sim/sim.hpp, write_sweep; docs/hdf5-schema.md, /sweep).
#include <sys/stat.h>

#include <algorithm>
#include <map>
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
  std::vector<double> spec;
  for (const auto& r : rs) {
    MORSE_CHECK(r.spectrum.size() == rec.frequencies.size(), "sweep: speed ", r.index, " has ", r.spectrum.size(),
                " spectrum values for ", rec.frequencies.size(), " frequencies");
    spec.insert(spec.end(), r.spectrum.begin(), r.spectrum.end());
  }
  out.write("/sweep/spectrum", spec, {static_cast<hsize_t>(rs.size()), static_cast<hsize_t>(rec.frequencies.size())});
  out.attribute("/sweep/spectrum", "description", "[speed][frequency] amplitude of the monitored displacement [m]");
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
  std::vector<hsize_t> d;
  std::vector<double> omega, tf, rms, mean, umax, tmax, fmax, tfmax, fnode, secs, spec;
  std::vector<std::int64_t> index, status, steps, act;
  std::string errors;
  bool ok = io::read_string(path, "/sweep/settings", &rec->settings, error) &&
            io::read_doubles(path, "/sweep/frequency", &rec->frequencies, &d, error) &&
            io::read_doubles(path, "/sweep/eigenfrequencies", &rec->eigenfrequencies_hz, &d, error) &&
            io::read_ints(path, "/sweep/index", &index, &d, error) &&
            io::read_doubles(path, "/sweep/omega", &omega, &d, error) &&
            io::read_ints(path, "/sweep/status", &status, &d, error) &&
            io::read_ints(path, "/sweep/steps", &steps, &d, error) &&
            io::read_doubles(path, "/sweep/t_final", &tf, &d, error) &&
            io::read_doubles(path, "/sweep/rms", &rms, &d, error) &&
            io::read_doubles(path, "/sweep/mean", &mean, &d, error) &&
            io::read_doubles(path, "/sweep/max_displacement", &umax, &d, error) &&
            io::read_doubles(path, "/sweep/time_of_max", &tmax, &d, error) &&
            io::read_doubles(path, "/sweep/max_contact_force", &fmax, &d, error) &&
            io::read_doubles(path, "/sweep/time_of_max_contact_force", &tfmax, &d, error) &&
            io::read_doubles(path, "/sweep/max_node_force", &fnode, &d, error) &&
            io::read_ints(path, "/sweep/max_active", &act, &d, error) &&
            io::read_doubles(path, "/sweep/seconds", &secs, &d, error) &&
            io::read_doubles(path, "/sweep/spectrum", &spec, &d, error) &&
            io::read_string(path, "/sweep/errors", &errors, error);
  if (!ok) {
    *error = cat(path, " is not a complete morse sweep file: ", *error);
    return false;
  }
  const std::size_t n = index.size(), nf = rec->frequencies.size();
  if (omega.size() != n || spec.size() != n * nf || secs.size() != n) {
    *error = cat(path, ": inconsistent /sweep datasets");
    return false;
  }
  std::map<long, std::string> msg;
  std::istringstream is(errors);
  for (std::string line; std::getline(is, line);) {
    auto tab = line.find('\t');
    if (tab != std::string::npos) msg[std::stol(line.substr(0, tab))] = line.substr(tab + 1);
  }
  rec->results.clear();
  for (std::size_t i = 0; i < n; ++i) {
    SpeedResult r;
    r.index = index[i], r.omega = omega[i], r.status = static_cast<int>(status[i]), r.steps = steps[i];
    r.t_final = tf[i], r.rms = rms[i], r.mean = mean[i], r.max_displacement = umax[i], r.time_of_max = tmax[i];
    r.max_force = fmax[i], r.time_of_max_force = tfmax[i], r.max_node_force = fnode[i];
    r.max_active = static_cast<int>(act[i]), r.seconds = secs[i];
    r.spectrum.assign(spec.begin() + static_cast<std::ptrdiff_t>(i * nf),
                      spec.begin() + static_cast<std::ptrdiff_t>((i + 1) * nf));
    if (r.status != 0) r.error = msg[r.index];
    rec->results.push_back(std::move(r));
  }
  return true;
}

}  // namespace morse::sim
