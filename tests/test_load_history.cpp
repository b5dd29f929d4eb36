// Tabulated nodal load histories (dyn::LoadTable, read_load_table, LoadHistory) against
// references from outside the code under test: hand-computed interpolation values, the readers'
// three formats against the table they were written from, bad input, the linear response to a
// tabulated ramp against modal superposition in closed form, the convergence of a tabulated
// sampling of a harmonic load to the harmonic -load_* path at O(dt_table^2), and the independence
// of the rank count.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "morse/dyn/dyn.hpp"
#include "morse/io/h5.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

int world_rank_of(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

// The ids of the nodes of a set, ascending, on every rank. Collective.
std::vector<std::int64_t> set_ids(const mesh::LocalMesh& lm, const std::string& set) {
  const int rank = world_rank_of(lm.comm);
  std::vector<std::int64_t> mine;
  for (auto k : lm.mesh.node_sets.at(set))
    if (lm.node_owner[k] == rank) mine.push_back(lm.mesh.node_ids[k]);
  int size = 0, n = static_cast<int>(mine.size());
  MPI_Comm_size(lm.comm, &size);
  std::vector<int> counts(size), displs(size, 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, lm.comm);
  for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
  std::vector<std::int64_t> all(displs.back() + counts.back());
  MPI_Allgatherv(mine.data(), n, MPI_INT64_T, all.data(), counts.data(), displs.data(), MPI_INT64_T, lm.comm);
  std::sort(all.begin(), all.end());
  return all;
}

// Component d of F at the node with id `id` (0 for a clamped DOF), on every rank. Collective.
double at_node(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, Vec F, std::int64_t id, int d) {
  const int rank = world_rank_of(lm.comm);
  const double* a;
  MORSE_CALL(VecGetArrayRead(F, &a));
  double v = 0.0;
  for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k)
    if (lm.mesh.node_ids[k] == id && lm.node_owner[k] == rank && dofs.node_dof[3 * k + d] >= 0)
      v = a[dofs.node_dof[3 * k + d] - dofs.first];
  MORSE_CALL(VecRestoreArrayRead(F, &a));
  double g = 0.0;
  MPI_Allreduce(&v, &g, 1, MPI_DOUBLE, MPI_SUM, lm.comm);
  return g;
}

// Mean of component d of u over the nodes of a set. Collective.
double set_mean(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, Vec u, const std::string& set, int d) {
  const int rank = world_rank_of(lm.comm);
  const double* a;
  MORSE_CALL(VecGetArrayRead(u, &a));
  double s[2] = {0, 0}, g[2];
  for (auto k : lm.mesh.node_sets.at(set)) {
    if (lm.node_owner[k] != rank) continue;
    const PetscInt dof = dofs.node_dof[3 * k + d];
    s[0] += dof >= 0 ? a[dof - dofs.first] : 0.0;
    s[1] += 1;
  }
  MORSE_CALL(VecRestoreArrayRead(u, &a));
  MPI_Allreduce(s, g, 2, MPI_DOUBLE, MPI_SUM, lm.comm);
  return g[0] / g[1];
}

// A table of the same force f(t) (3 components) on every node of `ids`, sampled at `times`.
template <class Fn>
dyn::LoadTable uniform_table(const std::vector<std::int64_t>& ids, const std::vector<double>& times, Fn f) {
  dyn::LoadTable t;
  t.source = "test table";
  t.time = times;
  t.node_ids = ids;
  for (double ti : times) {
    const auto v = f(ti);
    for (std::size_t k = 0; k < ids.size(); ++k) t.forces.insert(t.forces.end(), v.begin(), v.end());
  }
  return t;
}

dyn::NodalLoad tip_load(double amplitude, double omega, int dir) {
  dyn::NodalLoad l;
  l.set = "x1";
  l.dir[dir] = 1.0;
  l.amplitude = amplitude;
  l.omega = omega;
  return l;
}

