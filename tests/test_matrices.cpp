// Assembled-operator input (io/matrices.hpp): MatrixMarket, PETSc binary and OP4 files read back
// exactly in parallel; a matrix model (with a DOF map, row sets and a clamp) gives the same
// Craig–Bampton superelement as the mesh it came from; bad input is refused with a message that
// names the file and the place.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/files.hpp"
#include "morse/core/session.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/matrices.hpp"
#include "morse/io/matrix_model.hpp"
#include "morse/io/op4.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

namespace fs = std::filesystem;

// A directory shared by the ranks of PETSC_COMM_WORLD, one per test.
class MatricesTest : public test::SharedScratchDirTest {
 protected:
  MatricesTest() : SharedScratchDirTest("matrices") {}
};

// A cantilever with a non-square section (no repeated frequencies), slightly distorted.
mesh::BoxSpec beam_spec(ElementType type) {
  auto b = test::box_spec(type, 1.0, 0.08, 0.05, 8, 2, 1);
  b.distortion = 0.05;
  return b;
}

// ||A - B||_max over all entries (0 for identical matrices). Collective.
double max_diff(Mat A, Mat B) {
  UMat D;
  MORSE_CALL(MatDuplicate(A, MAT_COPY_VALUES, D.ptr()));
  MORSE_CALL(MatAXPY(D.get(), -1.0, B, DIFFERENT_NONZERO_PATTERN));
  PetscReal n = 0;
  MORSE_CALL(MatNorm(D.get(), NORM_INFINITY, &n));
  return n;
}

// Runs f and expects a morse::Error, on every rank, whose message holds every part.
template <class F>
void expect_error(F f, std::initializer_list<std::string> parts) {
  try {
    f();
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

// The CSR of a symmetric A on rank 0 (= its CSC), for the OP4 writer.
void gather_csc(Mat A, std::vector<std::int64_t>* ptr, std::vector<std::int64_t>* idx, std::vector<double>* val) {
  UMat S;
  Mat* sub = nullptr;
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(A, &n, nullptr));
  IS is;
  MORSE_CALL(ISCreateStride(PETSC_COMM_SELF, world_rank() == 0 ? n : 0, 0, 1, &is));
  MORSE_CALL(MatCreateSubMatrices(A, 1, &is, &is, MAT_INITIAL_MATRIX, &sub));
  ptr->assign(1, 0);
  idx->clear();
  val->clear();
  if (world_rank() == 0)
    for (PetscInt i = 0; i < n; ++i) {
      PetscInt nc;
      const PetscInt* c;
      const PetscScalar* v;
      MORSE_CALL(MatGetRow(sub[0], i, &nc, &c, &v));
      for (PetscInt k = 0; k < nc; ++k) idx->push_back(c[k]), val->push_back(v[k]);
      ptr->push_back(static_cast<std::int64_t>(idx->size()));
      MORSE_CALL(MatRestoreRow(sub[0], i, &nc, &c, &v));
    }
  MORSE_CALL(MatDestroySubMatrices(1, &sub));
  MORSE_CALL(ISDestroy(&is));
}

}  // namespace

// Every format morse reads returns the matrix it was given, bit for bit, on any rank count.
TEST_F(MatricesTest, FilesRoundTripExactly) {
  auto m = test::assembled_box(PETSC_COMM_WORLD, beam_spec(ElementType::Tet10), {"x0"});
  for (Mat A0 : {m.ops.K.get(), m.ops.M.get()}) {
    // Exactly symmetric (assembly on several ranks is symmetric to round-off only).
    UMat S;
    MORSE_CALL(MatTranspose(A0, MAT_INITIAL_MATRIX, S.ptr()));
    MORSE_CALL(MatAXPY(S.get(), 1.0, A0, SAME_NONZERO_PATTERN));
    MORSE_CALL(MatScale(S.get(), 0.5));
    Mat A = S.get();
    for (auto [name, sym] : {std::pair{"a_sym.mtx", true}, {"a_gen.mm", false}, {"a.petsc", false}}) {
      io::write_matrix(A, path(name), sym);
      auto B = io::read_matrix(PETSC_COMM_WORLD, path(name), "test");
      EXPECT_EQ(max_diff(A, B.get()), 0.0) << name;
      EXPECT_FALSE(fs::exists(path(name) + ".tmp"));
      EXPECT_FALSE(fs::exists(files::temp_path(PETSC_COMM_WORLD, path(name))));
    }
    std::vector<std::int64_t> ptr, idx;
    std::vector<double> val;
    gather_csc(A, &ptr, &idx, &val);
    PetscInt n = 0;
    MORSE_CALL(MatGetSize(A, &n, nullptr));
    for (bool binary : {false, true})
      for (bool sparse : {false, true}) {
        io::Op4WriteOptions o;
        o.binary = binary;
        o.sparse = sparse;
        const std::string f = path(cat("a_", binary, sparse, ".op4"));
        if (world_rank() == 0) {
          io::write_op4(f, "MAA", n, n, ptr, idx, std::vector<double>(val.size(), 1.0), o, false);
          io::write_op4(f, "KAA", n, n, ptr, idx, val, o, true);
        }
        MPI_Barrier(PETSC_COMM_WORLD);
        auto B = io::read_matrix(PETSC_COMM_WORLD, f + ":KAA", "test");
        EXPECT_EQ(max_diff(A, B.get()), 0.0) << "binary " << binary << " sparse " << sparse;
      }
  }
}

