// sim/sim_file.cpp: the file of a reduced run (/sim of `morse simulate`; sim/sim.hpp,
// docs/hdf5-schema.md).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/io/h5.hpp"
#include "morse/sim/sim.hpp"

namespace morse::sim {

namespace {
// The datasets of /sim/energy_balance, in the order written and read.
template <class Balance>
auto balance_columns(Balance& b) {
  using Column = std::pair<const char*, decltype(&b.time)>;
  return std::array<Column, 6>{{{"time", &b.time},
                                {"energy", &b.energy},
                                {"external", &b.external},
                                {"normal", &b.normal},
                                {"friction", &b.friction},
                                {"damping", &b.damping}}};
}
}  // namespace

void write_sim(io::H5Output& out, const SimRecord& rec, const Settings& s, const Stats& stats) {
  const bool implicit = s.scheme != Scheme::Central;
  const auto nt = static_cast<hsize_t>(rec.time.size());
  out.write("/sim/time", rec.time);
  out.write("/sim/energy", rec.energy);
  out.attribute("/sim/energy", "description",
                "seed 003 eq. 46: kinetic + linear strain energy of the reduced model [J]");
  out.write("/sim/q", rec.q, {nt, static_cast<hsize_t>(rec.final_q.size())});
  out.write("/sim/final/q", rec.final_q);
  out.write("/sim/final/v", rec.final_v);
  out.attribute("/sim/final", "time", rec.final_time);
  if (!rec.balance.time.empty()) {
    const auto& b = rec.balance;
    const std::string g = "/sim/energy_balance";
    for (const auto& [name, v] : balance_columns(b)) out.write(g + "/" + name, *v);
    out.attribute(g, "period", b.period);
    out.attribute(g, "description",
                  "energy balance of central differences (theory 10.6): energy(i) - energy(0) = external + normal + "
                  "friction - damping at row i (cumulative works from t = 0) [J], rows at t = 0, every period "
                  "(a revolution of the casing, or t_final / 100) and at the end; exact to round-off for a linear "
                  "model, O(dt^2) for a nonlinear one");
    out.attribute(g + "/energy", "description",
                  "E_{n+1/2} = v^T M v / 2 + q_n^T K q_{n+1} / 2 + V(q_{n+1/2}), v = (q_{n+1} - q_n) / dt [J]");
    out.attribute(g + "/normal", "description", "work of the normal contact forces on the model [J]");
    out.attribute(g + "/friction", "description", "work of the friction forces on the model [J]");
    out.attribute(g + "/damping", "description", "energy dissipated by the viscous damping (>= 0) [J]");
  }
  for (const auto& m : rec.sets) {
    out.write("/sim/sets/" + m.name + "/node_ids", m.node_ids);
    out.write("/sim/sets/" + m.name + "/u", m.u, {nt, m.node_ids.size(), 3});
    out.attribute("/sim/sets/" + m.name + "/u", "description", "[time][node][x,y,z] displacement u = Phi q [m]");
  }
  if (!rec.snapshots_fom.empty()) {
    const auto ns = static_cast<hsize_t>(rec.snapshot_time.size()),
               nd = static_cast<hsize_t>(rec.snapshot_node_ids.size());
    out.write("/sim/snapshots/time", rec.snapshot_time);
    out.write("/sim/snapshots/u", rec.snapshot_u, {ns, nd});
    out.write("/sim/snapshots/v", rec.snapshot_v, {ns, nd});
    out.write("/sim/snapshots/dof_node_ids", rec.snapshot_node_ids);
    out.write("/sim/snapshots/dof_components", rec.snapshot_components);
    out.attribute("/sim/snapshots", "fom", rec.snapshots_fom);
  }
  if (!s.contact.nodes.empty()) {
    const auto& c = rec.contact;
    const auto nn = static_cast<hsize_t>(s.contact.nodes.size());
    out.write("/sim/contact/node_ids", c.node_ids);
    out.write("/sim/contact/normal", c.normal, {nt, nn});
    out.attribute("/sim/contact/normal", "description", "[time][node] normal contact force lambda >= 0 [N]");
    out.write("/sim/contact/tangential", c.tangential, {nt, nn, 3});
    out.attribute("/sim/contact/tangential", "description", "[time][node][x,y,z] Coulomb friction force [N]");
    out.write("/sim/contact/normals", c.normals, {nn, 3});
    out.attribute("/sim/contact/normals", "description",
                  "[node][x,y,z] unit normal n_k to the free side (constant): the force on node k is "
                  "normal n_k + tangential");
    out.write("/sim/contact/mean_force", c.mean_force, {nt, nn, 3});
    out.attribute("/sim/contact/mean_force", "description",
                  "[time][node][x,y,z] mean contact force (normal n_k + tangential) over the steps since the "
                  "previous output row [N], global axes; row 0 is 0; at mean_force_time");
    out.write("/sim/contact/mean_force_time", c.mean_force_time);
    out.attribute("/sim/contact/mean_force_time", "description",
                  "centre of each row's output interval [s] (0 for row 0): the time grid of mean_force");
    out.write("/sim/contact/gap", c.gap, {nt, nn});
    out.attribute("/sim/contact/gap", "description", "[time][node] gap after the correction [m] (>= 0)");
    out.write("/sim/contact/active", c.active);
    out.write("/sim/contact/radial_displacement", c.radial_displacement, {nt, nn});
    out.attribute("/sim/contact/radial_displacement", "description",
                  "[time][node] e_r . u, e_r = (x, y, 0) / |(x, y)| of the node's reference position [m]");
    out.attribute("/sim/contact", "obstacle", s.contact.obstacle == Obstacle::Casing ? "casing" : "plane");
    out.attribute("/sim/contact", "mu", s.contact.mu);
    out.attribute("/sim/contact", "max_normal_force", c.max_normal_force);
    out.attribute("/sim/contact", "time_of_max_normal_force", c.time_of_max_normal_force);
    if (s.contact.obstacle == Obstacle::Casing) {
      const auto& cs = s.contact.casing;
      out.attribute("/sim/contact", "omega", cs.omega);
      out.attribute("/sim/contact", "sliding", s.contact.sliding == Sliding::Relative ? "relative" : "rotation");
      out.attribute("/sim/contact", "clearance", cs.clearance);
      out.attribute("/sim/contact", "bump_height", cs.bump_height);
      out.attribute_int("/sim/contact", "lobes", cs.lobes);
      out.attribute("/sim/contact", "width", cs.width);
      out.attribute("/sim/contact", "alpha", cs.alpha > 0 ? cs.alpha : std::log(100.0) / (0.2 * s.t_final));
    }
  }
  out.attribute("/sim", "rom", rec.rom);
  if (!rec.case_name.empty()) out.attribute("/sim", "case", rec.case_name);
  out.attribute_int("/sim", "linear", s.linear ? 1 : 0);
  out.attribute("/sim", "dt", s.dt);
  out.attribute_int("/sim", "steps", stats.steps);
  out.attribute("/sim", "seconds", stats.seconds);
  out.attribute("/sim", "critical_dt", stats.critical_dt);
  out.attribute("/sim", "kernel", stats.kernel);
  out.attribute("/sim", "scheme", s.scheme == Scheme::Energy ? "energy" : (implicit ? "trapezoidal" : "central"));
  if (implicit) {
    out.attribute_int("/sim", "newton_iterations", stats.newton_iterations);
    out.attribute_int("/sim", "line_searches", stats.line_searches);
    out.attribute_int("/sim", "newton_floor_steps", stats.newton_floor_steps);
    out.attribute("/sim", "newton_floor_ratio", stats.newton_floor_ratio);
  }
  if (!stats.tangent.empty()) {
    std::vector<double> rows;
    for (const auto& x : stats.tangent) rows.insert(rows.end(), {x.t, x.dt, static_cast<double>(x.negative)});
    out.write("/sim/tangent", rows, {static_cast<hsize_t>(stats.tangent.size()), 3});
    out.attribute("/sim/tangent", "description",
                  "[check][t, dt, negative]: the critical step of central differences for the model linearized at "
                  "q(t), 2 / omega_max of (K~ + sym dg~/dq, M~) [s], and its number of negative eigenvalues");
    out.attribute("/sim", "tangent_dt_min", stats.tangent_dt_min);
    out.attribute("/sim", "tangent_dt_min_time", stats.tangent_dt_min_time);
    out.attribute_int("/sim", "tangent_negative_checks", stats.tangent_negative_checks);
  }
  if (stats.error_estimated) {
    out.attribute("/sim", "error_local_max", stats.error_local_max);
    out.attribute("/sim", "error_local_max_time", stats.error_time);
    out.attribute("/sim", "error_local_rms", stats.error_local_rms);
    out.attribute("/sim", "error_sum", stats.error_sum);
    out.attribute("/sim", "error_q_max", stats.error_q_max);
  }
  dyn::write_load_description(out, "/sim/load", rec.load);
}

SimRecord read_sim(const std::string& file, const std::vector<std::string>& sets) {
  SimRecord rec;
  std::string err;
  std::vector<hsize_t> d;
  auto doubles = [&](const std::string& name, std::vector<double>* v) {
    MORSE_CHECK(io::read_doubles(file, name, v, &d, &err), err);
  };
  auto ints = [&](const std::string& name, std::vector<std::int64_t>* v) {
    MORSE_CHECK(io::read_ints(file, name, v, &d, &err), err);
  };
  doubles("/sim/time", &rec.time);
  doubles("/sim/energy", &rec.energy);
  doubles("/sim/q", &rec.q);
  doubles("/sim/final/q", &rec.final_q);
  doubles("/sim/final/v", &rec.final_v);
  MORSE_CHECK(io::read_attribute(file, "/sim/final", "time", &rec.final_time, &err), err);
  const std::size_t nt = rec.time.size(), r = rec.final_q.size();
  MORSE_CHECK(rec.energy.size() == nt && rec.q.size() == nt * r && rec.final_v.size() == r, file,
              ": /sim/energy, /sim/q or /sim/final do not match ", nt, " times of ", r, " coordinates");
  if (io::has_object(file, "/sim/energy_balance")) {
    auto& b = rec.balance;
    for (const auto& [name, v] : balance_columns(b)) doubles(cat("/sim/energy_balance/", name), v);
    MORSE_CHECK(io::read_attribute(file, "/sim/energy_balance", "period", &b.period, &err), err);
    for (const auto& [name, v] : balance_columns(b))
      MORSE_CHECK(v->size() == b.time.size(), file, ": /sim/energy_balance/", name, " has ", v->size(),
                  " rows, /sim/energy_balance/time ", b.time.size());
  }
  for (const auto& name : sets) {
    SimRecord::Set set;
    set.name = name;
    ints("/sim/sets/" + name + "/node_ids", &set.node_ids);
    doubles("/sim/sets/" + name + "/u", &set.u);
    MORSE_CHECK(set.u.size() == nt * set.node_ids.size() * 3, file, ": /sim/sets/", name, "/u has ", set.u.size(),
                " values for ", nt, " times and ", set.node_ids.size(), " nodes");
    rec.sets.push_back(std::move(set));
  }
  if (io::has_object(file, "/sim/snapshots")) {
    rec.snapshots_fom = io::read_string_attribute(file, "/sim/snapshots", "fom");
    doubles("/sim/snapshots/time", &rec.snapshot_time);
    doubles("/sim/snapshots/u", &rec.snapshot_u);
    doubles("/sim/snapshots/v", &rec.snapshot_v);
    ints("/sim/snapshots/dof_node_ids", &rec.snapshot_node_ids);
    ints("/sim/snapshots/dof_components", &rec.snapshot_components);
  }
  if (io::has_object(file, "/sim/contact")) {
    auto& c = rec.contact;
    ints("/sim/contact/node_ids", &c.node_ids);
    doubles("/sim/contact/normal", &c.normal);
    doubles("/sim/contact/tangential", &c.tangential);
    doubles("/sim/contact/normals", &c.normals);
    doubles("/sim/contact/mean_force", &c.mean_force);
    doubles("/sim/contact/mean_force_time", &c.mean_force_time);
    doubles("/sim/contact/gap", &c.gap);
    ints("/sim/contact/active", &c.active);
    doubles("/sim/contact/radial_displacement", &c.radial_displacement);
    MORSE_CHECK(io::read_attribute(file, "/sim/contact", "max_normal_force", &c.max_normal_force, &err), err);
    MORSE_CHECK(io::read_attribute(file, "/sim/contact", "time_of_max_normal_force", &c.time_of_max_normal_force, &err),
                err);
  }
  rec.rom = io::read_string_attribute(file, "/sim", "rom");
  rec.case_name = io::read_string_attribute(file, "/sim", "case");
  dyn::read_load_description(file, "/sim/load", &rec.load);
  return rec;
}

void write_stress(io::H5Output& out, const StressField& f, const StressRecord& r) {
  const auto nn = static_cast<hsize_t>(r.n_nodes), ne = static_cast<hsize_t>(r.n_elements);
  out.write("/stress/displacement", r.displacement, {1, nn, 3});
  out.attribute("/stress/displacement", "description", "[1][node][x,y,z] u = Phi q [m], nodes as /mesh/node_ids");
  out.write("/stress/von_mises", f.nodal_mises, {1, nn});
  out.attribute("/stress/von_mises", "description", "[1][node] von Mises stress of /stress/stress [Pa]");
  // In the component order of XDMF's Tensor6 as ParaView reads it (xx, xy, xz, yy, yz, zz).
  std::vector<double> t6(f.nodal_stress.size());
  for (std::size_t k = 0; k < t6.size(); k += 6) {
    const double* s = &f.nodal_stress[k];
    const double v[6] = {s[0], s[5], s[4], s[1], s[3], s[2]};
    std::copy(v, v + 6, &t6[k]);
  }
  out.write("/stress/stress", t6, {1, nn, 6});
  out.attribute("/stress/stress", "description",
                "[1][node][xx,xy,xz,yy,yz,zz] stress at the node, mean over its elements [Pa]");
  out.write("/stress/von_mises_element", f.element_mises, {1, ne});
  out.attribute("/stress/von_mises_element", "description",
                "[1][element] volume mean of von Mises over the element [Pa]");
  out.write("/stress/von_mises_element_max", f.element_mises_max, {1, ne});
  out.attribute("/stress/von_mises_element_max", "description",
                "[1][element] max of von Mises at its quadrature points [Pa]");
  out.attribute("/stress", "time", r.time);
  out.attribute_int("/stress", "step", r.step);
  out.attribute("/stress", "measure", r.measure == StressMeasure::Linear ? "linear" : "nonlinear");
  out.attribute("/stress", "max_von_mises", f.max_mises);
  out.attribute_int("/stress", "max_element_id", f.max_element_id);
  out.attribute("/stress", "max_nodal_von_mises", r.max_nodal_von_mises);
  out.attribute_int("/stress", "max_node_id", r.max_node_id);
  out.attribute("/stress", "rom", r.rom);
  out.attribute("/stress", "sim", r.sim);
  if (!r.monitor.empty()) {
    out.attribute("/stress", "monitor", r.monitor);
    out.attribute("/stress", "monitor_radial_displacement", r.monitor_radial_displacement);
  }
}

}  // namespace morse::sim