class LoadTableReader : public test::ScratchDirTest {
 protected:
  LoadTableReader() : ScratchDirTest("load_history") {}
};

// The table of the reader tests: 3 times, 2 nodes.
dyn::LoadTable reader_table() {
  dyn::LoadTable t;
  t.time = {0.0, 0.5, 2.0};
  t.node_ids = {7, 3};
  t.forces = {1,  2, 3,   -1,   -2, -3,   //
              4,  5, 6,   0.25, 0,  1e3,  //
              -7, 8, 9.5, 1e-7, 2,  3};
  return t;
}

}  // namespace

// Hand values of the linear interpolation, the dropped clamped DOFs, and the three behaviours
// outside the grid, on a distributed box.
TEST(LoadHistory, InterpolatesHandValuesAndDropsClampedDofs) {
  auto m = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex8, 4, 1, 1, 4, 1, 1));
  const auto tip = set_ids(m.lm, "x1"), root = set_ids(m.lm, "x0");
  ASSERT_EQ(tip.size(), 4u);
  // Node a (free) and node c (clamped, x0) carry forces; times 1, 2, 4.
  const std::int64_t a = tip[1], c = root[0];
  dyn::LoadTable t;
  t.source = "hand table";
  t.time = {1.0, 2.0, 4.0};
  t.node_ids = {c, a};
  t.forces = {100, 100, 100, 1,  2, 3,  //
              100, 100, 100, 3,  2, 1,  //
              100, 100, 100, -1, 0, 5};
  UVec F;
  MORSE_CALL(MatCreateVecs(m.ops.K.get(), F.ptr(), nullptr));
  auto value = [&](const dyn::LoadHistory& h, double time) {
    MORSE_CALL(VecSet(F.get(), 0.0));
    h.add_to(time, F.get());
    std::vector<double> v(3);
    for (int d = 0; d < 3; ++d) v[d] = at_node(m.lm, m.dofs, F.get(), a, d);
    double s = 0.0;
    MORSE_CALL(VecSum(F.get(), &s));
    v.push_back(s);
    return v;
  };
  dyn::LoadHistory h(m.lm, m.dofs, t, dyn::Outside::Error, 2.0);
  // (t, expected force of a / 2): between rows by hand.
  const std::vector<std::pair<double, std::vector<double>>> cases = {{1.0, {1, 2, 3}},   {1.25, {1.5, 2, 2.5}},
                                                                     {2.0, {3, 2, 1}},   {3.0, {1, 1, 3}},
                                                                     {3.5, {0, 0.5, 4}}, {4.0, {-1, 0, 5}}};
  for (const auto& [time, want] : cases) {
    const auto v = value(h, time);
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(v[d], 2.0 * want[d], 1e-12) << "t " << time << " component " << d;
    // The clamped node's 100s are reactions: F holds node a only.
    EXPECT_NEAR(v[3], 2.0 * (want[0] + want[1] + want[2]), 1e-12) << "t " << time;
  }
  EXPECT_NEAR(h.total(3.0)[0], 2.0 * (1 + 100), 1e-12);  // total() keeps every node
  EXPECT_THROW(value(h, 0.5), Error);
  EXPECT_THROW(value(h, 4.5), Error);
  EXPECT_NO_THROW(h.check_covers(1.0, 4.0));
  EXPECT_NO_THROW(h.check_covers(1.0, 4.0 * (1 + 1e-12)));  // round-off of n_steps * dt
  EXPECT_THROW(h.check_covers(0.0, 4.0), Error);
  EXPECT_THROW(h.check_covers(1.0, 4.1), Error);
  dyn::LoadHistory zero(m.lm, m.dofs, t, dyn::Outside::Zero);
  EXPECT_NO_THROW(zero.check_covers(0.0, 10.0));
  for (double time : {0.5, 4.5}) {
    const auto v = value(zero, time);
    for (double x : v) EXPECT_EQ(x, 0.0) << "t " << time;
  }
  dyn::LoadHistory hold(m.lm, m.dofs, t, dyn::Outside::Hold);
  EXPECT_NEAR(value(hold, 0.0)[0], 1.0, 1e-15);
  EXPECT_NEAR(value(hold, 9.0)[2], 5.0, 1e-15);
  // The history adds to the harmonic loads of dyn::Loads: a constant 10 N in z on x1.
  dyn::Loads loads(m.lm, m.dofs, {tip_load(10.0, 0.0, 2)});
  loads.set_history(std::make_shared<dyn::LoadHistory>(m.lm, m.dofs, t));
  loads.evaluate(3.0, F.get());
  EXPECT_NEAR(at_node(m.lm, m.dofs, F.get(), a, 2), 10.0 + 3.0, 1e-12);
  EXPECT_NEAR(at_node(m.lm, m.dofs, F.get(), tip[0], 2), 10.0, 1e-12);
}

