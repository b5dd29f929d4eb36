#include "morse/fe/constraints.hpp"

#include <petscblaslapack.h>
#include <petscksp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <utility>

#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"
#include "morse/core/log.hpp"
#include "morse/mesh/constraints.hpp"
#include "morse/mesh/mesh.hpp"

namespace morse::fe {

namespace {

using mesh::ComponentMask;

// A DOF by node (or point) id and component 1..6.
struct Key {
  std::int64_t id;
  int c;
  bool operator<(const Key& o) const { return id != o.id ? id < o.id : c < o.c; }
  bool operator==(const Key& o) const { return id == o.id && c == o.c; }
};

using Expr = std::vector<std::pair<Key, double>>;

// Sums equal keys and drops zero coefficients.
void compact(Expr* e) {
  std::sort(e->begin(), e->end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  Expr out;
  for (const auto& [k, a] : *e) {
    if (!out.empty() && out.back().first == k)
      out.back().second += a;
    else
      out.emplace_back(k, a);
  }
  out.erase(std::remove_if(out.begin(), out.end(), [](const auto& t) { return t.second == 0.0; }), out.end());
  e->swap(out);
}

const char* kComp[7] = {"", "1 (x)", "2 (y)", "3 (z)", "4 (rx)", "5 (ry)", "6 (rz)"};

// The coefficients of theta_x, theta_y, theta_z in component c (1..3) of theta x r: the rigid
// rotation's share of a point at offset r.
std::array<double, 3> rotation_row(int c, const double r[3]) {
  if (c == 1) return {0.0, r[2], -r[1]};
  if (c == 2) return {-r[2], 0.0, r[0]};
  return {r[1], -r[0], 0.0};
}

// LU factorization (LAPACK getrf, partial pivoting) of the n x n column-major A; returns the
// first column whose pivot |u_cc| is at most tol, or -1.
int lu_factor(int n, double* A, std::vector<PetscBLASInt>* piv, double tol) {
  PetscBLASInt bn = n, info = 0;
  piv->resize(n);
  LAPACKgetrf_(&bn, &bn, A, &bn, piv->data(), &info);
  for (int c = 0; c < n; ++c)
    if (!(std::abs(A[c + static_cast<std::size_t>(n) * c]) > tol)) return c;
  return -1;
}

// Solves A X = B for nrhs columns (column-major B, n rows) with lu_factor's factors.
void lu_solve(int n, const double* LU, const std::vector<PetscBLASInt>& piv, double* B, int nrhs) {
  PetscBLASInt bn = n, bnrhs = nrhs, info = 0;
  LAPACKgetrs_("N", &bn, &bnrhs, LU, &bn, piv.data(), B, &bn, &info);
}

// The nodes a constraint names: whether each is a point, its coordinates and (solid nodes) its
// three rows in the full layout (-1: clamped). Replicated on every rank.
class Nodes {
 public:
  Nodes(const mesh::LocalMesh& lm, const DofLayout& full, const std::vector<std::string>& clamp_sets) {
    const auto& cs = lm.mesh.constraints;
    ids_ = cs.referenced_ids();
    const std::size_t n = ids_.size();
    rows_.assign(3 * n, -3);
    xyz_.assign(3 * n, 0.0);
    is_point_.assign(n, 0);
    clamped_point_.assign(n, 0);
    int rank = 0;
    MPI_Comm_rank(lm.comm, &rank);
    std::vector<std::pair<std::int64_t, std::int64_t>> local;  // (id, local node), owned
    for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k)
      if (lm.node_owner[k] == rank) local.emplace_back(lm.mesh.node_ids[k], k);
    std::sort(local.begin(), local.end());
    for (std::size_t i = 0; i < n; ++i) {
      const auto p = cs.point_index(ids_[i]);
      if (p >= 0) {
        is_point_[i] = 1;
        if (rank == 0) std::copy_n(&cs.point_coords[3 * p], 3, &xyz_[3 * i]);
        for (const auto& name : clamp_sets) {
          auto it = cs.point_sets.find(name);
          if (it != cs.point_sets.end() && std::binary_search(it->second.begin(), it->second.end(), ids_[i]))
            clamped_point_[i] = 63;
          if (name == mesh::kDeckBoundarySet && !cs.point_fixed.empty()) clamped_point_[i] |= cs.point_fixed[p] & 63;
        }
        continue;
      }
      auto it = std::lower_bound(local.begin(), local.end(), std::make_pair(ids_[i], std::int64_t(-1)));
      if (it == local.end() || it->first != ids_[i]) continue;
      const auto k = it->second;
      for (int d = 0; d < 3; ++d) {
        rows_[3 * i + d] = full.node_dof[3 * k + d];  // -1 if clamped
        xyz_[3 * i + d] = lm.mesh.coords[3 * k + d];
      }
    }
    MPI_Allreduce(MPI_IN_PLACE, rows_.data(), static_cast<int>(rows_.size()), MPIU_INT, MPI_MAX, lm.comm);
    MPI_Allreduce(MPI_IN_PLACE, xyz_.data(), static_cast<int>(xyz_.size()), MPI_DOUBLE, MPI_SUM, lm.comm);
  }
  std::int64_t index(std::int64_t id) const {
    auto it = std::lower_bound(ids_.begin(), ids_.end(), id);
    return it != ids_.end() && *it == id ? it - ids_.begin() : -1;
  }
  bool is_point(std::int64_t id) const { return is_point_[index(id)]; }
  const double* xyz(std::int64_t id) const { return &xyz_[3 * index(id)]; }
  // Full-layout row of a node's translation c (1..3), -1 if clamped.
  PetscInt row(std::int64_t id, int c) const { return rows_[3 * index(id) + c - 1]; }
  bool clamped(const Key& k) const {
    const auto i = index(k.id);
    return is_point_[i] ? (clamped_point_[i] >> (k.c - 1)) & 1 : rows_[3 * i + k.c - 1] < 0;
  }
  const std::vector<std::int64_t>& ids() const { return ids_; }

 private:
  std::vector<std::int64_t> ids_;
  std::vector<PetscInt> rows_;
  std::vector<double> xyz_;
  std::vector<char> is_point_, clamped_point_;
};

// The equations of the records, their resolution and the error messages. Runs identically on
// every rank (the records are replicated), so its errors are thrown alike on every rank.
class Equations {
 public:
  explicit Equations(const Nodes& nodes) : nodes_(nodes) {}

