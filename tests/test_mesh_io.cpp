// Tests of the box generator and the Gmsh reader/writer (serial on every rank).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/session.hpp"
#include "morse/fe/element.hpp"
#include "morse/mesh/generator.hpp"
#include "morse/mesh/gmsh.hpp"
#include "morse/mesh/mesh.hpp"
#include "scratch.hpp"

namespace {

using morse::Error;
using morse::mesh::BoxSpec;
using morse::mesh::ElementType;
using morse::mesh::Mesh;

const ElementType kAllTypes[] = {ElementType::Tet4,    ElementType::Tet10, ElementType::Wedge6,
                                 ElementType::Wedge15, ElementType::Hex8,  ElementType::Hex20};

/// A file name in this rank's scratch directory (removed at exit).
std::string temp_path(const std::string& name) {
  static const morse::test::ScratchDir scratch("mesh_io");
  return scratch.path(name);
}

/// Writes text to a temporary file, removed by the destructor.
struct TempFile {
  std::string path;
  TempFile(const std::string& name, const std::string& text) : path(temp_path(name)) {
    std::ofstream(path, std::ios::binary) << text;
  }
  explicit TempFile(const std::string& name) : path(temp_path(name)) {}
  ~TempFile() { std::remove(path.c_str()); }
};

/// 1-based number of the first line of text that contains needle.
int line_of(const std::string& text, const std::string& needle) {
  const auto pos = text.find(needle);
  EXPECT_NE(pos, std::string::npos) << needle;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + pos, '\n'));
}

