// Tests of the Abaqus / CalculiX deck reader (mesh/abaqus.hpp). Every rank runs the same serial
// tests on its own temporary files; the cantilever with a rigid body is read, distributed and
// solved on all ranks together.
#include <petscsys.h>
#include <gtest/gtest.h>
#include <petscblaslapack.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/session.hpp"
#include "morse/fe/element.hpp"
#include "morse/fe/model.hpp"
#include "morse/mesh/abaqus.hpp"
#include "morse/mesh/generator.hpp"
#include "morse/mesh/nastran.hpp"
#include "scratch.hpp"
#include "util.hpp"

namespace {

namespace fs = std::filesystem;
using morse::cat;
using morse::mesh::ElementType;
using morse::mesh::Mesh;
using morse::mesh::read_abaqus;

class AbaqusTest : public morse::test::ScratchDirTest {
 protected:
  AbaqusTest() : ScratchDirTest("abaqus") {}

  /// Expects read_abaqus(path) to throw a morse::Error whose message contains every part.
  static void expect_error(const std::string& path, std::initializer_list<std::string> parts) {
    morse::test::expect_error_parts([&] { read_abaqus(path, false); }, parts, path);
  }
};

std::int64_t index_of(const Mesh& m, std::int64_t id) {
  for (std::int64_t k = 0; k < m.num_nodes(); ++k)
    if (m.node_ids[k] == id) return k;
  return -1;
}

std::vector<std::int64_t> ids_of(const Mesh& m, const std::vector<std::int64_t>& idx) {
  std::vector<std::int64_t> out;
  for (std::int64_t k : idx) out.push_back(m.node_ids[k]);
  return out;
}

/// Round-trip decimal representation.
std::string full(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// ------------------------------------------------------------------------------------------------
// One element of every type

struct TypeCase {
  const char* abaqus_name;
  ElementType type;
  double ref_volume;
  std::vector<std::pair<int, int>> abaqus_edges;  // 1-based, as in the Abaqus manual
};

std::vector<TypeCase> type_cases() {
  const std::vector<std::pair<int, int>> tet{{1, 2}, {2, 3}, {3, 1}, {1, 4}, {2, 4}, {3, 4}};
  const std::vector<std::pair<int, int>> wedge{{1, 2}, {2, 3}, {3, 1}, {4, 5}, {5, 6}, {6, 4}, {1, 4}, {2, 5}, {3, 6}};
  const std::vector<std::pair<int, int>> hex{{1, 2}, {2, 3}, {3, 4}, {4, 1}, {5, 6}, {6, 7},
                                             {7, 8}, {8, 5}, {1, 5}, {2, 6}, {3, 7}, {4, 8}};
  return {{"C3D4", ElementType::Tet4, 1.0 / 6, {}}, {"C3D10", ElementType::Tet10, 1.0 / 6, tet},
          {"C3D6", ElementType::Wedge6, 1.0, {}},   {"c3d15", ElementType::Wedge15, 1.0, wedge},
          {"C3D8", ElementType::Hex8, 8.0, {}},     {"C3D20", ElementType::Hex20, 8.0, hex},
          {"C3D20R", ElementType::Hex20, 8.0, hex}};
}

// Affine map x = M xi + c with det M > 0.
constexpr double kM[3][3] = {{2.0, 0.3, 0.0}, {0.1, 3.0, 0.2}, {0.0, 0.4, 0.5}};
constexpr double kC[3] = {10.0, -5.0, 2.5};

std::array<double, 3> map_point(const std::array<double, 3>& xi) {
  std::array<double, 3> x{};
  for (int i = 0; i < 3; ++i) x[i] = kC[i] + kM[i][0] * xi[0] + kM[i][1] * xi[1] + kM[i][2] * xi[2];
  return x;
}

double det_m() {
  return kM[0][0] * (kM[1][1] * kM[2][2] - kM[1][2] * kM[2][1]) -
         kM[0][1] * (kM[1][0] * kM[2][2] - kM[1][2] * kM[2][0]) +
         kM[0][2] * (kM[1][0] * kM[2][1] - kM[1][1] * kM[2][0]);
}

TEST_F(AbaqusTest, EveryElementTypeInAbaqusOrder) {
  for (const TypeCase& tc : type_cases()) {
    SCOPED_TRACE(tc.abaqus_name);
    const ElementType t = tc.type;
    const int n = morse::mesh::nodes_per_element(t);
    const int nv = morse::mesh::vertices_per_element(t);
    const auto& ref = morse::fe::reference_nodes(t);
    ASSERT_EQ(static_cast<int>(ref.size()), n);
    ASSERT_EQ(static_cast<int>(tc.abaqus_edges.size()), n - nv);

    // Abaqus node k: vertex k, or the midpoint of its edge, in physical coordinates.
    std::vector<std::array<double, 3>> abq(n);
    for (int k = 0; k < nv; ++k) abq[k] = map_point(ref[k]);
    for (int k = nv; k < n; ++k) {
      const auto [a, b] = tc.abaqus_edges[k - nv];
      std::array<double, 3> xi{};
      for (int d = 0; d < 3; ++d) xi[d] = 0.5 * (ref[a - 1][d] + ref[b - 1][d]);
      abq[k] = map_point(xi);
    }
    // Labels are non-contiguous and decreasing; nodes are written in reverse order; the
    // connectivity wraps after 8 nodes (continuation lines).
    auto label = [&](int k) { return 1000 + 7 * (n - 1 - k); };
    std::string deck = "*NODE\n";
    for (int k = n - 1; k >= 0; --k)
      deck += cat(label(k), ", ", full(abq[k][0]), ", ", full(abq[k][1]), ", ", full(abq[k][2]), "\n");
    deck += cat("*ELEMENT, TYPE=", tc.abaqus_name, ", ELSET=E1\n42");
    for (int k = 0; k < n; ++k) deck += cat(",", (k % 8 == 7 && k + 1 < n) ? "\n" : " ", label(k));
    deck += "\n";
    const Mesh m = read_abaqus(write(cat(tc.abaqus_name, ".inp"), deck), false);

    ASSERT_EQ(m.num_nodes(), n);
    ASSERT_EQ(m.num_elements(), 1);
    EXPECT_EQ(m.elem_types[0], t);
    EXPECT_EQ(m.elem_ids[0], 42);
    EXPECT_EQ(m.elem_material[0], -1);
    ASSERT_EQ(m.elem_offsets[1], n);
    EXPECT_TRUE(m.fixed_dofs.empty());
    EXPECT_EQ(m.units, "unknown");

    // Morse node k must sit at the mapped reference node k.
    std::vector<double> xyz(3 * n), u(3 * n);
    for (int k = 0; k < n; ++k) {
      const std::int64_t node = m.elem_nodes[k];
      const auto expect = map_point(ref[k]);
      for (int d = 0; d < 3; ++d) {
        xyz[3 * k + d] = m.coords[3 * node + d];
        EXPECT_NEAR(xyz[3 * k + d], expect[d], 1e-12) << "morse node " << k << " dim " << d;
      }
    }
    EXPECT_GT(morse::fe::min_jacobian(t, xyz.data()), 0.0);
    EXPECT_NEAR(morse::fe::element_volume(t, xyz.data()), tc.ref_volume * det_m(), 1e-12);

    // Constant strain: u = A x gives eps = sym(A) at any point.
    const double A[3][3] = {{1e-3, 2e-3, -1e-3}, {4e-3, -2e-3, 3e-3}, {0.5e-3, 1e-3, 2.5e-3}};
    for (int k = 0; k < n; ++k)
      for (int i = 0; i < 3; ++i)
        u[3 * k + i] = A[i][0] * xyz[3 * k] + A[i][1] * xyz[3 * k + 1] + A[i][2] * xyz[3 * k + 2];
    const double expect[6] = {A[0][0], A[1][1], A[2][2], A[1][2] + A[2][1], A[0][2] + A[2][0], A[0][1] + A[1][0]};
    const bool tet = t == ElementType::Tet4 || t == ElementType::Tet10;
    const bool hex = t == ElementType::Hex8 || t == ElementType::Hex20;
    const double points[3][3] = {{0.25, 0.25, 0.25},
                                 {0.1, 0.2, hex ? -0.7 : 0.3},
                                 {tet ? 0.6 : 0.3, 0.1,
                                  hex   ? 0.9
                                  : tet ? 0.2
                                        : -0.8}};
    std::vector<double> B(6 * 3 * n);
    for (const auto& xi : points) {
      EXPECT_GT(morse::fe::strain_displacement(t, xyz.data(), xi, B.data()), 0.0);
      for (int r = 0; r < 6; ++r) {
        double eps = 0;
        for (int c = 0; c < 3 * n; ++c) eps += B[r * 3 * n + c] * u[c];
        EXPECT_NEAR(eps, expect[r], 1e-12) << "Voigt component " << r;
      }
    }
  }
}

// ------------------------------------------------------------------------------------------------
// Keywords and features

TEST_F(AbaqusTest, KeywordsSetsIncludesBoundaryMaterials) {
  write("sub/nodes.inp",
        "** nodes of the unit cube\n"
        "*Node, Nset=Nall\n"
        "1, 0., 0., 0.\n"
        "2, 1.0, 0, 0\r\n"  // DOS line end
        "3, 1, 1, 0\n"
        "4,0,1,0\n"
        "\n"
        "   5 ,  0.0 , 0.0 , 1.0\n"
        "6, 1.0e0, 0.0, 1.0\n"
        "7, 1, 1, 1\n"
        "8, 0, 1, 1\n"
        "*INCLUDE, INPUT=more/extra.inp\n");
  write("sub/more/extra.inp",
        "*NODE, NSET=nall\n"
        "20, 2.0, 0.0, 0.0\n"
        "*node\n"
        "99, 5.0, 5.0, 5.0\n");
  const std::string path = write("main.inp",
                                 "** test deck\n"
                                 "*Heading\n"
                                 " a title line, with a comma\n"
                                 "*include, input=sub/nodes.inp\n"
                                 "*Element, type=c3d8, elset=Bricks\n"
                                 "1, 1, 2, 3, 4, 5, 6, 7, 8\n"
                                 "* element , type = C3D4 , ELSET = tets\n"
                                 "2,\n"
                                 " 2, 20,\n"
                                 "** a comment inside a continued element\n"
                                 " 3, 6\n"
                                 "*NSET, NSET=Bottom\n"
                                 "1, 2, 3, 4,\n"
                                 "20\n"
                                 "*Nset, nset=TOP, generate\n"
                                 "5, 8, 1\n"
                                 "*NSET,NSET=both\n"
                                 "bottom, Top\n"
                                 "*nset, nset=Odd, GENERATE\n"
                                 "1, 7, 2\n"
                                 "*ELSET, ELSET=all\n"
                                 "bricks, TETS\n"
                                 "*elset, elset=Evens, GENERATE\n"
                                 "2, 2\n"
                                 "*BOUNDARY\n"
                                 "BOTTOM, 1, 3\n"
                                 "5, 2\n"
                                 "6, 1, 2, 0.0\n"
                                 "7, 3, 6\n"
                                 "8, 1, , \n"
                                 "*Boundary\n"
                                 "top, XSYMM\n"
                                 "*SOLID SECTION, ELSET=Bricks, MATERIAL=Steel\n"
                                 "*solid section,elset=TETS,material=ALU\n"
                                 "1.0\n"
                                 "*Material, Name=steel\n"
                                 "*Elastic\n"
                                 " 210000., 0.3, 20.\n"
                                 " 200000., 0.3, 400.\n"
                                 "*EXPANSION\n"
                                 "1.2e-5\n"
                                 "*DENSITY\n"
                                 "7.85e-9, 20.\n"
                                 "*material, name=Alu\n"
                                 "*elastic, type=iso\n"
                                 "70e3, 0.33\n"
                                 "*density\n"
                                 "2.7D-9\n"
                                 "*STEP\n"
                                 "*STATIC\n"
                                 "*NODE PRINT, NSET=Nall\n"
                                 "U\n"
                                 "*END STEP\n"
                                 "*Step, perturbation\n"
                                 "*FREQUENCY, SOLVER=MATRIXSTORAGE, GLOBAL=YES,\n"
                                 "10\n"
                                 "*node print\n"
                                 "U\n"
                                 "*End Step\n");

  ::testing::internal::CaptureStderr();
  const Mesh m = read_abaqus(path);
  const std::string log = ::testing::internal::GetCapturedStderr();

  EXPECT_EQ(m.source, path);
  EXPECT_EQ(m.units, "unknown");
  ASSERT_EQ(m.num_nodes(), 10);
  EXPECT_EQ(m.node_ids, (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8, 20, 99}));
  EXPECT_EQ(m.coords[3 * 4 + 2], 1.0);
  EXPECT_EQ(m.coords[3 * 8 + 0], 2.0);

  ASSERT_EQ(m.num_elements(), 2);
  EXPECT_EQ(m.elem_types[0], ElementType::Hex8);
  EXPECT_EQ(m.elem_types[1], ElementType::Tet4);
  EXPECT_EQ(m.elem_ids, (std::vector<std::int64_t>{1, 2}));
  EXPECT_EQ(ids_of(m, {m.elem_nodes.begin() + 8, m.elem_nodes.end()}), (std::vector<std::int64_t>{2, 20, 3, 6}));
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    std::vector<double> xyz;
    for (auto k = m.elem_offsets[e]; k < m.elem_offsets[e + 1]; ++k)
      for (int d = 0; d < 3; ++d) xyz.push_back(m.coords[3 * m.elem_nodes[k] + d]);
    EXPECT_NEAR(morse::fe::element_volume(m.elem_types[e], xyz.data()), e == 0 ? 1.0 : 1.0 / 6, 1e-14);
  }

