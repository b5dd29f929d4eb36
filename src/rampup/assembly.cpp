// Stator superelements, their clamped modal bases, and the rotor–stator assembly
// (docs/rampup-theory.md §3–4).
#include <algorithm>
#include <cmath>

#include "lapack.hpp"
#include "morse/core/error.hpp"
#include "morse/core/units.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/rampup/rampup.hpp"

namespace morse::rampup {

std::vector<std::int64_t> resolve_nodes(const std::string& file, const std::vector<std::string>& spec,
                                        const std::string& who) {
  std::vector<std::int64_t> ids;
  auto add = [&](std::int64_t id) {
    if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
  };
  for (const std::string& item : spec) {
    MORSE_CHECK(!item.empty(), who, ": empty entry in the node list");
    if (item.find_first_not_of("0123456789") == std::string::npos) {
      MORSE_CHECK(item.size() <= 18, who, ": node id ", item, " is out of range");
      add(std::stoll(item));
      continue;
    }
    std::vector<std::int64_t> set;
    std::vector<hsize_t> dims;
    std::string err;
    MORSE_CHECK(io::read_ints(file, "/mesh/node_sets/" + item, &set, &dims, &err), who, ": ", item,
                " is neither a node id nor a node set of ", file,
                " (/mesh/node_sets/<NAME>, written with the mesh; superelements of matrix input "
                "have no sets: give node ids)");
    MORSE_CHECK(!set.empty(), who, ": node set ", item, " of ", file, " is empty");
    for (std::int64_t id : set) add(id);
  }
  return ids;
}

StatorModes stator_modes(const Superelement& se, const std::vector<std::int64_t>& clamped_nodes, double f_cut_hz,
                         double damping_ratio) {
  const std::string who = cat("superelement ", se.source, ": ");
  const std::size_t n = static_cast<std::size_t>(se.n);
  MORSE_CHECK(se.n > 0 && se.n_b >= 0 && se.n_b <= se.n && se.K.size() == n * n && se.M.size() == n * n, who,
              "inconsistent sizes (n = ", se.n, ", n_b = ", se.n_b, ")");
  MORSE_CHECK(se.C.empty() || se.C.size() == n * n, who, "C is not n x n");
  MORSE_CHECK(se.dof_node.size() == static_cast<std::size_t>(se.n_b) &&
                  se.dof_component.size() == static_cast<std::size_t>(se.n_b),
              who, "needs a node and a component for each of its ", se.n_b, " boundary DOFs");
  MORSE_CHECK(f_cut_hz > 0.0 && std::isfinite(f_cut_hz), who, "the truncation frequency must be positive, got ",
              f_cut_hz, " Hz");
  for (std::int64_t c : clamped_nodes)
    MORSE_CHECK(std::find(se.dof_node.begin(), se.dof_node.end(), c) != se.dof_node.end(), who, "clamped node ", c,
                " is not a boundary (interface) node");
  StatorModes sm;
  sm.name = se.source;
  sm.f_cut_hz = f_cut_hz;
  sm.clamped_nodes = clamped_nodes;
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < n; ++i) {
    const bool clamped = static_cast<int>(i) < se.n_b &&
                         std::find(clamped_nodes.begin(), clamped_nodes.end(), se.dof_node[i]) != clamped_nodes.end();
    if (clamped) continue;
    keep.push_back(i);
    if (static_cast<int>(i) < se.n_b) {
      sm.dof_node.push_back(se.dof_node[i]);
      sm.dof_component.push_back(se.dof_component[i]);
    }
  }
  const std::size_t nr = keep.size();
  sm.n_total = static_cast<int>(nr);
  if (nr == 0) return sm;
  std::vector<double> Kr(nr * nr), Mr(nr * nr);
  for (std::size_t i = 0; i < nr; ++i)
    for (std::size_t j = 0; j < nr; ++j) {
      Kr[i * nr + j] = se.K[keep[i] * n + keep[j]];
      Mr[i * nr + j] = se.M[keep[i] * n + keep[j]];
    }
  const double w_cut2 = omega2_of_hz(f_cut_hz);
  std::vector<double> V;
  std::vector<double> lam;
  try {
    lam = eigen::dense_eigenvalues(static_cast<int>(nr), Kr, Mr, &V, w_cut2);
  } catch (const Error& e) {
    throw Error(cat(who, "clamped modal basis: ", e.what()));
  }
  int k = 0;
  while (k < static_cast<int>(nr) && lam[k] <= w_cut2) ++k;
  sm.n_modes = k;
  for (int m = 0; m < k; ++m) sm.omega.push_back(std::sqrt(std::max(lam[m], 0.0)));
  const std::size_t nbf = sm.dof_node.size(), kk = static_cast<std::size_t>(k);
  sm.phi.resize(nbf * kk);
  for (std::size_t i = 0; i < nbf; ++i)
    for (std::size_t m = 0; m < kk; ++m) sm.phi[i * kk + m] = V[i * nr + m];
  sm.damping.assign(kk, 0.0);
  if (damping_ratio >= 0.0) {
    for (std::size_t m = 0; m < kk; ++m) sm.damping[m] = 2.0 * damping_ratio * sm.omega[m];
  } else if (!se.C.empty() && kk > 0) {
    // Phi^T C Phi with Phi the kept columns (row-major nr x nr, column m = mode m).
    std::vector<double> CP(nr * kk, 0.0), P(nr * kk);
    for (std::size_t i = 0; i < nr; ++i)
      for (std::size_t m = 0; m < kk; ++m) P[i * kk + m] = V[i * nr + m];
    for (std::size_t i = 0; i < nr; ++i)
      for (std::size_t j = 0; j < nr; ++j) {
        const double c = se.C[keep[i] * n + keep[j]];
        if (c == 0.0) continue;
        for (std::size_t m = 0; m < kk; ++m) CP[i * kk + m] += c * P[j * kk + m];
      }
    double all = 0.0, off = 0.0;
    for (std::size_t a = 0; a < kk; ++a)
      for (std::size_t b = 0; b < kk; ++b) {
        double s = 0.0;
        for (std::size_t i = 0; i < nr; ++i) s += P[i * kk + a] * CP[i * kk + b];
        all += s * s;
        if (a == b)
          sm.damping[a] = s;
        else
          off += s * s;
      }
    sm.damping_offdiag = all > 0.0 ? std::sqrt(off / all) : 0.0;
  }
  return sm;
}

