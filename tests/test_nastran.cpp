// Tests of the Nastran bulk data reader and writer (mesh/nastran.hpp). Every rank runs the same
// serial tests on its own temporary files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/session.hpp"
#include "morse/fe/element.hpp"
#include "morse/mesh/generator.hpp"
#include "morse/mesh/nastran.hpp"
#include "morse/mesh/partition.hpp"
#include "scratch.hpp"

namespace {

namespace fs = std::filesystem;
using morse::cat;
using morse::mesh::ElementType;
using morse::mesh::Mesh;
using morse::mesh::NastranWriteOptions;
using morse::mesh::read_nastran;
using morse::mesh::write_nastran;

const std::string kData = MORSE_SOURCE_DIR "/tests/data/";

class NastranTest : public morse::test::ScratchDirTest {
 protected:
  NastranTest() : ScratchDirTest("nastran") {}

  /// Expects read_nastran(path) to throw a morse::Error whose message contains every part.
  static void expect_error(const std::string& path, std::initializer_list<std::string> parts) {
    morse::test::expect_error_parts([&] { read_nastran(path, false); }, parts, path);
  }
};

std::vector<std::int64_t> ids_of(const Mesh& m, const std::vector<std::int64_t>& idx) {
  std::vector<std::int64_t> out;
  for (std::int64_t k : idx) out.push_back(m.node_ids[k]);
  return out;
}

/// Node ids of element e, in morse order.
std::vector<std::int64_t> element_ids(const Mesh& m, std::int64_t e) {
  return ids_of(m, {m.elem_nodes.begin() + m.elem_offsets[e], m.elem_nodes.begin() + m.elem_offsets[e + 1]});
}

std::vector<double> element_xyz(const Mesh& m, std::int64_t e) {
  std::vector<double> xyz;
  for (auto k = m.elem_offsets[e]; k < m.elem_offsets[e + 1]; ++k)
    for (int d = 0; d < 3; ++d) xyz.push_back(m.coords[3 * m.elem_nodes[k] + d]);
  return xyz;
}

std::vector<std::int64_t> range(std::int64_t a, std::int64_t b) {
  std::vector<std::int64_t> v;
  for (std::int64_t i = a; i <= b; ++i) v.push_back(i);
  return v;
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

/// Every mid-edge node of every element sits at the midpoint of its edge (morse's table).
void expect_midpoints(const Mesh& m) {
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    const ElementType t = m.elem_types[e];
    const auto xyz = element_xyz(m, e);
    const int nv = morse::mesh::vertices_per_element(t);
    const auto& edges = morse::mesh::mid_edges(t);
    for (std::size_t j = 0; j < edges.size(); ++j)
      for (int d = 0; d < 3; ++d)
        EXPECT_NEAR(xyz[3 * (nv + j) + d], 0.5 * (xyz[3 * edges[j].first + d] + xyz[3 * edges[j].second + d]), 1e-14)
            << "element " << m.elem_ids[e] << " mid-edge node " << nv + j;
  }
}

// ------------------------------------------------------------------------------------------------
// The formats deck (tests/data/nastran_formats.bdf and nastran_formats_inc.bdf)

TEST_F(NastranTest, FormatsDeck) {
  const std::string path = kData + "nastran_formats.bdf";
  // The deck holds a CQUAD4: an error unless skipped knowingly.
  expect_error(path, {"nastran_formats.bdf:", "card CQUAD4", "element type not supported", "-mesh_skip_unsupported"});
  ::testing::internal::CaptureStderr();
  const Mesh m = read_nastran(path, true, true);
  const std::string log = ::testing::internal::GetCapturedStderr();

  EXPECT_EQ(m.source, path);
  EXPECT_EQ(m.units, "unknown");

  // Grids in file order: hex 1-20, penta 201-215, then the included tet 301-310.
  std::vector<std::int64_t> ids = range(1, 20);
  for (std::int64_t id : range(201, 215)) ids.push_back(id);
  for (std::int64_t id : range(301, 310)) ids.push_back(id);
  ASSERT_EQ(m.node_ids, ids);

  // Basic coordinates, computed by hand from the systems of the deck:
  //   CORD2R 1: origin (10,0,0), x = basic y, y = -basic x, z = basic z: basic (10 - y, x, z)
  //   CORD2C 2 (in 1): (R, t, z) -> basic (10 - R sin t, R cos t, z)
  //   CORD2S 3 (in 2): origin basic (9,0,0), x = -basic x, y = -basic y, z = basic z:
  //                    (R, t, p) -> basic (9 - R sin t cos p, -R sin t sin p, R cos t)
  const std::vector<std::array<double, 3>> expect = {// hex20: corners, then midside grids G9..G20
                                                     {8, 0, 0},
                                                     {10, 0, 0},
                                                     {10, 2, 0},
                                                     {8, 2, 0},
                                                     {8, 0, 2},
                                                     {10, 0, 2},
                                                     {10, 2, 2},
                                                     {8, 2, 2},
                                                     {9, 0, 0},
                                                     {10, 1, 0},
                                                     {9, 2, 0},
                                                     {8, 1, 0},
                                                     {8, 0, 1},
                                                     {10, 0, 1},
                                                     {10, 2, 1},
                                                     {8, 2, 1},
                                                     {9, 0, 2},
                                                     {10, 1, 2},
                                                     {9, 2, 2},
                                                     {8, 1, 2},
                                                     // penta15
                                                     {0, 0, 0},
                                                     {2, 0, 0},
                                                     {0, 2, 0},
                                                     {0, 0, 2},
                                                     {2, 0, 2},
                                                     {0, 2, 2},
                                                     {1, 0, 0},
                                                     {1, 1, 0},
                                                     {0, 1, 0},
                                                     {0, 0, 1},
                                                     {2, 0, 1},
                                                     {0, 2, 1},
                                                     {1, 0, 2},
                                                     {1, 1, 2},
                                                     {0, 1, 2},
                                                     // tet10
                                                     {0, 0, 5},
                                                     {1, 0, 5},
                                                     {0, 1, 5},
                                                     {0, 0, 6},
                                                     {0.5, 0, 5},
                                                     {0.5, 0.5, 5},
                                                     {0, 0.5, 5},
                                                     {0, 0, 5.5},
                                                     {0.5, 0, 5.5},
                                                     {0, 0.5, 5.5}};
  ASSERT_EQ(static_cast<std::size_t>(m.num_nodes()), expect.size());
  for (std::int64_t k = 0; k < m.num_nodes(); ++k)
    for (int d = 0; d < 3; ++d)
      EXPECT_NEAR(m.coords[3 * k + d], expect[k][d], 1e-14) << "grid " << m.node_ids[k] << " x" << d;

  // Elements in file order, in morse order (fe/element.hpp's mid-edge table):
  //   hex20:   G1..G8, then G9 (0,1), G12 (0,3), G13 (0,4), G10 (1,2), G14 (1,5), G11 (2,3),
  //            G15 (2,6), G16 (3,7), G17 (4,5), G20 (4,7), G18 (5,6), G19 (6,7)
  //   wedge15: G1..G6, then G7 (0,1), G9 (0,2), G10 (0,3), G8 (1,2), G11 (1,4), G12 (2,5),
  //            G13 (3,4), G15 (3,5), G14 (4,5)
  //   tet10 given as a b c d -> a c b d (mirrored); morse: a b c d, ab bc ca ad cd bd.
  ASSERT_EQ(m.num_elements(), 3);
  EXPECT_EQ(m.elem_ids, (std::vector<std::int64_t>{1, 2, 3}));
  EXPECT_EQ(m.elem_types[0], ElementType::Hex20);
  EXPECT_EQ(m.elem_types[1], ElementType::Wedge15);
  EXPECT_EQ(m.elem_types[2], ElementType::Tet10);
  EXPECT_EQ(element_ids(m, 0),
            (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 13, 10, 14, 11, 15, 16, 17, 20, 18, 19}));
  EXPECT_EQ(element_ids(m, 1),
            (std::vector<std::int64_t>{201, 202, 203, 204, 205, 206, 207, 209, 210, 208, 211, 212, 213, 215, 214}));
  EXPECT_EQ(element_ids(m, 2), (std::vector<std::int64_t>{301, 302, 303, 304, 305, 306, 307, 308, 310, 309}));
  const double volumes[3] = {8.0, 4.0, 1.0 / 6};
  for (std::int64_t e = 0; e < 3; ++e) {
    const auto xyz = element_xyz(m, e);
    EXPECT_GT(morse::fe::min_jacobian(m.elem_types[e], xyz.data()), 0.0) << e;
    EXPECT_NEAR(morse::fe::element_volume(m.elem_types[e], xyz.data()), volumes[e], 1e-13) << e;
  }
  expect_midpoints(m);

