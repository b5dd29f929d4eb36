// St Venant–Kirchhoff internal forces, tangent and energy (see morse/fe/nonlinear.hpp).
//
// Only the nonlinear parts are integrated here: g_nl, K_T - K and W - u^T K u / 2. Each is
// written so that it vanishes term by term at u = 0 (no difference of large numbers), which
// keeps K_T(0) = K and g_nl(0) = 0 exact and small displacements accurate. The linear parts
// come from the assembled K.
#include "morse/fe/nonlinear.hpp"

#include <petscsys.h>
#include <petscblaslapack.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/fe/element.hpp"

namespace morse::fe {

namespace {

// The stress-strain part of the kernel at one quadrature point, for the pair (Ha, Hb).
struct PointState {
  double Hm[9];   // (Ha + Hb) / 2
  double S[9];    // S((E_a + E_b)/2)
  double Pnl[9];  // P - S_lin(Hm) = S_nl + Hm S
  double w_nl;    // nonlinear strain energy density (meaningful for Ha == Hb)
};

void point_state(const double* Ha, const double* Hb, double lam, double mu, PointState* p) {
  double eps[9], enl[9];
  for (int i = 0; i < 9; ++i) p->Hm[i] = 0.5 * (Ha[i] + Hb[i]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      eps[3 * i + j] = 0.5 * (p->Hm[3 * i + j] + p->Hm[3 * j + i]);
      double s = 0.0;
      for (int k = 0; k < 3; ++k) s += Ha[3 * k + i] * Ha[3 * k + j] + Hb[3 * k + i] * Hb[3 * k + j];
      enl[3 * i + j] = 0.25 * s;
    }
  const double tr_e = eps[0] + eps[4] + eps[8], tr_n = enl[0] + enl[4] + enl[8];
  double snl[9];
  double e_n = 0.0, n_n = 0.0;
  for (int i = 0; i < 9; ++i) {
    snl[i] = 2.0 * mu * enl[i];
    p->S[i] = 2.0 * mu * (eps[i] + enl[i]);
    e_n += eps[i] * enl[i];
    n_n += enl[i] * enl[i];
  }
  for (int i = 0; i < 3; ++i) {
    snl[4 * i] += lam * tr_n;
    p->S[4 * i] += lam * (tr_e + tr_n);
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = snl[3 * i + j];
      for (int k = 0; k < 3; ++k) s += p->Hm[3 * i + k] * p->S[3 * k + j];
      p->Pnl[3 * i + j] = s;
    }
  p->w_nl = lam * tr_e * tr_n + 0.5 * lam * tr_n * tr_n + 2.0 * mu * e_n + mu * n_n;
}

// Directional derivative of Pnl at H (S = S(E(H))) along dH:
//   dPnl = dS_nl + dH S + H dS,  dE_nl = (dH^T H + H^T dH)/2,  dS = S_lin(dH) + dS_nl.
void point_tangent_apply(const double* H, const double* dH, double lam, double mu, const double* S, double* dP) {
  double den[9], dsnl[9], ds[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0.0;
      for (int k = 0; k < 3; ++k) s += dH[3 * k + i] * H[3 * k + j] + H[3 * k + i] * dH[3 * k + j];
      den[3 * i + j] = 0.5 * s;
    }
  const double tr_n = den[0] + den[4] + den[8], tr_e = dH[0] + dH[4] + dH[8];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      dsnl[3 * i + j] = 2.0 * mu * den[3 * i + j];
      ds[3 * i + j] = dsnl[3 * i + j] + mu * (dH[3 * i + j] + dH[3 * j + i]);
    }
  for (int i = 0; i < 3; ++i) {
    dsnl[4 * i] += lam * tr_n;
    ds[4 * i] += lam * (tr_n + tr_e);
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = dsnl[3 * i + j];
      for (int k = 0; k < 3; ++k) s += dH[3 * i + k] * S[3 * k + j] + H[3 * i + k] * ds[3 * k + j];
      dP[3 * i + j] = s;
    }
}

// H[i][J] = sum_a u[3a+i] g[a][J].
void displacement_gradient(int n, const double* u, const double* g, double* H) {
  for (int k = 0; k < 9; ++k) H[k] = 0.0;
  for (int a = 0; a < n; ++a) {
    const double* ga = g + 3 * a;
    const double* ua = u + 3 * a;
    for (int i = 0; i < 3; ++i)
      for (int J = 0; J < 3; ++J) H[3 * i + J] += ua[i] * ga[J];
  }
}

}  // namespace

namespace {
// The stiffness the elements of Svk(Model) are assembled on: the nodes' (before elimination).
Mat nodes_stiffness(const Model& md) {
  if (!md.constraints) return md.K.get();
  MORSE_CHECK(md.constraints->K_nodes, "Svk: the model's constraints hold no stiffness of the nodes");
  return md.constraints->K_nodes.get();
}
}  // namespace

