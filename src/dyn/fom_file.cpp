// dyn/fom_file.cpp: the file of a full-order run (/fom of `morse fom`), written and read back
// (dyn/dyn.hpp, docs/hdf5-schema.md).
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/constraints.hpp"
#include "morse/io/h5.hpp"

namespace morse::dyn {

void FomHistory::record(const StepInfo& i) {
  time.push_back(i.t);
  energy.push_back(i.energy.eq46());
  kinetic.push_back(i.energy.kinetic);
  strain_linear.push_back(i.energy.strain_linear);
  strain_nonlinear.push_back(i.energy.strain_nonlinear);
  external_work.push_back(i.energy.external_work);
  damping_loss.push_back(i.energy.damping_loss);
  balance.push_back(i.energy.balance());
  newton_iterations.push_back(i.newton_iterations);
  residual.push_back(i.residual);
}

FomSnapshotWriter::FomSnapshotWriter(io::H5Output& out, const mesh::LocalMesh& lm, const fe::DofLayout& dofs,
                                     std::int64_t rows)
    : out_(&out) {
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  out.suspend();
  w_ = std::make_unique<io::H5SliceWriter>(lm.comm, out.tmp_path(), dofs.n_global, dofs.first, dofs.n_owned);
  u_ = w_->create("/fom/snapshots/u", rows);
  v_ = w_->create("/fom/snapshots/v", rows);
  // The DOF map of the snapshot columns: node id and component of every free DOF.
  std::vector<std::int64_t> node_id(dofs.n_owned), comp(dofs.n_owned);
  for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k) {
    if (lm.node_owner[k] != rank) continue;
    for (int d = 0; d < 3; ++d) {
      const PetscInt g = dofs.node_dof[3 * k + d];
      if (g < 0) continue;
      node_id[g - dofs.first] = lm.mesh.node_ids[k];
      comp[g - dofs.first] = d;
    }
  }
  w_->write_int("/fom/snapshots/dof_node_ids", node_id);
  w_->write_int("/fom/snapshots/dof_components", comp);
  w_->attribute("/fom/snapshots/u", "description",
                "[snapshot][free DOF] displacement [m]; column j is component dof_components[j] (0=x) of node "
                "dof_node_ids[j]; times in /fom/snapshots/time");
}

FomSnapshotWriter::~FomSnapshotWriter() = default;

void FomSnapshotWriter::write(const StepInfo& i) {
  const auto row = static_cast<std::int64_t>(times_.size());
  w_->write_row(u_, row, i.u);
  w_->write_row(v_, row, i.v);
  times_.push_back(i.t);
}

void FomSnapshotWriter::close() {
  w_->close();
  w_.reset();
  out_->resume();
}

void write_fom(io::H5Output& out, const FomHistory& h, const std::vector<double>& snapshot_times,
               PetscInt snapshot_every, const FomSettings& s, const FomStats& stats, const LoadDescription& load) {
  out.write("/fom/time", h.time);
  out.write("/fom/energy", h.energy);
  out.attribute("/fom/energy", "description",
                "seed 003 eq. 46: kinetic + linear strain energy, u'^T M u'/2 + u^T K u/2 [J]");
  out.write("/fom/energies/kinetic", h.kinetic);
  out.write("/fom/energies/strain_linear", h.strain_linear);
  out.write("/fom/energies/strain_nonlinear", h.strain_nonlinear);
  out.write("/fom/energies/external_work", h.external_work);
  out.write("/fom/energies/damping_loss", h.damping_loss);
  out.write("/fom/energies/balance", h.balance);
  out.attribute("/fom/energies/balance", "description",
                "kinetic + strain (linear + nonlinear) + damping loss - external work: constant for an exact balance");
  out.write("/fom/newton_iterations", h.newton_iterations);
  out.write("/fom/residual", h.residual);
  for (const auto& set : h.sets) {
    const std::string g = "/fom/sets/" + set.name;
    const auto n = static_cast<hsize_t>(set.node_ids.size());
    out.write(g + "/node_ids", set.node_ids);
    out.write(g + "/u", set.u, {static_cast<hsize_t>(h.time.size()), n, 3});
    out.attribute(g + "/u", "description", "[time][node][x,y,z] displacement [m] in the mesh frame");
  }
  if (snapshot_every > 0) {
    out.write("/fom/snapshots/time", snapshot_times);
    out.attribute_int("/fom/snapshots", "every", snapshot_every);
  }
  if (!stats.damping_omega.empty()) out.write("/fom/damping/omega", stats.damping_omega);
  if (!load.history.empty()) {
    out.attribute("/fom", "load_history", load.history);
    out.attribute("/fom", "load_history_scale", load.history_scale);
  }
  out.attribute_int("/fom", "linear", s.linear ? 1 : 0);
  out.attribute("/fom", "scheme", s.scheme == Scheme::Energy ? "energy" : "trapezoidal");
  out.attribute("/fom", "dt", s.dt);
  out.attribute_int("/fom", "steps", stats.steps);
  out.attribute_int("/fom", "newton_iterations", stats.newton_iterations);
  out.attribute_int("/fom", "factorizations", stats.factorizations);
  out.attribute_int("/fom", "krylov_iterations", stats.krylov_iterations);
  out.attribute("/fom", "newton",
                s.linear || s.scheme == Scheme::Energy || s.newton == Newton::Modified ? "modified" : "krylov");
  out.attribute("/fom", "seconds_total", stats.seconds_total);
  out.attribute("/fom", "seconds_force", stats.seconds_force);
  out.attribute("/fom", "seconds_tangent", stats.seconds_tangent);
  out.attribute("/fom", "seconds_factor", stats.seconds_factor);
  out.attribute("/fom", "seconds_solve", stats.seconds_solve);
  out.attribute("/fom", "modal_damping_ratio", s.modal_xi);
  out.attribute_int("/fom", "modal_damping_modes", s.damping_modes);
  out.attribute("/fom", "rayleigh_alpha", s.rayleigh_alpha);
  out.attribute("/fom", "rayleigh_beta", s.rayleigh_beta);
  write_load_description(out, "/fom/load", load);
}

