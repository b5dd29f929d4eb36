// dyn/load_file.cpp: the load description stored with a run, written and read back
// (dyn/dyn.hpp, docs/hdf5-schema.md: /fom/load, /sim/load).
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/io/h5.hpp"

namespace morse::dyn {

namespace {

const char* outside_name(Outside o) {
  switch (o) {
    case Outside::Zero:
      return "zero";
    case Outside::Hold:
      return "hold";
    default:
      return "error";
  }
}

}  // namespace

double first_maximum(const std::vector<NodalLoad>& loads) {
  for (const auto& l : loads)
    if (l.omega > 0) {
      double ph = std::fmod(M_PI / 2 - l.phase, 2 * M_PI);
      if (ph < 0) ph += 2 * M_PI;
      return ph / l.omega;
    }
  return -1;
}

void write_load_description(io::H5Output& out, const std::string& group, const LoadDescription& d) {
  const auto n = d.loads.size();
  out.attribute_int(group, "n_loads", static_cast<std::int64_t>(n));
  out.attribute(group, "description",
                "nodal loads F(t) = amplitude sin(omega t + phase) dir on every node of a set (omega = 0: constant "
                "amplitude dir), plus the tabulated history if any");
  if (n > 0) {
    std::string sets;
    std::vector<double> dir, amp, omega, phase;
    for (const auto& l : d.loads) {
      sets += l.set + "\n";
      dir.insert(dir.end(), l.dir, l.dir + 3);
      amp.push_back(l.amplitude);
      omega.push_back(l.omega);
      phase.push_back(l.phase);
    }
    out.write_string(group + "/sets", sets);
    out.write(group + "/direction", dir, {static_cast<hsize_t>(n), 3});
    out.write(group + "/amplitude", amp);
    out.write(group + "/omega", omega);
    out.write(group + "/phase", phase);
  }
  if (!d.history.empty()) {
    out.attribute(group, "history", d.history);
    out.attribute(group, "history_scale", d.history_scale);
    out.attribute(group, "history_outside", outside_name(d.history_outside));
  }
}

bool read_load_description(const std::string& file, const std::string& group, LoadDescription* d) {
  if (!io::has_object(file, group)) return false;
  LoadDescription r;
  std::string err;
  double n_d = 0;
  MORSE_CHECK(io::read_attribute(file, group, "n_loads", &n_d, &err), err);
  const auto n = static_cast<std::size_t>(n_d);
  if (n > 0) {
    std::string sets;
    std::vector<double> dir, amp, omega, phase;
    std::vector<hsize_t> dims;
    MORSE_CHECK(io::read_string(file, group + "/sets", &sets, &err), err);
    MORSE_CHECK(io::read_doubles(file, group + "/direction", &dir, &dims, &err), err);
    MORSE_CHECK(io::read_doubles(file, group + "/amplitude", &amp, &dims, &err), err);
    MORSE_CHECK(io::read_doubles(file, group + "/omega", &omega, &dims, &err), err);
    MORSE_CHECK(io::read_doubles(file, group + "/phase", &phase, &dims, &err), err);
    std::istringstream in(sets);
    std::string name;
    while (std::getline(in, name)) r.loads.emplace_back().set = name;
    MORSE_CHECK(r.loads.size() == n && dir.size() == 3 * n && amp.size() == n && omega.size() == n && phase.size() == n,
                file, ": ", group, " does not describe its ", n, " loads (sets, direction, amplitude, omega, phase)");
    for (std::size_t k = 0; k < n; ++k) {
      auto& l = r.loads[k];
      for (int c = 0; c < 3; ++c) l.dir[c] = dir[3 * k + c];
      l.amplitude = amp[k];
      l.omega = omega[k];
      l.phase = phase[k];
    }
  }
  r.history = io::read_string_attribute(file, group, "history");
  if (!r.history.empty()) {
    MORSE_CHECK(io::read_attribute(file, group, "history_scale", &r.history_scale, &err), err);
    const std::string o = io::read_string_attribute(file, group, "history_outside");
    const std::string why = parse_outside(o, &r.history_outside);
    MORSE_CHECK(why.empty(), file, ": ", group, "@history_outside: ", why);
  }
  *d = std::move(r);
  return true;
}

}  // namespace morse::dyn