double default_cut_hz(const std::vector<RotorSpec>& rotors, double omega_max, double factor) {
  double top = 0.0;
  for (const RotorSpec& r : rotors) top = std::max(top, std::fabs(r.speed_ratio * omega_max));
  MORSE_CHECK(top > 0.0 && factor > 0.0, "stator truncation: the top spin speed and the factor must be positive");
  return factor * top / (2.0 * M_PI);
}

// ------------------------------------------------------------------------------------------

Assembly::Assembly(std::vector<RotorSpec> rotors, std::vector<StatorModes> stators, std::vector<Bearing> bearings,
                   Torsion torsion)
    : rotors_(std::move(rotors)),
      stators_(std::move(stators)),
      bearings_(std::move(bearings)),
      torsion_(std::move(torsion)) {
  for (const StatorModes& s : stators_) {
    MORSE_CHECK(s.omega.size() == static_cast<std::size_t>(s.n_modes) && s.damping.size() == s.omega.size() &&
                    s.phi.size() == s.dof_node.size() * s.omega.size() && s.dof_component.size() == s.dof_node.size(),
                "stator ", s.name, ": inconsistent modal basis sizes");
    stator_offset_.push_back(n_stator_);
    n_stator_ += s.n_modes;
    for (int m = 0; m < s.n_modes; ++m) {
      om2_.push_back(s.omega[m] * s.omega[m]);
      cs_.push_back(s.damping[m]);
    }
  }
  std::vector<RotorMatrices> rm;
  for (const RotorSpec& r : rotors_) {
    rm.push_back(rotor_matrices(r));
    rotor_offset_.push_back(n_rotor_);
    n_rotor_ += rm.back().n;
  }
  // Band of the rotor block (rotors are block-diagonal; bearings to a stator or the ground add to
  // the diagonal only, intershaft bearings couple two rotors' stations).
  bw_ = 0;
  for (const RotorMatrices& m : rm)
    for (int i = 0; i < m.n; ++i)
      for (int j = 0; j < m.n; ++j) {
        const std::size_t g = static_cast<std::size_t>(i) * m.n + j;
        if (m.M[g] != 0.0 || m.K[g] != 0.0 || m.G[g] != 0.0 || m.C[g] != 0.0) bw_ = std::max(bw_, std::abs(i - j));
      }
  auto station_ok = [&](int rotor, int station) {
    return rotor >= 0 && rotor < static_cast<int>(rotors_.size()) && station >= 0 &&
           station < static_cast<int>(rotors_[rotor].z.size());
  };
  for (const Bearing& b : bearings_) {
    if (b.rotor2 < 0) continue;
    const std::string who = cat("bearing '", b.name, "': ");
    MORSE_CHECK(station_ok(b.rotor, b.station), who, "rotor ", b.rotor, " station ", b.station, " does not exist");
    MORSE_CHECK(station_ok(b.rotor2, b.station2), who, "intershaft: rotor ", b.rotor2, " station ", b.station2,
                " does not exist");
    MORSE_CHECK(b.rotor2 != b.rotor, who, "an intershaft bearing joins two different rotors (both are '",
                rotors_[b.rotor].name, "')");
    MORSE_CHECK(b.stator == -1 && b.nodes.empty() && b.node == -1, who,
                "an intershaft bearing has no stator and no housing nodes");
    bw_ = std::max(bw_, std::abs(rotor_offset_[b.rotor] + 4 * b.station - rotor_offset_[b.rotor2] - 4 * b.station2));
  }
  const std::size_t ld = 2 * static_cast<std::size_t>(bw_) + 1;
  for (auto* b : {&bM_, &bC_, &bK_, &bG_}) b->assign(ld * n_rotor_, 0.0);
  for (std::size_t r = 0; r < rm.size(); ++r) {
    const RotorMatrices& m = rm[r];
    for (int i = 0; i < m.n; ++i)
      for (int j = std::max(0, i - bw_); j < std::min(m.n, i + bw_ + 1); ++j) {
        const std::size_t g = static_cast<std::size_t>(i) * m.n + j;
        const int gi = rotor_offset_[r] + i, gj = rotor_offset_[r] + j;
        const std::size_t b = static_cast<std::size_t>(bw_ + gi - gj) + ld * gj;
        bM_[b] = m.M[g];
        bC_[b] = m.C[g];
        bK_[b] = m.K[g];
        bG_[b] = rotors_[r].speed_ratio * m.G[g];
      }
    for (const Unbalance& u : rotors_[r].unbalances) {
      const auto d = std::find_if(rotors_[r].disks.begin(), rotors_[r].disks.end(),
                                  [&](const Disk& k) { return k.name == u.disk; });
      unbalance_.push_back({rotor_dof(static_cast<int>(r), d->station, 0), rotors_[r].speed_ratio, u.me, u.phase});
    }
  }
  for (const Bearing& b : bearings_) {
    const std::string who = cat("bearing '", b.name, "': ");
    MORSE_CHECK(b.rotor >= 0 && b.rotor < static_cast<int>(rotors_.size()), who, "rotor index ", b.rotor,
                " is not in 0..", static_cast<int>(rotors_.size()) - 1);
    const int ns = static_cast<int>(rotors_[b.rotor].z.size());
    MORSE_CHECK(b.station >= 0 && b.station < ns, who, "station ", b.station, " is not in 0..", ns - 1, " of rotor '",
                rotors_[b.rotor].name, "'");
    MORSE_CHECK(b.stator >= -1 && b.stator < static_cast<int>(stators_.size()), who, "stator index ", b.stator,
                " is not -1 (ground) or in 0..", static_cast<int>(stators_.size()) - 1);
    const double kc[4] = {b.kxx, b.kyy, b.cxx, b.cyy};
    for (double v : kc)
      MORSE_CHECK(v >= 0.0 && std::isfinite(v), who, "stiffness and damping must be finite and >= 0 (kxx ", b.kxx,
                  ", kyy ", b.kyy, ", cxx ", b.cxx, ", cyy ", b.cyy, ")");
    for (int d = 0; d < 2; ++d) {
      Coupling c;
      c.rotor_index = rotor_offset_[b.rotor] + 4 * b.station + d;
      c.k = d == 0 ? b.kxx : b.kyy;
      c.c = d == 0 ? b.cxx : b.cyy;
      if (b.rotor2 >= 0) {
        // Intershaft: the spring and damper join two rotor DOFs, inside the band.
        c.rotor_index2 = rotor_offset_[b.rotor2] + 4 * b.station2 + d;
        const int i = c.rotor_index, j = c.rotor_index2;
        for (auto [band, v] : {std::pair<std::vector<double>*, double>{&bK_, c.k}, {&bC_, c.c}}) {
          (*band)[static_cast<std::size_t>(bw_) + ld * i] += v;
          (*band)[static_cast<std::size_t>(bw_) + ld * j] += v;
          (*band)[static_cast<std::size_t>(bw_ + i - j) + ld * j] -= v;
          (*band)[static_cast<std::size_t>(bw_ + j - i) + ld * i] -= v;
        }
      } else if (b.stator >= 0) {
        const StatorModes& s = stators_[b.stator];
        const std::vector<std::int64_t> nodes = b.nodes.empty() ? std::vector<std::int64_t>{b.node} : b.nodes;
        c.stator_offset = stator_offset_[b.stator];
        c.n_modes = s.n_modes;
        c.phi.assign(static_cast<std::size_t>(s.n_modes), 0.0);
        for (std::size_t q = 0; q < nodes.size(); ++q) {
          const std::int64_t node = nodes[q];
          MORSE_CHECK(std::find(nodes.begin(), nodes.begin() + q, node) == nodes.begin() + q, who, "node ", node,
                      " is listed twice");
          const bool clamped = std::find(s.clamped_nodes.begin(), s.clamped_nodes.end(), node) != s.clamped_nodes.end();
          MORSE_CHECK(!clamped, who, "node ", node, " of stator ", s.name, " is clamped");
          std::size_t row = s.dof_node.size();
          for (std::size_t i = 0; i < s.dof_node.size(); ++i)
            if (s.dof_node[i] == node && s.dof_component[i] == d + 1) row = i;
          MORSE_CHECK(row < s.dof_node.size(), who, "node ", node, " is not in the interface of stator ", s.name,
                      " (no boundary DOF ", d == 0 ? "x" : "y", ")");
          // The housing point is the mean of the nodes (equal weights).
          const double w = 1.0 / static_cast<double>(nodes.size());
          for (int m = 0; m < s.n_modes; ++m) c.phi[m] += w * s.phi[row * static_cast<std::size_t>(s.n_modes) + m];
        }
      }
      couplings_.push_back(std::move(c));
    }
  }
  build_torsion();
}