  void rigid(const mesh::RigidElement& r) {
    MORSE_CHECK(nodes_.is_point(r.reference), r.where, ": the independent node ", r.reference,
                " is a node of solid elements, which have no rotations; give the rigid element its own grid (a "
                "spider's centre) as the independent node");
    const double* xr = nodes_.xyz(r.reference);
    for (auto d : r.dependent) {
      MORSE_CHECK(d != r.reference, r.where, ": node ", d, " is both the independent and a dependent node");
      const double* xd = nodes_.xyz(d);
      const double rd[3] = {xd[0] - xr[0], xd[1] - xr[1], xd[2] - xr[2]};
      const bool point = nodes_.is_point(d);
      const ComponentMask mask = point ? r.components : static_cast<ComponentMask>(r.components & 7);
      MORSE_CHECK(mask, r.where, ": dependent node ", d, " is a node of solid elements, and the components ",
                  mesh::component_digits(r.components), " hold none of its translations 1, 2, 3");
      for (int c = 1; c <= 6; ++c) {
        if (!(mask & (1u << (c - 1)))) continue;
        Expr e{{{r.reference, c}, 1.0}};
        if (c <= 3) {
          const auto rot = rotation_row(c, rd);
          for (int j = 0; j < 3; ++j) e.push_back({{r.reference, 4 + j}, rot[j]});
        }
        add({d, c}, std::move(e), r.where);  // compact() drops the zero coefficients
      }
    }
  }

  void linear(const mesh::LinearConstraint& r) {
    MORSE_CHECK(!r.terms.empty(), r.where, ": no terms");
    const auto& t0 = r.terms[0];
    MORSE_CHECK(t0.coefficient != 0.0, r.where, ": the first coefficient (of node ", t0.node, " component ",
                t0.component, ", the dependent DOF) is 0");
    for (const auto& t : r.terms) check_component(t.node, t.component, r.where);
    Expr e;
    for (std::size_t k = 1; k < r.terms.size(); ++k)
      e.push_back({{r.terms[k].node, r.terms[k].component}, -r.terms[k].coefficient / t0.coefficient});
    for (const auto& [k, a] : e)
      MORSE_CHECK(!(k == Key{t0.node, t0.component}), r.where, ": the dependent DOF (node ", t0.node, " component ",
                  t0.component, ") appears again among the other terms");
    add({t0.node, t0.component}, std::move(e), r.where);
  }