  // Materials: one per PSOLID, in increasing PID; E/G/NU rules; WTMASS = 0.25 on densities.
  ASSERT_EQ(m.materials.size(), 3u);
  EXPECT_EQ(m.materials[0].name, "PSOLID_10");
  EXPECT_EQ(m.materials[0].E, 2.1e5);
  EXPECT_EQ(m.materials[0].nu, 0.3);
  EXPECT_EQ(m.materials[0].rho, 7.85e-9 * 0.25);
  EXPECT_EQ(m.materials[1].name, "PSOLID_20");
  EXPECT_EQ(m.materials[1].E, 72000.0);
  EXPECT_DOUBLE_EQ(m.materials[1].nu, 72000.0 / (2 * 27000.0) - 1);
  EXPECT_EQ(m.materials[1].rho, 2.7e-9 * 0.25);
  EXPECT_EQ(m.materials[2].name, "PSOLID_30");
  EXPECT_EQ(m.materials[2].E, 2 * (1 + 0.25) * 8e4);
  EXPECT_EQ(m.materials[2].nu, 0.25);
  EXPECT_EQ(m.materials[2].rho, 0.0);
  EXPECT_EQ(m.elem_material, (std::vector<int>{0, 1, 2}));
  ASSERT_EQ(m.elem_sets.size(), 3u);
  EXPECT_EQ(m.elem_sets.at("PSOLID_10"), (std::vector<std::int64_t>{0}));
  EXPECT_EQ(m.elem_sets.at("PSOLID_20"), (std::vector<std::int64_t>{1}));
  EXPECT_EQ(m.elem_sets.at("PSOLID_30"), (std::vector<std::int64_t>{2}));

  // Node sets: SET1 (THRU with gaps), ASET + ASET1.
  ASSERT_EQ(m.node_sets.size(), 3u);
  EXPECT_EQ(ids_of(m, m.node_sets.at("SET1_5")), (std::vector<std::int64_t>{1, 2, 3, 4, 17}));
  EXPECT_EQ(ids_of(m, m.node_sets.at("SET1_7")), range(201, 215));
  EXPECT_EQ(ids_of(m, m.node_sets.at("ASET")), (std::vector<std::int64_t>{5, 6, 7, 8, 19}));

  // Fixed DOFs: SPC1 123 on 1-4, SPC1 3 on 9-12, SPC 12 on 201 and 3 on 202 (SID 2), PS 1 on
  // 203, SPC1 123456 on 301 (CD = 2, all translations: allowed); 456 and GRDSET PS 456 ignored.
  ASSERT_EQ(m.fixed_dofs.size(), static_cast<std::size_t>(m.num_nodes()));
  const std::vector<std::pair<std::int64_t, int>> fixed = {{1, 7},  {2, 7},  {3, 7},   {4, 7},   {9, 4},   {10, 4},
                                                           {11, 4}, {12, 4}, {201, 3}, {202, 4}, {203, 1}, {301, 7}};
  for (std::int64_t k = 0; k < m.num_nodes(); ++k) {
    int mask = 0;
    for (const auto& [id, f] : fixed)
      if (id == m.node_ids[k]) mask = f;
    EXPECT_EQ(m.fixed_dofs[k], mask) << "grid " << m.node_ids[k];
  }

  // Point masses: CONM2 2.0 and 1.0 on grid 7, times WTMASS.
  ASSERT_EQ(m.point_mass.size(), static_cast<std::size_t>(m.num_nodes()));
  for (std::int64_t k = 0; k < m.num_nodes(); ++k)
    EXPECT_EQ(m.point_mass[k], m.node_ids[k] == 7 ? 0.75 : 0.0) << "grid " << m.node_ids[k];