// A node id that is not in the mesh: every rank throws the same message naming it.
TEST(LoadHistory, UnknownNodeIsACollectiveError) {
  auto m = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex8, 4, 1, 1, 4, 1, 1));
  const auto tip = set_ids(m.lm, "x1");
  auto t = uniform_table({tip[0], 987654}, {0.0, 1.0}, [](double) { return std::vector<double>{1, 0, 0}; });
  test::expect_error_parts([&] { dyn::LoadHistory h(m.lm, m.dofs, t); }, {"test table", "987654", "not nodes of"},
                           "unknown node");
  t.time = {0.0, 0.0};
  test::expect_error_parts([&] { dyn::LoadHistory h(m.lm, m.dofs, t); }, {"not strictly increasing"}, "equal times");
}

// The CSV, the generic HDF5 table and a morse simulate contact group read back the table they
// were written from.
TEST_F(LoadTableReader, ThreeFormatsReadBackTheTable) {
  const auto ref = reader_table();
  std::string csv = "# a comment line\ntime, node, fx, fy, fz\n";
  for (std::size_t i = 0; i < ref.time.size(); ++i)
    for (std::size_t k = 0; k < 2; ++k) {
      // node 3 before node 7 in the second block: any order within a block
      const std::size_t kk = i == 1 ? 1 - k : k;
      csv += cat(ref.time[i], ",", ref.node_ids[kk]);
      for (int d = 0; d < 3; ++d) csv += cat(", ", ref.forces[(i * 2 + kk) * 3 + d]);
      csv += "   # trailing comment\n";
    }
  const auto csv_path = write("table.CSV", csv);
  const auto h5 = path("table.h5");
  {
    io::H5Output out(PETSC_COMM_SELF, h5);
    out.write("/load_history/time", ref.time);
    out.write("/load_history/node_ids", ref.node_ids);
    out.write("/load_history/forces", ref.forces, {3, 2, 3});
    out.write("/elsewhere/time", ref.time);
    out.write("/elsewhere/node_ids", ref.node_ids);
    out.write("/elsewhere/forces", ref.forces, {3, 2, 3});
    out.commit();
  }
  const auto sim = path("sim.h5");
  {
    io::H5Output out(PETSC_COMM_SELF, sim);
    out.write("/sim/contact/node_ids", ref.node_ids);
    out.write("/sim/contact/normal", std::vector<double>(6, 0.0), {3, 2});
    out.write("/sim/contact/mean_force", ref.forces, {3, 2, 3});
    out.write("/sim/contact/mean_force_time", ref.time);
    out.commit();
  }
  for (const std::string& spec : {csv_path, h5, h5 + ":/elsewhere", sim, sim + ":/sim/contact/"}) {
    dyn::LoadTable t;
    const auto err = dyn::read_load_table(spec, &t);
    ASSERT_EQ(err, "") << spec;
    EXPECT_EQ(t.time, ref.time) << spec;
    EXPECT_EQ(t.node_ids, ref.node_ids) << spec;
    EXPECT_EQ(t.forces, ref.forces) << spec;
  }
}