  // After rigid and linear: the DOFs made dependent here avoid those already dependent.
  void interpolation(const mesh::InterpolationElement& r) {
    MORSE_CHECK(nodes_.is_point(r.reference), r.where, ": the reference node ", r.reference,
                " is a node of solid elements; give the interpolation element its own grid as the reference");
    MORSE_CHECK(!r.nodes.empty(), r.where, ": no independent nodes");
    const double* xr = nodes_.xyz(r.reference);
    // Rows of the least-squares fit: one per (node, translation), a = [e_c, coefficients of theta].
    std::vector<Key> cols;
    std::vector<std::array<double, 6>> rows;
    std::vector<double> w;
    double l2 = 0, wsum = 0;
    for (std::size_t i = 0; i < r.nodes.size(); ++i) {
      const auto id = r.nodes[i];
      MORSE_CHECK(id != r.reference, r.where, ": the reference node ", id, " is also one of its nodes");
      MORSE_CHECK(r.weights[i] > 0 && std::isfinite(r.weights[i]), r.where, ": node ", id, " has weight ", r.weights[i],
                  "; weights must be positive");
      MORSE_CHECK(r.node_components[i] && !(r.node_components[i] & ~7u), r.where, ": node ", id, " has components ",
                  mesh::component_digits(r.node_components[i]),
                  "; only translations (1, 2, 3) are supported as the independent components");
      const double* x = nodes_.xyz(id);
      const double p[3] = {x[0] - xr[0], x[1] - xr[1], x[2] - xr[2]};
      l2 += r.weights[i] * (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
      wsum += r.weights[i];
      for (int c = 1; c <= 3; ++c) {
        if (!(r.node_components[i] & (1u << (c - 1)))) continue;
        std::array<double, 6> a{};
        a[c - 1] = 1.0;
        const auto rot = rotation_row(c, p);  // (theta x p)_c
        std::copy(rot.begin(), rot.end(), a.begin() + 3);
        cols.push_back({id, c});
        rows.push_back(a);
        w.push_back(r.weights[i]);
      }
    }
    // Normal equations in scaled unknowns (rotations times L, a characteristic length), so that
    // the singularity test compares like with like.
    const double L = std::sqrt(l2 / wsum) > 0 ? std::sqrt(l2 / wsum) : 1.0;
    std::vector<double> N(36, 0.0);  // column-major (symmetric)
    for (std::size_t k = 0; k < rows.size(); ++k)
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j)
          N[i + 6 * j] += w[k] * rows[k][i] * rows[k][j] / ((i >= 3 ? L : 1) * (j >= 3 ? L : 1));
    // A pivot below 1e-10 of the largest diagonal entry means the nodes do not determine the fit.
    double scale = 0;
    for (int i = 0; i < 6; ++i) scale = std::max(scale, N[7 * i]);
    std::vector<PetscBLASInt> piv;
    const int bad = lu_factor(6, N.data(), &piv, 1e-10 * scale);
    MORSE_CHECK(bad < 0, r.where, ": its ", r.nodes.size(),
                " nodes and weights do not determine the reference's motion (", bad < 3 ? "translation" : "rotation",
                " ", "xyz"[bad < 0 ? 0 : bad % 3], " is free: collinear or too few nodes, or too few components)");
    // G = N^-1 A_s^T W (6 x m) in the scaled unknowns (rotations times L): X = N^-1 B.
    const std::size_t m = cols.size();
    std::vector<double> X(6 * m);
    for (std::size_t k = 0; k < m; ++k)
      for (int j = 0; j < 6; ++j) X[j + 6 * k] = rows[k][j] / (j >= 3 ? L : 1) * w[k];
    lu_solve(6, N.data(), piv, X.data(), static_cast<int>(m));
    std::vector<int> ref;  // reference components (0..5) made independent
    for (int c = 0; c < 6; ++c)
      if (r.ref_components & (1u << c)) ref.push_back(c);
    MORSE_CHECK(!ref.empty(), r.where, ": no reference components");
    const std::size_t nr = ref.size();
    std::vector<double> G(nr * m, 0.0);  // row-major; rows scaled: rotations times L (units of length)
    for (std::size_t a = 0; a < nr; ++a)
      for (std::size_t k = 0; k < m; ++k) G[a * m + k] = X[ref[a] + 6 * k];
    // Columns that may become dependent: not clamped (their u = 0 drops out), not dependent in
    // another element and not a term of another element's equations (overlapping elements: a
    // DOF made dependent here that an earlier equation uses could close a cycle).
    std::vector<char> ok(m);
    for (std::size_t k = 0; k < m; ++k)
      ok[k] = !nodes_.clamped(cols[k]) && !dep_.count(cols[k]) && !used_.count(cols[k]);
    // Complete pivoting on G over the allowed columns: the pivot columns S.
    std::vector<double> R(G);
    std::vector<char> row_done(nr, 0), col_done(m, 0);
    std::vector<std::size_t> S(nr);
    double gmax = 0;
    for (double v : G) gmax = std::max(gmax, std::abs(v));
    bool flip = true;
    for (std::size_t step = 0; step < nr && flip; ++step) {
      double best = -1;
      std::size_t br = 0, bc = 0;
      for (std::size_t a = 0; a < nr; ++a)
        if (!row_done[a])
          for (std::size_t k = 0; k < m; ++k)
            if (ok[k] && !col_done[k] && std::abs(R[a * m + k]) > best) best = std::abs(R[a * m + k]), br = a, bc = k;
      if (!(best > 1e-10 * gmax)) {
        flip = false;
        break;
      }
      row_done[br] = col_done[bc] = 1;
      S[br] = bc;
      for (std::size_t a = 0; a < nr; ++a) {
        if (a == br || R[a * m + bc] == 0) continue;
        const double f = R[a * m + bc] / R[br * m + bc];
        for (std::size_t k = 0; k < m; ++k) R[a * m + k] -= f * R[br * m + k];
      }
    }
    if (!flip) {
      // Its nodes' free DOFs (not clamped, not dependent elsewhere: overlapping elements) cannot
      // carry the reference's components: the reference stays dependent (Nastran's default), so
      // it is no DOF of the model (it cannot be a boundary node or carry a mass of its own).
      for (std::size_t a = 0; a < nr; ++a) {
        Expr e;
        const double s = ref[a] >= 3 ? L : 1.0;
        for (std::size_t k = 0; k < m; ++k) e.push_back({cols[k], G[a * m + k] / s});
        add({r.reference, ref[a] + 1}, std::move(e), r.where);
      }
      dependent_references_.push_back(r.where);
      return;
    }
    // u_ref = G_S u_S + G_N u_N  =>  u_S = G_S^-1 (u_ref - G_N u_N). Solve G_S Y = [I, -G_N]
    // (column-major; G_S is invertible: its pivots passed above).
    const std::size_t nc = nr + m;
    std::vector<double> GS(nr * nr), Y(nr * nc, 0.0);
    for (std::size_t a = 0; a < nr; ++a) {
      for (std::size_t b = 0; b < nr; ++b) GS[a + nr * b] = G[a * m + S[b]];
      Y[a + nr * a] = (ref[a] >= 3 ? L : 1);  // u_ref scaled like the row
      for (std::size_t k = 0; k < m; ++k)
        if (std::find(S.begin(), S.end(), k) == S.end()) Y[a + nr * (nr + k)] = -G[a * m + k];
    }
    std::vector<PetscBLASInt> pivs;
    lu_factor(static_cast<int>(nr), GS.data(), &pivs, 0.0);
    lu_solve(static_cast<int>(nr), GS.data(), pivs, Y.data(), static_cast<int>(nc));
    for (std::size_t b = 0; b < nr; ++b) {
      Expr e;
      for (std::size_t a = 0; a < nr; ++a) e.push_back({{r.reference, ref[a] + 1}, Y[b + nr * a]});
      for (std::size_t k = 0; k < m; ++k)
        if (Y[b + nr * (nr + k)] != 0) e.push_back({cols[k], Y[b + nr * (nr + k)]});
      add(cols[S[b]], std::move(e), r.where);
    }
  }