/// Runs read_gmsh on text and returns the error message ("" if it did not throw).
std::string read_error(const std::string& name, const std::string& text) {
  TempFile f(name, text);
  try {
    morse::mesh::read_gmsh(f.path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::vector<double> element_xyz(const Mesh& m, std::int64_t e) {
  std::vector<double> xyz;
  for (auto j = m.elem_offsets[e]; j < m.elem_offsets[e + 1]; ++j)
    for (int d = 0; d < 3; ++d) xyz.push_back(m.coords[3 * m.elem_nodes[j] + d]);
  return xyz;
}

// Closed forms for an nx x ny x nz box.
struct Counts {
  std::int64_t nodes, elems;
};
std::int64_t grid_edges(std::int64_t a, std::int64_t b, std::int64_t c) {
  return a * (b + 1) * (c + 1) + (a + 1) * b * (c + 1) + (a + 1) * (b + 1) * c;
}
Counts box_counts(ElementType t, std::int64_t nx, std::int64_t ny, std::int64_t nz) {
  const std::int64_t nv = (nx + 1) * (ny + 1) * (nz + 1), cells = nx * ny * nz;
  const std::int64_t edges = grid_edges(nx, ny, nz);
  const std::int64_t xy_faces = nx * ny * (nz + 1);
  const std::int64_t all_faces = xy_faces + nx * (ny + 1) * nz + (nx + 1) * ny * nz;
  switch (t) {
    case ElementType::Tet4:
      return {nv, 6 * cells};
    case ElementType::Tet10:
      return {nv + edges + all_faces + cells, 6 * cells};
    case ElementType::Wedge6:
      return {nv, 2 * cells};
    case ElementType::Wedge15:
      return {nv + edges + xy_faces, 2 * cells};
    case ElementType::Hex8:
      return {nv, cells};
    case ElementType::Hex20:
      return {nv + edges, cells};
  }
  return {0, 0};
}
/// Nodes on a face normal to axis d of an nx x ny x nz box.
std::int64_t face_count(ElementType t, int d, const std::int64_t n[3]) {
  const std::int64_t a = n[(d + 1) % 3], b = n[(d + 2) % 3];
  std::int64_t count = (a + 1) * (b + 1);
  if (!morse::mesh::is_quadratic(t)) return count;
  count += a * (b + 1) + (a + 1) * b;                       // grid edges in the face
  if (t == ElementType::Tet10) count += a * b;              // one diagonal per face quad
  if (t == ElementType::Wedge15 && d == 2) count += a * b;  // diagonals of x-y quads
  return count;
}

void expect_same_mesh(const Mesh& a, const Mesh& b) {
  EXPECT_EQ(a.node_ids, b.node_ids);
  EXPECT_EQ(a.coords, b.coords);  // bit-identical
  EXPECT_EQ(a.elem_types, b.elem_types);
  EXPECT_EQ(a.elem_offsets, b.elem_offsets);
  EXPECT_EQ(a.elem_nodes, b.elem_nodes);
  EXPECT_EQ(a.elem_ids, b.elem_ids);
  EXPECT_EQ(a.node_sets, b.node_sets);
  EXPECT_EQ(a.elem_sets, b.elem_sets);
}

// ---------------------------------------------------------------------------------------------
// Generator

class GeneratorTest : public ::testing::TestWithParam<ElementType> {};

void check_box(const BoxSpec& s) {
  SCOPED_TRACE(morse::cat(morse::mesh::element_name(s.type), " distortion ", s.distortion));
  const Mesh m = morse::mesh::generate_box(s);
  const std::int64_t n[3] = {s.nx, s.ny, s.nz};
  const Counts c = box_counts(s.type, s.nx, s.ny, s.nz);
  ASSERT_EQ(m.num_nodes(), c.nodes);
  ASSERT_EQ(m.num_elements(), c.elems);
  ASSERT_EQ(m.coords.size(), 3 * m.node_ids.size());
  for (std::int64_t k = 0; k < m.num_nodes(); ++k) EXPECT_EQ(m.node_ids[k], k + 1);
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    EXPECT_EQ(m.elem_ids[e], e + 1);
    EXPECT_EQ(m.elem_types[e], s.type);
    EXPECT_EQ(m.elem_material[e], -1);
    EXPECT_EQ(m.elem_offsets[e + 1] - m.elem_offsets[e], morse::mesh::nodes_per_element(s.type));
  }
  EXPECT_TRUE(m.materials.empty());

  // Positive Jacobians, total volume, mid-edge nodes at edge midpoints.
  const double volume = s.lx * s.ly * s.lz;
  double total = 0;
  const auto& mids = morse::mesh::mid_edges(s.type);
  const int nvert = morse::mesh::vertices_per_element(s.type);
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    const auto xyz = element_xyz(m, e);
    ASSERT_GT(morse::fe::min_jacobian(s.type, xyz.data()), 0) << "element " << e;
    total += morse::fe::element_volume(s.type, xyz.data());
    for (std::size_t k = 0; k < mids.size(); ++k)
      for (int d = 0; d < 3; ++d)
        EXPECT_NEAR(xyz[3 * (nvert + k) + d], 0.5 * (xyz[3 * mids[k].first + d] + xyz[3 * mids[k].second + d]), 1e-15);
  }
  EXPECT_NEAR(total, volume, 1e-12);

  // Face sets: exact coordinates and closed-form counts; "all" sets.
  const char* names[3][2] = {{"x0", "x1"}, {"y0", "y1"}, {"z0", "z1"}};
  const double len[3] = {s.lx, s.ly, s.lz};
  for (int d = 0; d < 3; ++d)
    for (int side = 0; side < 2; ++side) {
      ASSERT_TRUE(m.node_sets.count(names[d][side])) << names[d][side];
      const auto& set = m.node_sets.at(names[d][side]);
      const double plane = s.origin[d] + (side ? len[d] : 0.0);
      EXPECT_EQ(static_cast<std::int64_t>(set.size()), face_count(s.type, d, n)) << names[d][side];
      for (auto v : set) EXPECT_EQ(m.coords[3 * v + d], plane) << names[d][side];
      std::int64_t on_plane = 0;
      for (std::int64_t k = 0; k < m.num_nodes(); ++k) on_plane += m.coords[3 * k + d] == plane;
      EXPECT_EQ(on_plane, static_cast<std::int64_t>(set.size())) << names[d][side];
      EXPECT_TRUE(std::is_sorted(set.begin(), set.end()));
    }
  EXPECT_EQ(m.node_sets.size(), 7u);
  EXPECT_EQ(static_cast<std::int64_t>(m.node_sets.at("all").size()), m.num_nodes());
  ASSERT_EQ(m.elem_sets.size(), 1u);
  EXPECT_EQ(static_cast<std::int64_t>(m.elem_sets.at("all").size()), m.num_elements());

  // Every coordinate inside the box.
  for (std::int64_t k = 0; k < m.num_nodes(); ++k)
    for (int d = 0; d < 3; ++d) {
      EXPECT_GE(m.coords[3 * k + d], s.origin[d]);
      EXPECT_LE(m.coords[3 * k + d], s.origin[d] + len[d]);
    }
}

TEST_P(GeneratorTest, RegularBox) {
  BoxSpec s;
  s.type = GetParam();
  s.lx = 2.0;
  s.ly = 0.5;
  s.lz = 0.7;
  s.nx = 3;
  s.ny = 2;
  s.nz = 4;
  check_box(s);
}

TEST_P(GeneratorTest, DefaultBeam) {
  BoxSpec s;
  s.type = GetParam();
  check_box(s);
  const Mesh m = morse::mesh::generate_box(s);
  EXPECT_EQ(m.source, morse::cat("box ", morse::mesh::element_name(s.type), " 10x1x1 size 1x0.1x0.1"));
}

TEST_P(GeneratorTest, DistortedBoxWithOrigin) {
  BoxSpec s;
  s.type = GetParam();
  s.lx = 1.0;
  s.ly = 1.5;
  s.lz = 0.8;
  s.nx = 4;
  s.ny = 5;
  s.nz = 3;
  s.origin = {-1.0, 2.0, 0.25};
  s.distortion = 0.2;
  s.seed = 7;
  check_box(s);
  // Interior vertices actually moved.
  const Mesh m = morse::mesh::generate_box(s);
  s.distortion = 0;
  const Mesh r = morse::mesh::generate_box(s);
  EXPECT_NE(m.coords, r.coords);
  EXPECT_EQ(m.elem_nodes, r.elem_nodes);
}

TEST_P(GeneratorTest, Deterministic) {
  BoxSpec s;
  s.type = GetParam();
  s.nx = 3;
  s.ny = 3;
  s.nz = 2;
  s.distortion = 0.15;
  const Mesh a = morse::mesh::generate_box(s);
  const Mesh b = morse::mesh::generate_box(s);
  expect_same_mesh(a, b);
  EXPECT_EQ(a.source, b.source);
  s.seed = 2;
  const Mesh c = morse::mesh::generate_box(s);
  EXPECT_NE(a.coords, c.coords);
}

INSTANTIATE_TEST_SUITE_P(AllTypes, GeneratorTest, ::testing::ValuesIn(kAllTypes),
                         [](const ::testing::TestParamInfo<ElementType>& info) {
                           return std::string(morse::mesh::element_name(info.param));
                         });

TEST(Generator, RejectsBadSpecs) {
  BoxSpec s;
  s.nx = 0;
  EXPECT_THROW(morse::mesh::generate_box(s), Error);
  s = BoxSpec();
  s.ly = -1;
  EXPECT_THROW(morse::mesh::generate_box(s), Error);
  s = BoxSpec();
  s.distortion = 0.5;
  EXPECT_THROW(morse::mesh::generate_box(s), Error);
}

// ---------------------------------------------------------------------------------------------
// Gmsh reader on hand-written files
//
// Two unit hex8 cells along x. Node (i,j,k) has tag 10*(1 + i + 3j + 6k) (non-contiguous), at
// (i,j,k). Physical groups: point 5 "tip" (node 30), surface 3 "clamp face" (quad on x = 0),
// volume 1 "body" (both hexes), volume 7 unnamed (second hex, element tag 9).

const char* kMsh41 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Comments
anything, even $Nodes
$EndComments
$PhysicalNames
3
0 5 "tip"
2 3 "clamp face"
3 1 "body"
$EndPhysicalNames
$Entities
1 1 1 2
1 2 0 0 1 5
1 0 0 0 2 0 0 0 2 1 -2
1 0 0 0 0 1 1 1 3 4 1 2 3 4
1 0 0 0 1 1 1 1 1 6 1 2 3 4 5 6
2 1 0 0 2 1 1 2 1 7 6 7 8 9 10 11 12
$EndEntities
$Nodes
2 12 10 120
2 1 1 4
10
40
70
100
0 0 0 0.5 0.5
0 1 0 0.5 0.5
0 0 1 0.5 0.5
0 1 1 0.5 0.5
3 1 0 8
20
30
50
60
80
90
110
120
1 0 0
2 0 0
1 1 0
2 1 0
1 0 1
2 0 1
1 1 1
2 1 1
$EndNodes
$Elements
5 6 1 9
0 1 15 1
1 30
1 1 1 2
2 10 20
3 20 30
2 1 3 1
4 10 40 100 70
3 1 5 1
5 10 20 50 40 70 80 110 100
3 2 5 1
9 20 30 60 50 80 90 120 110
$EndElements
)";