// Bad input: each message names the file and the fault.
TEST_F(LoadTableReader, BadInputNamesFileAndFault) {
  auto fails = [&](const std::string& spec, std::initializer_list<std::string> parts) {
    test::expect_error_parts([&] { dyn::read_load_table(PETSC_COMM_SELF, spec); }, parts, spec);
  };
  fails(path("missing.csv"), {"missing.csv", "cannot open"});
  fails(path("missing.h5"), {"missing.h5", "cannot open"});
  fails(write("words.csv", "time,node,fx,fy,fz\n0,1,2,3\n"), {"words.csv:2", "expected 5 numbers"});
  fails(write("back.csv", "0,1,0,0,0\n1,1,0,0,0\n0.5,1,0,0,0\n"), {"back.csv:3", "not increasing"});
  fails(write("nan.csv", "0,1,0,0,0\n1,1,0,nan,0\n"), {"nan.csv:2", "not finite"});
  fails(write("gap.csv", "0,1,0,0,0\n0,2,0,0,0\n1,2,0,0,0\n2,1,0,0,0\n2,2,0,0,0\n"), {"gap.csv:3", "lacks node 1"});
  fails(write("twice.csv", "0,1,0,0,0\n0,1,0,0,0\n"), {"twice.csv:2", "node 1 appears twice"});
  // A node id is an integer: never truncated (1401.5 is not node 1401), never out of range.
  fails(write("frac.csv", "0,1401.5,0,0,0\n"), {"frac.csv:1", "node id 1401.5 is not an integer node id"});
  fails(write("huge.csv", "0,1e30,0,0,0\n"), {"huge.csv:1", "node id 1e30 is not an integer node id"});
  fails(write("new.csv", "0,1,0,0,0\n1,2,0,0,0\n"), {"new.csv:2", "node 2 is not in the first time block"});
  fails(write("empty.csv", "# nothing\n"), {"empty.csv", "no data row"});
  fails(write("text.h5", "not hdf5"), {"text.h5", "cannot open as HDF5"});
  auto ref = reader_table();
  const auto h5 = path("bad.h5");
  {
    io::H5Output out(PETSC_COMM_SELF, h5);
    out.write("/no_forces/time", ref.time);
    out.write("/no_forces/node_ids", ref.node_ids);
    out.write("/no_ids/time", ref.time);
    out.write("/no_ids/forces", ref.forces, {3, 2, 3});
    out.write("/shape/time", ref.time);
    out.write("/shape/node_ids", ref.node_ids);
    out.write("/shape/forces", ref.forces, {3, 6});
    out.write("/down/time", std::vector<double>{0.0, 2.0, 1.0});
    out.write("/down/node_ids", ref.node_ids);
    out.write("/down/forces", ref.forces, {3, 2, 3});
    auto nan = ref.forces;
    nan[13] = std::numeric_limits<double>::quiet_NaN();
    out.write("/nan/time", ref.time);
    out.write("/nan/node_ids", ref.node_ids);
    out.write("/nan/forces", nan, {3, 2, 3});
    out.write("/dup/time", ref.time);
    out.write("/dup/node_ids", std::vector<std::int64_t>{3, 3});
    out.write("/dup/forces", ref.forces, {3, 2, 3});
    out.write("/frac/time", ref.time);
    out.write("/frac/node_ids", std::vector<double>{3, 1401.5});  // floating point: HDF5 would truncate
    out.write("/frac/forces", ref.forces, {3, 2, 3});
    out.write("/real_ids/time", ref.time);
    out.write("/real_ids/node_ids", std::vector<double>{7, 3});  // integral floats: accepted
    out.write("/real_ids/forces", ref.forces, {3, 2, 3});
    out.write("/sim/contact/normal", std::vector<double>(6, 0.0), {3, 2});  // an old simulate file
    out.commit();
  }
  fails(h5, {"bad.h5", "no mean_force"});  // no /load_history: /sim/contact is taken
  const auto other = path("other.h5");
  {
    io::H5Output out(PETSC_COMM_SELF, other);
    out.write("/x", ref.time);
    out.commit();
  }
  fails(other, {"other.h5", "no load table (/load_history) nor", "/sim/contact"});
  fails(h5 + ":/nosuch", {"bad.h5", "no group /nosuch"});
  fails(h5 + ":/no_forces", {"bad.h5", "/no_forces/forces"});
  fails(h5 + ":/no_ids", {"bad.h5", "/no_ids/node_ids"});
  fails(h5 + ":/shape", {"bad.h5", "/shape/forces must have the shape"});
  fails(h5 + ":/down", {"bad.h5:/down", "not strictly increasing", "time 2"});
  fails(h5 + ":/nan", {"bad.h5:/nan", "force y of node 7 at time 2", "not finite"});
  fails(h5 + ":/dup", {"bad.h5:/dup", "node 3 appears twice"});
  fails(h5 + ":/frac", {"bad.h5", "/frac/node_ids holds 1401.5 (entry 1), not an integer"});
  {
    dyn::LoadTable t;
    ASSERT_EQ(dyn::read_load_table(h5 + ":/real_ids", &t), "");
    EXPECT_EQ(t.node_ids, ref.node_ids);
  }
  fails(h5 + ":/sim/contact", {"bad.h5", "no mean_force", "older morse simulate"});
  fails(h5 + ":/no_forces/time", {"bad.h5", "neither a load table"});
}