void Assembly::build_torsion() {
  if (torsion_.empty()) return;
  const int nr = static_cast<int>(rotors_.size());
  for (int r = 0; r < nr; ++r) {
    twist_offset_.push_back(n_twist_);
    n_twist_ += static_cast<int>(rotors_[r].z.size());
    twist_rotor_.insert(twist_rotor_.end(), rotors_[r].z.size(), r);
  }
  const std::size_t n = static_cast<std::size_t>(n_twist_);
  for (auto* m : {&tM_, &tC_, &tK_}) m->assign(n * n, 0.0);
  for (int r = 0; r < nr; ++r) {
    const RotorMatrices t = torsion_matrices(rotors_[r]);
    const std::size_t o = static_cast<std::size_t>(twist_offset_[r]), m = static_cast<std::size_t>(t.n);
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t j = 0; j < m; ++j) {
        tM_[(o + i) * n + o + j] = t.M[i * m + j];
        tC_[(o + i) * n + o + j] = t.C[i * m + j];
        tK_[(o + i) * n + o + j] = t.K[i * m + j];
      }
  }
  auto check_station = [&](const std::string& who, int rotor, int station) {
    MORSE_CHECK(rotor >= 0 && rotor < nr, who, "rotor index ", rotor, " is not in 0..", nr - 1);
    const int ns = static_cast<int>(rotors_[rotor].z.size());
    MORSE_CHECK(station >= 0 && station < ns, who, "station ", station, " is not in 0..", ns - 1, " of rotor '",
                rotors_[rotor].name, "'");
  };
  // Rotors joined by gearboxes form groups; each group needs a drive.
  std::vector<int> group(nr);
  for (int r = 0; r < nr; ++r) group[r] = r;
  auto root = [&](int r) {
    while (group[r] != r) r = group[r];
    return r;
  };
  for (const Gearbox& g : torsion_.gearboxes) {
    const std::string who = cat("gearbox '", g.name, "': ");
    check_station(who + "input: ", g.input, g.input_station);
    check_station(who + "output: ", g.output, g.output_station);
    MORSE_CHECK(g.input != g.output, who, "input and output are both on rotor '", rotors_[g.input].name, "'");
    MORSE_CHECK(std::isfinite(g.ratio) && g.ratio != 0.0, who, "the ratio must be finite and nonzero, got ", g.ratio);
    MORSE_CHECK(std::isfinite(g.k) && g.k > 0.0 && std::isfinite(g.c) && g.c >= 0.0, who,
                "the mesh stiffness must be > 0 and the damping >= 0 (k ", g.k, " N m/rad, c ", g.c, " N m s/rad)");
    const double si = rotors_[g.input].speed_ratio, so = rotors_[g.output].speed_ratio;
    MORSE_CHECK(std::fabs(si - g.ratio * so) <= 1e-9 * std::max(std::fabs(si), std::fabs(g.ratio * so)), who, "ratio ",
                g.ratio, ", but rotor '", rotors_[g.input].name, "' turns at ", si, " and '", rotors_[g.output].name,
                "' at ", so, " times the driving speed (their ratio is ", si / so,
                "): make the speed ratios agree with the gearbox");
    const std::size_t i = static_cast<std::size_t>(twist_dof(g.input, g.input_station)),
                      j = static_cast<std::size_t>(twist_dof(g.output, g.output_station));
    for (auto [m, v] : {std::pair<std::vector<double>*, double>{&tK_, g.k}, {&tC_, g.c}}) {
      (*m)[i * n + i] += v;
      (*m)[j * n + j] += g.ratio * g.ratio * v;
      (*m)[i * n + j] -= g.ratio * v;
      (*m)[j * n + i] -= g.ratio * v;
    }
    group[root(g.input)] = root(g.output);
  }
  for (const Drive& d : torsion_.drives) {
    const std::string who = cat("drive '", d.name, "': ");
    check_station(who, d.rotor, d.station);
    const int dof = twist_dof(d.rotor, d.station);
    MORSE_CHECK(std::find(driven_.begin(), driven_.end(), dof) == driven_.end(), who, "station ", d.station,
                " of rotor '", rotors_[d.rotor].name, "' is driven twice");
    driven_.push_back(dof);
  }
  std::sort(driven_.begin(), driven_.end());
  for (const Torque& t : torsion_.torques) {
    const std::string who = cat("torque '", t.name, "': ");
    check_station(who, t.rotor, t.station);
    MORSE_CHECK(std::isfinite(t.coefficient) && t.coefficient >= 0.0, who, "the coefficient must be >= 0, got ",
                t.coefficient, " N m s^2");
  }
  for (int r = 0; r < nr; ++r) {
    bool driven = false;
    for (const Drive& d : torsion_.drives) driven = driven || root(d.rotor) == root(r);
    MORSE_CHECK(driven, "rotor '", rotors_[r].name,
                "' is not driven: with torsion (drives, gearboxes or torques) every rotor needs a drive, on itself "
                "or through gearboxes (-rampup_drives, -rampup_gearboxes), or its rigid rotation would be free");
  }
  for (int i = 0; i < n_twist_; ++i)
    if (!std::binary_search(driven_.begin(), driven_.end(), i)) free_.push_back(i);
  tMs_.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) tMs_[i] += tM_[i * n + j] * rotors_[twist_rotor_[j]].speed_ratio;
}