  // Substitutes chains: every dependent DOF in terms of independent, unclamped DOFs only.
  void resolve() {
    for (auto& [k, eq] : dep_) resolve(k, nullptr);
  }

  const std::map<Key, Expr>& resolved() const { return done_; }
  /// Interpolation elements whose reference stayed dependent.
  const std::vector<std::string>& dependent_references() const { return dependent_references_; }
  bool dependent(const Key& k) const { return dep_.count(k) != 0; }

 private:
  struct Eq {
    Expr e;
    std::string where;
  };

  void check_component(std::int64_t id, int c, const std::string& where) const {
    MORSE_CHECK(c >= 1 && c <= 6, where, ": component ", c, " of node ", id, " is not in 1..6");
    MORSE_CHECK(c <= 3 || nodes_.is_point(id), where, ": component ", c, " of node ", id,
                ": a node of solid elements has no rotations (components 1, 2, 3 only)");
  }

  void add(Key k, Expr e, const std::string& where) {
    check_component(k.id, k.c, where);
    for (const auto& [t, a] : e) check_component(t.id, t.c, where);
    MORSE_CHECK(!nodes_.clamped(k), where, ": node ", k.id, " component ", kComp[k.c],
                " is dependent but also fixed (SPC, *BOUNDARY or -clamp); a dependent DOF cannot be constrained twice");
    auto it = dep_.find(k);
    MORSE_CHECK(it == dep_.end(), where, ": node ", k.id, " component ", kComp[k.c], " is dependent here and in ",
                it == dep_.end() ? "" : it->second.where, "; a DOF can be dependent in one element only");
    compact(&e);
    for (const auto& [t, a] : e) used_.insert(t);
    dep_.emplace(k, Eq{std::move(e), where});
  }

  const Expr& resolve(const Key& k, std::vector<Key>* chain) {
    auto d = done_.find(k);
    if (d != done_.end()) return d->second;
    std::vector<Key> local;
    if (!chain) chain = &local;
    if (std::find(chain->begin(), chain->end(), k) != chain->end()) {
      std::string cycle;
      for (const auto& c : *chain) cycle += cat(c.id, ":", c.c, " (", dep_.at(c).where, ") -> ");
      throw Error(cat("circular dependency between constraints: ", cycle, k.id, ":", k.c));
    }
    chain->push_back(k);
    Expr out;
    for (const auto& [t, a] : dep_.at(k).e) {
      if (nodes_.clamped(t)) continue;
      if (dep_.count(t)) {
        for (const auto& [u, b] : resolve(t, chain)) out.emplace_back(u, a * b);
      } else {
        out.emplace_back(t, a);
      }
    }
    chain->pop_back();
    compact(&out);
    return done_.emplace(k, std::move(out)).first->second;
  }