Svk::Svk(const Model& md, const mesh::Material& fallback)
    : Svk(*md.mesh, md.constraints ? md.constraints->full : md.dofs, fallback, nodes_stiffness(md)) {
  if (!md.constraints) return;
  T_ = md.constraints->T.get();
  K_ = md.K.get();
  MORSE_CALL(MatCreateVecs(T_, nullptr, wf_.ptr()));
}

Svk::Svk(const mesh::LocalMesh& lm, const DofLayout& dofs, const mesh::Material& fallback, Mat K)
    : comm_(lm.comm), K_(K), Kn_(K) {
  StageTimer stage(comm_, "SvkSetup");
  const auto& m = lm.mesh;
  const std::int64_t nn = m.num_nodes(), ne = m.num_elements();
  // Compact local numbering of the free DOFs of the local nodes.
  std::vector<PetscInt> pos(3 * nn, -1), from;
  for (std::int64_t k = 0; k < 3 * nn; ++k)
    if (dofs.node_dof[k] >= 0) {
      pos[k] = static_cast<PetscInt>(from.size());
      from.push_back(dofs.node_dof[k]);
    }
  n_local_ = static_cast<PetscInt>(from.size());

  type_n_.resize(ne);
  elem_off_.assign(1, 0);
  elem_nq_.resize(ne);
  grad_off_.assign(1, 0);
  wdet_off_.assign(1, 0);
  lambda_.resize(ne);
  mu_.resize(ne);
  std::string err;
  double xyz[3 * kMaxNodes];
  for (std::int64_t e = 0; e < ne; ++e) {
    const auto t = m.elem_types[e];
    const auto off = m.elem_offsets[e];
    const int n = static_cast<int>(m.elem_offsets[e + 1] - off);
    type_n_[e] = n;
    for (int a = 0; a < n; ++a) {
      const auto k = m.elem_nodes[off + a];
      for (int d = 0; d < 3; ++d) {
        elem_pos_.push_back(pos[3 * k + d]);
        elem_glob_.push_back(dofs.node_dof[3 * k + d]);
        xyz[3 * a + d] = m.coords[3 * k + d];
      }
    }
    elem_off_.push_back(static_cast<std::int64_t>(elem_pos_.size()));
    const int nq = static_cast<int>(stiffness_rule(t).points.size());
    elem_nq_[e] = nq;
    grad_.resize(grad_.size() + 3 * n * nq);
    wdet_.resize(wdet_.size() + nq);
    const double det = stiffness_gradients(t, xyz, &grad_[grad_off_.back()], &wdet_[wdet_off_.back()]);
    if (!(det > 0) && err.empty())
      err = cat("element ", m.elem_ids[e], " of ", m.source, " is inverted or degenerate (min det J = ", det, ")");
    grad_off_.push_back(static_cast<std::int64_t>(grad_.size()));
    wdet_off_.push_back(static_cast<std::int64_t>(wdet_.size()));
    const auto& mat = m.elem_material[e] >= 0 ? m.materials[m.elem_material[e]] : fallback;
    lambda_[e] = mat.E * mat.nu / ((1.0 + mat.nu) * (1.0 - 2.0 * mat.nu));
    mu_[e] = mat.E / (2.0 * (1.0 + mat.nu));
  }
  collective_check(comm_, err);

  MORSE_CALL(VecCreateSeq(PETSC_COMM_SELF, n_local_, la_.ptr()));
  MORSE_CALL(VecDuplicate(la_.get(), lb_.ptr()));
  MORSE_CALL(VecDuplicate(la_.get(), lg_.ptr()));
  UVec global;
  MORSE_CALL(MatCreateVecs(K, global.ptr(), nullptr));
  UIS is_from;
  MORSE_CALL(ISCreateGeneral(PETSC_COMM_SELF, n_local_, from.data(), PETSC_COPY_VALUES, is_from.ptr()));
  MORSE_CALL(VecScatterCreate(global.get(), is_from.get(), la_.get(), nullptr, scatter_.ptr()));
}

Svk::~Svk() = default;

void Svk::to_local(Vec u, Vec local) const {
  if (T_) {  // the nodes' translations T u_bar
    MORSE_CALL(MatMult(T_, u, wf_.get()));
    u = wf_.get();
  }
  MORSE_CALL(VecScatterBegin(scatter_.get(), u, local, INSERT_VALUES, SCATTER_FORWARD));
  MORSE_CALL(VecScatterEnd(scatter_.get(), u, local, INSERT_VALUES, SCATTER_FORWARD));
}