// The same mesh in MSH 2.2; the second hex is written once per physical group, under a new tag,
// as Gmsh does.
const char* kMsh22 = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
3
0 5 "tip"
2 3 "clamp face"
3 1 "body"
$EndPhysicalNames
$Nodes
12
10 0 0 0
40 0 1 0
70 0 0 1
100 0 1 1
20 1 0 0
30 2 0 0
50 1 1 0
60 2 1 0
80 1 0 1
90 2 0 1
110 1 1 1
120 2 1 1
$EndNodes
$Elements
7
1 15 2 5 1 30
2 1 2 0 1 10 20
3 1 2 0 1 20 30
4 3 2 3 1 10 40 100 70
5 5 2 1 1 10 20 50 40 70 80 110 100
9 5 2 1 2 20 30 60 50 80 90 120 110
12 5 2 7 2 20 30 60 50 80 90 120 110
$EndElements
)";

void check_two_hex_mesh(const Mesh& m, const std::string& path) {
  EXPECT_EQ(m.source, path);
  const std::vector<std::int64_t> ids = {10, 40, 70, 100, 20, 30, 50, 60, 80, 90, 110, 120};
  ASSERT_EQ(m.node_ids, ids);
  auto index = [&](std::int64_t tag) {
    return static_cast<std::int64_t>(std::find(ids.begin(), ids.end(), tag) - ids.begin());
  };
  for (std::int64_t k = 0; k < m.num_nodes(); ++k) {
    const std::int64_t t = ids[k] / 10 - 1;
    EXPECT_EQ(m.coords[3 * k], t % 3);
    EXPECT_EQ(m.coords[3 * k + 1], (t / 3) % 2);
    EXPECT_EQ(m.coords[3 * k + 2], t / 6);
  }
  ASSERT_EQ(m.num_elements(), 2);
  EXPECT_EQ(m.elem_ids, (std::vector<std::int64_t>{5, 9}));
  EXPECT_EQ(m.elem_types, (std::vector<ElementType>{ElementType::Hex8, ElementType::Hex8}));
  EXPECT_EQ(m.elem_material, (std::vector<int>{-1, -1}));
  std::vector<std::int64_t> conn;
  for (std::int64_t t : {10, 20, 50, 40, 70, 80, 110, 100, 20, 30, 60, 50, 80, 90, 120, 110}) conn.push_back(index(t));
  EXPECT_EQ(m.elem_nodes, conn);

  auto sorted = [&](std::vector<std::int64_t> tags) {
    std::vector<std::int64_t> v;
    for (auto t : tags) v.push_back(index(t));
    std::sort(v.begin(), v.end());
    return v;
  };
  std::vector<std::int64_t> all(12);
  for (int k = 0; k < 12; ++k) all[k] = k;
  std::map<std::string, std::vector<std::int64_t>> nsets = {
      {"tip", sorted({30})},
      {"clamp face", sorted({10, 40, 70, 100})},
      {"body", all},
      {"physical_3_7", sorted({20, 30, 60, 50, 80, 90, 120, 110})}};
  EXPECT_EQ(m.node_sets, nsets);
  std::map<std::string, std::vector<std::int64_t>> esets = {{"body", {0, 1}}, {"physical_3_7", {1}}};
  EXPECT_EQ(m.elem_sets, esets);
}