void Assembly::torsion_load(double omega, double omega_dot, double* f) const {
  for (std::size_t i = 0; i < tMs_.size(); ++i) f[i] = -tMs_[i] * omega_dot;
  for (const Torque& t : torsion_.torques) {
    const double w = rotors_[t.rotor].speed_ratio * omega;
    f[twist_dof(t.rotor, t.station)] -= t.coefficient * w * std::fabs(w);
  }
}

void Assembly::torsion_state(const double* phi, const double* dphi, const double* ddphi, double omega, double omega_dot,
                             double* drive_torque, double* gearbox_torque) const {
  const std::size_t n = static_cast<std::size_t>(n_twist_);
  if (drive_torque) {
    std::vector<double> f(n);
    torsion_load(omega, omega_dot, f.data());
    for (std::size_t k = 0; k < torsion_.drives.size(); ++k) {
      const std::size_t i = static_cast<std::size_t>(twist_dof(torsion_.drives[k].rotor, torsion_.drives[k].station));
      double s = -f[i];
      for (std::size_t j = 0; j < n; ++j)
        s += tM_[i * n + j] * ddphi[j] + tC_[i * n + j] * dphi[j] + tK_[i * n + j] * phi[j];
      drive_torque[k] = s;
    }
  }
  if (gearbox_torque)
    for (std::size_t k = 0; k < torsion_.gearboxes.size(); ++k) {
      const Gearbox& g = torsion_.gearboxes[k];
      const int i = twist_dof(g.input, g.input_station), j = twist_dof(g.output, g.output_station);
      gearbox_torque[k] = g.k * (phi[i] - g.ratio * phi[j]) + g.c * (dphi[i] - g.ratio * dphi[j]);
    }
}