void Svk::add_to_global(Vec local, Vec g) const {
  Vec to = T_ ? wf_.get() : g;
  MORSE_CALL(VecSet(to, 0.0));
  MORSE_CALL(VecScatterBegin(scatter_.get(), local, to, ADD_VALUES, SCATTER_REVERSE));
  MORSE_CALL(VecScatterEnd(scatter_.get(), local, to, ADD_VALUES, SCATTER_REVERSE));
  if (T_) MORSE_CALL(MatMultTranspose(T_, to, g));  // T^T g_nodes on the model's DOFs
}

void Svk::element_loop(int what, int nv, const double* a, const double* b, double* g, Mat Kt, double* energy) const {
  const std::int64_t ne = static_cast<std::int64_t>(type_n_.size());
  double ua[kMaxDofs], ub[kMaxDofs], ge[kMaxDofs], h[3 * kMaxNodes];
  std::vector<double> Ke((what & kTangent) ? kMaxDofs * kMaxDofs : 0);
  double w_total = 0.0;
  for (std::int64_t e = 0; e < ne; ++e) {
    const int n = type_n_[e], nd = 3 * n, nq = elem_nq_[e];
    const PetscInt* pos = &elem_pos_[elem_off_[e]];
    const double lam = lambda_[e], mu = mu_[e];
    if (what & kTangent) std::fill(Ke.begin(), Ke.begin() + nd * nd, 0.0);
    for (int v = 0; v < nv; ++v) {
      const double* av = a + static_cast<std::int64_t>(v) * n_local_;
      const double* bv = b ? b + static_cast<std::int64_t>(v) * n_local_ : nullptr;
      for (int k = 0; k < nd; ++k) {
        ua[k] = pos[k] >= 0 ? av[pos[k]] : 0.0;
        if (bv) ub[k] = pos[k] >= 0 ? bv[pos[k]] : 0.0;
      }
      std::fill(ge, ge + nd, 0.0);
      for (int q = 0; q < nq; ++q) {
        const double* gq = &grad_[grad_off_[e] + 3 * n * q];
        const double w = wdet_[wdet_off_[e] + q];
        double Ha[9], Hb[9];
        if (what & kApply) {
          // ua is the direction: ge += (K_T(u*) - K) ua, u* = the state of tangent_point().
          const double* hs = &point_cache_[18 * (wdet_off_[e] + q)];
          displacement_gradient(n, ua, gq, Hb);
          double dP[9];
          point_tangent_apply(hs, Hb, lam, mu, hs + 9, dP);
          for (int c = 0; c < n; ++c) {
            const double* gc = gq + 3 * c;
            for (int i = 0; i < 3; ++i)
              ge[3 * c + i] += w * (dP[3 * i] * gc[0] + dP[3 * i + 1] * gc[1] + dP[3 * i + 2] * gc[2]);
          }
          continue;
        }
        displacement_gradient(n, ua, gq, Ha);
        if (what & kPoint) {  // cache H and S of the state a at this point
          PointState p;
          point_state(Ha, Ha, lam, mu, &p);
          double* hs = &point_cache_[18 * (wdet_off_[e] + q)];
          std::copy(Ha, Ha + 9, hs);
          std::copy(p.S, p.S + 9, hs + 9);
          continue;
        }
        if (bv)
          displacement_gradient(n, ub, gq, Hb);
        else
          std::copy(Ha, Ha + 9, Hb);
        PointState p;
        point_state(Ha, Hb, lam, mu, &p);
        if (what & kEnergy) w_total += w * p.w_nl;
        if (what & kForce)
          for (int c = 0; c < n; ++c) {
            const double* gc = gq + 3 * c;
            for (int i = 0; i < 3; ++i)
              ge[3 * c + i] += w * (p.Pnl[3 * i] * gc[0] + p.Pnl[3 * i + 1] * gc[1] + p.Pnl[3 * i + 2] * gc[2]);
          }
        if (what & kTangent) {
          // h_c = Hm g_c; B = Hm + Hm^T + Hm Hm^T (F F^T - I).
          for (int c = 0; c < n; ++c) {
            const double* gc = gq + 3 * c;
            for (int i = 0; i < 3; ++i)
              h[3 * c + i] = p.Hm[3 * i] * gc[0] + p.Hm[3 * i + 1] * gc[1] + p.Hm[3 * i + 2] * gc[2];
          }
          double B[9];
          for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) {
              double s = p.Hm[3 * i + k] + p.Hm[3 * k + i];
              for (int l = 0; l < 3; ++l) s += p.Hm[3 * i + l] * p.Hm[3 * k + l];
              B[3 * i + k] = w * mu * s;
            }
          const double wl = w * lam, wm = w * mu;
          for (int c = 0; c < n; ++c) {
            const double* gc = gq + 3 * c;
            const double* hc = h + 3 * c;
            double Sg[3];
            for (int i = 0; i < 3; ++i)
              Sg[i] = w * (p.S[3 * i] * gc[0] + p.S[3 * i + 1] * gc[1] + p.S[3 * i + 2] * gc[2]);
            for (int d = c; d < n; ++d) {
              const double* gd = gq + 3 * d;
              const double* hd = h + 3 * d;
              const double geo = Sg[0] * gd[0] + Sg[1] * gd[1] + Sg[2] * gd[2];
              const double gg = gc[0] * gd[0] + gc[1] * gd[1] + gc[2] * gd[2];
              double* blk = &Ke[3 * c * nd + 3 * d];
              for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k)
                  blk[i * nd + k] += (i == k ? geo : 0.0) + wl * (gc[i] * hd[k] + hc[i] * gd[k] + hc[i] * hd[k]) +
                                     gg * B[3 * i + k] + wm * (gd[i] * hc[k] + hd[i] * gc[k] + hd[i] * hc[k]);
            }
          }
        }
      }
      if (what & (kForce | kApply)) {
        double* gv = g + static_cast<std::int64_t>(v) * n_local_;
        for (int k = 0; k < nd; ++k)
          if (pos[k] >= 0) gv[pos[k]] += ge[k];
      }
    }
    if (what & kTangent) {
      for (int r = 0; r < nd; ++r)
        for (int c = r + 1; c < nd; ++c) Ke[c * nd + r] = Ke[r * nd + c];
      MORSE_CALL(MatSetValues(Kt, nd, &elem_glob_[elem_off_[e]], nd, &elem_glob_[elem_off_[e]], Ke.data(), ADD_VALUES));
    }
  }
  if (energy) *energy = w_total;
}