  // Sets: names as first written, indices sorted.
  ASSERT_EQ(m.node_sets.size(), 5u);
  EXPECT_EQ(ids_of(m, m.node_sets.at("Nall")), (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8, 20}));
  EXPECT_EQ(ids_of(m, m.node_sets.at("Bottom")), (std::vector<std::int64_t>{1, 2, 3, 4, 20}));
  EXPECT_EQ(ids_of(m, m.node_sets.at("TOP")), (std::vector<std::int64_t>{5, 6, 7, 8}));
  EXPECT_EQ(ids_of(m, m.node_sets.at("both")), (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8, 20}));
  EXPECT_EQ(ids_of(m, m.node_sets.at("Odd")), (std::vector<std::int64_t>{1, 3, 5, 7}));
  ASSERT_EQ(m.elem_sets.size(), 4u);
  EXPECT_EQ(m.elem_sets.at("Bricks"), (std::vector<std::int64_t>{0}));
  EXPECT_EQ(m.elem_sets.at("tets"), (std::vector<std::int64_t>{1}));
  EXPECT_EQ(m.elem_sets.at("all"), (std::vector<std::int64_t>{0, 1}));
  EXPECT_EQ(m.elem_sets.at("Evens"), (std::vector<std::int64_t>{1}));

  // *BOUNDARY: bottom xyz; 5: y + x (XSYMM on TOP); 6: x y; 7: z + x; 8: x; 99: free.
  ASSERT_EQ(m.fixed_dofs.size(), 10u);
  const std::vector<std::pair<std::int64_t, int>> fixed = {{1, 7}, {2, 7}, {3, 7}, {4, 7},  {5, 3},
                                                           {6, 3}, {7, 5}, {8, 1}, {20, 7}, {99, 0}};
  // (bits 3-5, the rotations of XSYMM and friends, count for six-DOF points only)
  for (const auto& [id, mask] : fixed) EXPECT_EQ(m.fixed_dofs[index_of(m, id)] & 7, mask) << id;

  // Materials: in order of definition; first temperature line; sections resolved afterwards.
  ASSERT_EQ(m.materials.size(), 2u);
  EXPECT_EQ(m.materials[0].name, "steel");
  EXPECT_EQ(m.materials[0].E, 210000.0);
  EXPECT_EQ(m.materials[0].nu, 0.3);
  EXPECT_EQ(m.materials[0].rho, 7.85e-9);
  EXPECT_EQ(m.materials[1].name, "Alu");
  EXPECT_EQ(m.materials[1].E, 70e3);
  EXPECT_EQ(m.materials[1].nu, 0.33);
  EXPECT_EQ(m.materials[1].rho, 2.7e-9);
  EXPECT_EQ(m.elem_material, (std::vector<int>{0, 1}));

  // Notices: one per distinct ignored keyword, plus temperature and rotational DOFs.
  EXPECT_EQ(count(log, "*STEP"), 1) << log;
  EXPECT_EQ(count(log, "*END STEP"), 1) << log;
  EXPECT_EQ(count(log, "*NODE PRINT"), 1) << log;
  EXPECT_EQ(count(log, "*HEADING"), 1) << log;
  EXPECT_EQ(count(log, "*FREQUENCY"), 1) << log;
  EXPECT_EQ(count(log, "*EXPANSION"), 1) << log;
  EXPECT_EQ(count(log, "temperature"), 1) << log;
  EXPECT_EQ(count(log, "DOFs 4-6 (rotations) act on six-DOF points only"), 1) << log;

  // verbose = false: silent.
  ::testing::internal::CaptureStderr();
  read_abaqus(path, false);
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST_F(AbaqusTest, InputParameterAndTextualInclude) {
  // INPUT= on *NODE / *ELEMENT reads data lines from a file; an *INCLUDE placed among data lines
  // continues the keyword in force.
  write("data/nodes.txt", "1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n");
  write("data/more_nodes.txt", "4, 0, 0, 1\n");
  write("data/elems.txt", "10, 1, 2, 3, 4\n");
  const std::string path = write("deck.inp",
                                 "*NODE, INPUT=data/nodes.txt\n"
                                 "*INCLUDE, INPUT=data/more_nodes.txt\n"
                                 "*ELEMENT, TYPE=C3D4, INPUT=data/elems.txt, ELSET=EALL\n"
                                 "*BOUNDARY\n"
                                 "1, ENCASTRE\n"
                                 "2, PINNED\n"
                                 "3, ZSYMM\n");
  const Mesh m = read_abaqus(path, false);
  EXPECT_EQ(m.num_nodes(), 4);
  ASSERT_EQ(m.num_elements(), 1);
  EXPECT_EQ(m.elem_ids[0], 10);
  EXPECT_EQ(m.elem_sets.at("EALL"), (std::vector<std::int64_t>{0}));
  // Translations (ENCASTRE and ZSYMM also set the rotation bits 3-5, which only points use).
  EXPECT_EQ(m.fixed_dofs, (std::vector<std::uint8_t>{63, 7, 28, 0}));
}

