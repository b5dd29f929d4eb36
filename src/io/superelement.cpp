// io/superelement.cpp: the superelement files (/rom) written and read back (io/superelement.hpp,
// docs/hdf5-schema.md). The exports are in io/export.cpp.
#include "morse/io/superelement.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include "morse/core/error.hpp"
#include "morse/core/handle.hpp"
#include "morse/core/units.hpp"
#include "morse/io/h5.hpp"

namespace morse::io {

namespace fs = std::filesystem;

namespace {

// Largest K_CB r_k relative to ||K_CB||_F ||r_k|| for a superelement that can move rigidly.
// Round-off of the Schur complement gives ~1e-12 on well-conditioned models; a clamp gives O(1).
constexpr double kRigidTol = 1e-6;

std::string shape_text(const std::vector<hsize_t>& d) {
  std::string s = "[";
  for (std::size_t i = 0; i < d.size(); ++i) s += cat(i ? "][" : "", d[i]);
  return s + "]";
}

void check_finite(const std::vector<double>& a, int n, const std::string& file, const char* name) {
  for (std::size_t k = 0; k < a.size(); ++k)
    MORSE_CHECK(std::isfinite(a[k]), file, ": ", name, "[", k / n, "][", k % n, "] is not finite (", a[k], ")");
}

}  // namespace

double Superelement::modal_frequency_hz(int k) const {
  const std::size_t j = static_cast<std::size_t>(n_b + k);
  const double m = M[j * n + j], s = K[j * n + j];
  return m > 0 && s > 0 ? hz(s / m) : 0.0;
}

Superelement read_superelement(const std::string& file) {
  MORSE_CHECK(!file.empty(), "no superelement file given");
  MORSE_CHECK(fs::is_regular_file(file), file, ": no such file");
  Superelement se;
  se.source = file;
  std::string err;
  std::vector<hsize_t> dk, dm, dc, db;
  if (!read_doubles(file, "/rom/K", &se.K, &dk, &err)) {
    if (err.find("cannot open") != std::string::npos)
      throw Error(cat(err, " (a superelement file of morse reduce or select is expected)"));
    if (err.find(": no dataset ") == std::string::npos) throw Error(err);  // e.g. a corrupt shape
    throw Error(cat(file, ": no /rom/K: not a superelement file (/rom is written by morse reduce and morse select)"));
  }
  MORSE_CHECK(dk.size() == 2 && dk[0] == dk[1] && dk[0] > 0, file, ": /rom/K must be square, got ", shape_text(dk));
  se.n = static_cast<int>(dk[0]);
  MORSE_CHECK(read_doubles(file, "/rom/M", &se.M, &dm, &err),
              err.find(": no dataset ") == std::string::npos ? err : cat(file, ": no /rom/M"));
  MORSE_CHECK(dm == dk, file, ": /rom/M is ", shape_text(dm), " but /rom/K is ", shape_text(dk));
  if (has_object(file, "/rom/C")) {
    MORSE_CHECK(read_doubles(file, "/rom/C", &se.C, &dc, &err), err);
    MORSE_CHECK(dc == dk, file, ": /rom/C is ", shape_text(dc), " but /rom/K is ", shape_text(dk));
  }
  check_finite(se.K, se.n, file, "/rom/K");
  check_finite(se.M, se.n, file, "/rom/M");
  check_finite(se.C, se.n, file, "/rom/C");

  std::vector<std::int64_t> labels;
  MORSE_CHECK(read_ints(file, "/rom/boundary_dofs", &labels, &db, &err), file, ": no /rom/boundary_dofs");
  MORSE_CHECK(db.size() == 2 && db[1] == 2 && db[0] <= dk[0], file,
              ": /rom/boundary_dofs must be [n_b][2] with n_b <= ", se.n, " (the size of /rom/K), got ",
              shape_text(db));
  se.n_b = static_cast<int>(db[0]);
  std::set<std::pair<std::int64_t, int>> seen;
  for (int j = 0; j < se.n_b; ++j) {
    const std::int64_t node = labels[2 * j], c = labels[2 * j + 1];
    MORSE_CHECK(c >= 1 && c <= 6, file, ": /rom/boundary_dofs[", j, "]: component ", c, " of node ", node,
                " is not in 1..6");
    MORSE_CHECK(seen.insert({node, static_cast<int>(c)}).second, file, ": /rom/boundary_dofs: node ", node,
                " component ", c, " is given twice");
    se.dof_node.push_back(node);
    se.dof_component.push_back(static_cast<int>(c));
  }
  std::vector<std::int64_t> nodes = se.dof_node;
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  std::vector<hsize_t> dn;
  if (has_object(file, "/rom/boundary_nodes")) {
    MORSE_CHECK(read_ints(file, "/rom/boundary_nodes", &se.boundary_nodes, &dn, &err), err);
    auto sorted = se.boundary_nodes;
    std::sort(sorted.begin(), sorted.end());
    MORSE_CHECK(sorted == nodes && std::is_sorted(se.boundary_nodes.begin(), se.boundary_nodes.end()), file,
                ": /rom/boundary_nodes (", se.boundary_nodes.size(),
                " ids) is not the ascending list of the nodes of /rom/boundary_dofs (", nodes.size(), " nodes)");
  } else {
    se.boundary_nodes = nodes;
  }

  std::string ignored;
  if (!read_string(file, "/meta/units", &se.units, &ignored)) se.units = "unknown";
  read_string(file, "/meta/command", &se.command, &ignored);
  se.selection_method = read_string_attribute(file, "/rom", "selection_method");
  if (has_object(file, "/rom/frequencies_hz"))
    MORSE_CHECK(read_doubles(file, "/rom/frequencies_hz", &se.frequencies_hz, &dn, &err), err);
  if (!read_attribute(file, "/rom", "damping_ratio", &se.damping_ratio, &ignored)) se.damping_ratio = 0;
  if (has_object(file, "/rom/selected_modes"))
    MORSE_CHECK(read_ints(file, "/rom/selected_modes", &se.selected_modes, &dn, &err), err);

  if (has_object(file, "/mesh/node_ids")) {
    std::vector<std::int64_t> ids;
    std::vector<double> xyz;
    std::vector<hsize_t> di, dx;
    MORSE_CHECK(read_ints(file, "/mesh/node_ids", &ids, &di, &err), err);
    MORSE_CHECK(read_doubles(file, "/mesh/coordinates", &xyz, &dx, &err), err);
    MORSE_CHECK(dx.size() == 2 && dx[1] == 3 && dx[0] == ids.size(), file, ": /mesh/coordinates is ", shape_text(dx),
                " but /mesh/node_ids has ", ids.size(), " nodes");
    std::map<std::int64_t, std::size_t> row;
    for (std::size_t k = 0; k < ids.size(); ++k) row[ids[k]] = k;
    // Six-DOF points (rigid and interpolation elements' reference nodes) may be boundary nodes.
    std::vector<std::int64_t> pids;
    std::vector<double> pxyz;
    if (has_object(file, "/mesh/point_ids")) {
      MORSE_CHECK(read_ints(file, "/mesh/point_ids", &pids, &di, &err), err);
      MORSE_CHECK(read_doubles(file, "/mesh/point_coordinates", &pxyz, &dx, &err), err);
      MORSE_CHECK(dx.size() == 2 && dx[1] == 3 && dx[0] == pids.size(), file, ": /mesh/point_coordinates is ",
                  shape_text(dx), " but /mesh/point_ids has ", pids.size(), " points");
    }
    std::map<std::int64_t, std::size_t> prow;
    for (std::size_t k = 0; k < pids.size(); ++k) prow[pids[k]] = k;
    for (std::int64_t node : se.boundary_nodes) {
      auto it = row.find(node);
      if (it != row.end()) {
        for (int d = 0; d < 3; ++d) se.boundary_xyz.push_back(xyz[3 * it->second + d]);
        continue;
      }
      auto pt = prow.find(node);
      MORSE_CHECK(pt != prow.end(), file, ": boundary node ", node,
                  " of /rom/boundary_dofs is not in /mesh/node_ids or /mesh/point_ids");
      for (int d = 0; d < 3; ++d) se.boundary_xyz.push_back(pxyz[3 * pt->second + d]);
    }
    se.from_mesh = true;
    se.model_node_ids = ids;
  } else if (has_object(file, "/dofs/node")) {
    std::vector<std::int64_t> node, comp;
    std::vector<hsize_t> d1, d2;
    MORSE_CHECK(read_ints(file, "/dofs/node", &node, &d1, &err), err);
    MORSE_CHECK(read_ints(file, "/dofs/component", &comp, &d2, &err), file, ": /dofs/node without /dofs/component");
    MORSE_CHECK(node.size() == comp.size(), file, ": /dofs/node has ", node.size(), " rows but /dofs/component ",
                comp.size());
    se.model_dof_node = node;
    for (std::int64_t c : comp) se.model_dof_component.push_back(static_cast<int>(c));
    se.model_node_ids = node;
  }
  std::sort(se.model_node_ids.begin(), se.model_node_ids.end());
  se.model_node_ids.erase(std::unique(se.model_node_ids.begin(), se.model_node_ids.end()), se.model_node_ids.end());
  return se;
}

void write_superelement(H5Output& out, const Superelement& se) {
  const auto n = static_cast<hsize_t>(se.n);
  out.write("/rom/M", se.M, {n, n});
  out.write("/rom/K", se.K, {n, n});
  if (!se.C.empty()) out.write("/rom/C", se.C, {n, n});
  out.write("/rom/boundary_nodes", se.boundary_nodes);
  std::vector<std::int64_t> labels;
  for (int j = 0; j < se.n_b; ++j) {
    labels.push_back(se.dof_node[j]);
    labels.push_back(se.dof_component[j]);
  }
  out.write("/rom/boundary_dofs", labels, {static_cast<hsize_t>(se.n_b), 2});
  out.attribute("/rom/boundary_dofs", "description",
                "[boundary DOF][node id, component 1..6 (1..3 = x, y, z; 4..6 = rotations, matrix input only)]");
  out.write("/rom/frequencies_hz", se.frequencies_hz);
  out.attribute_int("/rom", "n_boundary_dofs", se.n_b);
  out.attribute_int("/rom", "n_modes", se.n_modes());
  out.attribute("/rom", "damping_ratio", se.damping_ratio);
  out.attribute("/rom", "dof_order",
                "boundary DOFs first (those of /rom/boundary_dofs: nodes by ascending id, then components), then "
                "the fixed-interface modal coordinates by ascending frequency (select: those of /rom/selected_modes)");
  if (!se.selection_method.empty()) {
    out.write("/rom/selected_modes", se.selected_modes);
    out.attribute("/rom", "selection_method", se.selection_method);
  }
}

void write_fixed_interface(H5Output& out, const std::vector<double>& omega2) {
  std::vector<double> f;
  for (double l : omega2) f.push_back(std::sqrt(std::max(0.0, l)) / kTwoPi);
  out.write("/cb/fixed_interface/frequencies_hz", f);
  out.write("/cb/fixed_interface/eigenvalues", omega2);
}

void set_boundary_coordinates(Superelement* se, const std::string& path) {
  std::ifstream in(path);
  MORSE_CHECK(in, path, ": cannot open (coordinates: one 'node x y z' per line)");
  std::map<std::int64_t, std::array<double, 3>> xyz;
  std::string line;
  for (int ln = 1; std::getline(in, line); ++ln) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream is(line);
    std::string first;
    if (!(is >> first)) continue;
    char* end = nullptr;
    const long long id = std::strtoll(first.c_str(), &end, 10);
    std::array<double, 3> x{};
    std::string extra;
    MORSE_CHECK(*end == '\0' && (is >> x[0] >> x[1] >> x[2]) && !(is >> extra) && std::isfinite(x[0]) &&
                    std::isfinite(x[1]) && std::isfinite(x[2]),
                path, ":", ln, ": expected 'node x y z'");
    MORSE_CHECK(xyz.emplace(id, x).second, path, ":", ln, ": node ", id, " is given twice");
  }
  std::vector<double> out;
  for (std::int64_t node : se->boundary_nodes) {
    auto it = xyz.find(node);
    MORSE_CHECK(it != xyz.end(), path, ": no coordinates for interface node ", node, " of ", se->source);
    out.insert(out.end(), it->second.begin(), it->second.end());
  }
  se->boundary_xyz = std::move(out);
}

