// The ramp-up's time histories: recording, the /rampup datasets, and seed 000's error eq. 24
// (docs/rampup-theory.md §6, docs/hdf5-schema.md /rampup).
#include <algorithm>
#include <cmath>
#include <limits>

#include "morse/core/error.hpp"
#include "morse/io/h5.hpp"
#include "morse/rampup/rampup.hpp"

namespace morse::rampup {

History record(const Assembly& a, const LoadCase& load, const IntegratorSettings& s, IntegratorStats* stats,
               const std::function<void(double)>& progress) {
  History h;
  h.n_bearings = static_cast<int>(a.bearings().size());
  if (a.n_torsion() > 0) {
    h.n_drives = static_cast<int>(a.torsion().drives.size());
    h.n_gearboxes = static_cast<int>(a.torsion().gearboxes.size());
  }
  const std::size_t nb2 = 2 * a.bearings().size();
  const double t_end = end_time(load, s);
  auto cb = [&](const StepOutput& o) {
    h.t.push_back(o.t);
    h.omega.push_back(o.speed);
    h.force.insert(h.force.end(), o.force, o.force + nb2);
    h.rotor_disp.insert(h.rotor_disp.end(), o.rotor_disp, o.rotor_disp + nb2);
    h.stator_disp.insert(h.stator_disp.end(), o.stator_disp, o.stator_disp + nb2);
    if (o.drive_torque) h.drive_torque.insert(h.drive_torque.end(), o.drive_torque, o.drive_torque + h.n_drives);
    if (o.gearbox_torque)
      h.gearbox_torque.insert(h.gearbox_torque.end(), o.gearbox_torque, o.gearbox_torque + h.n_gearboxes);
    if (progress && t_end > 0.0) progress(std::min(1.0, o.t / t_end));
  };
  IntegratorStats st = integrate(a, load, s, cb);
  if (stats) *stats = std::move(st);
  return h;
}

double feature_error(const double* x, const double* x_ref, std::size_t n, std::size_t stride) {
  MORSE_CHECK(n > 0, "feature_error: empty history");
  double lo = x_ref[0], hi = x_ref[0], worst = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = x_ref[i * stride];
    lo = std::min(lo, r);
    hi = std::max(hi, r);
    worst = std::max(worst, std::abs(x[i * stride] - r));
  }
  if (worst == 0.0) return 0.0;
  return hi > lo ? worst / (hi - lo) : std::numeric_limits<double>::infinity();
}

void write_history(io::H5Output& out, const std::string& group, const History& h) {
  const auto nt = static_cast<hsize_t>(h.n_out()), nb = static_cast<hsize_t>(h.n_bearings);
  out.write(group + "/time", h.t);
  out.attribute(group + "/time", "description", "output times [s]");
  out.write(group + "/omega", h.omega);
  out.attribute(group + "/omega", "description", "driving speed [rad/s]");
  const std::pair<const char*, const std::vector<double>*> sets[] = {
      {"bearing_force", &h.force}, {"rotor_displacement", &h.rotor_disp}, {"stator_displacement", &h.stator_disp}};
  const char* what[] = {
      "[time][bearing][x,y] bearing force F = k (u_rotor - u_housing) + c (v_rotor - v_housing) [N] "
      "(on the housing; the rotor gets -F)",
      "[time][bearing][x,y] displacement of the rotor station [m]",
      "[time][bearing][x,y] displacement of the housing point (mean of its nodes; 0 on the ground) [m]"};
  for (int k = 0; k < 3; ++k) {
    out.write(group + "/" + sets[k].first, *sets[k].second, {nt, nb, 2});
    out.attribute(group + "/" + sets[k].first, "description", what[k]);
  }
  if (h.n_drives > 0) {
    out.write(group + "/drive_torque", h.drive_torque, {nt, static_cast<hsize_t>(h.n_drives)});
    out.attribute(group + "/drive_torque", "description",
                  "[time][drive] torque the drive applies about +z to hold its imposed speed [N m]");
  }
  if (h.n_gearboxes > 0) {
    out.write(group + "/gearbox_torque", h.gearbox_torque, {nt, static_cast<hsize_t>(h.n_gearboxes)});
    out.attribute(group + "/gearbox_torque", "description",
                  "[time][gearbox] mesh torque T = k (phi_in - ratio phi_out) + c (...)' at the input [N m] "
                  "(the input gets -T, the output +ratio T)");
  }
}