// The superelement of the matrix model equals the one of the mesh: the matrices of an unclamped
// model, its DOF map with the face sets as row sets, and -clamp x0 -boundary x1 give the same
// boundary block, the same reduced spectrum and the same fixed-interface frequencies as
// reducing the clamped mesh directly. Rows are labeled, so the partition of the writing run does
// not matter.
TEST_F(MatricesTest, MatrixModelGivesTheMeshSuperelement) {
  const auto spec = beam_spec(ElementType::Hex20);
  cb::CBSettings cs;
  cs.boundary_set = "x1";
  cs.n_fixed = 12;
  // Reference: the mesh path.
  auto ref_model = test::assembled_box(PETSC_COMM_WORLD, spec, {"x0"});
  auto ref = cb::craig_bampton(test::model_of(ref_model), cs);
  // The free (unclamped) model written as files.
  auto free_model = test::assembled_box(PETSC_COMM_WORLD, spec, {});
  io::write_matrix(free_model.ops.K.get(), path("K.mtx"), true);
  io::write_matrix(free_model.ops.M.get(), path("M.petsc"), false);
  auto map = io::mesh_dof_map(free_model.lm, free_model.dofs);
  if (world_rank() == 0) io::write_dof_map(path("dofs.txt"), map);
  MPI_Barrier(PETSC_COMM_WORLD);

  io::MatrixInput in;
  in.K = path("K.mtx");
  in.M = path("M.petsc");
  in.dofmap = path("dofs.txt");
  in.clamp = {"x0"};
  auto mm = io::matrix_model(PETSC_COMM_WORLD, in);
  EXPECT_EQ(mm.dofs.n_global, ref_model.dofs.n_global);
  EXPECT_EQ(mm.dofs.n_global + mm.dofs.n_clamped_global, free_model.dofs.n_global);
  EXPECT_EQ(mm.asymmetry_K, 0.0);
  auto res = cb::craig_bampton(mm, cs);

  ASSERT_EQ(res.n_b, ref.n_b);
  ASSERT_EQ(res.n_phi, ref.n_phi);
  EXPECT_EQ(res.boundary_node_ids, ref.boundary_node_ids);
  EXPECT_EQ(res.boundary_dof_node, ref.boundary_dof_node);
  EXPECT_EQ(res.boundary_dof_component, ref.boundary_dof_component);
  for (PetscInt j = 0; j < res.n_phi; ++j)
    EXPECT_NEAR(res.fixed_omega2[j], ref.fixed_omega2[j], 1e-10 * ref.fixed_omega2[j]) << "mode " << j;
  // Boundary blocks (Guyan: independent of mode signs) to round-off.
  const PetscInt n = res.n();
  double kmax = 0, mmax = 0, dk = 0, dm = 0;
  for (PetscInt i = 0; i < res.n_b; ++i)
    for (PetscInt j = 0; j < res.n_b; ++j) {
      kmax = std::max(kmax, std::abs(ref.K[i * n + j]));
      mmax = std::max(mmax, std::abs(ref.M[i * n + j]));
      dk = std::max(dk, std::abs(res.K[i * n + j] - ref.K[i * n + j]));
      dm = std::max(dm, std::abs(res.M[i * n + j] - ref.M[i * n + j]));
    }
  EXPECT_LT(dk, 1e-9 * kmax);
  EXPECT_LT(dm, 1e-9 * mmax);
  // The superelement's spectrum (independent of the signs of the modes). Two eigen solves of
  // operators assembled differently agree to their tolerance (relative residual 1e-10 of the
  // shift-inverted problem), not to round-off: the fixed-interface vectors then differ by about
  // 1e-10 / (relative gap), and the Ritz values of the superelement by up to ~1e-9.
  auto wr = eigen::dense_eigenvalues(static_cast<int>(n), res.K, res.M);
  auto wf = eigen::dense_eigenvalues(static_cast<int>(n), ref.K, ref.M);
  for (PetscInt j = 0; j < n; ++j)
    EXPECT_NEAR(wr[j], wf[j], 1e-8 * std::abs(wf[j]) + 1e-6) << "superelement mode " << j;
}