NodalShapes read_nodal_shapes(const Superelement& se) {
  const std::string& file = se.source;
  NodalShapes ns;
  std::string err;
  std::vector<hsize_t> di, dx, dp, df, ds;
  const char* why = " (mode shapes at every node need a file of morse reduce -cb_write_basis)";
  MORSE_CHECK(read_ints(file, "/mesh/node_ids", &ns.node_ids, &di, &err), err, why);
  MORSE_CHECK(read_doubles(file, "/mesh/coordinates", &ns.xyz, &dx, &err), err, why);
  const std::size_t nn = ns.node_ids.size();
  MORSE_CHECK(dx.size() == 2 && dx[0] == nn && dx[1] == 3, file, ": /mesh/coordinates is ", shape_text(dx), " for ", nn,
              " nodes");
  std::vector<double> psi, phi;
  MORSE_CHECK(read_doubles(file, "/cb/constraint_modes", &psi, &dp, &err), err, why);
  MORSE_CHECK(dp.size() == 3 && dp[0] == static_cast<hsize_t>(se.n_b) && dp[1] == nn && dp[2] == 3, file,
              ": /cb/constraint_modes is ", shape_text(dp), ", expected [", se.n_b, "][", nn, "][3]");
  std::vector<std::int64_t> columns;
  if (se.n_modes() > 0) {
    MORSE_CHECK(read_doubles(file, "/cb/fixed_interface/mode_shapes", &phi, &df, &err), err, why);
    MORSE_CHECK(df.size() == 3 && df[1] == nn && df[2] == 3, file, ": /cb/fixed_interface/mode_shapes is ",
                shape_text(df), " for ", nn, " nodes");
    if (has_object(file, "/rom/selected_modes")) {
      MORSE_CHECK(read_ints(file, "/rom/selected_modes", &columns, &ds, &err), err);
    } else {
      for (int k = 0; k < se.n_modes(); ++k) columns.push_back(k);
    }
    MORSE_CHECK(columns.size() == static_cast<std::size_t>(se.n_modes()), file, ": ", columns.size(),
                " fixed-interface shapes for ", se.n_modes(), " modal coordinates of /rom");
    for (std::int64_t c : columns)
      MORSE_CHECK(c >= 0 && static_cast<hsize_t>(c) < df[0], file, ": /rom/selected_modes names mode ", c, " but ",
                  "/cb/fixed_interface/mode_shapes has ", df[0]);
  }
  ns.shapes = std::move(psi);
  ns.shapes.reserve(static_cast<std::size_t>(se.n) * nn * 3);
  for (std::int64_t c : columns)
    ns.shapes.insert(ns.shapes.end(), phi.begin() + c * nn * 3, phi.begin() + (c + 1) * nn * 3);
  return ns;
}