TEST_F(AbaqusTest, RotationsOnlyBoundaryFixesNoTranslation) {
  const std::string path = write("deck.inp",
                                 "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n"
                                 "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n"
                                 "*BOUNDARY\n1, 4, 6");  // rotations only; no final newline
  const Mesh m = read_abaqus(path, false);
  // No translation is fixed (rotation bits count for six-DOF points only).
  EXPECT_TRUE(std::all_of(m.fixed_dofs.begin(), m.fixed_dofs.end(), [](std::uint8_t f) { return (f & 7) == 0; }));
  EXPECT_TRUE(m.node_sets.empty());
  EXPECT_TRUE(m.elem_sets.empty());
  EXPECT_TRUE(m.materials.empty());
}

// ------------------------------------------------------------------------------------------------
// Errors: every message names the file and line

const char* const kTet = "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n";  // lines 1-5

TEST_F(AbaqusTest, ErrorMissingFiles) {
  expect_error((dir_ / "nowhere.inp").string(), {"nowhere.inp", "cannot read"});
  const std::string path = write("main.inp", "** c\n*HEADING\n*INCLUDE, INPUT=sub/nope.inp\n");
  expect_error(path, {"main.inp:3:", "sub/nope.inp"});
  // A missing file included from an included file names the inner file.
  write("a/inner.inp", "*NODE\n1, 0, 0, 0\n*INCLUDE, INPUT=gone.inp\n");
  expect_error(write("outer.inp", "*INCLUDE, INPUT=a/inner.inp\n"), {"a/inner.inp:3:", "a/gone.inp"});
}