History read_history(const std::string& file, const std::string& group) {
  History h;
  std::vector<hsize_t> d;
  std::string err;
  MORSE_CHECK(io::read_doubles(file, group + "/time", &h.t, &d, &err), err, " (not a `morse rampup` file?)");
  MORSE_CHECK(io::read_doubles(file, group + "/omega", &h.omega, &d, &err), err);
  MORSE_CHECK(d.size() == 1 && d[0] == h.t.size(), file, ": ", group, "/omega and /time differ in length");
  std::vector<double>* sets[] = {&h.force, &h.rotor_disp, &h.stator_disp};
  const char* names[] = {"bearing_force", "rotor_displacement", "stator_displacement"};
  for (int k = 0; k < 3; ++k) {
    MORSE_CHECK(io::read_doubles(file, group + "/" + names[k], sets[k], &d, &err), err);
    MORSE_CHECK(d.size() == 3 && d[0] == h.t.size() && d[2] == 2, file, ": ", group, "/", names[k],
                " must be [time][bearing][2]");
    if (k == 0) h.n_bearings = static_cast<int>(d[1]);
    MORSE_CHECK(static_cast<int>(d[1]) == h.n_bearings, file, ": ", group, ": the bearing datasets disagree in size");
  }
  const std::pair<std::vector<double>*, int*> torques[] = {{&h.drive_torque, &h.n_drives},
                                                           {&h.gearbox_torque, &h.n_gearboxes}};
  const char* tnames[] = {"drive_torque", "gearbox_torque"};
  for (int k = 0; k < 2; ++k) {
    if (!io::has_object(file, group + "/" + tnames[k])) continue;
    MORSE_CHECK(io::read_doubles(file, group + "/" + tnames[k], torques[k].first, &d, &err), err);
    MORSE_CHECK(d.size() == 2 && d[0] == h.t.size(), file, ": ", group, "/", tnames[k], " must be [time][",
                k == 0 ? "drive" : "gearbox", "]");
    *torques[k].second = static_cast<int>(d[1]);
  }
  return h;
}

HistoryErrors compare(const History& h, const History& ref) {
  MORSE_CHECK(h.n_bearings == ref.n_bearings, "the reference has ", ref.n_bearings, " bearings, this run ",
              h.n_bearings, ": not the same engine model");
  MORSE_CHECK(h.n_out() == ref.n_out() && h.n_out() > 0, "the reference has ", ref.n_out(), " output times, this run ",
              h.n_out(), ": run both with the same -rampup_dt, -rampup_t_final and -rampup_output_every");
  for (std::size_t i = 0; i < h.n_out(); ++i)
    MORSE_CHECK(std::abs(h.t[i] - ref.t[i]) <= 1e-9 * std::max(1.0, std::abs(ref.t[i])), "output time ", i, " is ",
                h.t[i], " s here and ", ref.t[i],
                " s in the reference: run both with the same time step and output interval");
  HistoryErrors e;
  const std::size_t nf = 2 * static_cast<std::size_t>(h.n_bearings);
  auto summary = [](const std::vector<double>& v, double* worst, double* best, double* mean) {
    *worst = 0.0, *best = std::numeric_limits<double>::infinity(), *mean = 0.0;
    for (double x : v) *worst = std::max(*worst, x), *best = std::min(*best, x), *mean += x;
    if (v.empty())
      *best = 0.0;
    else
      *mean /= static_cast<double>(v.size());
  };
  for (std::size_t f = 0; f < nf; ++f) {
    e.force.push_back(feature_error(h.force.data() + f, ref.force.data() + f, h.n_out(), nf));
    e.displacement.push_back(feature_error(h.rotor_disp.data() + f, ref.rotor_disp.data() + f, h.n_out(), nf));
  }
  summary(e.force, &e.force_worst, &e.force_best, &e.force_mean);
  summary(e.displacement, &e.displacement_worst, &e.displacement_best, &e.displacement_mean);
  // Against the largest range of any bearing and direction.
  auto global = [&](const std::vector<double>& x, const std::vector<double>& xr, const std::vector<double>& own,
                    std::vector<double>* out, double* scale, double* worst, double* mean, int* dominant) {
    *scale = 0;
    std::vector<double> dev(nf, 0.0);
    for (std::size_t f = 0; f < nf; ++f) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (std::size_t i = 0; i < h.n_out(); ++i) {
        lo = std::min(lo, xr[i * nf + f]), hi = std::max(hi, xr[i * nf + f]);
        dev[f] = std::max(dev[f], std::abs(x[i * nf + f] - xr[i * nf + f]));
      }
      *scale = std::max(*scale, hi - lo);
    }
    out->clear();
    for (std::size_t f = 0; f < nf; ++f)
      out->push_back(*scale > 0 ? dev[f] / *scale : (dev[f] > 0 ? std::numeric_limits<double>::infinity() : 0.0));
    double best = 0;
    summary(*out, worst, &best, mean);
    *dominant = static_cast<int>(std::max_element(own.begin(), own.end()) - own.begin());
  };
  global(h.force, ref.force, e.force, &e.force_global, &e.force_scale, &e.force_global_worst, &e.force_global_mean,
         &e.force_dominant);
  global(h.rotor_disp, ref.rotor_disp, e.displacement, &e.displacement_global, &e.displacement_scale,
         &e.displacement_global_worst, &e.displacement_global_mean, &e.displacement_dominant);
  return e;
}