  // One notice of each kind.
  EXPECT_EQ(count(log, "executive and case control"), 1) << log;
  EXPECT_EQ(count(log, "column 80"), 1) << log;
  EXPECT_EQ(count(log, "mirrored"), 1) << log;
  EXPECT_EQ(count(log, "CTETRA 3"), 1) << log;
  EXPECT_EQ(count(log, "SIDs 1, 2"), 1) << log;
  EXPECT_EQ(count(log, "components 4-6"), 1) << log;
  EXPECT_EQ(count(log, "use -cb_num_fixed_modes 10"), 1) << log;
  EXPECT_EQ(count(log, "WTMASS = 0.25"), 1) << log;
  EXPECT_EQ(count(log, "MAT1 300 has no density"), 1) << log;
  EXPECT_EQ(count(log, "offsets or inertias"), 1) << log;
  EXPECT_EQ(count(log, "WARNING"), 1) << log;
  EXPECT_EQ(count(log, "MISSING"), 1) << log;
  EXPECT_EQ(count(log, "1 CQUAD4"), 1) << log;
  EXPECT_EQ(count(log, "1 EIGRL"), 1) << log;
  EXPECT_EQ(count(log, "1 PARAM (POST)"), 1) << log;

  // verbose = false: silent.
  ::testing::internal::CaptureStderr();
  read_nastran(path, false, true);
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST_F(NastranTest, ReadAndDistributeDispatchesByExtension) {
  // .bdf goes to the Nastran reader; each rank reads its own copy on PETSC_COMM_SELF.
  ::testing::internal::CaptureStderr();
  const auto lm = morse::mesh::read_and_distribute(PETSC_COMM_SELF, kData + "nastran_formats.bdf", true);
  ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(lm.n_global_nodes, 45);
  EXPECT_EQ(lm.n_global_elements, 3);
}

// ------------------------------------------------------------------------------------------------
// Numbers and fields

TEST_F(NastranTest, RealForms) {
  const std::vector<std::pair<std::string, double>> forms = {{"1.0", 1.0},
                                                             {"1.", 1.0},
                                                             {".5", 0.5},
                                                             {"-.5", -0.5},
                                                             {"1.E5", 1e5},
                                                             {"1.0D-3", 1e-3},
                                                             {"1.-3", 1e-3},
                                                             {"1.+3", 1e3},
                                                             {"-2.5-4", -2.5e-4},
                                                             {"7", 7.0},
                                                             {"+3.e+2", 300},
                                                             {"2.5d2", 250},
                                                             {"-1.e-0", -1.0},
                                                             {"12.345+12", 12.345e12},
                                                             {"1.25E-300", 1.25e-300}};
  std::string deck;
  for (std::size_t i = 0; i < forms.size(); ++i) deck += cat("GRID,", i + 1, ",,", forms[i].first, ",0.,0.\n");
  const Mesh m = read_nastran(write("reals.bdf", deck), false);
  ASSERT_EQ(static_cast<std::size_t>(m.num_nodes()), forms.size());
  for (std::size_t i = 0; i < forms.size(); ++i) EXPECT_EQ(m.coords[3 * i], forms[i].second) << forms[i].first;

  for (const char* bad :
       {"1..0", "1.0E", "1.0-", "e5", "1.0x", "inf", "nan", "0x1p3", "1 .0", "1.0E+5.", "--1.", "."}) {
    SCOPED_TRACE(bad);
    expect_error(write("bad.bdf", cat("GRID,1,,0.,", bad, ",0.\n")),
                 {"bad.bdf:1:", "card GRID", cat("field 5 ('", bad, "') is not a real number")});
  }
  // The same in fixed format: the field number is the column field.
  expect_error(write("fixed.bdf", "GRID    1               0.      abc     0.\n"),
               {"fixed.bdf:1:", "card GRID: field 5 ('abc') is not a real number (X2)"});
  expect_error(write("int.bdf", "GRID    1.0             0.      0.      0.\n"),
               {"int.bdf:1:", "card GRID: field 2 ('1.0') is not an integer (ID)"});
}

TEST_F(NastranTest, ContinuationsAndFormatsAgree) {
  // One CHEXA (hex20) written six ways must give the same element.
  const std::string grids =
      "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\n"
      "GRID,5,,0.,0.,1.\nGRID,6,,1.,0.,1.\nGRID,7,,1.,1.,1.\nGRID,8,,0.,1.,1.\n"
      "GRID,9,,.5,0.,0.\nGRID,10,,1.,.5,0.\nGRID,11,,.5,1.,0.\nGRID,12,,0.,.5,0.\n"
      "GRID,13,,0.,0.,.5\nGRID,14,,1.,0.,.5\nGRID,15,,1.,1.,.5\nGRID,16,,0.,1.,.5\n"
      "GRID,17,,.5,0.,1.\nGRID,18,,1.,.5,1.\nGRID,19,,.5,1.,1.\nGRID,20,,0.,.5,1.\n"
      "PSOLID,1,1\nMAT1,1,1.,,.3,1.\n";
  const std::vector<std::string> variants = {
      // small, new style (blank field 1)
      "CHEXA   1       1       1       2       3       4       5       6\n"
      "        7       8       9       10      11      12      13      14\n"
      "        15      16      17      18      19      20\n",
      // small, '+' continuation and tabs
      "CHEXA\t1\t1\t1\t2\t3\t4\t5\t6\n+\t7\t8\t9\t10\t11\t12\t13\t14\n+\t15\t16\t17\t18\t19\t20\n",
      // large with markers
      "CHEXA*  1               1               1               2               *A\n"
      "*A      3               4               5               6               *B\n"
      "*B      7               8               9               10\n"
      "*       11              12              13              14\n"
      "*       15              16              17              18\n"
      "*       19              20\n",
      // free, continuation lines starting with ',' and '+'
      "CHEXA,1,1,1,2,3,4,5,6\n,7,8,9,10,11,12,13,14\n+,15,16,17,18,19,20\n",
      // free with markers, comment lines in between
      "CHEXA,1,1,1,2,3,4,5,6,+X1\n$ "
      "comment\n\n+X1,7,8,9,10,11,12,13,14,+X2\n+X2,15,16,17,18,19,20\n",
      // large free field
      "CHEXA*,1,1,1,2\n*,3,4,5,6\n*,7,8,9,10\n*,11,12,13,14\n*,15,16,17,18\n*,19,20\n"};
  std::vector<std::int64_t> reference;
  for (std::size_t v = 0; v < variants.size(); ++v) {
    SCOPED_TRACE(v);
    const Mesh m = read_nastran(write(cat("v", v, ".bdf"), grids + variants[v]), false);
    ASSERT_EQ(m.num_elements(), 1);
    EXPECT_EQ(m.elem_types[0], ElementType::Hex20);
    const auto ids = element_ids(m, 0);
    if (v == 0) reference = ids;
    EXPECT_EQ(ids, reference);
    expect_midpoints(m);
  }
}

TEST_F(NastranTest, IncludeNestingAndRelativePaths) {
  write("a/b/nodes.bdf", "GRID,3,,0.,1.,0.\nINCLUDE ../more.bdf $ a comment\n");
  write("a/more.bdf", "GRID,4,,0.,0.,1.\n");
  write("a/tet.bdf",
        "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\ninclude \"b/nodes.bdf\"\n"
        "CTETRA,1,1,1,2,3,4\n");
  const std::string path = write("main.dat",
                                 "SOL 103\nCEND\nbegin  bulk\n"
                                 "INCLUDE 'a/tet.bdf'\nPSOLID,1,1\nMAT1,1,1.,,.3,1.\nENDDATA\n");
  const Mesh m = read_nastran(path, false);
  EXPECT_EQ(m.node_ids, (std::vector<std::int64_t>{1, 2, 3, 4}));
  ASSERT_EQ(m.num_elements(), 1);
  EXPECT_EQ(m.elem_types[0], ElementType::Tet4);
  EXPECT_TRUE(m.fixed_dofs.empty());
  EXPECT_TRUE(m.point_mass.empty());
  EXPECT_TRUE(m.node_sets.empty());
}

TEST_F(NastranTest, MaterialRulesAndWtmass) {
  const std::string tet =
      "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,0.,1.,0.\nGRID,4,,0.,0.,1.\n"
      "CTETRA,1,1,1,2,3,4\nPSOLID,1,7\n";
  // All three given and consistent: as given, no notice.
  {
    ::testing::internal::CaptureStderr();
    const Mesh m = read_nastran(write("a.bdf", tet + "MAT1,7,200.,80.,.25,2.\n"));
    const std::string log = ::testing::internal::GetCapturedStderr();
    EXPECT_EQ(m.materials[0].E, 200.0);
    EXPECT_EQ(m.materials[0].nu, 0.25);
    EXPECT_EQ(m.materials[0].rho, 2.0);
    EXPECT_EQ(count(log, "differs from 1"), 0) << log;
  }
  // All three given, inconsistent: as given, with a notice.
  {
    ::testing::internal::CaptureStderr();
    const Mesh m = read_nastran(write("b.bdf", tet + "MAT1,7,200.,70.,.25,2.\n"));
    const std::string log = ::testing::internal::GetCapturedStderr();
    EXPECT_EQ(m.materials[0].E, 200.0);
    EXPECT_EQ(m.materials[0].nu, 0.25);
    EXPECT_EQ(count(log, "differs from 1"), 1) << log;
  }
  // Case-control WTMASS overrides the bulk data one.
  {
    const Mesh m = read_nastran(write("c.bdf", "SOL 103\nCEND\nPARAM,WTMASS,0.5\nBEGIN BULK\nPARAM,WTMASS,4.\n" + tet +
                                                   "MAT1,7,200.,,.25,2.\nCONM2,9,1,,3.\n"),
                                false);
    EXPECT_EQ(m.materials[0].rho, 1.0);
    EXPECT_EQ(m.point_mass, (std::vector<double>{1.5, 0, 0, 0}));
  }
  expect_error(write("e.bdf", tet + "MAT1,7,200.\n"), {"e.bdf:7:", "card MAT1", "only E"});
  expect_error(write("g.bdf", tet + "MAT1,7,,80.\n"), {"g.bdf:7:", "card MAT1", "only G"});
  expect_error(write("n.bdf", tet + "MAT1,7,200.,,.6\n"), {"n.bdf:7:", "card MAT1", "NU = 0.6"});
  expect_error(write("mid.bdf", tet + "MAT8,7,1.,1.,.3\n"),
               {"mid.bdf:6:", "card PSOLID", "MAT1 7", "not defined", "is a MAT8"});
  expect_error(write("pid.bdf",
                     "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,0.,1.,0.\n"
                     "GRID,4,,0.,0.,1.\nCTETRA,1,2,1,2,3,4\nPLSOLID,2,7\n"),
               {"pid.bdf:5:", "card CTETRA", "PSOLID 2", "is a PLSOLID"});
  expect_error(write("fluid.bdf", tet + "PSOLID,8,7,,,,,PFLUID\n"), {"fluid.bdf:7:", "card PSOLID", "FCTN"});
}

// ------------------------------------------------------------------------------------------------
// Orientation

TEST_F(NastranTest, UpsideDownHexIsMirrored) {
  // Unit cube; corners 1-4 at z = 0, 5-8 at z = 1; midside grid ids by edge. The CHEXA starts
  // with the top face, so its corners have a negative volume as given.
  const std::string grids =
      "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\nGRID,4,,0.,1.,0.\n"
      "GRID,5,,0.,0.,1.\nGRID,6,,1.,0.,1.\nGRID,7,,1.,1.,1.\nGRID,8,,0.,1.,1.\n"
      "GRID,11,,.5,0.,0.\nGRID,12,,1.,.5,0.\nGRID,13,,.5,1.,0.\nGRID,14,,0.,.5,0.\n"
      "GRID,15,,0.,0.,.5\nGRID,16,,1.,0.,.5\nGRID,17,,1.,1.,.5\nGRID,18,,0.,1.,.5\n"
      "GRID,19,,.5,0.,1.\nGRID,20,,1.,.5,1.\nGRID,21,,.5,1.,1.\nGRID,22,,0.,.5,1.\n"
      "PSOLID,1,1\nMAT1,1,1.,,.3,1.\n";
  // G9..G12 on the edges of the first face (5-6, 6-7, 7-8, 8-5), G13..G16 on 5-1, 6-2, 7-3,
  // 8-4, G17..G20 on the second face's edges (1-2, 2-3, 3-4, 4-1).
  const std::string hex20 = "CHEXA,1,1,5,6,7,8,1,2\n,3,4,19,20,21,22,15,16\n,17,18,11,12,13,14\n";
  ::testing::internal::CaptureStderr();
  const Mesh m = read_nastran(write("hex20.bdf", grids + hex20));
  const std::string log = ::testing::internal::GetCapturedStderr();
  ASSERT_EQ(m.num_elements(), 1);
  ASSERT_EQ(m.elem_types[0], ElementType::Hex20);
  const auto xyz = element_xyz(m, 0);
  EXPECT_GT(morse::fe::min_jacobian(ElementType::Hex20, xyz.data()), 0.0);
  EXPECT_NEAR(morse::fe::element_volume(ElementType::Hex20, xyz.data()), 1.0, 1e-14);
  expect_midpoints(m);
  EXPECT_EQ(element_ids(m, 0),
            (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8, 11, 14, 15, 12, 16, 13, 17, 18, 19, 22, 20, 21}));
  EXPECT_EQ(count(log, "1 element(s) were given with their corners in the other orientation"), 1) << log;