TEST(GmshRead, Format41) {
  TempFile f("two_hex41.msh", kMsh41);
  check_two_hex_mesh(morse::mesh::read_gmsh(f.path), f.path);
}

TEST(GmshRead, Format22) {
  TempFile f("two_hex22.msh", kMsh22);
  check_two_hex_mesh(morse::mesh::read_gmsh(f.path), f.path);
  // The repeated element may also keep its tag.
  std::string same_tag = kMsh22;
  same_tag.replace(same_tag.find("12 5 2 7"), 8, "9 5 2 7");
  TempFile g("two_hex22_same_tag.msh", same_tag);
  check_two_hex_mesh(morse::mesh::read_gmsh(g.path), g.path);
}

TEST(GmshRead, QuadraticTypes22AndUnnamedGroups) {
  // One tet10 on tags 1..10, one wedge15 + one hex20 sharing nothing: checks the node counts of
  // the quadratic types and the "physical_<dim>_<tag>" names of unnamed groups.
  std::string text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n45\n";
  for (int k = 1; k <= 45; ++k) text += morse::cat(k, " ", k, " ", 2 * k, " ", 3 * k, "\n");
  text += "$EndNodes\n$Elements\n4\n";
  text += "1 11 2 4 1";
  for (int k = 1; k <= 10; ++k) text += morse::cat(" ", k);
  text += "\n2 18 2 4 1";
  for (int k = 11; k <= 25; ++k) text += morse::cat(" ", k);
  text += "\n3 17 0";
  for (int k = 26; k <= 45; ++k) text += morse::cat(" ", k);
  text += "\n4 9 2 2 1 1 2 3 4 5 6\n$EndElements\n";
  TempFile f("quadratic22.msh", text);
  const Mesh m = morse::mesh::read_gmsh(f.path);
  EXPECT_EQ(m.elem_types, (std::vector<ElementType>{ElementType::Tet10, ElementType::Wedge15, ElementType::Hex20}));
  EXPECT_EQ(m.elem_offsets, (std::vector<std::int64_t>{0, 10, 25, 45}));
  EXPECT_EQ(m.elem_sets.at("physical_3_4"), (std::vector<std::int64_t>{0, 1}));
  EXPECT_EQ(m.node_sets.at("physical_3_4").size(), 25u);
  EXPECT_EQ(m.node_sets.at("physical_2_2"), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(m.node_sets.size(), 2u);
  EXPECT_EQ(m.elem_sets.size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// Round trip

TEST_P(GeneratorTest, GmshRoundTrip) {
  BoxSpec s;
  s.type = GetParam();
  s.nx = 3;
  s.ny = 2;
  s.nz = 2;
  s.distortion = 0.1;
  s.origin = {0.1, -0.3, 1e-7};
  Mesh m = morse::mesh::generate_box(s);
  // Non-contiguous ids and sets that do not match each other.
  for (auto& id : m.node_ids) id = 3 * id + 1000;
  for (auto& id : m.elem_ids) id = 7 * id + 5;
  m.node_sets["empty"] = {};
  m.node_sets["with space"] = {0, 5, m.num_nodes() - 1};
  m.elem_sets["none"] = {};
  m.elem_sets["first half"].clear();
  for (std::int64_t e = 0; e < m.num_elements() / 2; ++e) m.elem_sets["first half"].push_back(e);
  m.elem_sets["odd"].clear();
  for (std::int64_t e = 1; e < m.num_elements(); e += 2) m.elem_sets["odd"].push_back(e);

  TempFile f(morse::cat("roundtrip_", morse::mesh::element_name(s.type), ".msh"));
  morse::mesh::write_gmsh(m, f.path);
  EXPECT_FALSE(std::ifstream(f.path + ".tmp").good()) << "temporary file left behind";
  EXPECT_FALSE(std::ifstream(morse::files::temp_path(f.path)).good()) << "temporary file left behind";
  const Mesh r = morse::mesh::read_gmsh(f.path);
  expect_same_mesh(m, r);
  EXPECT_EQ(r.source, f.path);

  // Writing the read mesh again gives the same file.
  TempFile g(morse::cat("roundtrip2_", morse::mesh::element_name(s.type), ".msh"));
  morse::mesh::write_gmsh(r, g.path);
  std::ifstream a(f.path), b(g.path);
  std::string ta((std::istreambuf_iterator<char>(a)), {}), tb((std::istreambuf_iterator<char>(b)), {});
  EXPECT_EQ(ta, tb);
}

TEST(GmshWrite, Errors) {
  Mesh m = morse::mesh::generate_box(BoxSpec());
  EXPECT_THROW(morse::mesh::write_gmsh(m, "/nonexistent_dir_morse/x.msh"), Error);
  Mesh bad = m;
  bad.node_ids[3] = 0;
  EXPECT_THROW(morse::mesh::write_gmsh(bad, temp_path("bad.msh")), Error);
  bad = m;
  bad.node_sets["quote\"d"] = {1};
  EXPECT_THROW(morse::mesh::write_gmsh(bad, temp_path("bad.msh")), Error);
}

// A 200k-node tet10 mesh: write and read back, report the times.
TEST(GmshRead, LargeMeshIsFast) {
  BoxSpec s;
  s.type = ElementType::Tet10;
  s.nx = s.ny = s.nz = 29;
  s.lx = s.ly = s.lz = 1.0;
  s.distortion = 0.1;
  const Mesh m = morse::mesh::generate_box(s);
  ASSERT_GT(m.num_nodes(), 200000);
  TempFile f("large.msh");
  using clock = std::chrono::steady_clock;
  auto t0 = clock::now();
  morse::mesh::write_gmsh(m, f.path);
  auto t1 = clock::now();
  const Mesh r = morse::mesh::read_gmsh(f.path);
  auto t2 = clock::now();
  const double tw = std::chrono::duration<double>(t1 - t0).count();
  const double tr = std::chrono::duration<double>(t2 - t1).count();
  std::cout << "[ timing ] " << m.num_nodes() << " nodes, " << m.num_elements() << " tet10: write " << tw << " s, read "
            << tr << " s\n";
  expect_same_mesh(m, r);
  EXPECT_LT(tr, 10.0);  // loose bound: shared CI machines; typically well under 1 s
}

// ---------------------------------------------------------------------------------------------
// Errors: each message names the file and the line

void expect_error(const std::string& msg, const std::string& path, int line, const std::string& what) {
  SCOPED_TRACE(msg);
  EXPECT_NE(msg.find(morse::cat(path, ":", line, ":")), std::string::npos) << "expected line " << line;
  EXPECT_NE(msg.find(what), std::string::npos) << "expected '" << what << "'";
}

TEST(GmshErrors, MissingFile) {
  const std::string path = temp_path("does_not_exist.msh");
  try {
    morse::mesh::read_gmsh(path);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
}

TEST(GmshErrors, Truncated) {
  const std::string full = kMsh41;
  // Cut inside the coordinates of the second node block.
  const std::string cut_nodes = full.substr(0, full.find("2 0 1\n"));
  TempFile f("trunc1.msh", cut_nodes);
  std::string msg;
  try {
    morse::mesh::read_gmsh(f.path);
  } catch (const Error& e) {
    msg = e.what();
  }
  expect_error(msg, f.path, line_of(full, "1 0 1\n"), "truncated");
  EXPECT_NE(msg.find("$Nodes"), std::string::npos) << msg;

  // Missing $EndElements.
  const std::string cut_end = full.substr(0, full.find("$EndElements"));
  TempFile g("trunc2.msh", cut_end);
  msg.clear();
  try {
    morse::mesh::read_gmsh(g.path);
  } catch (const Error& e) {
    msg = e.what();
  }
  expect_error(msg, g.path, line_of(full, "9 20 30 60"), "$EndElements");

  // A section shorter than its count (2.2: 12 nodes announced, 11 given).
  std::string short22 = kMsh22;
  short22.erase(short22.find("120 2 1 1\n"), 10);
  msg = read_error("trunc3.msh", short22);
  expect_error(msg, temp_path("trunc3.msh"), line_of(short22, "$EndNodes"), "$EndNodes");
}

TEST(GmshErrors, UnsupportedElementType) {
  std::string text = kMsh41;
  const std::string hex = "3 2 5 1\n9 20 30 60 50 80 90 120 110\n";
  text.replace(text.find(hex), hex.size(), "3 2 7 1\n9 20 30 60 50 80\n");
  const std::string msg = read_error("pyramid41.msh", text);
  expect_error(msg, temp_path("pyramid41.msh"), line_of(text, "3 2 7 1"), "type 7");
  EXPECT_NE(msg.find("pyramid"), std::string::npos) << msg;

  std::string text22 = kMsh22;
  const std::string hex22 = "12 5 2 7 2 20 30 60 50 80 90 120 110";
  text22.replace(text22.find(hex22), hex22.size(), "12 12 2 7 2 20 30 60 50 80 90 120 110");
  const std::string msg22 = read_error("hex27_22.msh", text22);
  expect_error(msg22, temp_path("hex27_22.msh"), line_of(text22, "12 12 2 7"), "type 12");

  std::string unknown = kMsh22;
  unknown.replace(unknown.find("2 1 2 0 1 10 20"), 15, "2 99 2 0 1 10 20");
  const std::string msg99 = read_error("type99.msh", unknown);
  expect_error(msg99, temp_path("type99.msh"), line_of(unknown, "2 99 2"), "type 99");
}

TEST(GmshErrors, UndefinedNode) {
  std::string text = kMsh41;
  text.replace(text.find("9 20 30 60"), 10, "9 20 31 60");
  expect_error(read_error("undef41.msh", text), temp_path("undef41.msh"), line_of(text, "9 20 31 60"), "node 31");

  std::string text22 = kMsh22;
  text22.replace(text22.find("4 3 2 3 1 10 40"), 15, "4 3 2 3 1 10 45");
  expect_error(read_error("undef22.msh", text22), temp_path("undef22.msh"), line_of(text22, "4 3 2 3 1 10 45"),
               "node 45");
}

TEST(GmshErrors, BinaryAndVersion) {
  const std::string bin = std::string("$MeshFormat\n4.1 1 8\n") + '\x01' + '\0' + '\0' + '\0' + "\n$EndMeshFormat\n";
  expect_error(read_error("binary.msh", bin), temp_path("binary.msh"), 2,
               "binary .msh not supported, re-save as ASCII");
  expect_error(read_error("v40.msh", "$MeshFormat\n4 0 8\n$EndMeshFormat\n"), temp_path("v40.msh"), 2, "version 4");
  expect_error(read_error("notmsh.msh", "hello\n"), temp_path("notmsh.msh"), 1, "hello");
}

TEST(GmshErrors, MalformedNumbers) {
  std::string text = kMsh41;
  text.replace(text.find("2 1 1\n"), 6, "2 1 x1\n");
  expect_error(read_error("badnum.msh", text), temp_path("badnum.msh"), line_of(text, "2 1 x1"), "x1");
  std::string text2 = kMsh22;
  text2.replace(text2.find("50 1 1 0"), 8, "50 1 1.0.0 0");
  expect_error(read_error("badnum22.msh", text2), temp_path("badnum22.msh"), line_of(text2, "1.0.0"), "1.0.0");
  std::string text3 = kMsh22;
  text3.replace(text3.find("5 5 2 1 1 10"), 12, "5 5 2 1 1 1e1");
  expect_error(read_error("badint22.msh", text3), temp_path("badint22.msh"), line_of(text3, "1e1"), "1e1");
}

TEST(GmshErrors, DuplicatesAndNoSolids) {
  std::string text = kMsh22;
  text.replace(text.find("40 0 1 0"), 8, "10 0 1 0");
  expect_error(read_error("dupnode.msh", text), temp_path("dupnode.msh"), line_of(text, "10 0 1 0"), "node tag 10");

  std::string dup_elem = kMsh22;
  dup_elem.replace(dup_elem.find("12 5 2 7 2 20 30"), 16, "9 5 2 7 2 20 60");
  const std::string msg = read_error("dupelem.msh", dup_elem);
  expect_error(msg, temp_path("dupelem.msh"), line_of(dup_elem, "9 5 2 7 2 20 60"), "element tag 9");

  const std::string flat =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n"
      "$Elements\n1\n1 2 2 1 1 1 2 3\n$EndElements\n";
  expect_error(read_error("flat.msh", flat), temp_path("flat.msh"), 13, "no supported 3D");
}

// A count cannot promise more entries than the rest of the file has bytes for (2 per number at
// least): refused before anything is allocated (a node block of 2e9 entries took 16 GB), naming
// the line of the count.
TEST(GmshErrors, CountsBeyondTheFileSize) {
  const std::string head = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n";
  const std::string header = head + "1 1000000000000 1 1000000000000\n3 1 0 1\n1\n0 0 0\n$EndNodes\n";
  std::string msg = read_error("header.msh", header);
  expect_error(msg, temp_path("header.msh"), 5, "the number of nodes is 1000000000000, but the ");
  EXPECT_NE(msg.find("bytes left in the file hold at most"), std::string::npos) << msg;
  const std::string block = head + "1 2 1 2\n3 1 0 2000000000\n1\n2\n0 0 0\n1 0 0\n$EndNodes\n";
  expect_error(read_error("block.msh", block), temp_path("block.msh"), 6, "nodes in the block is 2000000000");
  const std::string v2 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n999999999\n1 0 0 0\n$EndNodes\n";
  expect_error(read_error("v2.msh", v2), temp_path("v2.msh"), 5, "the number of nodes is 999999999");
  const std::string elems = std::string(kMsh41).substr(0, std::string(kMsh41).find("$Elements")) +
                            "$Elements\n1 123456789 1 2\n3 1 5 2\n1 10 20 50 40 70 80 110 100\n$EndElements\n";
  expect_error(read_error("elems.msh", elems), temp_path("elems.msh"), line_of(elems, "1 123456789"),
               "the number of elements is 123456789");
}

// A generated box whose mesh and file text cannot fit in the memory available is refused before
// it is built, saying what it needs.
TEST(Generator, RefusesABoxBeyondTheMemory) {
  BoxSpec s;
  s.type = ElementType::Tet10;
  s.nx = 1000, s.ny = 1000, s.nz = 260;
  try {
    morse::mesh::generate_box(s);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("a box of 1000x1000x260 tet10 cells (1560000000 elements) needs ", 0), 0u)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("for the mesh and the text of its file; "), std::string::npos) << e.what();
  }
}

}  // namespace

// Materials survive a write/read round trip ($MorseMaterials section), including elements
// without material (-1).
TEST(GmshRoundTrip, Materials) {
  BoxSpec spec;
  spec.type = ElementType::Wedge15;
  spec.nx = 3;
  Mesh m = generate_box(spec);
  m.materials.push_back({"steel A", 2.1e11, 0.3, 7800.0});
  m.materials.push_back({"titanium", 1.1e11, 0.34, 4430.0});
  for (std::int64_t e = 0; e < m.num_elements(); ++e) m.elem_material[e] = static_cast<int>(e % 3) - 1;
  const std::string path = temp_path("materials.msh");
  morse::mesh::write_gmsh(m, path);
  Mesh r = morse::mesh::read_gmsh(path);
  std::remove(path.c_str());
  ASSERT_EQ(r.materials.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(r.materials[i].name, m.materials[i].name);
    EXPECT_EQ(r.materials[i].E, m.materials[i].E);
    EXPECT_EQ(r.materials[i].nu, m.materials[i].nu);
    EXPECT_EQ(r.materials[i].rho, m.materials[i].rho);
  }
  EXPECT_EQ(r.elem_material, m.elem_material);
}