std::vector<double> Assembly::torsion_frequencies() const {
  const std::size_t nf = free_.size(), n = static_cast<std::size_t>(n_twist_);
  if (nf == 0) return {};
  std::vector<double> K(nf * nf), M(nf * nf);
  for (std::size_t a = 0; a < nf; ++a)
    for (std::size_t b = 0; b < nf; ++b) {
      K[a * nf + b] = tK_[free_[a] * n + free_[b]];
      M[a * nf + b] = tM_[free_[a] * n + free_[b]];
    }
  std::vector<double> w = eigen::dense_eigenvalues(static_cast<int>(nf), K, M);
  for (double& v : w) v = std::sqrt(std::max(v, 0.0));
  return w;
}

void Assembly::apply(double cM, double cD, double cK, double omega, const double* x, double* y) const {
  for (int i = 0; i < n_stator_; ++i) y[i] = (cM + cD * cs_[i] + cK * om2_[i]) * x[i];
  const double* xr = x + n_stator_;
  double* yr = y + n_stator_;
  const std::size_t ld = 2 * static_cast<std::size_t>(bw_) + 1;
  const double cG = cD * omega;
  for (int i = 0; i < n_rotor_; ++i) yr[i] = 0.0;
  for (int j = 0; j < n_rotor_; ++j) {
    const double xj = xr[j];
    if (xj == 0.0) continue;
    const std::size_t col = ld * j;
    for (int i = std::max(0, j - bw_); i < std::min(n_rotor_, j + bw_ + 1); ++i) {
      const std::size_t b = col + static_cast<std::size_t>(bw_ + i - j);
      yr[i] += (cM * bM_[b] + cD * bC_[b] + cK * bK_[b] + cG * bG_[b]) * xj;
    }
  }
  for (const Coupling& c : couplings_) {
    const double a = cK * c.k + cD * c.c;
    if (a == 0.0 || c.rotor_index2 >= 0) continue;  // intershaft: in the band
    double d = xr[c.rotor_index];
    const double* xs = c.stator_offset >= 0 ? x + c.stator_offset : nullptr;
    for (int m = 0; m < c.n_modes; ++m) d -= c.phi[m] * xs[m];
    yr[c.rotor_index] += a * d;
    for (int m = 0; m < c.n_modes; ++m) y[c.stator_offset + m] -= a * d * c.phi[m];
  }
}