  // The linear hexahedron and the pentahedron, upside down too.
  const Mesh h8 = read_nastran(write("hex8.bdf", grids + "CHEXA,1,1,5,6,7,8,1,2\n,3,4\n"), false);
  const auto x8 = element_xyz(h8, 0);
  EXPECT_GT(morse::fe::min_jacobian(ElementType::Hex8, x8.data()), 0.0);
  EXPECT_EQ(element_ids(h8, 0), (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8}));
  const Mesh p15 = read_nastran(write("penta.bdf", grids + "GRID,23,,.5,.5,0.\nGRID,24,,.5,.5,1.\n"
                                                           "CPENTA,1,1,5,6,8,1,2,4\n,19,24,22,15,16,18,11,23\n,14\n"),
                                false);
  const auto x15 = element_xyz(p15, 0);
  EXPECT_GT(morse::fe::min_jacobian(ElementType::Wedge15, x15.data()), 0.0);
  EXPECT_NEAR(morse::fe::element_volume(ElementType::Wedge15, x15.data()), 0.5, 1e-14);
  expect_midpoints(p15);
}

// ------------------------------------------------------------------------------------------------
// Round trip: write_nastran then read_nastran

TEST_F(NastranTest, RoundTripEveryTypeAndFormat) {
  using Format = NastranWriteOptions::Format;
  for (ElementType t : {ElementType::Hex20, ElementType::Tet10, ElementType::Wedge15, ElementType::Hex8,
                        ElementType::Tet4, ElementType::Wedge6}) {
    morse::mesh::BoxSpec b;
    b.type = t;
    b.lx = 0.3;
    b.ly = 0.07;
    b.lz = 0.11;
    b.nx = 3;
    b.ny = 2;
    b.nz = 2;
    b.distortion = 0.15;
    b.seed = 7;
    b.origin = {0.5, 1.25, 2.0};
    Mesh m = morse::mesh::generate_box(b);
    m.materials = {{"steel", 2.1e11, 0.3, 7800.0}, {"alu", 7e10, 0.33, 2700.0}};
    for (std::int64_t e = 0; e < m.num_elements(); ++e) m.elem_material[e] = static_cast<int>(e % 2);
    m.fixed_dofs.assign(static_cast<std::size_t>(m.num_nodes()), 0);
    for (auto k : m.node_sets.at("x0")) m.fixed_dofs[k] = 7;
    for (auto k : m.node_sets.at("y0")) m.fixed_dofs[k] |= 2;
    for (auto k : m.node_sets.at("z1")) m.fixed_dofs[k] |= 5;
    m.point_mass.assign(static_cast<std::size_t>(m.num_nodes()), 0.0);
    for (auto k : m.node_sets.at("x1")) m.point_mass[k] = 1.0 / 3.0 + 0.125 * (k % 3);

    for (Format f : {Format::Free, Format::Large, Format::Small}) {
      const char* fname = f == Format::Free ? "free" : f == Format::Large ? "large" : "small";
      SCOPED_TRACE(cat(morse::mesh::element_name(t), " ", fname));
      NastranWriteOptions o;
      o.format = f;
      o.aset = "x1";
      const std::string path = (dir_ / cat(morse::mesh::element_name(t), "_", fname, ".bdf")).string();
      write_nastran(m, path, o);
      EXPECT_FALSE(fs::exists(path + ".tmp"));
      EXPECT_FALSE(fs::exists(morse::files::temp_path(path)));
      ::testing::internal::CaptureStderr();
      const Mesh r = read_nastran(path, true);
      const std::string log = ::testing::internal::GetCapturedStderr();
      EXPECT_EQ(log, "") << "a written file reads back without notices";

      EXPECT_EQ(r.node_ids, m.node_ids);
      EXPECT_EQ(r.elem_ids, m.elem_ids);
      EXPECT_EQ(r.elem_types, m.elem_types);
      EXPECT_EQ(r.elem_offsets, m.elem_offsets);
      EXPECT_EQ(r.elem_nodes, m.elem_nodes);
      ASSERT_EQ(r.coords.size(), m.coords.size());
      int n_bad = 0;
      for (std::size_t i = 0; i < m.coords.size(); ++i) {
        const double x = m.coords[i], y = r.coords[i];
        const bool ok = f == Format::Free    ? x == y
                        : f == Format::Large ? std::fabs(x - y) <= 1e-14 * std::max(1.0, std::fabs(x))
                                             : std::fabs(x - y) <= 1e-6 * std::fabs(x);
        if (!ok && n_bad++ < 5) ADD_FAILURE() << "coordinate " << i << ": " << x << " read " << y;
      }

      ASSERT_EQ(r.materials.size(), 2u);
      for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(r.materials[i].name, cat("PSOLID_", i + 1));
        EXPECT_EQ(r.materials[i].E, m.materials[i].E);
        EXPECT_EQ(r.materials[i].nu, m.materials[i].nu);
        EXPECT_EQ(r.materials[i].rho, m.materials[i].rho);
      }
      EXPECT_EQ(r.elem_material, m.elem_material);
      std::vector<std::int64_t> even, odd;
      for (std::int64_t e = 0; e < m.num_elements(); ++e) (e % 2 ? odd : even).push_back(e);
      EXPECT_EQ(r.elem_sets.at("PSOLID_1"), even);
      EXPECT_EQ(r.elem_sets.at("PSOLID_2"), odd);

      // Node sets: SET1 1, 2, ... in name order, plus the ASET.
      ASSERT_EQ(r.node_sets.size(), m.node_sets.size() + 1);
      int sid = 0;
      for (const auto& [name, members] : m.node_sets) EXPECT_EQ(r.node_sets.at(cat("SET1_", ++sid)), members) << name;
      EXPECT_EQ(r.node_sets.at("ASET"), m.node_sets.at("x1"));

      EXPECT_EQ(r.fixed_dofs, m.fixed_dofs);
      ASSERT_EQ(r.point_mass.size(), m.point_mass.size());
      for (std::size_t k = 0; k < m.point_mass.size(); ++k) {
        const double x = m.point_mass[k], y = r.point_mass[k];
        if (f == Format::Free)
          EXPECT_EQ(y, x) << k;
        else
          EXPECT_NEAR(y, x, (f == Format::Large ? 1e-14 : 1e-6) * x) << k;
      }
    }
  }
}

