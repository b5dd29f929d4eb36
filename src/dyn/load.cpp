// Nodal loads (see morse/dyn/dyn.hpp).
#include <cmath>
#include <sstream>

#include "morse/core/error.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/fe/constraints.hpp"

namespace morse::dyn {

std::string parse_direction(const std::string& text, double dir[3]) {
  if (text == "x" || text == "y" || text == "z") {
    for (int d = 0; d < 3; ++d) dir[d] = (text[0] - 'x') == d ? 1.0 : 0.0;
    return {};
  }
  std::stringstream ss(text);
  std::string part;
  int n = 0;
  double v[3] = {0, 0, 0};
  while (std::getline(ss, part, ',')) {
    if (n == 3) return cat("direction '", text, "' has more than three components");
    char* end = nullptr;
    v[n] = std::strtod(part.c_str(), &end);
    if (part.empty() || *end != '\0' || !std::isfinite(v[n]))
      return cat("direction '", text, "' is not x, y, z or vx,vy,vz");
    ++n;
  }
  if (n != 3) return cat("direction '", text, "' is not x, y, z or vx,vy,vz");
  const double norm = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(norm > 0)) return cat("direction '", text, "' is the zero vector");
  for (int d = 0; d < 3; ++d) dir[d] = v[d];
  return {};
}

Loads::Loads(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::vector<NodalLoad>& loads)
    : loads_(loads) {
  std::string err;
  for (auto& l : loads_) {
    const double norm = std::sqrt(l.dir[0] * l.dir[0] + l.dir[1] * l.dir[1] + l.dir[2] * l.dir[2]);
    if (!(norm > 0) || !std::isfinite(norm)) {
      err = cat("load on set ", l.set, ": the direction is zero");
      break;
    }
    if (!std::isfinite(l.amplitude) || !std::isfinite(l.omega) || !std::isfinite(l.phase) || l.omega < 0) {
      err = cat("load on set ", l.set, ": amplitude, omega and phase must be finite and omega >= 0");
      break;
    }
    for (auto& c : l.dir) c /= norm;
    err = mesh::check_node_set(lm, l.set, cat("load node set (-load_sets)"));
    if (!err.empty()) break;
  }
  collective_check(lm.comm, err);
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  for (const auto& l : loads_) {
    UVec p;
    MORSE_CALL(VecCreateMPI(lm.comm, dofs.n_owned, dofs.n_global, p.ptr()));
    MORSE_CALL(VecSet(p.get(), 0.0));
    PetscScalar* a;
    MORSE_CALL(VecGetArray(p.get(), &a));
    for (auto k : lm.mesh.node_sets.at(l.set)) {
      if (lm.node_owner[k] != rank) continue;
      for (int d = 0; d < 3; ++d) {
        const PetscInt g = dofs.node_dof[3 * k + d];
        if (g >= 0) a[g - dofs.first] += l.dir[d];
      }
    }
    MORSE_CALL(VecRestoreArray(p.get(), &a));
    patterns_.push_back(std::move(p));
  }
}

Loads::Loads(const fe::Model& md, const std::vector<NodalLoad>& loads) : Loads(*md.mesh, fe::node_layout(md), loads) {
  if (!md.constraints) return;
  T_ = md.constraints->T.get();
  MORSE_CALL(MatCreateVecs(T_, nullptr, nodal_.ptr()));
  for (auto& p : patterns_) {
    UVec q;
    MORSE_CALL(MatCreateVecs(md.constraints->T.get(), q.ptr(), nullptr));
    MORSE_CALL(MatMultTranspose(md.constraints->T.get(), p.get(), q.get()));
    p = std::move(q);
  }
}

double Loads::factor(std::size_t i, double t) const {
  const auto& l = loads_[i];
  return harmonic_factor(l.amplitude, l.omega, l.phase, t);
}

void Loads::evaluate(double t, Vec F) const {
  MORSE_CALL(VecSet(F, 0.0));
  for (std::size_t i = 0; i < loads_.size(); ++i) MORSE_CALL(VecAXPY(F, factor(i, t), patterns_[i].get()));
  if (history_ && T_) {
    MORSE_CALL(VecSet(nodal_.get(), 0.0));
    history_->add_to(t, nodal_.get());
    MORSE_CALL(MatMultTransposeAdd(T_, nodal_.get(), F, F));
  } else if (history_) {
    history_->add_to(t, F);
  }
}

double Loads::max_omega() const {
  double w = 0.0;
  for (const auto& l : loads_) w = std::max(w, l.omega);
  return w;
}

}  // namespace morse::dyn