// Linear model under a tabulated ramp F t / T held from T on (a two-row table with
// Outside::Hold: linear interpolation is then exact) against modal superposition in closed form:
// q_k = c_k / (w_k^2 T) (t - sin(w_k t) / w_k) =: r_k(t) for t <= T, r_k(t) - r_k(t - T) after,
// plus the quasi-static response of the modes above the 20 computed ones.
TEST(LoadHistory, LinearRampMatchesClosedForm) {
  auto m = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex20, 1.0, 0.1, 0.1, 6, 1, 1));
  auto mat = test::steel();
  fe::Svk svk(m.lm, m.dofs, mat, m.ops.K.get());
  eigen::EigenSettings es;
  es.nev = 20;
  es.prefix = "test_modes_";
  auto eig = eigen::solve_eigen(m.ops.K.get(), m.ops.M.get(), es, nullptr);
  const double w1 = std::sqrt(eig.omega2[0]), T1 = 2 * M_PI / w1, T = 2.3 * T1, A = 100.0;
  const auto tip = set_ids(m.lm, "x1");
  auto table = uniform_table(tip, {0.0, T}, [&](double t) { return std::vector<double>{0, 0, A * t / T}; });
  dyn::Loads loads(m.lm, m.dofs, {});
  loads.set_history(std::make_shared<dyn::LoadHistory>(m.lm, m.dofs, table, dyn::Outside::Hold));
  // The final load pattern F from the harmonic path (a constant 100 N per x1 node in z).
  dyn::Loads final_load(m.lm, m.dofs, {tip_load(A, 0.0, 2)});
  UVec F, ustat;
  MORSE_CALL(MatCreateVecs(m.ops.K.get(), F.ptr(), ustat.ptr()));
  final_load.evaluate(0.0, F.get());
  test::direct_solve(m.ops.K.get(), F.get(), ustat.get());
  const int nm = 20;
  std::vector<double> coef(nm), tipk(nm);
  const double tip_static = set_mean(m.lm, m.dofs, ustat.get(), "x1", 2);  // K^-1 F
  double tip_rest = tip_static;
  for (int k = 0; k < nm; ++k) {
    Vec phi;
    MORSE_CALL(MatDenseGetColumnVecRead(eig.V.get(), k, &phi));
    MORSE_CALL(VecDot(phi, F.get(), &coef[k]));
    tipk[k] = set_mean(m.lm, m.dofs, phi, "x1", 2);
    MORSE_CALL(MatDenseRestoreColumnVecRead(eig.V.get(), k, &phi));
    tip_rest -= coef[k] * tipk[k] / eig.omega2[k];
  }
  auto exact = [&](double t) {
    double u = tip_rest * std::min(t / T, 1.0);
    for (int k = 0; k < nm; ++k) {
      const double wk = std::sqrt(eig.omega2[k]);
      auto r = [&](double s) { return s <= 0 ? 0.0 : (s - std::sin(wk * s) / wk) / (eig.omega2[k] * T); };
      u += tipk[k] * coef[k] * (r(t) - r(t - T));
    }
    return u;
  };
  dyn::FomSettings s;
  s.linear = true;
  s.dt = T1 / 200;
  s.t_final = 2 * T;
  double err = 0, peak = 0, dyn_part = 0;
  dyn::integrate(svk, m.ops.M.get(), loads, s, nullptr, nullptr, [&](const dyn::StepInfo& i) {
    const double u = set_mean(m.lm, m.dofs, i.u, "x1", 2), e = exact(i.t);
    err = std::max(err, std::abs(u - e));
    peak = std::max(peak, std::abs(e));
    dyn_part = std::max(dyn_part, std::abs(e - tip_static * std::min(i.t / T, 1.0)));
  });
  EXPECT_GT(dyn_part, 0.05 * peak) << "the ramp is too slow to test the dynamics";
  EXPECT_LT(err, 0.01 * peak) << "max error " << err << " peak " << peak;
}