double Assembly::energy(const double* x, const double* v) const {
  std::vector<double> y(n());
  double e = 0.0;
  apply(1.0, 0.0, 0.0, 0.0, v, y.data());
  for (int i = 0; i < n(); ++i) e += 0.5 * v[i] * y[i];
  apply(0.0, 0.0, 1.0, 0.0, x, y.data());
  for (int i = 0; i < n(); ++i) e += 0.5 * x[i] * y[i];
  return e;
}

AssembledMatrices Assembly::dense() const {
  AssembledMatrices A;
  A.n = n();
  A.n_stator = n_stator_;
  const std::size_t N = static_cast<std::size_t>(A.n);
  for (auto* m : {&A.M, &A.C, &A.K, &A.G}) m->assign(N * N, 0.0);
  for (int i = 0; i < n_stator_; ++i) {
    A.M[i * N + i] = 1.0;
    A.C[i * N + i] = cs_[i];
    A.K[i * N + i] = om2_[i];
  }
  const std::size_t ld = 2 * static_cast<std::size_t>(bw_) + 1, o = static_cast<std::size_t>(n_stator_);
  for (int j = 0; j < n_rotor_; ++j)
    for (int i = std::max(0, j - bw_); i < std::min(n_rotor_, j + bw_ + 1); ++i) {
      const std::size_t b = ld * j + static_cast<std::size_t>(bw_ + i - j), g = (o + i) * N + o + j;
      A.M[g] = bM_[b];
      A.C[g] = bC_[b];
      A.K[g] = bK_[b];
      A.G[g] = bG_[b];
    }
  for (const Coupling& c : couplings_) {
    if (c.rotor_index2 >= 0) continue;  // intershaft: in the band
    const std::size_t r = o + c.rotor_index;
    for (auto [mat, a] : {std::pair<std::vector<double>*, double>{&A.K, c.k}, {&A.C, c.c}}) {
      std::vector<double>& X = *mat;
      X[r * N + r] += a;
      for (int p = 0; p < c.n_modes; ++p) {
        const std::size_t sp = static_cast<std::size_t>(c.stator_offset + p);
        X[r * N + sp] -= a * c.phi[p];
        X[sp * N + r] -= a * c.phi[p];
        for (int q = 0; q < c.n_modes; ++q) X[sp * N + c.stator_offset + q] += a * c.phi[p] * c.phi[q];
      }
    }
  }
  return A;
}