FomHistory read_fom(const std::string& file, const std::vector<std::string>& sets) {
  FomHistory h;
  std::string err;
  std::vector<hsize_t> d;
  auto doubles = [&](const std::string& name, std::vector<double>* v) {
    MORSE_CHECK(io::read_doubles(file, name, v, &d, &err), err);
  };
  doubles("/fom/time", &h.time);
  doubles("/fom/energy", &h.energy);
  doubles("/fom/energies/kinetic", &h.kinetic);
  doubles("/fom/energies/strain_linear", &h.strain_linear);
  doubles("/fom/energies/strain_nonlinear", &h.strain_nonlinear);
  doubles("/fom/energies/external_work", &h.external_work);
  doubles("/fom/energies/damping_loss", &h.damping_loss);
  doubles("/fom/energies/balance", &h.balance);
  MORSE_CHECK(io::read_ints(file, "/fom/newton_iterations", &h.newton_iterations, &d, &err), err);
  doubles("/fom/residual", &h.residual);
  const std::size_t nt = h.time.size();
  for (const auto* v : {&h.energy, &h.kinetic, &h.strain_linear, &h.strain_nonlinear, &h.external_work, &h.damping_loss,
                        &h.balance, &h.residual})
    MORSE_CHECK(v->size() == nt, file, ": a /fom history has ", v->size(), " values for ", nt, " times");
  MORSE_CHECK(h.newton_iterations.size() == nt, file, ": /fom/newton_iterations has ", h.newton_iterations.size(),
              " values for ", nt, " times");
  for (const auto& name : sets) {
    FomHistory::Set set;
    set.name = name;
    MORSE_CHECK(io::read_ints(file, "/fom/sets/" + name + "/node_ids", &set.node_ids, &d, &err), err);
    doubles("/fom/sets/" + name + "/u", &set.u);
    MORSE_CHECK(set.u.size() == nt * set.node_ids.size() * 3, file, ": /fom/sets/", name, "/u has ", set.u.size(),
                " values for ", nt, " times and ", set.node_ids.size(), " nodes");
    h.sets.push_back(std::move(set));
  }
  return h;
}

SnapshotRow read_fom_snapshot_row(const std::string& file, double time) {
  SnapshotRow s;
  std::string err;
  std::vector<hsize_t> d;
  std::vector<double> times;
  if (!io::read_doubles(file, "/fom/snapshots/time", &times, &d, &err) || times.empty())
    throw Error(cat(file, ": no full-field snapshots (run morse fom with -fom_snapshot_every K)"));
  MORSE_CHECK(io::read_ints(file, "/fom/snapshots/dof_node_ids", &s.node_ids, &d, &err), err);
  MORSE_CHECK(io::read_ints(file, "/fom/snapshots/dof_components", &s.components, &d, &err), err);
  MORSE_CHECK(s.node_ids.size() == s.components.size(), file, ": /fom/snapshots/dof_node_ids has ", s.node_ids.size(),
              " entries and dof_components ", s.components.size());
  std::size_t k = 0;
  for (std::size_t j = 1; j < times.size(); ++j)
    if (std::abs(times[j] - time) < std::abs(times[k] - time)) k = j;
  MORSE_CHECK(io::read_double_row(file, "/fom/snapshots/u", static_cast<std::int64_t>(k), &s.u, &err), err);
  MORSE_CHECK(s.u.size() == s.node_ids.size(), file, ": /fom/snapshots/u has ", s.u.size(), " columns but the DOF map ",
              s.node_ids.size());
  s.time = times[k], s.index = static_cast<std::int64_t>(k), s.n_rows = static_cast<std::int64_t>(times.size());
  return s;
}

SnapshotField read_fom_snapshot(const std::string& file, double time) {
  const SnapshotRow row = read_fom_snapshot_row(file, time);
  SnapshotField f;
  f.time = row.time, f.index = row.index, f.n_rows = row.n_rows;
  std::map<std::int64_t, std::size_t> at;
  for (auto id : row.node_ids) at.emplace(id, 0);
  std::size_t n = 0;
  for (auto& [id, slot] : at) slot = n++, f.node_ids.push_back(id);
  f.u.assign(3 * n, 0.0);
  for (std::size_t j = 0; j < row.node_ids.size(); ++j) {
    const auto c = row.components[j];
    MORSE_CHECK(c >= 0 && c <= 2, file, ": /fom/snapshots/dof_components[", j, "] = ", c, " is not 0, 1 or 2");
    f.u[3 * at[row.node_ids[j]] + static_cast<std::size_t>(c)] = row.u[j];
  }
  return f;
}

UMat read_fom_snapshots(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::string& file) {
  return io::read_dof_rows(lm, dofs, file, "/fom/snapshots/u");
}

UMat read_fom_snapshots(const fe::Model& md, const std::string& file) {
  MORSE_CHECK(md.mesh, "the snapshots of ", file, " need a mesh model");
  auto X = read_fom_snapshots(*md.mesh, fe::node_layout(md), file);
  return md.constraints ? fe::restrict_columns(md, X.get()) : std::move(X);
}

}  // namespace morse::dyn