  const Nodes& nodes_;
  std::vector<std::string> dependent_references_;
  std::map<Key, Eq> dep_;
  std::set<Key> used_;  // terms of the equations so far
  std::map<Key, Expr> done_;
};

// Values of a distributed vector x at global rows `rows` (any rank's), on every
// rank that asks. Collective.
std::vector<double> fetch(Vec x, const std::vector<PetscInt>& rows) {
  UVec local;
  MORSE_CALL(VecCreateSeq(PETSC_COMM_SELF, static_cast<PetscInt>(rows.size()), local.ptr()));
  UIS from;
  MORSE_CALL(
      ISCreateGeneral(PETSC_COMM_SELF, static_cast<PetscInt>(rows.size()), rows.data(), PETSC_COPY_VALUES, from.ptr()));
  VecScatter sc;
  MORSE_CALL(VecScatterCreate(x, from.get(), local.get(), nullptr, &sc));
  MORSE_CALL(VecScatterBegin(sc, x, local.get(), INSERT_VALUES, SCATTER_FORWARD));
  MORSE_CALL(VecScatterEnd(sc, x, local.get(), INSERT_VALUES, SCATTER_FORWARD));
  MORSE_CALL(VecScatterDestroy(&sc));
  std::vector<double> out(rows.size());
  const PetscScalar* a;
  MORSE_CALL(VecGetArrayRead(local.get(), &a));
  for (std::size_t i = 0; i < rows.size(); ++i) out[i] = PetscRealPart(a[i]);
  MORSE_CALL(VecRestoreArrayRead(local.get(), &a));
  return out;
}

// (A + A^T) / 2 in place.
void symmetrize(Mat A) {
  UMat At;
  MORSE_CALL(MatTranspose(A, MAT_INITIAL_MATRIX, At.ptr()));
  MORSE_CALL(MatAXPY(A, 1.0, At.get(), UNKNOWN_NONZERO_PATTERN));
  MORSE_CALL(MatScale(A, 0.5));
  MORSE_CALL(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
  MORSE_CALL(MatSetOption(A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
}

}  // namespace

void eliminate_constraints(Model* md, const std::vector<std::string>& clamp_sets, bool keep_node_stiffness) {
  MORSE_CHECK(md->mesh.has_value(), "eliminate_constraints: not a mesh model");
  const auto& lm = *md->mesh;
  const auto& cs = lm.mesh.constraints;
  MPI_Comm comm = lm.comm;
  StageTimer timer(comm, "Constraints");
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  const DofLayout& full = md->dofs;

  Nodes nodes(lm, full, clamp_sets);
  Equations eq(nodes);
  std::string err;
  try {
    for (const auto& r : cs.rigid) eq.rigid(r);
    for (const auto& r : cs.linear) eq.linear(r);
    for (const auto& r : cs.interpolation) eq.interpolation(r);
    eq.resolve();
  } catch (const std::exception& e) {
    err = message_of(e);
  }
  // Every rank holds the same records, so every rank has the same message; a check keeps it so.
  collective_check(comm, err);
  const auto& dep = eq.resolved();

  if (rank == 0 && !eq.dependent_references().empty())
    PetscPrintf(comm,
                "morse: notice: %zu interpolation element(s) keep their reference dependent (their nodes' free DOFs, "
                "shared with other elements, cannot carry it): it is no DOF of the model (first: %s)\n",
                eq.dependent_references().size(), eq.dependent_references()[0].c_str());
  // Points' DOFs kept: independent, not clamped, used by some equation.
  std::vector<Key> point_dofs;
  {
    std::map<Key, char> used;
    for (const auto& [k, e] : dep)
      for (const auto& [t, a] : e)
        if (nodes.is_point(t.id)) used[t] = 1;
    std::string dropped;
    int n_dropped = 0;
    for (auto id : cs.point_ids) {
      if (nodes.index(id) < 0) continue;
      for (int c = 1; c <= 6; ++c) {
        const Key k{id, c};
        if (eq.dependent(k) || nodes.clamped(k)) continue;
        if (used.count(k))
          point_dofs.push_back(k);
        else if (++n_dropped <= 8)
          dropped += cat(dropped.empty() ? "" : ", ", id, ":", c);
      }
    }
    if (n_dropped && rank == 0)
      PetscPrintf(comm, "morse: notice: %d DOF(s) of six-DOF points are held by no element and are left out: %s%s\n",
                  n_dropped, dropped.c_str(), n_dropped > 8 ? ", ..." : "");
  }

  // Reduced numbering: owned full rows that are not dependent, then (rank 0) the points' DOFs.
  std::vector<char> is_dep(full.n_owned, 0);
  std::int64_t n_dep_nodes = 0, n_dep_points = 0;
  for (const auto& [k, e] : dep) {
    if (nodes.is_point(k.id)) {
      ++n_dep_points;
      continue;
    }
    ++n_dep_nodes;
    const PetscInt g = nodes.row(k.id, k.c);
    if (g >= full.first && g < full.first + full.n_owned) is_dep[g - full.first] = 1;
  }
  DofLayout red;
  red.comm = comm;
  PetscInt n_solid = 0;
  for (PetscInt i = 0; i < full.n_owned; ++i) n_solid += !is_dep[i];
  red.n_owned = n_solid + (rank == 0 ? static_cast<PetscInt>(point_dofs.size()) : 0);
  MPI_Exscan(&red.n_owned, &red.first, 1, MPIU_INT, MPI_SUM, comm);
  if (rank == 0) red.first = 0;
  MPI_Allreduce(&red.n_owned, &red.n_global, 1, MPIU_INT, MPI_SUM, comm);
  PetscInt point_base = n_solid;  // rank 0's first point row (rank 0 starts at 0)
  MPI_Bcast(&point_base, 1, MPIU_INT, 0, comm);
  std::int64_t clamped_points = 0;
  for (auto id : cs.point_ids)
    if (nodes.index(id) >= 0)
      for (int c = 1; c <= 6; ++c) clamped_points += nodes.clamped({id, c}) ? 1 : 0;
  red.n_clamped_global = full.n_clamped_global + clamped_points;

  // full row -> reduced row (-1 dependent), as a distributed vector for remote lookups.
  std::vector<PetscInt> to_red(full.n_owned, -1);
  {
    PetscInt next = red.first;
    for (PetscInt i = 0; i < full.n_owned; ++i)
      if (!is_dep[i]) to_red[i] = next++;
  }
  UVec map;
  MORSE_CALL(VecCreateMPI(comm, full.n_owned, full.n_global, map.ptr()));
  {
    PetscScalar* a;
    MORSE_CALL(VecGetArray(map.get(), &a));
    for (PetscInt i = 0; i < full.n_owned; ++i) a[i] = static_cast<double>(to_red[i]);
    MORSE_CALL(VecRestoreArray(map.get(), &a));
  }
  // Reduced rows of the local nodes (owned and ghost) and of the nodes the equations name.
  const std::int64_t nn = lm.mesh.num_nodes();
  std::vector<PetscInt> ask;
  for (std::int64_t k = 0; k < 3 * nn; ++k)
    if (full.node_dof[k] >= 0) ask.push_back(full.node_dof[k]);
  const std::size_t n_local_ask = ask.size();
  for (auto id : nodes.ids())
    if (!nodes.is_point(id))
      for (int c = 1; c <= 3; ++c)
        if (nodes.row(id, c) >= 0) ask.push_back(nodes.row(id, c));
  const auto got = fetch(map.get(), ask);
  red.node_dof.assign(3 * nn, -1);
  {
    std::size_t j = 0;
    for (std::int64_t k = 0; k < 3 * nn; ++k)
      if (full.node_dof[k] >= 0) red.node_dof[k] = static_cast<PetscInt>(got[j++]);
  }
  std::map<Key, PetscInt> col;  // reduced column of every independent DOF the equations use
  {
    std::size_t j = n_local_ask;
    for (auto id : nodes.ids())
      if (!nodes.is_point(id))
        for (int c = 1; c <= 3; ++c)
          if (nodes.row(id, c) >= 0) {
            const auto v = static_cast<PetscInt>(got[j++]);
            if (v >= 0) col[{id, c}] = v;
          }
    for (std::size_t i = 0; i < point_dofs.size(); ++i) col[point_dofs[i]] = point_base + static_cast<PetscInt>(i);
  }
  // Labels and sets of the reduced rows.
  red.node.resize(red.n_owned);
  red.component.resize(red.n_owned);
  for (PetscInt i = 0; i < full.n_owned; ++i)
    if (!is_dep[i]) {
      red.node[to_red[i] - red.first] = full.node[i];
      red.component[to_red[i] - red.first] = full.component[i];
    }
  if (rank == 0)
    for (std::size_t i = 0; i < point_dofs.size(); ++i) {
      red.node[point_base + i] = point_dofs[i].id;
      red.component[point_base + i] = point_dofs[i].c;
    }
  for (const auto& [name, rows] : full.sets) {
    auto& out = red.sets[name];
    for (auto g : rows)
      if (to_red[g - full.first] >= 0) out.push_back(to_red[g - full.first]);
  }
  for (const auto& [name, ids] : cs.point_sets) {
    auto& out = red.sets[name];  // every rank knows every set name
    if (rank == 0)
      for (std::size_t i = 0; i < point_dofs.size(); ++i)
        if (std::binary_search(ids.begin(), ids.end(), point_dofs[i].id)) out.push_back(point_base + i);
  }
  for (auto& [name, rows] : red.sets) std::sort(rows.begin(), rows.end());

  // T: rows as full, columns as red.
  auto cm = std::make_shared<ConstraintMap>();
  {
    std::vector<PetscInt> dnz(full.n_owned, 0), onz(full.n_owned, 0);
    std::vector<std::vector<std::pair<PetscInt, double>>> dep_rows(full.n_owned);
    for (const auto& [k, e] : dep) {
      if (nodes.is_point(k.id)) continue;
      const PetscInt g = nodes.row(k.id, k.c);
      if (g < full.first || g >= full.first + full.n_owned) continue;
      for (const auto& [t, a] : e) dep_rows[g - full.first].emplace_back(col.at(t), a);
    }
    for (PetscInt i = 0; i < full.n_owned; ++i) {
      if (!is_dep[i]) {
        ++dnz[i];
        continue;
      }
      for (const auto& [c, a] : dep_rows[i]) (c >= red.first && c < red.first + red.n_owned ? dnz : onz)[i]++;
    }
    MORSE_CALL(MatCreateAIJ(comm, full.n_owned, red.n_owned, full.n_global, red.n_global, 0, dnz.data(), 0, onz.data(),
                            cm->T.ptr()));
    for (PetscInt i = 0; i < full.n_owned; ++i) {
      const PetscInt g = full.first + i;
      if (!is_dep[i]) {
        MORSE_CALL(MatSetValue(cm->T.get(), g, to_red[i], 1.0, INSERT_VALUES));
        continue;
      }
      for (const auto& [c, a] : dep_rows[i]) MORSE_CALL(MatSetValue(cm->T.get(), g, c, a, INSERT_VALUES));
    }
    MORSE_CALL(MatAssemblyBegin(cm->T.get(), MAT_FINAL_ASSEMBLY));
    MORSE_CALL(MatAssemblyEnd(cm->T.get(), MAT_FINAL_ASSEMBLY));
  }

  // K_bar, M_bar.
  UMat Kr, Mr;
  MORSE_CALL(MatPtAP(md->K.get(), cm->T.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, Kr.ptr()));
  MORSE_CALL(MatPtAP(md->M.get(), cm->T.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, Mr.ptr()));
  symmetrize(Kr.get());
  symmetrize(Mr.get());
  // Points' masses: a 6 x 6 matrix M6 about each point (a lumped mass m on the translations, and
  // rigid masses with offsets and inertias) adds sum_ab M6_ab t_a t_b^T, t_a the point's row a of
  // T (a dependent DOF's equation, or a unit row, or nothing if clamped).
  double point_mass = 0;
  MORSE_CALL(MatSetOption(Mr.get(), MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE));
  {
    std::map<std::int64_t, std::vector<double>> m6;  // by point id
    for (std::size_t p = 0; p < cs.point_ids.size(); ++p)
      if (cs.point_mass[p] != 0.0) {
        auto& M = m6[cs.point_ids[p]];
        M.assign(36, 0.0);
        for (int c = 0; c < 3; ++c) M[7 * c] = cs.point_mass[p];
        point_mass += cs.point_mass[p];
      }
    for (std::size_t q = 0; q < cs.mass_ids.size(); ++q) {
      auto& M = m6[cs.mass_ids[q]];
      M.resize(36, 0.0);
      for (int k = 0; k < 36; ++k) M[k] += cs.mass_matrices[36 * q + k];
      point_mass += cs.mass_matrices[36 * q];
    }
    if (rank == 0)
      for (const auto& [id, M] : m6) {
        if (nodes.index(id) < 0) continue;
        std::map<PetscInt, std::array<double, 6>> t;  // column -> its coefficient in rows a = 0..5
        for (int a = 0; a < 6; ++a) {
          const Key k{id, a + 1};
          if (nodes.clamped(k)) continue;
          if (auto it = dep.find(k); it != dep.end()) {
            for (const auto& [u, c] : it->second) t[col.at(u)][a] += c;
          } else if (auto jt = col.find(k); jt != col.end()) {
            t[jt->second][a] += 1.0;
          }
        }
        std::vector<PetscInt> cols;
        for (const auto& [c, v] : t) cols.push_back(c);
        const auto n = static_cast<PetscInt>(cols.size());
        std::vector<double> block(cols.size() * cols.size(), 0.0);
        std::size_t i = 0;
        for (const auto& [ci, vi] : t) {
          std::size_t j = 0;
          for (const auto& [cj, vj] : t) {
            double s = 0;
            for (int a = 0; a < 6; ++a)
              for (int b = 0; b < 6; ++b) s += vi[a] * M[6 * a + b] * vj[b];
            block[i * cols.size() + j++] = s;
          }
          ++i;
        }
        if (n) MORSE_CALL(MatSetValues(Mr.get(), n, cols.data(), n, cols.data(), block.data(), ADD_VALUES));
      }
  }
  MORSE_CALL(MatAssemblyBegin(Mr.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(Mr.get(), MAT_FINAL_ASSEMBLY));
  for (Mat A : {Kr.get(), Mr.get()}) {
    MORSE_CALL(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
    MORSE_CALL(MatSetOption(A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
  }

  cm->n_dependent = n_dep_nodes + n_dep_points;
  cm->n_point_dofs = static_cast<std::int64_t>(point_dofs.size());
  cm->n_rigid = static_cast<std::int64_t>(cs.rigid.size());
  cm->n_interpolation = static_cast<std::int64_t>(cs.interpolation.size());
  cm->n_linear = static_cast<std::int64_t>(cs.linear.size());
  cm->point_ids = cs.point_ids;
  cm->point_coords = cs.point_coords;
  cm->full = std::move(md->dofs);
  md->dofs = std::move(red);
  if (keep_node_stiffness) cm->K_nodes = std::move(md->K);
  md->K = std::move(Kr);
  md->M = std::move(Mr);
  md->mass += point_mass;
  md->constraints = std::move(cm);
  if (rank == 0)
    PetscPrintf(comm, "morse: constraints: %s; %lld DOF(s) eliminated, %lld point DOF(s) kept\n", cs.summary().c_str(),
                static_cast<long long>(md->constraints->n_dependent),
                static_cast<long long>(md->constraints->n_point_dofs));
}

UVec expand(const Model& md, Vec u_bar) {
  UVec u;
  if (!md.constraints) {
    MORSE_CALL(VecDuplicate(u_bar, u.ptr()));
    MORSE_CALL(VecCopy(u_bar, u.get()));
    return u;
  }
  MORSE_CALL(MatCreateVecs(md.constraints->T.get(), nullptr, u.ptr()));
  MORSE_CALL(MatMult(md.constraints->T.get(), u_bar, u.get()));
  return u;
}

namespace {
// Least squares on the model's DOFs, min ||T y - x||, by the normal equations (T^T T) y = T^T x.
// T has full column rank (every model DOF moves some node, or is a node's own translation), so
// T^T T is positive definite, and for x = T y the solution is y.
class Restriction {
 public:
  explicit Restriction(const Model& md) : T_(md.constraints->T.get()) {
    MORSE_CALL(MatTransposeMatMult(T_, T_, MAT_INITIAL_MATRIX, PETSC_DEFAULT, TtT_.ptr()));
    MPI_Comm comm;
    MORSE_CALL(PetscObjectGetComm((PetscObject)T_, &comm));
    MORSE_CALL(KSPCreate(comm, ksp_.ptr()));
    MORSE_CALL(KSPSetOperators(ksp_.get(), TtT_.get(), TtT_.get()));
    MORSE_CALL(KSPSetType(ksp_.get(), KSPPREONLY));
    PC pc;
    MORSE_CALL(KSPGetPC(ksp_.get(), &pc));
    MORSE_CALL(PCSetType(pc, PCCHOLESKY));
    MORSE_CALL(PCFactorSetMatSolverType(pc, cholesky_solver(comm)));
    MORSE_CALL(KSPSetUp(ksp_.get()));
    MORSE_CALL(MatCreateVecs(TtT_.get(), y_.ptr(), b_.ptr()));
  }
  // y = the fit of x (y: a vector of the model's DOFs).
  void apply(Vec x, Vec y) {
    MORSE_CALL(MatMultTranspose(T_, x, b_.get()));
    MORSE_CALL(KSPSolve(ksp_.get(), b_.get(), y));
  }
  Vec work() { return y_.get(); }

 private:
  Mat T_;
  UMat TtT_;
  UKSP ksp_;
  UVec y_, b_;
};
}  // namespace

UMat restrict_columns(const Model& md, Mat X) {
  UMat Y;
  if (!md.constraints) {
    MORSE_CALL(MatDuplicate(X, MAT_COPY_VALUES, Y.ptr()));
    return Y;
  }
  Restriction r(md);
  PetscInt m = 0, n = 0;
  MORSE_CALL(MatGetLocalSize(md.constraints->T.get(), nullptr, &m));
  MORSE_CALL(MatGetSize(X, nullptr, &n));
  MPI_Comm comm;
  MORSE_CALL(PetscObjectGetComm((PetscObject)X, &comm));
  MORSE_CALL(MatCreateDense(comm, m, PETSC_DECIDE, PETSC_DETERMINE, n, nullptr, Y.ptr()));
  for (PetscInt j = 0; j < n; ++j) {  // one solve per column, with the one factor
    Vec x, y;
    MORSE_CALL(MatDenseGetColumnVecRead(X, j, &x));
    r.apply(x, r.work());
    MORSE_CALL(MatDenseRestoreColumnVecRead(X, j, &x));
    MORSE_CALL(MatDenseGetColumnVecWrite(Y.get(), j, &y));
    MORSE_CALL(VecCopy(r.work(), y));
    MORSE_CALL(MatDenseRestoreColumnVecWrite(Y.get(), j, &y));
  }
  return Y;
}

UVec restrict_vector(const Model& md, Vec x) {
  UVec y;
  if (!md.constraints) {
    MORSE_CALL(VecDuplicate(x, y.ptr()));
    MORSE_CALL(VecCopy(x, y.get()));
    return y;
  }
  Restriction r(md);
  MORSE_CALL(VecDuplicate(r.work(), y.ptr()));
  r.apply(x, y.get());
  return y;
}

const DofLayout& node_layout(const Model& md) { return md.constraints ? md.constraints->full : md.dofs; }

std::vector<std::int64_t> point_dof_slots(const Model& md) {
  if (!md.constraints || !md.mesh || md.mesh->mesh.constraints.point_ids.empty()) return {};
  const auto& pids = md.mesh->mesh.constraints.point_ids;
  std::vector<std::int64_t> slot(static_cast<std::size_t>(md.dofs.n_owned), -1);
  for (PetscInt i = 0; i < md.dofs.n_owned; ++i) {
    const auto it = std::find(pids.begin(), pids.end(), md.dofs.node[i]);
    if (it != pids.end()) slot[i] = 6 * (it - pids.begin()) + md.dofs.component[i] - 1;
  }
  return slot;
}

}  // namespace morse::fe