TEST_F(NastranTest, WriterFormatsAndErrors) {
  Mesh m = morse::mesh::generate_box([] {
    morse::mesh::BoxSpec b;
    b.type = ElementType::Hex8;
    b.nx = 1;
    return b;
  }());
  // No material: refused.
  try {
    write_nastran(m, (dir_ / "x.bdf").string());
    ADD_FAILURE() << "no error";
  } catch (const morse::Error& e) {
    EXPECT_NE(std::string(e.what()).find("element 1 has no material"), std::string::npos) << e.what();
  }
  m.materials = {{"steel", 2.1e11, 0.3, 7800.0}};
  m.elem_material.assign(1, 0);
  NastranWriteOptions o;
  o.aset = "nope";
  try {
    write_nastran(m, (dir_ / "x.bdf").string(), o);
    ADD_FAILURE() << "no error";
  } catch (const morse::Error& e) {
    EXPECT_NE(std::string(e.what()).find("'nope'"), std::string::npos) << e.what();
  }

  // The layout of each format.
  const auto text = [&](NastranWriteOptions::Format f) {
    NastranWriteOptions w;
    w.format = f;
    const std::string path = (dir_ / "fmt.bdf").string();
    write_nastran(m, path, w);
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const std::string small = text(NastranWriteOptions::Format::Small);
  EXPECT_NE(small.find("\nBEGIN BULK\n"), std::string::npos);
  EXPECT_NE(small.find("\nGRID    2               1.      0.      0.\n"), std::string::npos) << small;
  EXPECT_NE(small.find("\nMAT1    1       2.1E+11         0.3     7800.\n"), std::string::npos) << small;
  EXPECT_NE(small.find("\nENDDATA\n"), std::string::npos);
  const std::string large = text(NastranWriteOptions::Format::Large);
  EXPECT_NE(large.find("\nCHEXA*  1               1               1               2\n"
                       "*       4               3               5               6\n"
                       "*       8               7\n"),
            std::string::npos)
      << large;
  const std::string free = text(NastranWriteOptions::Format::Free);
  EXPECT_NE(free.find("\nGRID,2,,1.,0.,0.\n"), std::string::npos) << free;
  EXPECT_NE(free.find("\nSET1,1,"), std::string::npos) << free;
  EXPECT_NE(free.find("\n$ SET1 1 = all\n"), std::string::npos) << free;
}

// ------------------------------------------------------------------------------------------------
// Errors: every message names the file, the line and the card

// Lines 1-7.
const char* const kTet =
    "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,0.,1.,0.\nGRID,4,,0.,0.,1.\n"
    "CTETRA,1,1,1,2,3,4\nPSOLID,1,1\nMAT1,1,2.1+5,,.3,7.8-9\n";

TEST_F(NastranTest, ErrorsGridsElementsAndFields) {
  expect_error((dir_ / "nowhere.bdf").string(), {"nowhere.bdf", "cannot read"});
  expect_error(write("real.bdf", cat(kTet, "GRID,5,,abc,0.,0.\n")),
               {"real.bdf:8:", "card GRID", "field 4 ('abc') is not a real number"});
  expect_error(write("nogrid.bdf", cat(kTet, "CTETRA,2,1,1,2,3,99\n")),
               {"nogrid.bdf:8:", "card CTETRA", "element 2", "undefined grid 99"});
  expect_error(write("dupgrid.bdf", cat(kTet, "GRID,2,,5.,5.,5.\n")),
               {"dupgrid.bdf:8:", "card GRID", "grid 2 is defined twice", "dupgrid.bdf:2)"});
  expect_error(write("dupelem.bdf", cat(kTet, "CONM2,1,1,,1.\n")),
               {"dupelem.bdf:8:", "card CONM2", "element id 1 is used twice"});
  expect_error(write("partial.bdf", cat(kTet, "CTETRA,2,1,1,2,3,4,1,2\n")),
               {"partial.bdf:8:", "card CTETRA", "2 of its 6 midside grids"});
  expect_error(write("corner.bdf", cat(kTet, "CTETRA,2,1,1,2,,4\n")),
               {"corner.bdf:8:", "card CTETRA", "field 6 (G3) is blank"});
  expect_error(write("twice.bdf", cat(kTet, "CTETRA,2,1,1,2,3,3\n")),
               {"twice.bdf:8:", "card CTETRA", "grid 3 appears twice"});
  expect_error(write("many.bdf", cat(kTet, "GRID,5,,0.,0.,0.,,,,,1\n")),
               {"many.bdf:8:", "card GRID", "11 fields; at most 10"});
  expect_error(write("manyl.bdf", cat(kTet, "GRID*,5,,0.,0.,0.,1\n")), {"manyl.bdf:8:", "card GRID", "at most 6"});
  expect_error(write("extra.bdf", cat(kTet, "GRID,5,,0.,0.,0.\n,7\n")),
               {"extra.bdf:9:", "card GRID", "field 2 ('7'): unexpected data"});
  expect_error(write("orphan.bdf", cat("+A      1\n", kTet)),
               {"orphan.bdf:1:", "continuation line", "without a parent card"});
  expect_error(write("name.bdf", cat(kTet, "GRID 5 0 1. 2. 3.\n")), {"name.bdf:8:", "not a card name"});
  expect_error(write("repl.bdf", cat(kTet, "GRID,5,,=,0.,0.\n")), {"repl.bdf:8:", "card GRID", "replication"});
  expect_error(write("pid.bdf", cat(kTet, "CTETRA,2,5,1,2,3,4\n")),
               {"pid.bdf:8:", "card CTETRA", "PSOLID 5", "not defined"});
  expect_error(write("mat.bdf", cat(kTet, "CTETRA,2,5,1,2,3,4\nPSOLID,5,9\n")),
               {"mat.bdf:9:", "card PSOLID", "MAT1 9", "not defined"});
}

TEST_F(NastranTest, ErrorsUnsupportedCards) {
  // An unsupported element is an error naming it; skipped knowingly, a WARNING lists its
  // MISSING stiffness. Rigid elements other than RBE2 and RBE3 are always errors.
  const std::string quad = write("quad.bdf", cat(kTet, "CQUAD4,10,1,1,2,3,4\nCBAR,11,1,1,2\n"));
  expect_error(quad, {"quad.bdf:8:", "card CQUAD4", "element type not supported", "stiffness and mass"});
  ::testing::internal::CaptureStderr();
  const Mesh m = read_nastran(quad, true, true);
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(m.num_elements(), 1);
  EXPECT_EQ(count(log, "MISSING"), 1) << log;
  EXPECT_EQ(count(log, "1 CBAR, 1 CQUAD4"), 1) << log;
  expect_error(write("rbar.bdf", cat(kTet, "RBAR,10,1,2,123456\n")),
               {"rbar.bdf:8:", "card RBAR", "not supported (morse reads RBE2, RBE3 and MPC)", "-matrices_K"});
  expect_error(write("cord1.bdf", cat(kTet, "CORD1R,5,1,2,3\n")), {"cord1.bdf:8:", "card CORD1R", "CORD2R"});
  expect_error(write("super.bdf", cat(kTet, "BEGIN SUPER=1\n")), {"super.bdf:8:", "card BEGIN", "not supported"});
  expect_error(write("qset.bdf", cat(kTet, "QSET1,123,1\n")),
               {"qset.bdf:8:", "card QSET1", "on grids (1) is not supported"});
  expect_error(write("conm2.bdf", cat(kTet, "GRID,9,,5.,5.,5.\nCONM2,5,9,,1.\n")),
               {"conm2.bdf:9:", "card CONM2", "grid 9", "no solid element, rigid element or MPC uses"});
}

TEST_F(NastranTest, RigidElementsAndMpcs) {
  // RBE2 with THRU and ALPHA; RBE3 with two weight groups, UM and ALPHA over continuations; MPC
  // with a continuation; a CONM2 on the spider's centre.
  const std::string deck = cat(kTet,
                               "GRID,9,,0.3,0.3,0.3\n"
                               "RBE2,10,9,123456,1,THRU,3,1.2-5\n"
                               "RBE3,11,,9,123456,1.0,123,1,2\n"
                               ",2.5,12,3,4,UM,1,1\n"
                               ",ALPHA,1.-5\n"
                               "MPC,7,4,3,2.,1,3,-1.\n"
                               ",,2,1,0.5\n"
                               "CONM2,12,9,,3.\n"
                               "CONM2,13,9,0,2.,0.1,0.,0.\n"
                               ",1.,0.,2.,0.,0.,3.\n");
  const Mesh m = read_nastran(write("rigid.bdf", deck), false);
  const auto& cs = m.constraints;
  ASSERT_EQ(cs.rigid.size(), 1u);
  EXPECT_EQ(cs.rigid[0].id, 10);
  EXPECT_EQ(cs.rigid[0].reference, 9);
  EXPECT_EQ(cs.rigid[0].components, 63);
  EXPECT_EQ(cs.rigid[0].dependent, (std::vector<std::int64_t>{1, 2, 3}));
  EXPECT_NE(cs.rigid[0].where.find("rigid.bdf:9: RBE2 10"), std::string::npos) << cs.rigid[0].where;
  ASSERT_EQ(cs.interpolation.size(), 1u);
  const auto& r3 = cs.interpolation[0];
  EXPECT_EQ(r3.reference, 9);
  EXPECT_EQ(r3.ref_components, 63);
  EXPECT_EQ(r3.nodes, (std::vector<std::int64_t>{1, 2, 3, 4}));
  EXPECT_EQ(r3.weights, (std::vector<double>{1.0, 1.0, 2.5, 2.5}));
  EXPECT_EQ(r3.node_components, (std::vector<std::uint8_t>{7, 7, 3, 3}));
  ASSERT_EQ(cs.linear.size(), 1u);
  const auto& t = cs.linear[0].terms;
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].node, 4);
  EXPECT_EQ(t[0].component, 3);
  EXPECT_EQ(t[0].coefficient, 2.0);
  EXPECT_EQ(t[2].node, 2);
  EXPECT_EQ(t[2].component, 1);
  EXPECT_EQ(t[2].coefficient, 0.5);
  EXPECT_EQ(m.point_mass[4], 3.0);  // grid 9 is node 4 (file order)
  // CONM2 13: m = 2 at offset (0.1, 0, 0), inertia diag(1, 2, 3) about its centre of gravity:
  // [[m I, -m [d]x], [m [d]x, J + m (|d|^2 I - d d^T)]] about grid 9.
  ASSERT_EQ(cs.mass_ids, (std::vector<std::int64_t>{9}));
  ASSERT_EQ(cs.mass_matrices.size(), 36u);
  const auto& M6 = cs.mass_matrices;
  EXPECT_EQ(M6[0], 2.0);
  EXPECT_DOUBLE_EQ(M6[6 * 1 + 5], 0.2);   // y-force of a rotation about z
  EXPECT_DOUBLE_EQ(M6[6 * 2 + 4], -0.2);  // z-force of a rotation about y
  EXPECT_DOUBLE_EQ(M6[6 * 5 + 1], 0.2);
  EXPECT_DOUBLE_EQ(M6[6 * 3 + 3], 1.0);
  EXPECT_DOUBLE_EQ(M6[6 * 4 + 4], 2.02);
  EXPECT_DOUBLE_EQ(M6[6 * 5 + 5], 3.02);
  EXPECT_EQ(M6[6 * 0 + 4], 0.0);

  expect_error(write("rbe2n.bdf", cat(kTet, "RBE2,10,1,123\n")), {"rbe2n.bdf:8:", "card RBE2", "no dependent grid"});
  expect_error(write("rbe2g.bdf", cat(kTet, "RBE2,10,1,123,77\n")), {"rbe2g.bdf:8:", "card RBE2", "undefined grid 77"});
  expect_error(write("rbe3w.bdf", cat(kTet, "GRID,9,,0.,0.,0.\nRBE3,11,,9,123456,1,2\n")),
               {"rbe3w.bdf:9:", "card RBE3", "a weight WT1"});
  expect_error(write("rbe3z.bdf", cat(kTet, "GRID,9,,0.,0.,0.\nRBE3,11,,9,123456,0.,123,1,2\n")),
               {"rbe3z.bdf:9:", "card RBE3", "must be positive"});
  expect_error(write("rbe3f.bdf", cat(kTet, "RBE3,11,1,9,123456,1.,123,1,2\n")),
               {"rbe3f.bdf:8:", "card RBE3", "field 3 of RBE3 must be blank"});
  expect_error(write("mpc0.bdf", cat(kTet, "MPC,7,4,3,0.,1,3,-1.\n")),
               {"mpc0.bdf:8:", "card MPC", "first coefficient A1", "is 0"});
  expect_error(write("mpcc.bdf", cat(kTet, "MPC,7,4,12,1.,1,3,-1.\n")),
               {"mpcc.bdf:8:", "card MPC", "one component 1 to 6"});
  expect_error(write("dupe.bdf", cat(kTet, "RBE2,1,1,123,2\n")),
               {"dupe.bdf:8:", "card RBE2", "element id 1 is used twice"});
}