// A node set given by node ids (as -mesh_node_set_NAME does) selects every row of its nodes,
// including rotations; the boundary order is node id, then component.
TEST_F(MatricesTest, NodeSetsAndRotationalComponents) {
  // A chain of 3 nodes with 2 DOFs each (component 1 and 5), springs and masses: k = 1, m = 1.
  auto K = write("k.mtx",
                 "%%MatrixMarket matrix coordinate real symmetric\n6 6 10\n"
                 "1 1 2\n2 2 2\n3 1 -1\n3 3 2\n4 2 -1\n4 4 2\n5 3 -1\n5 5 1\n6 4 -1\n6 6 1\n");
  auto M = write("m.mtx",
                 "%%MatrixMarket matrix coordinate real general\n6 6 6\n1 1 1\n2 2 1\n3 3 1\n4 4 1\n5 5 1\n6 6 1\n");
  auto map = write("map.txt", "# node component\n10 1\n10 5\n20 1\n20 5 # rotation\n30 1 tip\n30 5 tip\n");
  io::MatrixInput in;
  in.K = K;
  in.M = M;
  in.dofmap = map;
  in.node_sets = {{"end", {20, 30}}};
  auto mm = io::matrix_model(PETSC_COMM_WORLD, in);
  auto rows = fe::set_rows(mm.dofs, "end", "boundary set");
  ASSERT_EQ(rows.size(), 4u);
  const std::int64_t nodes[] = {20, 20, 30, 30};
  const int comps[] = {1, 5, 1, 5};
  const PetscInt r[] = {2, 3, 4, 5};
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(rows[k].node, nodes[k]);
    EXPECT_EQ(rows[k].component, comps[k]);
    EXPECT_EQ(rows[k].row, r[k]);
  }
  // Guyan on "tip" (nodes 30): the chain 1-2-3 in component 1 condenses to k = 1/3 at the tip
  // (three unit springs in series from the ground); the rotational chain likewise.
  cb::CBSettings cs;
  cs.boundary_set = "tip";
  cs.n_fixed = 0;
  auto res = cb::craig_bampton(mm, cs);
  ASSERT_EQ(res.n_b, 2);
  EXPECT_NEAR(res.K[0], 1.0 / 3.0, 1e-14);
  EXPECT_NEAR(res.K[3], 1.0 / 3.0, 1e-14);
  EXPECT_NEAR(res.K[1], 0.0, 1e-14);
  EXPECT_EQ(res.boundary_dof_component, (std::vector<int>{1, 5}));
}