double score(double error_mean, double t, double t_ref) {
  const double pct = 100.0 * error_mean;
  const double s1 = pct < 10.0 ? 10.0 - pct : 0.0;
  const double s2 = t < t_ref ? 10.0 * (1.0 - t / t_ref) : 0.0;
  return s1 + s2;
}

void write_errors(io::H5Output& out, const std::string& group, const HistoryErrors& he, const std::string& reference) {
  const std::string g = group + "/error";
  const auto nb = static_cast<hsize_t>(he.force.size() / 2);
  out.write(g + "/bearing_force", he.force, {nb, 2});
  out.write(g + "/displacement", he.displacement, {nb, 2});
  out.attribute(g, "reference", reference);
  out.attribute(g, "description",
                "seed 000 eq. 24: max over the run of |x - x_ref| / (max x_ref - min x_ref), per bearing "
                "and direction (fractions, not %)");
  const std::pair<const char*, double> sums[] = {{"force_worst", he.force_worst},
                                                 {"force_best", he.force_best},
                                                 {"force_mean", he.force_mean},
                                                 {"displacement_worst", he.displacement_worst},
                                                 {"displacement_best", he.displacement_best},
                                                 {"displacement_mean", he.displacement_mean}};
  for (const auto& [k, v] : sums) out.attribute(g, k, v);
  out.write(g + "/bearing_force_global", he.force_global, {nb, 2});
  out.write(g + "/displacement_global", he.displacement_global, {nb, 2});
  out.attribute(g + "/bearing_force_global", "description",
                "max over the run of |x - x_ref| / (the largest max x_ref - min x_ref of any bearing and direction)");
  const std::pair<const char*, double> global[] = {{"force_global_worst", he.force_global_worst},
                                                   {"force_global_mean", he.force_global_mean},
                                                   {"force_scale", he.force_scale},
                                                   {"displacement_global_worst", he.displacement_global_worst},
                                                   {"displacement_global_mean", he.displacement_global_mean},
                                                   {"displacement_scale", he.displacement_scale}};
  for (const auto& [k, v] : global) out.attribute(g, k, v);
  out.attribute(g, "force_dominant", static_cast<std::int64_t>(he.force_dominant));
  out.attribute(g, "displacement_dominant", static_cast<std::int64_t>(he.displacement_dominant));
}

void write_stator(io::H5Output& out, const std::string& group, const StatorModes& sm, const std::string& file,
                  std::int64_t n_boundary_dofs) {
  constexpr double kTwoPi = 6.283185307179586;
  const std::string g = group + "/stators/" + sm.name;
  std::vector<double> f;
  for (double w : sm.omega) f.push_back(w / kTwoPi);
  out.write(g + "/frequencies_hz", f);
  out.write(g + "/clamped_nodes", sm.clamped_nodes);
  out.attribute(g, "file", file);
  out.attribute_int(g, "n_modes", sm.n_modes);
  out.attribute_int(g, "n_total", sm.n_total);
  out.attribute_int(g, "n_boundary_dofs", n_boundary_dofs);
  out.attribute(g, "f_cut_hz", sm.f_cut_hz);
  out.attribute(g, "damping_offdiag", sm.damping_offdiag);
}

void write_matrices(io::H5Output& out, const std::string& group, const AssembledMatrices& A) {
  const std::string g = group + "/matrices";
  const auto n = static_cast<hsize_t>(A.n);
  out.write(g + "/M", A.M, {n, n});
  out.write(g + "/C", A.C, {n, n});
  out.write(g + "/K", A.K, {n, n});
  out.write(g + "/G", A.G, {n, n});
  out.attribute(g, "description",
                "M x'' + (C + Omega G) x' + K x = f: x = stator modal coordinates, then rotor DOFs "
                "(u_x, u_y, theta_x, theta_y per station); G per unit driving speed [rad/s]");
  out.attribute_int(g, "n_stator_modes", A.n_stator);
}

}  // namespace morse::rampup