TEST_F(NastranTest, ErrorsConstraintsAndSets) {
  expect_error(write("aset.bdf", cat(kTet, "ASET1,12,1,2\n")),
               {"aset.bdf:8:", "card ASET1", "field 2 ('12')", "1, 2, 3"});
  expect_error(write("asetp.bdf", cat(kTet, "ASET,1,123456,2,13\n")), {"asetp.bdf:8:", "card ASET", "field 5 ('13')"});
  expect_error(write("spcd.bdf", cat(kTet, "SPC,1,1,123,0.5\n")),
               {"spcd.bdf:8:", "card SPC", "field 5 ('0.5')", "enforced displacements"});
  // A grid in a rotated displacement system: SPC 1 alone would act along a skewed axis.
  const std::string cord = "CORD2R,5,,0.,0.,0.,1.,1.,0.\n,0.,0.,1.\n";  // lines 8-9
  expect_error(write("cd.bdf", cat(kTet, cord, "GRID,5,,0.,0.,2.,5\nSPC1,1,1,5\n")),
               {"cd.bdf:11:", "card SPC1", "grid 5", "CD = 5"});
  expect_error(write("cdps.bdf", cat(kTet, cord, "GRID,5,,0.,0.,2.,5,13\n")),
               {"cdps.bdf:10:", "card GRID", "grid 5", "CD = 5"});
  // All three translations (or rotations only) are fine in any system.
  const Mesh ok =
      read_nastran(write("cdok.bdf", cat(kTet, cord, "GRID,5,,0.,0.,2.,5\nSPC1,1,123,5\nSPC,1,5,456\n")), false);
  EXPECT_EQ(ok.fixed_dofs[4], 63);  // grid 5 is no solid's: it keeps 4-6 (in case it is a six-DOF point)

  expect_error(write("set.bdf", cat(kTet, "SET1,3,1,2,77\n")), {"set.bdf:8:", "card SET1", "undefined grid 77"});
  expect_error(write("thru.bdf", cat(kTet, "SPC1,1,123,50,THRU,60\n")),
               {"thru.bdf:8:", "card SPC1", "50 THRU 60 contains no grid"});
  expect_error(write("thru2.bdf", cat(kTet, "SET1,1,4,THRU,2\n")), {"thru2.bdf:8:", "card SET1", "empty"});
  expect_error(write("comp.bdf", cat(kTet, "SPC1,1,1223,1\n")),
               {"comp.bdf:8:", "card SPC1", "field 3 ('1223') is not a component set"});
  expect_error(write("setsp.bdf", cat(kTet, "SPOINT,100\nSET1,1,100\n")),
               {"setsp.bdf:9:", "card SET1", "scalar point"});
}