void Assembly::add_unbalance(double omega, double omega_dot, double angle, double* f) const {
  for (const Force& u : unbalance_) {
    const double w = u.ratio * omega, wd = u.ratio * omega_dot, th = u.ratio * angle + u.phase;
    const double c = std::cos(th), s = std::sin(th);
    f[u.dof_x] += u.me * (w * w * c + wd * s);
    f[u.dof_x + 1] += u.me * (w * w * s - wd * c);
  }
}

void Assembly::bearing_state(const double* x, const double* v, double* force, double* rotor_disp,
                             double* stator_disp) const {
  for (std::size_t j = 0; j < couplings_.size(); ++j) {
    const Coupling& c = couplings_[j];
    const std::size_t r = static_cast<std::size_t>(n_stator_ + c.rotor_index);
    double us = 0.0, vs = 0.0;
    if (c.rotor_index2 >= 0) {
      const std::size_t r2 = static_cast<std::size_t>(n_stator_ + c.rotor_index2);
      us = x[r2];
      vs = v ? v[r2] : 0.0;
    }
    for (int m = 0; m < c.n_modes; ++m) {
      us += c.phi[m] * x[c.stator_offset + m];
      if (v) vs += c.phi[m] * v[c.stator_offset + m];
    }
    if (force) force[j] = c.k * (x[r] - us) + (v ? c.c * (v[r] - vs) : 0.0);
    if (rotor_disp) rotor_disp[j] = x[r];
    if (stator_disp) stator_disp[j] = us;
  }
}

// ------------------------------------------------------------------------------------------