void Svk::nonlinear_force(Vec u, Vec g) const { midpoint_nonlinear_force(u, nullptr, g); }

void Svk::midpoint_nonlinear_force(Vec ua, Vec ub, Vec g) const {
  PetscLogEvent ev = log_event("SvkForce");
  MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
  to_local(ua, la_.get());
  if (ub) to_local(ub, lb_.get());
  MORSE_CALL(VecSet(lg_.get(), 0.0));
  const double *a, *b = nullptr;
  double* gl;
  MORSE_CALL(VecGetArrayRead(la_.get(), &a));
  if (ub) MORSE_CALL(VecGetArrayRead(lb_.get(), &b));
  MORSE_CALL(VecGetArray(lg_.get(), &gl));
  element_loop(kForce, 1, a, b, gl, nullptr, nullptr);
  MORSE_CALL(VecRestoreArray(lg_.get(), &gl));
  if (ub) MORSE_CALL(VecRestoreArrayRead(lb_.get(), &b));
  MORSE_CALL(VecRestoreArrayRead(la_.get(), &a));
  add_to_global(lg_.get(), g);
  MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
}

void Svk::tangent_point(Vec u) const {
  PetscLogEvent ev = log_event("SvkTangentPoint");
  MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
  point_cache_.resize(18 * wdet_.size());
  to_local(u, la_.get());
  const double* a;
  MORSE_CALL(VecGetArrayRead(la_.get(), &a));
  element_loop(kPoint, 1, a, nullptr, nullptr, nullptr, nullptr);
  MORSE_CALL(VecRestoreArrayRead(la_.get(), &a));
  MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
}

void Svk::tangent_apply_nonlinear(Vec v, Vec y) const {
  MORSE_CHECK(point_cache_.size() == 18 * wdet_.size(), "Svk::tangent_apply_nonlinear before tangent_point");
  PetscLogEvent ev = log_event("SvkTangentApply");
  MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
  to_local(v, la_.get());
  MORSE_CALL(VecSet(lg_.get(), 0.0));
  const double* a;
  double* gl;
  MORSE_CALL(VecGetArrayRead(la_.get(), &a));
  MORSE_CALL(VecGetArray(lg_.get(), &gl));
  element_loop(kApply, 1, a, nullptr, gl, nullptr, nullptr);
  MORSE_CALL(VecRestoreArray(lg_.get(), &gl));
  MORSE_CALL(VecRestoreArrayRead(la_.get(), &a));
  add_to_global(lg_.get(), y);
  MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
}

void Svk::tangent_apply(Vec u, Vec v, Vec y) const {
  tangent_point(u);
  tangent_apply_nonlinear(v, y);
  MORSE_CALL(MatMultAdd(K_, v, y, y));
}

void Svk::internal_force(Vec u, Vec f) const {
  nonlinear_force(u, f);
  MORSE_CALL(MatMultAdd(K_, u, f, f));
}