TEST_F(NastranTest, ErrorsIncludeCoordinatesAndContinuations) {
  expect_error(write("inc.bdf", cat(kTet, "INCLUDE 'sub/nope.bdf'\n")), {"inc.bdf:8:", "card INCLUDE", "sub/nope.bdf"});
  // An error inside an included file names that file and line.
  write("sub/bad.bdf", "$ comment\nGRID,8,,1.,2.,x\n");
  expect_error(write("inc2.bdf", cat(kTet, "INCLUDE sub/bad.bdf\n")), {"sub/bad.bdf:2:", "card GRID", "field 6 ('x')"});
  expect_error(write("cycle.bdf", cat(kTet, "CORD2R,7,8,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\n",
                                      "CORD2C,8,7,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\n")),
               {"cycle.bdf:8:", "card CORD2R", "cycle", "7 -> 8 -> 7"});
  expect_error(write("undef.bdf", cat(kTet, "GRID,5,3,0.,0.,0.\n")),
               {"undef.bdf:8:", "card GRID", "undefined coordinate system 3"});
  expect_error(write("trunc.bdf", cat(kTet, "CORD2R,7,,0.,0.,0.,0.,0.,1.\n")),
               {"trunc.bdf:8:", "card CORD2R", "truncated"});
  expect_error(write("line.bdf", cat(kTet, "CORD2R,7,,0.,0.,0.,0.,0.,1.\n,0.,0.,2.\n")),
               {"line.bdf:8:", "card CORD2R", "on one line"});
  expect_error(write("dupcord.bdf",
                     cat(kTet, "CORD2R,7,,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\n", "CORD2R,7,,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\n")),
               {"dupcord.bdf:10:", "card CORD2R", "defined twice"});
  // Fields 2-7, two blank fields, then the marker in columns 73-80.
  const std::string parent =
      cat("CTETRA  2       1       1       2       3       4       ", std::string(16, ' '), "+A");
  ASSERT_EQ(parent.size(), 74u);
  expect_error(write("marker.bdf", cat(kTet, parent, "\n+B\n")), {"marker.bdf:9:", "card CTETRA", "'+B'", "'+A'"});
}

}  // namespace