std::vector<std::complex<double>> whirl_eigenvalues(const Assembly& a, double omega) {
  const AssembledMatrices A = a.dense();
  const std::size_t n = static_cast<std::size_t>(A.n), n2 = 2 * n;
  if (n == 0) return {};
  // lambda = s0 mu with s0^2 ~ K/M balances the pencil.
  double kmax = 0.0, mmax = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    kmax = std::max(kmax, std::fabs(A.K[i * n + i]));
    mmax = std::max(mmax, std::fabs(A.M[i * n + i]));
  }
  const double s0 = kmax > 0.0 && mmax > 0.0 ? std::sqrt(kmax / mmax) : 1.0;
  // Column-major 2n x 2n: P = [0 I; -K/s0^2 -D/s0], Q = [I 0; 0 M].
  std::vector<double> P(n2 * n2, 0.0), Q(n2 * n2, 0.0);
  auto at = [n2](std::vector<double>& X, std::size_t i, std::size_t j) -> double& { return X[i + n2 * j]; };
  for (std::size_t i = 0; i < n; ++i) {
    at(P, i, n + i) = 1.0;
    at(Q, i, i) = 1.0;
    for (std::size_t j = 0; j < n; ++j) {
      at(P, n + i, j) = -A.K[i * n + j] / (s0 * s0);
      at(P, n + i, n + j) = -(A.C[i * n + j] + omega * A.G[i * n + j]) / s0;
      at(Q, n + i, n + j) = A.M[i * n + j];
    }
  }
  PetscBLASInt N = static_cast<PetscBLASInt>(n2), one = 1, lwork = static_cast<PetscBLASInt>(16 * n2), info = 0;
  std::vector<double> ar(n2), ai(n2), be(n2), work(static_cast<std::size_t>(lwork));
  double dummy = 0.0;
  dggev_("N", "N", &N, P.data(), &N, Q.data(), &N, ar.data(), ai.data(), be.data(), &dummy, &one, &dummy, &one,
         work.data(), &lwork, &info);
  MORSE_CHECK(info == 0, "whirl eigenvalues: LAPACK dggev failed (info = ", info, ")");
  std::vector<std::complex<double>> out;
  for (std::size_t k = 0; k < n2; ++k) {
    const double mag = std::hypot(ar[k], ai[k]);
    if (!(std::fabs(be[k]) > 1e-12 * mag) || be[k] == 0.0) continue;  // infinite: massless DOFs
    const std::complex<double> l(s0 * ar[k] / be[k], s0 * ai[k] / be[k]);
    if (l.imag() >= 0.0) out.push_back(l);
  }
  std::sort(out.begin(), out.end(), [](const std::complex<double>& x, const std::complex<double>& y) {
    return x.imag() != y.imag() ? x.imag() < y.imag() : x.real() < y.real();
  });
  return out;
}

std::vector<std::complex<double>> unbalance_response(const Assembly& a, double omega, int rotor) {
  MORSE_CHECK(rotor >= 0 && rotor < static_cast<int>(a.rotors().size()), "unbalance response: no rotor ", rotor);
  const AssembledMatrices A = a.dense();
  const std::size_t n = static_cast<std::size_t>(A.n), n2 = 2 * n;
  const double s = a.rotors()[rotor].speed_ratio, w = s * omega;
  // Real form, column-major: [K - w^2 M, -w D; w D, K - w^2 M] [Xr; Xi] = [Fr; Fi].
  std::vector<double> S(n2 * n2), b(n2, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) {
      const double k = A.K[i * n + j] - w * w * A.M[i * n + j], d = w * (A.C[i * n + j] + omega * A.G[i * n + j]);
      S[i + n2 * j] = k;
      S[n + i + n2 * (n + j)] = k;
      S[i + n2 * (n + j)] = -d;
      S[n + i + n2 * j] = d;
    }
  // Only this rotor's unbalances: F_x = m e w^2 e^{i phase}, F_y = -i F_x.
  for (const Unbalance& u : a.rotors()[rotor].unbalances) {
    const auto& disks = a.rotors()[rotor].disks;
    const auto d = std::find_if(disks.begin(), disks.end(), [&](const Disk& k) { return k.name == u.disk; });
    const std::size_t ix = static_cast<std::size_t>(a.rotor_dof(rotor, d->station, 0));
    const double f = u.me * w * w;
    b[ix] += f * std::cos(u.phase);
    b[n + ix] += f * std::sin(u.phase);
    b[ix + 1] += f * std::sin(u.phase);
    b[n + ix + 1] -= f * std::cos(u.phase);
  }
  PetscBLASInt N = static_cast<PetscBLASInt>(n2), one = 1, info = 0;
  std::vector<PetscBLASInt> piv(n2);
  LAPACKgesv_(&N, &one, S.data(), &N, piv.data(), b.data(), &N, &info);
  MORSE_CHECK(info == 0, "unbalance response: the dynamic stiffness is singular at ", omega, " rad/s (info = ", info,
              ")");
  std::vector<std::complex<double>> X(n);
  for (std::size_t i = 0; i < n; ++i) X[i] = {b[i], b[n + i]};
  return X;
}

}  // namespace morse::rampup