UMat Svk::create_tangent() const {
  UMat Kt;
  if (T_) {
    MORSE_CALL(MatPtAP(Kn_, T_, MAT_INITIAL_MATRIX, PETSC_DEFAULT, Kt.ptr()));
    return Kt;
  }
  MORSE_CALL(MatDuplicate(K_, MAT_COPY_VALUES, Kt.ptr()));
  return Kt;
}

void Svk::tangent(Vec u, Mat Kt) const { midpoint_tangent(u, nullptr, Kt); }

void Svk::midpoint_tangent(Vec ua, Vec ub, Mat Kt) const {
  PetscLogEvent ev = log_event("SvkTangent");
  MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
  // With constraints the elements fill the nodes' tangent, projected below.
  if (T_ && !Ktn_) MORSE_CALL(MatDuplicate(Kn_, MAT_COPY_VALUES, Ktn_.ptr()));
  Mat to = T_ ? Ktn_.get() : Kt;
  MORSE_CALL(MatCopy(Kn_, to, SAME_NONZERO_PATTERN));
  to_local(ua, la_.get());
  if (ub) to_local(ub, lb_.get());
  const double *a, *b = nullptr;
  MORSE_CALL(VecGetArrayRead(la_.get(), &a));
  if (ub) MORSE_CALL(VecGetArrayRead(lb_.get(), &b));
  element_loop(kTangent, 1, a, b, nullptr, to, nullptr);
  if (ub) MORSE_CALL(VecRestoreArrayRead(lb_.get(), &b));
  MORSE_CALL(VecRestoreArrayRead(la_.get(), &a));
  MORSE_CALL(MatAssemblyBegin(to, MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(to, MAT_FINAL_ASSEMBLY));
  if (T_) MORSE_CALL(MatPtAP(to, T_, MAT_REUSE_MATRIX, PETSC_DEFAULT, &Kt));  // Kt from create_tangent()
  MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
}

StrainEnergy Svk::energy(Vec u) const {
  StrainEnergy s;
  UVec Ku;
  MORSE_CALL(VecDuplicate(u, Ku.ptr()));
  MORSE_CALL(MatMult(K_, u, Ku.get()));
  MORSE_CALL(VecDot(Ku.get(), u, &s.linear));
  s.linear *= 0.5;
  to_local(u, la_.get());
  const double* a;
  MORSE_CALL(VecGetArrayRead(la_.get(), &a));
  double local = 0.0;
  element_loop(kEnergy, 1, a, nullptr, nullptr, nullptr, &local);
  MORSE_CALL(VecRestoreArrayRead(la_.get(), &a));
  MPI_Allreduce(&local, &s.nonlinear, 1, MPI_DOUBLE, MPI_SUM, comm_);
  return s;
}

void Svk::nonlinear_force_block(Mat U, Mat G, PetscInt chunk) const {
  PetscInt nu = 0, ng = 0;
  MORSE_CALL(MatGetSize(U, nullptr, &nu));
  MORSE_CALL(MatGetSize(G, nullptr, &ng));
  MORSE_CHECK(nu == ng, "Svk::nonlinear_force_block: U has ", nu, " columns, G has ", ng);
  MORSE_CHECK(chunk > 0, "Svk::nonlinear_force_block: chunk must be positive");
  PetscLogEvent ev = log_event("SvkForceBlock");
  MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
  std::vector<double> a, g;
  for (PetscInt j0 = 0; j0 < nu; j0 += chunk) {
    const PetscInt nv = std::min(chunk, nu - j0);
    a.assign(static_cast<std::size_t>(nv) * n_local_, 0.0);
    g.assign(a.size(), 0.0);
    for (PetscInt j = 0; j < nv; ++j) {
      Vec x;
      MORSE_CALL(MatDenseGetColumnVecRead(U, j0 + j, &x));
      to_local(x, la_.get());
      MORSE_CALL(MatDenseRestoreColumnVecRead(U, j0 + j, &x));
      const double* l;
      MORSE_CALL(VecGetArrayRead(la_.get(), &l));
      std::copy(l, l + n_local_, a.begin() + j * n_local_);
      MORSE_CALL(VecRestoreArrayRead(la_.get(), &l));
    }
    element_loop(kForce, static_cast<int>(nv), a.data(), nullptr, g.data(), nullptr, nullptr);
    for (PetscInt j = 0; j < nv; ++j) {
      double* l;
      MORSE_CALL(VecGetArray(lg_.get(), &l));
      std::copy(g.begin() + j * n_local_, g.begin() + (j + 1) * n_local_, l);
      MORSE_CALL(VecRestoreArray(lg_.get(), &l));
      Vec y;
      MORSE_CALL(MatDenseGetColumnVecWrite(G, j0 + j, &y));
      add_to_global(lg_.get(), y);
      MORSE_CALL(MatDenseRestoreColumnVecWrite(G, j0 + j, &y));
    }
  }
  MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
}

std::vector<double> Svk::local_columns(Mat A) const {
  PetscInt nc = 0;
  MORSE_CALL(MatGetSize(A, nullptr, &nc));
  std::vector<double> out(static_cast<std::size_t>(nc) * n_local_);
  for (PetscInt j = 0; j < nc; ++j) {
    Vec x;
    MORSE_CALL(MatDenseGetColumnVecRead(A, j, &x));
    to_local(x, la_.get());
    MORSE_CALL(MatDenseRestoreColumnVecRead(A, j, &x));
    const double* l;
    MORSE_CALL(VecGetArrayRead(la_.get(), &l));
    std::copy(l, l + n_local_, out.begin() + static_cast<std::size_t>(j) * n_local_);
    MORSE_CALL(VecRestoreArrayRead(la_.get(), &l));
  }
  return out;
}

std::vector<double> Svk::reduced_nonlinear_forces(Mat Phi, Mat W, const std::vector<double>& Q, PetscInt nf,
                                                  PetscInt chunk) const {
  PetscLogEvent ev = log_event("SvkReducedForces");
  MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
  PetscInt r = 0, nw = 0;
  MORSE_CALL(MatGetSize(Phi, nullptr, &r));
  if (!W) W = Phi;
  MORSE_CALL(MatGetSize(W, nullptr, &nw));
  MORSE_CHECK(static_cast<PetscInt>(Q.size()) == r * nf, "Svk::reduced_nonlinear_forces: Q has ", Q.size(),
              " entries, expected ", r, " x ", nf);
  MORSE_CHECK(chunk > 0, "Svk::reduced_nonlinear_forces: chunk must be positive");
  const auto phi = local_columns(Phi);
  const auto w_own = W == Phi ? std::vector<double>() : local_columns(W);
  const double* w = W == Phi ? phi.data() : w_own.data();
  std::vector<double> out(static_cast<std::size_t>(nw) * nf, 0.0), a, g;
  PetscBLASInt n = static_cast<PetscBLASInt>(n_local_), rr = static_cast<PetscBLASInt>(r),
               rw = static_cast<PetscBLASInt>(nw);
  const double one = 1.0, zero = 0.0;
  for (PetscInt f0 = 0; f0 < nf; f0 += chunk) {
    const PetscInt nv = std::min(chunk, nf - f0);
    PetscBLASInt m = static_cast<PetscBLASInt>(nv);
    a.assign(static_cast<std::size_t>(nv) * n_local_, 0.0);
    g.assign(a.size(), 0.0);
    if (n > 0) {
      // a = Phi_local Q(:, f0 : f0 + nv), g = element forces, out(:, f0..) = W_local^T g.
      BLASgemm_("N", "N", &n, &m, &rr, &one, phi.data(), &n, Q.data() + static_cast<std::size_t>(f0) * r, &rr, &zero,
                a.data(), &n);
      element_loop(kForce, static_cast<int>(nv), a.data(), nullptr, g.data(), nullptr, nullptr);
      BLASgemm_("T", "N", &rw, &m, &n, &one, w, &n, g.data(), &n, &zero, out.data() + static_cast<std::size_t>(f0) * nw,
                &rw);
    }
  }
  // Ghost rows of W hold the same values as their owners, and each element is evaluated by one
  // rank only, so the sum over ranks of the local projections is W^T g.
  MPI_Allreduce(MPI_IN_PLACE, out.data(), static_cast<int>(out.size()), MPI_DOUBLE, MPI_SUM, comm_);
  MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
  return out;
}

namespace {
// sym(X^T Y) with X[i][J] (3x3 row-major), in engineering Voigt order (00, 11, 22, 2·01, 2·02, 2·12):
// (X^T Y)_{KL} = sum_i X[i][K] Y[i][L].
inline void sym_tn_voigt(const double* X, const double* Y, double* s) {
  static const int K[6] = {0, 1, 2, 0, 0, 1}, L[6] = {0, 1, 2, 1, 2, 2};
  for (int c = 0; c < 6; ++c) {
    double v = 0.0;
    for (int i = 0; i < 3; ++i) v += X[3 * i + K[c]] * Y[3 * i + L[c]] + Y[3 * i + K[c]] * X[3 * i + L[c]];
    s[c] = c < 3 ? 0.5 * v : v;
  }
}
// Upper Cholesky factor R of the isotropic elasticity matrix in engineering Voigt notation,
// C = R^T R: the normal block 2 mu I + lam 1 1^T (3 x 3) and mu on the shear diagonal.
// Stored as rn[3][3] (upper) and rs = sqrt(mu).
struct VoigtRoot {
  double rn[9] = {0.0};
  double rs = 0.0;
  VoigtRoot(double lam, double mu) {
    double c[9];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) c[3 * i + j] = lam + (i == j ? 2.0 * mu : 0.0);
    for (int j = 0; j < 3; ++j) {
      double d = c[4 * j];
      for (int k = 0; k < j; ++k) d -= rn[3 * k + j] * rn[3 * k + j];
      MORSE_CHECK(d > 0.0 && mu > 0.0, "Svk::project_tensors: the elasticity matrix is not positive definite (lambda ",
                  lam, ", mu ", mu, ")");
      rn[4 * j] = std::sqrt(d);
      for (int i = j + 1; i < 3; ++i) {
        double v = c[3 * j + i];
        for (int k = 0; k < j; ++k) v -= rn[3 * k + j] * rn[3 * k + i];
        rn[3 * j + i] = v / rn[4 * j];
      }
    }
    rs = std::sqrt(mu);
  }
  // y = s R v (six rows written with stride 1).
  void apply(double s, const double* v, double* y) const {
    for (int i = 0; i < 3; ++i) {
      double t = 0.0;
      for (int j = i; j < 3; ++j) t += rn[3 * i + j] * v[j];
      y[i] = s * t;
    }
    for (int i = 3; i < 6; ++i) y[i] = s * rs * v[i];
  }
};
}  // namespace

