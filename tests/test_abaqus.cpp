// Tests of the Abaqus / CalculiX deck reader (mesh/abaqus.hpp). Every rank runs the same serial
// tests on its own temporary files.
#include <gtest/gtest.h>
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
#include <string>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/session.hpp"
#include "morse/fe/element.hpp"
#include "morse/mesh/abaqus.hpp"
#include "scratch.hpp"

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
  for (const auto& [id, mask] : fixed) EXPECT_EQ(m.fixed_dofs[index_of(m, id)], mask) << id;

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
  EXPECT_EQ(count(log, "DOFs above 3"), 1) << log;

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
  EXPECT_EQ(m.fixed_dofs, (std::vector<std::uint8_t>{7, 7, 4, 0}));
}

TEST_F(AbaqusTest, NoBoundaryGivesEmptyFixedDofs) {
  const std::string path = write("deck.inp",
                                 "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n4, 0, 0, 1\n"
                                 "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n"
                                 "*BOUNDARY\n1, 4, 6");  // rotations only; no final newline
  const Mesh m = read_abaqus(path, false);
  EXPECT_TRUE(m.fixed_dofs.empty());
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