// A table sampled from A sin(W t) every T_W / n against the harmonic -load_* path (the same
// steps): the difference is the response to the interpolation error, O(dt_table^2) (ratio 4 when
// n doubles). Harmonic load plus the table at scale -1 is, by linearity, exactly the difference.
TEST(LoadHistory, SampledHarmonicConvergesToHarmonicLoad) {
  auto m = test::assembled_box(PETSC_COMM_WORLD, test::box_spec(ElementType::Hex20, 1.0, 0.1, 0.1, 6, 1, 1));
  auto mat = test::steel();
  fe::Svk svk(m.lm, m.dofs, mat, m.ops.K.get());
  eigen::EigenSettings es;
  es.nev = 1;
  es.prefix = "test_modes_";
  auto eig = eigen::solve_eigen(m.ops.K.get(), m.ops.M.get(), es, nullptr);
  const double w1 = std::sqrt(eig.omega2[0]), W = 0.6 * w1, A = 100.0, TW = 2 * M_PI / W;
  const auto tip = set_ids(m.lm, "x1");
  dyn::FomSettings s;
  s.linear = true;
  s.dt = 2 * M_PI / w1 / 160;
  s.t_final = 2 * TW;
  auto run = [&](const dyn::Loads& loads) {
    std::vector<double> u;
    dyn::integrate(svk, m.ops.M.get(), loads, s, nullptr, nullptr,
                   [&](const dyn::StepInfo& i) { u.push_back(set_mean(m.lm, m.dofs, i.u, "x1", 1)); });
    return u;
  };
  auto sampled = [&](int n) {
    std::vector<double> times;
    for (int j = 0; j <= 2 * n + 1; ++j) times.push_back(j * TW / n);
    return uniform_table(tip, times, [&](double t) { return std::vector<double>{0, A * std::sin(W * t), 0}; });
  };
  const auto harmonic = run(dyn::Loads(m.lm, m.dofs, {tip_load(A, W, 1)}));
  double peak = 0;
  for (double v : harmonic) peak = std::max(peak, std::abs(v));
  std::vector<double> errs;
  std::vector<std::vector<double>> tables;
  for (int n : {12, 24, 48}) {
    dyn::Loads tab(m.lm, m.dofs, {});
    tab.set_history(std::make_shared<dyn::LoadHistory>(m.lm, m.dofs, sampled(n)));
    auto u = run(tab);
    ASSERT_EQ(u.size(), harmonic.size());
    double e = 0;
    for (std::size_t i = 0; i < u.size(); ++i) e = std::max(e, std::abs(u[i] - harmonic[i]));
    errs.push_back(e);
    tables.push_back(std::move(u));
  }
  EXPECT_GT(peak, 0.0);
  EXPECT_LT(errs[2], 0.005 * peak) << "n = 48: " << errs[2] << " of " << peak;
  for (int j = 0; j < 2; ++j) {
    const double ratio = errs[j] / errs[j + 1];
    EXPECT_GT(ratio, 3.2) << "n = " << (12 << j) << ": errors " << errs[j] << ", " << errs[j + 1];
    EXPECT_LT(ratio, 4.8) << "n = " << (12 << j) << ": errors " << errs[j] << ", " << errs[j + 1];
  }
  dyn::Loads both(m.lm, m.dofs, {tip_load(A, W, 1)});
  both.set_history(std::make_shared<dyn::LoadHistory>(m.lm, m.dofs, sampled(24), dyn::Outside::Error, -1.0));
  const auto diff = run(both);
  double worst = 0;
  for (std::size_t i = 0; i < diff.size(); ++i)
    worst = std::max(worst, std::abs(diff[i] - (harmonic[i] - tables[1][i])));
  EXPECT_LT(worst, 1e-9 * peak);
}