// With H_a the displacement gradient of column a at a quadrature point, N_ab = sym(H_a^T H_b)
// and h_a = sym(H_a), the strain energy of u = Phi q is quadratic + cubic + quartic in q with
//   cubic   = 1/2 sum q_i q_j q_k  h_i : C : N_jk,
//   quartic = 1/8 sum q_i q_j q_k q_l  N_ij : C : N_kl.
// Both reduce to two Gram matrices over the pairs (i <= j), summed over the quadrature points:
//   F_{(ij),(kl)} = sum w N_ij : C : N_kl      (n2 x n2, symmetric),
//   G_{p,(jk)}    = sum w h_p  : C : N_jk      (r x n2).
// With C = R^T R and the rows x = sqrt(w) R N (six per point), F = X^T X is a rank-k update
// (BLAS-3 syrk) and G = Y^T X a product, in blocks of points. The coefficients of the gradient
// of the energy are then
//   A_(ij),p  = (G_{p,ij} + G_{j,ip} + G_{i,jp}) / m!,
//   B_(ijk),p = (F_{jk,ip} + F_{ik,jp} + F_{ij,kp}) / (m!) (one over the number of repeated-index
//               orderings: 1 distinct, 2 for one pair, 6 for i = j = k).
void Svk::project_tensors(Mat Phi, std::vector<double>* A, std::vector<double>* B) const {
  PetscLogEvent ev = log_event("SvkProjectTensors");
  MORSE_CALL(PetscLogEventBegin(ev, 0, 0, 0, 0));
  PetscInt r = 0;
  MORSE_CALL(MatGetSize(Phi, nullptr, &r));
  const std::size_t R = static_cast<std::size_t>(r);
  const std::size_t n2 = R * (R + 1) / 2, n3 = R * (R + 1) * (R + 2) / 6;
  MORSE_CHECK(n2 * n2 < static_cast<std::size_t>(INT32_MAX), "Svk::project_tensors: ", r,
              " basis vectors need a pair Gram matrix of ", n2, "^2 entries; use STEP (-nlrom_forces step)");
  const auto phi = local_columns(Phi);
  // Pair numbering: i <= j, lexicographic (the row order of A).
  std::vector<std::size_t> idx2(R * R);
  {
    std::size_t m = 0;
    for (std::size_t i = 0; i < R; ++i)
      for (std::size_t j = i; j < R; ++j) idx2[i * R + j] = idx2[j * R + i] = m++;
  }
  // Blocks of points: X (kb x n2) and Y (kb x r), column-major, kb = 6 x points.
  const std::size_t block_points = std::max<std::size_t>(64, std::min<std::size_t>(512, (1u << 22) / (6 * n2 + 1)));
  const std::size_t kb_max = 6 * block_points;
  std::vector<double> X(kb_max * n2), Y(kb_max * R), F(n2 * n2, 0.0), G(R * n2, 0.0);
  std::vector<double> H(9 * R), ua(kMaxDofs);
  std::size_t kb = 0;
  double flops = 0.0, points = 0.0;
  auto flush = [&]() {
    if (kb == 0) return;
    flops += static_cast<double>(n2) * static_cast<double>(n2 + 1) * kb + 2.0 * R * n2 * kb;
    PetscBLASInt k = static_cast<PetscBLASInt>(kb), np = static_cast<PetscBLASInt>(n2),
                 nr = static_cast<PetscBLASInt>(R), ld = static_cast<PetscBLASInt>(kb_max);
    const double one = 1.0;
    BLASsyrk_("U", "T", &np, &k, &one, X.data(), &ld, &one, F.data(), &np);
    BLASgemm_("T", "N", &nr, &np, &k, &one, Y.data(), &ld, X.data(), &ld, &one, G.data(), &nr);
    kb = 0;
  };
  const std::int64_t ne = static_cast<std::int64_t>(type_n_.size());
  Progress progress(comm_, "exact tensors", static_cast<double>(ne));
  const double t_start = MPI_Wtime();
  double nvec[6];
  for (std::int64_t e = 0; e < ne; ++e) {
    const int n = type_n_[e], nd = 3 * n, nq = elem_nq_[e];
    const PetscInt* pos = &elem_pos_[elem_off_[e]];
    const VoigtRoot root(lambda_[e], mu_[e]);
    for (int q = 0; q < nq; ++q) {
      const double* gq = &grad_[grad_off_[e] + 3 * n * q];
      const double sw = std::sqrt(wdet_[wdet_off_[e] + q]);
      for (std::size_t a = 0; a < R; ++a) {
        const double* col = phi.data() + a * n_local_;
        for (int k = 0; k < nd; ++k) ua[k] = pos[k] >= 0 ? col[pos[k]] : 0.0;
        double* Ha = &H[9 * a];
        displacement_gradient(n, ua.data(), gq, Ha);
        const double hv[6] = {Ha[0], Ha[4], Ha[8], Ha[1] + Ha[3], Ha[2] + Ha[6], Ha[5] + Ha[7]};
        root.apply(sw, hv, &Y[a * kb_max + kb]);
      }
      std::size_t m = 0;
      for (std::size_t a = 0; a < R; ++a)
        for (std::size_t b = a; b < R; ++b, ++m) {
          sym_tn_voigt(&H[9 * a], &H[9 * b], nvec);
          root.apply(sw, nvec, &X[m * kb_max + kb]);
        }
      kb += 6;
      points += 1.0;
      if (kb == kb_max) flush();
    }
    progress.update(static_cast<double>(e + 1));
  }
  flush();
  double seconds = MPI_Wtime() - t_start, sums[2] = {flops, points};
  MPI_Allreduce(MPI_IN_PLACE, &seconds, 1, MPI_DOUBLE, MPI_MAX, comm_);
  MPI_Allreduce(MPI_IN_PLACE, sums, 2, MPI_DOUBLE, MPI_SUM, comm_);
  print0(comm_, "  exact tensors: r = %d, %zu pairs, %.0f quadrature points, %.3g GFLOP in BLAS-3 (%.1f GFLOP/s)\n",
         static_cast<int>(r), n2, sums[1], sums[0] * 1e-9, sums[0] * 1e-9 / std::max(seconds, 1e-9));
  MPI_Allreduce(MPI_IN_PLACE, F.data(), static_cast<int>(F.size()), MPI_DOUBLE, MPI_SUM, comm_);
  MPI_Allreduce(MPI_IN_PLACE, G.data(), static_cast<int>(G.size()), MPI_DOUBLE, MPI_SUM, comm_);
  auto f = [&](std::size_t x, std::size_t y) { return x <= y ? F[x + y * n2] : F[y + x * n2]; };
  auto g = [&](std::size_t p, std::size_t x) { return G[p + x * R]; };
  A->assign(n2 * R, 0.0);
  B->assign(n3 * R, 0.0);
  for (std::size_t i = 0; i < R; ++i)
    for (std::size_t j = i; j < R; ++j) {
      const double c = i == j ? 0.5 : 1.0;
      const std::size_t ij = idx2[i * R + j];
      double* row = &(*A)[ij * R];
      for (std::size_t p = 0; p < R; ++p) row[p] = c * (g(p, ij) + g(j, idx2[i * R + p]) + g(i, idx2[j * R + p]));
    }
  std::size_t m = 0;
  for (std::size_t i = 0; i < R; ++i)
    for (std::size_t j = i; j < R; ++j)
      for (std::size_t k = j; k < R; ++k, ++m) {
        const double c = (i == j && j == k) ? 1.0 / 6.0 : (i == j || j == k) ? 0.5 : 1.0;
        const std::size_t jk = idx2[j * R + k], ik = idx2[i * R + k], ij = idx2[i * R + j];
        const std::size_t *ip = &idx2[i * R], *jp = &idx2[j * R], *kp = &idx2[k * R];
        double* row = &(*B)[m * R];
        for (std::size_t p = 0; p < R; ++p) row[p] = c * (f(jk, ip[p]) + f(ik, jp[p]) + f(ij, kp[p]));
      }
  MORSE_CALL(PetscLogEventEnd(ev, 0, 0, 0, 0));
}

}  // namespace morse::fe