RigidBodyInertia rigid_body_inertia(const Superelement& se) {
  MORSE_CHECK(se.boundary_xyz.size() == 3 * se.boundary_nodes.size() && !se.boundary_nodes.empty(), se.source,
              ": the rigid-body inertia needs the coordinates of the interface nodes (matrix "
              "input: give them "
              "with -export_coordinates FILE)");
  const int n = se.n, nb = se.n_b;
  std::map<std::int64_t, std::size_t> at;
  for (std::size_t k = 0; k < se.boundary_nodes.size(); ++k) at[se.boundary_nodes[k]] = k;
  // R: n_b x 6, the rigid motions at the boundary DOFs (the modal rows are 0).
  std::vector<double> R(static_cast<std::size_t>(nb) * 6, 0.0);
  for (int j = 0; j < nb; ++j) {
    const double* x = &se.boundary_xyz[3 * at[se.dof_node[j]]];
    const int c = se.dof_component[j];
    double* r = &R[static_cast<std::size_t>(j) * 6];
    if (c <= 3) {
      const int d = c - 1;
      r[d] = 1.0;
      // e_a x x for a = x, y, z: (0, -z, y), (z, 0, -x), (-y, x, 0).
      const double rot[3][3] = {{0, -x[2], x[1]}, {x[2], 0, -x[0]}, {-x[1], x[0], 0}};
      for (int a = 0; a < 3; ++a) r[3 + a] = rot[a][d];
    } else {
      r[3 + (c - 4)] = 1.0;
    }
  }
  RigidBodyInertia out;
  double knorm = 0;
  for (double v : se.K) knorm += v * v;
  knorm = std::sqrt(knorm);
  for (int k = 0; k < 6; ++k) {
    double rn = 0, kr = 0;
    for (int j = 0; j < nb; ++j) rn += R[j * 6 + k] * R[j * 6 + k];
    for (int i = 0; i < n; ++i) {
      double s = 0;
      for (int j = 0; j < nb; ++j) s += se.K[static_cast<std::size_t>(i) * n + j] * R[j * 6 + k];
      kr += s * s;
    }
    if (rn == 0) {
      out.reason = cat("the boundary DOFs do not see the rigid rotation about ", "xyz"[k - 3]);
      out.stiffness_residual = 1;
      return out;
    }
    out.stiffness_residual =
        std::max(out.stiffness_residual, knorm > 0 ? std::sqrt(kr) / (knorm * std::sqrt(rn)) : 0.0);
  }
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b) {
      double s = 0;
      for (int i = 0; i < nb; ++i) {
        double mr = 0;
        for (int j = 0; j < nb; ++j) mr += se.M[static_cast<std::size_t>(i) * n + j] * R[j * 6 + b];
        s += R[i * 6 + a] * mr;
      }
      out.rigid_mass[a * 6 + b] = s;
    }
  if (out.stiffness_residual > kRigidTol) {
    out.reason = cat("the superelement cannot move rigidly (||K_CB r|| / (||K_CB|| ||r||) = ", out.stiffness_residual,
                     " for a rigid motion r: DOFs besides the interface are clamped)");
    return out;
  }
  const auto& Mr = out.rigid_mass;
  out.mass = (Mr[0] + Mr[7] + Mr[14]) / 3.0;
  if (!(out.mass > 0)) {
    out.reason = cat("the rigid-body mass is not positive (", out.mass, ")");
    return out;
  }
  const double S[3] = {0.5 * (Mr[5 * 6 + 1] - Mr[4 * 6 + 2]), 0.5 * (Mr[3 * 6 + 2] - Mr[5 * 6 + 0]),
                       0.5 * (Mr[4 * 6 + 0] - Mr[3 * 6 + 1])};
  for (int d = 0; d < 3; ++d) out.center[d] = S[d] / out.mass;
  const double c2 = out.center[0] * out.center[0] + out.center[1] * out.center[1] + out.center[2] * out.center[2];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      const double jo = 0.5 * (Mr[(3 + a) * 6 + 3 + b] + Mr[(3 + b) * 6 + 3 + a]);
      out.inertia_origin[a * 3 + b] = jo;
      out.inertia_cm[a * 3 + b] = jo - out.mass * ((a == b ? c2 : 0.0) - out.center[a] * out.center[b]);
    }
  out.valid = true;
  return out;
}

}  // namespace morse::io