TEST_F(AbaqusTest, ErrorUnknownElementType) {
  expect_error(write("deck.inp", cat(kTet, "*ELEMENT, TYPE=C3D8R\n1, 1, 2, 3, 4, 1, 2, 3, 4\n")),
               {"deck.inp:6:", "C3D8R"});
  expect_error(write("deck2.inp", cat(kTet, "*ELEMENT\n1, 1, 2, 3, 4\n")), {"deck2.inp:6:", "TYPE"});
}

TEST_F(AbaqusTest, ErrorUndefinedNode) {
  expect_error(write("deck.inp", cat(kTet, "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n7, 1, 2, 3,\n", "99\n")),
               {"deck.inp:8:", "element 7", "undefined node 99"});
  expect_error(write("deck2.inp", cat(kTet, "*NSET, NSET=S\n1, 2\n5\n")), {"deck2.inp:8:", "'S'", "undefined node 5"});
  expect_error(write("deck3.inp", cat(kTet, "*BOUNDARY\n1, 1\n6, 1\n")), {"deck3.inp:8:", "undefined node 6"});
}

TEST_F(AbaqusTest, ErrorTruncatedAndMalformedLines) {
  // Element continued past the end of the file.
  expect_error(write("eof.inp", cat(kTet, "*ELEMENT, TYPE=C3D10\n1, 1, 2, 3, 4, 1,\n")),
               {"eof.inp:7:", "element 1", "truncated"});
  // Element continued into the next keyword.
  expect_error(write("kw.inp", cat(kTet, "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3\n*NSET, NSET=A\n1\n")),
               {"kw.inp:7:", "element 1", "truncated"});
  expect_error(write("many.inp", cat(kTet, "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4, 1\n")), {"many.inp:7:", "more than 4"});
  expect_error(write("nan.inp", "*NODE\n1, 0.0, 0.0, 0.0\n2, 0.0, abc, 0\n"), {"nan.inp:3:", "'abc'"});
  expect_error(write("short.inp", "*NODE\n1, 0.0, 0.0\n"), {"short.inp:2:", "label, x, y, z"});
  expect_error(write("label.inp", cat(kTet, "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3x, 4\n")), {"label.inp:7:", "'3x'"});
  expect_error(write("dup.inp", cat(kTet, "2, 5, 5, 5\n")), {"dup.inp:6:", "node 2"});
  expect_error(write("gen.inp", cat(kTet, "*NSET, NSET=A, GENERATE\n4, 1\n")), {"gen.inp:7:", "GENERATE"});
  expect_error(write("data.inp", "1, 2, 3\n"), {"data.inp:1:", "before the first keyword"});
}

TEST_F(AbaqusTest, ErrorUndefinedSetsAndMaterials) {
  const std::string base = cat(kTet, "*ELEMENT, TYPE=C3D4, ELSET=E\n1, 1, 2, 3, 4\n");  // 1-7
  expect_error(write("bc.inp", cat(base, "*BOUNDARY\n1, 1, 3\nFixed, 1, 3\n")),
               {"bc.inp:10:", "undefined node set 'Fixed'"});
  expect_error(write("nested.inp", cat(base, "*NSET, NSET=A\n1, B\n")), {"nested.inp:9:", "undefined node set 'B'"});
  expect_error(write("sec.inp", cat(base, "*SOLID SECTION, ELSET=Other, MATERIAL=M\n")),
               {"sec.inp:8:", "undefined element set 'Other'"});
  expect_error(write("mat.inp", cat(base, "*SOLID SECTION, ELSET=e, MATERIAL=Steel\n",
                                    "*MATERIAL, NAME=Alu\n*ELASTIC\n7e4, 0.3\n")),
               {"mat.inp:8:", "undefined material 'Steel'"});
  expect_error(write("bcval.inp", cat(base, "*BOUNDARY\n1, 1, 3, 0.5\n")),
               {"bcval.inp:9:", "nonzero prescribed displacement"});
  expect_error(write("ela.inp", cat(base, "*ELASTIC\n7e4, 0.3\n")), {"ela.inp:8:", "outside a *MATERIAL"});
  expect_error(write("aniso.inp", cat(base, "*MATERIAL, NAME=A\n*ELASTIC, TYPE=ORTHO\n1,2,3\n")),
               {"aniso.inp:9:", "ORTHO"});
  // An error inside an included file names that file.
  write("inc/bad.inp", "*BOUNDARY\n\n1, 1, 2, 1.0\n");
  expect_error(write("inc.inp", cat(base, "*INCLUDE, INPUT=inc/bad.inp\n")), {"inc/bad.inp:3:"});
}