// Bad input: each error names the file (and the line or the row) and says what is wrong.
TEST_F(MatricesTest, BadInputIsRefusedClearly) {
  auto good = write("good.mtx", "%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 2\n2 2 2\n3 3 2\n");
  auto nonsym = write("nonsym.mtx",
                      "%%MatrixMarket matrix coordinate real general\n3 3 5\n1 1 2\n2 2 2\n3 3 2\n1 2 -1\n2 1 -1.5\n");
  auto big = write("big.mtx", "%%MatrixMarket matrix coordinate real symmetric\n4 4 4\n1 1 2\n2 2 2\n3 3 2\n4 4 2\n");
  auto badline =
      write("badline.mtx", "%%MatrixMarket matrix coordinate real symmetric\n% comment\n3 3 3\n1 1 2\n2 x 2\n3 3 2\n");
  auto outside = write("outside.mtx", "%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 2\n2 2 2\n4 3 2\n");
  auto twice =
      write("twice.mtx", "%%MatrixMarket matrix coordinate real symmetric\n3 3 4\n1 1 2\n2 2 2\n3 3 2\n1 2 1\n");
  auto twice2 = write("twice2.mtx",
                      "%%MatrixMarket matrix coordinate real symmetric\n3 3 5\n1 1 2\n2 2 2\n3 3 2\n1 2 1\n2 1 1\n");
  auto complex = write("complex.mtx", "%%MatrixMarket matrix coordinate complex general\n1 1 1\n1 1 1 0\n");
  auto count = write("count.mtx", "%%MatrixMarket matrix coordinate real symmetric\n3 3 4\n1 1 2\n2 2 2\n3 3 2\n");
  auto map_long = write("long.txt", "1 1\n1 2\n1 3\n2 1\n");
  auto map_short = write("short.txt", "1 1\n1 2\n");
  auto map_dup = write("dup.txt", "1 1\n1 2\n1 1\n");
  auto map_comp = write("comp.txt", "1 1\n1 2\n1 7\n");
  const MPI_Comm w = PETSC_COMM_WORLD;
  auto model = [&](const std::string& K, const std::string& M, const std::string& map) {
    io::MatrixInput in;
    in.K = K;
    in.M = M;
    in.dofmap = map;
    io::matrix_model(w, in);
  };
  expect_error([&] { model(nonsym, good, ""); },
               {"-matrices_K", "nonsym.mtx", "not symmetric", "column 2 (node 1 component 2)"});
  expect_error([&] { model(good, big, ""); }, {"size mismatch", "good.mtx", "big.mtx", "3 x 3", "4 x 4"});
  expect_error([&] { model(good, good, map_long); }, {"long.txt:4", "row 4", "only 3 rows"});
  expect_error([&] { model(good, good, map_short); }, {"short.txt", "2 rows listed", "3"});
  expect_error([&] { model(good, good, map_dup); }, {"dup.txt", "node 1 component 1", "rows 1 and 3"});
  expect_error([&] { model(good, good, map_comp); }, {"comp.txt:3", "component '7'"});
  expect_error([&] { io::read_matrix(w, badline, "-matrices_K"); }, {"badline.mtx:5", "expected 'row column value'"});
  expect_error([&] { io::read_matrix(w, outside, "-matrices_K"); }, {"outside.mtx:5", "outside the 3 x 3"});
  expect_error([&] { io::read_matrix(w, twice2, "-matrices_K"); }, {"twice2.mtx", "(1, 2) is given twice"});
  expect_error([&] { io::read_matrix(w, complex, "-matrices_M"); }, {"-matrices_M", "complex.mtx:1", "complex"});
  expect_error([&] { io::read_matrix(w, count, "-matrices_K"); }, {"count.mtx", "announces 4 entries", "holds 3"});
  expect_error([&] { io::read_matrix(w, path("missing.mtx"), "-matrices_K"); }, {"missing.mtx", "cannot open"});
  expect_error([&] { io::read_matrix(w, path("k.txt"), "-matrices_K"); }, {"k.txt", "unknown format"});
  // Symmetric storage with the upper entry: mirrored, so it equals the general matrix.
  auto A = io::read_matrix(w, twice, "t");
  PetscInt ncols = 0;
  PetscReal norm = 0;
  MORSE_CALL(MatNorm(A.get(), NORM_1, &norm));
  MORSE_CALL(MatGetSize(A.get(), &ncols, nullptr));
  EXPECT_EQ(norm, 3.0);
  // A boundary set that is not a row set.
  io::MatrixInput in;
  in.K = good;
  in.M = good;
  in.dofmap = write("sets.txt", "1 1 a\n1 2\n1 3 a\n");
  auto mm = io::matrix_model(w, in);
  cb::CBSettings cs;
  cs.boundary_set = "b";
  cs.n_fixed = 0;
  expect_error([&] { cb::craig_bampton(mm, cs); }, {"boundary set 'b'", "sets: a"});
  in.clamp = {"nope"};
  expect_error([&] { io::matrix_model(w, in); }, {"-clamp nope", "sets: a"});
  in.clamp = {};
  in.node_sets = {{"n", {1, 2}}};
  expect_error([&] { io::matrix_model(w, in); }, {"-mesh_node_set_n", "node 2 has no row"});
}