// A nonlinear run under a tabulated history on one rank and on all ranks agrees to round-off.
TEST(LoadHistory, NonlinearRunIndependentOfRankCount) {
  const int rank = world_rank_of(PETSC_COMM_WORLD);
  auto run = [](MPI_Comm comm) {
    auto m = test::assembled_box(comm, test::box_spec(ElementType::Wedge15, 1.0, 0.05, 0.05, 6, 1, 1));
    auto mat = test::steel();
    fe::Svk svk(m.lm, m.dofs, mat, m.ops.K.get());
    const double P = 3.0 * mat.E * std::pow(0.05, 4) / 12.0;
    auto ids = set_ids(m.lm, "x1");
    // Unequal forces per node and a node in the middle of the beam (id of a y0 node at x > 0).
    dyn::LoadTable t;
    t.source = "rank test";
    t.time = {0.0, 1e-3, 2.5e-3, 4e-3};
    t.node_ids = ids;
    for (std::size_t i = 0; i < t.time.size(); ++i)
      for (std::size_t k = 0; k < ids.size(); ++k)
        t.forces.insert(t.forces.end(), {0.1 * P * (k % 2), P * std::sin(1e3 * t.time[i]) / (1.0 + k), 0.2 * P * i});
    dyn::Loads loads(m.lm, m.dofs, {});
    loads.set_history(std::make_shared<dyn::LoadHistory>(m.lm, m.dofs, t));
    dyn::FomSettings s;
    s.dt = 1e-4;
    s.t_final = 40 * s.dt;
    s.rayleigh_alpha = 1.0;
    std::vector<double> h;
    dyn::integrate(svk, m.ops.M.get(), loads, s, nullptr, nullptr, [&](const dyn::StepInfo& i) {
      for (int d = 0; d < 3; ++d) h.push_back(set_mean(m.lm, m.dofs, i.u, "x1", d));
      h.push_back(i.energy.strain_nonlinear);
    });
    return h;
  };
  std::vector<double> serial;
  if (rank == 0) serial = run(PETSC_COMM_SELF);
  auto all = run(PETSC_COMM_WORLD);
  std::string msg;
  if (rank == 0) {
    double energy = 0;
    msg = test::history_rank_difference(serial, all, 1e-10, &energy);
    if (!(energy > 0)) msg += "not a nonlinear test (no nonlinear strain energy); ";
  }
  EXPECT_FALSE(any_rank(PETSC_COMM_WORLD, !msg.empty())) << msg;
}