// ------------------------------------------------------------------------------------------------
// Constraints: *EQUATION, *RIGID BODY, *COUPLING with *KINEMATIC / *DISTRIBUTING, *SURFACE

// A unit cube (nodes 1-8, element 1 in set BRICK) and a node 100 that no element uses: lines 1-13.
const char* const kCube =
    "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 1, 1, 0\n4, 0, 1, 0\n5, 0, 0, 1\n6, 1, 0, 1\n7, 1, 1, 1\n8, 0, 1, 1\n"
    "*ELEMENT, TYPE=C3D8, ELSET=BRICK\n1, 1, 2, 3, 4, 5, 6, 7, 8\n*NODE\n100, 0.5, 0.5, 2.0\n";

using morse::mesh::Term;

void expect_terms(const morse::mesh::LinearConstraint& c, const std::vector<Term>& terms) {
  ASSERT_EQ(c.terms.size(), terms.size()) << c.where;
  for (std::size_t k = 0; k < terms.size(); ++k) {
    EXPECT_EQ(c.terms[k].node, terms[k].node) << c.where << " term " << k;
    EXPECT_EQ(c.terms[k].component, terms[k].component) << c.where << " term " << k;
    EXPECT_EQ(c.terms[k].coefficient, terms[k].coefficient) << c.where << " term " << k;
  }
}

TEST_F(AbaqusTest, Equations) {
  // Three terms over two lines (a trailing comma); two equations in one block; node-set terms
  // (sets defined further down) matched in ascending order, a single node in every equation.
  const std::string path = write("deck.inp", cat(kCube,
                                                 "*EQUATION\n"                // 14
                                                 "3\n"                        // 15
                                                 "5, 3, 2.0, 6, 3, -1.0,\n"   // 16
                                                 "7, 1, 0.5\n"                // 17
                                                 "2\n"                        // 18
                                                 "8, 2, 1., 100, 4, -0.25\n"  // 19
                                                 "*Equation\n"                // 20
                                                 "3\n"                        // 21
                                                 "A, 1, 1.0, b, 1, -1.0\n"    // 22
                                                 "100, 1, -1.5D0\n"           // 23
                                                 "*NSET, NSET=A\n6, 5\n*NSET, NSET=B\n8\n7\n"));
  const Mesh m = read_abaqus(path, false);
  const auto& cs = m.constraints;
  EXPECT_TRUE(cs.rigid.empty());
  EXPECT_TRUE(cs.interpolation.empty());
  ASSERT_EQ(cs.linear.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(cs.linear[i].id, static_cast<std::int64_t>(i) + 1);
  EXPECT_EQ(cs.linear[0].where, path + ":15: *EQUATION");
  expect_terms(cs.linear[0], {{5, 3, 2.0}, {6, 3, -1.0}, {7, 1, 0.5}});
  EXPECT_EQ(cs.linear[1].where, path + ":18: *EQUATION");
  expect_terms(cs.linear[1], {{8, 2, 1.0}, {100, 4, -0.25}});
  EXPECT_EQ(cs.linear[2].where, path + ":21: *EQUATION");
  expect_terms(cs.linear[2], {{5, 1, 1.0}, {7, 1, -1.0}, {100, 1, -1.5}});
  EXPECT_EQ(cs.linear[3].where, path + ":21: *EQUATION");
  expect_terms(cs.linear[3], {{6, 1, 1.0}, {8, 1, -1.0}, {100, 1, -1.5}});
  // The reference node stays an ordinary node of the serial mesh.
  EXPECT_EQ(m.num_nodes(), 9);
  EXPECT_EQ(index_of(m, 100), 8);
}

TEST_F(AbaqusTest, RigidBodies) {
  const std::string path = write("deck.inp", cat(kCube,
                                                 "*RIGID BODY, NSET=Top, REF NODE=100\n"  // 14
                                                 "*NSET, NSET=TOP\n8, 7, 6, 5, 7\n"
                                                 "*NODE, NSET=REF2\n101, 0.5, 0.5, -1.0\n"  // 17-18
                                                 "*Rigid Body, ref node=REF2, tie nset=Bottom, pin nset=Pins\n"  // 19
                                                 "*NSET, NSET=Bottom\n2, 1\n*NSET, NSET=Pins\n3, 4\n"
                                                 "*NODE\n102, 2, 2, 2\n"
                                                 "*RIGID BODY, ELSET=brick, REF NODE=102, ISOTHERMAL=YES\n"));  // 26
  const Mesh m = read_abaqus(path, false);
  const auto& rs = m.constraints.rigid;
  ASSERT_EQ(rs.size(), 4u);
  const std::vector<std::int64_t> ids{1, 2, 3, 4}, refs{100, 101, 101, 102};
  const std::vector<int> masks{63, 63, 7, 63};
  const std::vector<std::string> wheres{":14: *RIGID BODY", ":19: *RIGID BODY", ":19: *RIGID BODY (PIN NSET)",
                                        ":26: *RIGID BODY"};
  const std::vector<std::vector<std::int64_t>> dependent{{5, 6, 7, 8}, {1, 2}, {3, 4}, {1, 2, 3, 4, 5, 6, 7, 8}};
  for (std::size_t i = 0; i < rs.size(); ++i) {
    EXPECT_EQ(rs[i].id, ids[i]);
    EXPECT_EQ(rs[i].where, path + wheres[i]);
    EXPECT_EQ(rs[i].reference, refs[i]);
    EXPECT_EQ(rs[i].components, masks[i]);
    EXPECT_EQ(rs[i].dependent, dependent[i]);
  }
  EXPECT_TRUE(m.constraints.linear.empty());
  EXPECT_TRUE(m.constraints.interpolation.empty());
}

TEST_F(AbaqusTest, Couplings) {
  const std::string path = write("deck.inp", cat(kCube,
                                                 "*NODE\n101, 0.5, 0.5, -1.0\n102, 2, 0.5, 0.5\n"  // 14-16
                                                 "*SURFACE, NAME=TopSurf, TYPE=NODE\n"             // 17
                                                 "TOP\n"                                           // 18
                                                 "*COUPLING, CONSTRAINT NAME=C1, REF NODE=100, SURFACE=topsurf\n"  // 19
                                                 "*KINEMATIC\n"                                                    // 20
                                                 "1, 3\n"                                                          // 21
                                                 "*Coupling, ref node=101, surface=BOT, constraint name=C2\n"      // 22
                                                 "*Distributing, weighting method=UNIFORM\n"                       // 23
                                                 "*Surface, name=Bot, type=node\n"                                 // 24
                                                 "1, 2.5\n"
                                                 "2\n"
                                                 "BOTH, 0.5\n"
                                                 "*NSET, NSET=TOP\n5, 6, 7, 8\n"
                                                 "*NSET, NSET=BOTH\n3, 4\n"
                                                 "*SURFACE, NAME=Faces\nBRICK, S1\n"       // 32-33
                                                 "*COUPLING, REF NODE=102, SURFACE=Bot\n"  // 34
                                                 "*DISTRIBUTING\n"                         // 35
                                                 "4, 6\n"
                                                 "1\n"));
  ::testing::internal::CaptureStderr();
  const Mesh m = read_abaqus(path);
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(count(log, "TYPE=ELEMENT"), 1) << log;  // the element surface is skipped, with a notice
  const auto& cs = m.constraints;
  ASSERT_EQ(cs.rigid.size(), 1u);
  EXPECT_EQ(cs.rigid[0].id, 1);
  EXPECT_EQ(cs.rigid[0].where, path + ":19: *COUPLING C1");
  EXPECT_EQ(cs.rigid[0].reference, 100);
  EXPECT_EQ(cs.rigid[0].components, 7);
  EXPECT_EQ(cs.rigid[0].dependent, (std::vector<std::int64_t>{5, 6, 7, 8}));
  ASSERT_EQ(cs.interpolation.size(), 2u);
  const auto& d = cs.interpolation[0];
  EXPECT_EQ(d.id, 1);
  EXPECT_EQ(d.where, path + ":22: *COUPLING C2");
  EXPECT_EQ(d.reference, 101);
  EXPECT_EQ(d.ref_components, 63);
  EXPECT_EQ(d.nodes, (std::vector<std::int64_t>{1, 2, 3, 4}));
  EXPECT_EQ(d.weights, (std::vector<double>{2.5, 1.0, 0.5, 0.5}));
  EXPECT_EQ(d.node_components, (std::vector<std::uint8_t>{7, 7, 7, 7}));
  const auto& d2 = cs.interpolation[1];
  EXPECT_EQ(d2.id, 2);
  EXPECT_EQ(d2.where, path + ":34: *COUPLING");
  EXPECT_EQ(d2.reference, 102);
  EXPECT_EQ(d2.ref_components, 1 | 8 | 16 | 32);
  EXPECT_EQ(d2.nodes, d.nodes);
  EXPECT_EQ(d2.weights, d.weights);
  EXPECT_TRUE(cs.linear.empty());
  EXPECT_TRUE(m.node_sets.count("TopSurf") == 0 && m.node_sets.count("Bot") == 0);  // surfaces are no node sets
}

TEST_F(AbaqusTest, ErrorsInConstraints) {
  // *EQUATION (lines 14-16).
  expect_error(write("zero.inp", cat(kCube, "*EQUATION\n2\n5, 3, 0., 6, 3, 1.\n")),
               {"zero.inp:16:", "first coefficient", "node 5 DOF 3", "is 0"});
  expect_error(write("node.inp", cat(kCube, "*EQUATION\n2\n5, 3, 1., 66, 3, 1.\n")),
               {"node.inp:16:", "*EQUATION references undefined node 66"});
  expect_error(write("set.inp", cat(kCube, "*EQUATION\n2\n5, 3, 1.\nNOPE, 3, 1.\n")),
               {"set.inp:17:", "*EQUATION references undefined node set 'NOPE'"});
  expect_error(write("short.inp", cat(kCube, "*EQUATION\n3\n5, 3, 1., 6, 3, 1.\n*NSET, NSET=A\n1\n")),
               {"short.inp:15:", "2 of its 3 terms", "short.inp:17)"});
  expect_error(write("long.inp", cat(kCube, "*EQUATION\n1\n5, 3, 1., 6, 3, 1.\n")),
               {"long.inp:16:", "more terms than the 1"});
  expect_error(write("dof.inp", cat(kCube, "*EQUATION\n2\n5, 11, 1., 6, 3, 1.\n")), {"dof.inp:16:", "DOF 11"});
  expect_error(
      write("sizes.inp", cat(kCube, "*NSET, NSET=A\n1, 2\n*NSET, NSET=B\n3\n*EQUATION\n2\nA, 1, 1., B, 1, -1.\n")),
      {"sizes.inp:20:", "node set 'B' has 1 nodes and 'A' has 2"});
  // *RIGID BODY (line 14).
  expect_error(write("rot.inp", cat(kCube, "*RIGID BODY, NSET=BRICK, REF NODE=100, ROT NODE=101\n")),
               {"rot.inp:14:", "ROT NODE=101 is not supported"});
  expect_error(write("ref.inp", cat(kCube, "*NSET, NSET=S\n1\n*RIGID BODY, NSET=S, REF NODE=77\n")),
               {"ref.inp:16:", "*RIGID BODY references undefined node 77"});
  expect_error(write("rset.inp", cat(kCube, "*RIGID BODY, NSET=Nope, REF NODE=100\n")),
               {"rset.inp:14:", "undefined node set 'Nope'"});
  expect_error(write("refset.inp", cat(kCube, "*NSET, NSET=R\n1, 2\n*RIGID BODY, NSET=R, REF NODE=R\n")),
               {"refset.inp:16:", "node set of 2 nodes"});
  expect_error(
      write("pos.inp", cat(kCube, "*NSET, NSET=S\n1\n*RIGID BODY, NSET=S, REF NODE=100, POSITION=CENTER OF MASS\n")),
      {"pos.inp:16:", "POSITION is not supported"});
  expect_error(
      write("both.inp", cat(kCube, "*NSET, NSET=S\n1, 2\n*RIGID BODY, TIE NSET=S, PIN NSET=S, REF NODE=100\n")),
      {"both.inp:16:", "node 1 is both tied"});
  expect_error(write("rdata.inp", cat(kCube, "*NSET, NSET=S\n1\n*RIGID BODY, NSET=S, REF NODE=100\n1, 2\n")),
               {"rdata.inp:17:", "*RIGID BODY takes no data lines"});
  // *COUPLING and *SURFACE (lines 14-).
  const std::string surf = cat(kCube, "*SURFACE, NAME=S, TYPE=NODE\n1\n2\n");  // 14-16
  expect_error(write("elsurf.inp",
                     cat(kCube, "*SURFACE, NAME=S\nBRICK, S1\n*COUPLING, REF NODE=100, SURFACE=s\n", "*KINEMATIC\n")),
               {"elsurf.inp:16:", "surface 'S' (", "elsurf.inp:14) is not node-based (TYPE=ELEMENT)", "TYPE=NODE"});
  expect_error(
      write("weight.inp", cat(surf, "*COUPLING, REF NODE=100, SURFACE=S\n*DISTRIBUTING, WEIGHTING METHOD=CUBIC\n")),
      {"weight.inp:18:", "WEIGHTING METHOD=CUBIC is not supported"});
  expect_error(write("nosurf.inp", cat(surf, "*COUPLING, REF NODE=100, SURFACE=T\n*KINEMATIC\n")),
               {"nosurf.inp:17:", "undefined surface 'T'"});
  expect_error(
      write("snode.inp",
            cat(kCube, "*SURFACE, NAME=S, TYPE=NODE\n1\n55, 2.\n*COUPLING, REF NODE=100, SURFACE=S\n", "*KINEMATIC\n")),
      {"snode.inp:16:", "*SURFACE S references undefined node 55"});
  expect_error(write("alone.inp", cat(surf, "*COUPLING, REF NODE=100, SURFACE=S\n*NSET, NSET=A\n1\n")),
               {"alone.inp:17:", "must be followed by *KINEMATIC or *DISTRIBUTING", "alone.inp:18)"});
  expect_error(write("eof.inp", cat(surf, "*COUPLING, REF NODE=100, SURFACE=S\n")),
               {"eof.inp:17:", "must be followed by *KINEMATIC or *DISTRIBUTING", "end of the deck"});
  expect_error(write("kin.inp", cat(surf, "*KINEMATIC\n")), {"kin.inp:17:", "must directly follow a *COUPLING"});
  expect_error(write("kdof.inp", cat(surf, "*COUPLING, REF NODE=100, SURFACE=S\n*KINEMATIC\n3, 7\n")),
               {"kdof.inp:19:", "invalid DOF range 3..7"});
  expect_error(write("orient.inp", cat(surf, "*COUPLING, REF NODE=100, SURFACE=S, ORIENTATION=OR1\n*KINEMATIC\n")),
               {"orient.inp:17:", "ORIENTATION=OR1 is not supported"});
  expect_error(
      write("struct.inp", cat(surf, "*COUPLING, REF NODE=100, SURFACE=S\n*DISTRIBUTING, COUPLING=STRUCTURAL\n")),
      {"struct.inp:18:", "COUPLING=STRUCTURAL is not supported"});
  expect_error(write("twice.inp", cat(surf, "*NSET, NSET=NS\n1, 2\n*SURFACE, NAME=T, TYPE=NODE\n1, 2.\nNS\n",
                                      "*COUPLING, REF NODE=100, SURFACE=T\n*DISTRIBUTING\n")),
               {"twice.inp:21:", "*SURFACE T: node 1 has the weight 1 here and 2 at", "twice.inp:20"});
  // Unused surfaces are not resolved; a used one is, wherever its members are.
  EXPECT_NO_THROW(read_abaqus(write("unused.inp", cat(kCube, "*SURFACE, NAME=S, TYPE=NODE\n55\n")), false));
}

// ------------------------------------------------------------------------------------------------
// End to end: a cantilever with a rigid body at its tip, from .inp and from .bdf (RBE2)

class AbaqusModelTest : public morse::test::SharedScratchDirTest {
 protected:
  AbaqusModelTest() : SharedScratchDirTest("abaqus_model") {}
};

TEST_F(AbaqusModelTest, RigidBodyCantileverMatchesNastranRbe2) {
  // Hex8 box 1 x 0.1 x 0.1 (8 x 2 x 2), clamped at x = 0; node 9001 beyond the tip, tied to the
  // 9 tip-face nodes: *RIGID BODY, and *COUPLING + *KINEMATIC, against RBE2 123456.
  Mesh box = morse::mesh::generate_box(morse::test::box_spec(ElementType::Hex8, 1.0, 0.1, 0.1, 8, 2, 2));
  const double xr[3] = {1.05, 0.05, 0.05};
  const auto steel = morse::test::steel();
  std::vector<std::int64_t> root, tip;
  for (auto k : box.node_sets.at("x0")) root.push_back(box.node_ids[k]);
  for (auto k : box.node_sets.at("x1")) tip.push_back(box.node_ids[k]);
  ASSERT_EQ(tip.size(), 9u);

  std::string inp = "*NODE\n";
  for (std::int64_t k = 0; k < box.num_nodes(); ++k)
    inp += cat(box.node_ids[k], ", ", full(box.coords[3 * k]), ", ", full(box.coords[3 * k + 1]), ", ",
               full(box.coords[3 * k + 2]), "\n");
  inp += cat("9001, ", full(xr[0]), ", ", full(xr[1]), ", ", full(xr[2]), "\n*ELEMENT, TYPE=C3D8, ELSET=EALL\n");
  for (std::int64_t e = 0; e < box.num_elements(); ++e) {
    inp += cat(box.elem_ids[e]);
    for (auto k = box.elem_offsets[e]; k < box.elem_offsets[e + 1]; ++k)
      inp += cat(", ", box.node_ids[box.elem_nodes[k]]);
    inp += "\n";
  }
  inp += cat("*MATERIAL, NAME=STEEL\n*ELASTIC\n", full(steel.E), ", ", full(steel.nu), "\n*DENSITY\n", full(steel.rho),
             "\n*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL\n*NSET, NSET=ROOT\n");
  for (auto id : root) inp += cat(id, "\n");
  inp += "*NSET, NSET=TIP\n";
  for (auto id : tip) inp += cat(id, ",\n");
  inp += "*BOUNDARY\nROOT, 1, 3\n";
  const std::string rigid_inp = write("rigid.inp", inp + "*RIGID BODY, NSET=TIP, REF NODE=9001\n");
  const std::string kinematic_inp = write("kinematic.inp", inp +
                                                               "*SURFACE, NAME=TIPS, TYPE=NODE\nTIP\n"
                                                               "*COUPLING, CONSTRAINT NAME=TIE, REF NODE=9001, "
                                                               "SURFACE=TIPS\n*KINEMATIC\n");

  // The Nastran deck: write_nastran (free field, exact) plus an RBE2 before ENDDATA.
  box.add_node(9001, xr[0], xr[1], xr[2]);
  box.materials = {steel};
  box.elem_material.assign(static_cast<std::size_t>(box.num_elements()), 0);
  box.fixed_dofs.assign(static_cast<std::size_t>(box.num_nodes()), 0);
  for (auto k : box.node_sets.at("x0")) box.fixed_dofs[k] = 7;
  box.node_sets.clear();
  std::string bdf;
  if (morse::world_rank() == 0) {
    morse::mesh::NastranWriteOptions o;
    o.format = morse::mesh::NastranWriteOptions::Format::Free;
    const std::string plain = path("plain.bdf");
    morse::mesh::write_nastran(box, plain, o);
    std::ifstream in(plain);
    bdf.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    std::string rbe2 = "RBE2,9999,9001,123456";
    for (std::size_t i = 0; i < tip.size(); ++i) rbe2 += cat(i == 5 ? "\n," : ",", tip[i]);
    const auto at = bdf.find("ENDDATA");
    EXPECT_NE(at, std::string::npos);
    if (at != std::string::npos) bdf.insert(at, rbe2 + "\n");
  }
  const std::string rbe2_bdf = write("rbe2.bdf", bdf);

  auto model = [&](const std::string& file) {
    morse::fe::MeshInput in;
    in.path = file;
    in.clamp = {"*BOUNDARY"};
    in.material = steel;
    return morse::fe::mesh_model(PETSC_COMM_WORLD, in);
  };
  auto ref = model(rbe2_bdf);
  ASSERT_TRUE(ref.constraints);
  const auto wr = morse::test::lowest_eigenvalues(ref.K.get(), ref.M.get(), 6);
  {
    // Without the rigid tip face the box is softer.
    auto plain = model(path("plain.bdf"));
    EXPECT_FALSE(plain.constraints);
    const auto wp = morse::test::lowest_eigenvalues(plain.K.get(), plain.M.get(), 6);
    // The rigid tip face matters (1e-6 in bending, 1e-4 in the sixth mode), far above the
    // tolerance of the comparison below.
    EXPECT_GT(wr[0] - wp[0], 1e-7 * wr[0]);
    EXPECT_GT(wr[5] - wp[5], 1e-5 * wr[5]);
  }
  for (const std::string& file : {rigid_inp, kinematic_inp}) {
    SCOPED_TRACE(file);
    auto md = model(file);
    ASSERT_TRUE(md.constraints);
    EXPECT_EQ(md.constraints->n_point_dofs, 6);
    EXPECT_EQ(md.constraints->n_dependent, ref.constraints->n_dependent);
    EXPECT_EQ(md.dofs.n_global, ref.dofs.n_global);
    EXPECT_NEAR(md.mass, ref.mass, 1e-14 * ref.mass);
    const auto w = morse::test::lowest_eigenvalues(md.K.get(), md.M.get(), 6);
    for (int i = 0; i < 6; ++i) {
      EXPECT_GT(wr[i], 0.0);
      EXPECT_NEAR(w[i], wr[i], 1e-10 * wr[i]) << "mode " << i + 1;
    }
  }
}

// ------------------------------------------------------------------------------------------------
// The real rotor 37 blade deck (CalculiX, C3D15), if the shared data directory is present.

TEST_F(AbaqusTest, Rotor37BladeDeck) {
  const fs::path deck = morse::test::shared_data_path("meshes/rotor37-nlstep/blade.inp");
  if (!fs::exists(deck))
    GTEST_SKIP() << "rotor 37 deck " << deck.string()
                 << " not found (../shared beside the repository, or set MORSE_SHARED_DIR)";

  const auto t0 = std::chrono::steady_clock::now();
  const Mesh m = read_abaqus(deck.string(), morse::world_rank() == 0);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (morse::world_rank() == 0) std::printf("[ info     ] read %s in %.3f s\n", deck.c_str(), seconds);

  EXPECT_EQ(m.num_nodes(), 20831);
  ASSERT_EQ(m.num_elements(), 6732);
  for (ElementType t : m.elem_types) ASSERT_EQ(t, ElementType::Wedge15);
  ASSERT_EQ(m.materials.size(), 1u);
  EXPECT_EQ(m.materials[0].E, 210000.0);
  EXPECT_EQ(m.materials[0].nu, 0.3);
  EXPECT_EQ(m.materials[0].rho, 9e-9);
  for (int mat : m.elem_material) ASSERT_EQ(mat, 0);
  EXPECT_EQ(m.node_sets.at("Nall").size(), 20831u);
  EXPECT_EQ(m.elem_sets.at("Eall").size(), 6732u);

  ASSERT_EQ(m.fixed_dofs.size(), 20831u);
  int clamped = 0, partial = 0;
  for (std::uint8_t f : m.fixed_dofs) {
    clamped += f == 7;
    partial += f != 0 && f != 7;
  }
  EXPECT_EQ(clamped, 465);
  EXPECT_EQ(partial, 0);

  double volume = 0, worst = 1e300;
  std::vector<double> xyz(45);
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    for (int k = 0; k < 15; ++k)
      for (int d = 0; d < 3; ++d) xyz[3 * k + d] = m.coords[3 * m.elem_nodes[15 * e + k] + d];
    const double j = morse::fe::min_jacobian(ElementType::Wedge15, xyz.data());
    worst = std::min(worst, j);
    EXPECT_GT(j, 0.0) << "element " << m.elem_ids[e];
    volume += morse::fe::element_volume(ElementType::Wedge15, xyz.data());
  }
  EXPECT_GT(volume, 0.0);
  if (morse::world_rank() == 0)
    std::printf("[ info     ] blade volume %.6g mm^3, smallest Jacobian %.3g\n", volume, worst);
}

}  // namespace
