// Superelement export (io/export.hpp, `morse export`): a real Craig-Bampton superelement of
// a box, made by `morse reduce` (app::run_command, on every rank), is exported in every format and
// read back by small readers written here, independent of the writers:
//   - the MBDyn FEM file by a reader that follows MBDyn's ReadModal (mbdyn/struct/modal.cc): record
//     groups found by their "** RECORD GROUP n" line, one comment line after record 1's, a "**"
//     header line before each mode of record 8, numbers read as a free stream;
//   - the DMIG deck by a fixed-column large-field parser (DMIG*, GRID*, SPOINT ... THRU);
//   - the OP4 file by io::Op4Reader, the MatrixMarket files and the DOF map by plain parsers.
// Each is compared with /rom of the HDF5 file: exactly (17 significant digits) for MBDyn, OP4 and
// MatrixMarket, to the 16-character field's precision for DMIG. The rigid-body inertia of the
// MBDyn file is checked against the closed form of the box and against the full model's mass
// matrix (rigid vectors on every DOF), which does not go through the superelement.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "morse/app/commands.hpp"
#include "morse/core/session.hpp"
#include "morse/io/export.hpp"
#include "morse/io/h5.hpp"
#include "morse/io/op4.hpp"
#include "morse/mesh/gmsh.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
namespace fs = std::filesystem;

namespace {

// The box: its own dimensions, not at the origin's centre, so that every first moment is nonzero.
constexpr double kLx = 1.2, kLy = 0.3, kLz = 0.2;
constexpr double kRho = 7800;

using Dense = std::vector<double>;

double rel_diff(const Dense& a, const Dense& b) {
  double d = 0, r = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    d += (a[k] - b[k]) * (a[k] - b[k]);
    r += a[k] * a[k];
  }
  return std::sqrt(d / r);
}

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(' ');
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(' ') - a + 1);
}

// ---------------------------------------------------------------------------------------------
// MBDyn FEM file, read the way ReadModal reads it.
struct Fem {
  int n_nodes = 0, n_normal = 0, n_attached = 0, n_constraint = 0, n_rejected = 0, n_modes = 0;
  std::string rev;
  std::vector<std::string> labels;
  Dense q0, v0, x, y, z;
  Dense shapes;  // [mode][node][6]
  Dense M, K, C;
  bool has12 = false, has13 = false;
  double mass = 0;
  std::array<double, 3> cm{};
  std::array<double, 9> J{};
  std::set<int> groups;
};

Fem read_fem(const std::string& path) {
  std::ifstream f(path);
  EXPECT_TRUE(f) << path;
  Fem r;
  std::string line;
  auto reals = [&](std::size_t count, Dense* out) {
    out->resize(count);
    for (auto& v : *out) f >> v;
  };
  while (std::getline(f, line)) {
    if (line.rfind("** END OF FILE", 0) == 0) break;
    if (line.rfind("** RECORD GROUP ", 0) != 0) continue;
    const int g = std::atoi(line.c_str() + 16);
    EXPECT_TRUE(r.groups.insert(g).second) << "record group " << g << " twice";
    EXPECT_TRUE(g == 1 || r.groups.count(1)) << "record group " << g << " before the header";
    const auto nm = static_cast<std::size_t>(r.n_modes);
    switch (g) {
      case 1:
        std::getline(f, line);  // ReadModal skips one line before the counts
        f >> r.rev >> r.n_nodes >> r.n_normal >> r.n_attached >> r.n_constraint >> r.n_rejected;
        r.n_modes = r.n_normal + r.n_attached + r.n_constraint - r.n_rejected;
        break;
      case 2:
        r.labels.resize(r.n_nodes);
        for (auto& l : r.labels) f >> l;
        break;
      case 3:
        reals(nm, &r.q0);
        break;
      case 4:
        reals(nm, &r.v0);
        break;
      case 5:
        reals(r.n_nodes, &r.x);
        break;
      case 6:
        reals(r.n_nodes, &r.y);
        break;
      case 7:
        reals(r.n_nodes, &r.z);
        break;
      case 8:
        r.shapes.resize(nm * r.n_nodes * 6);
        for (std::size_t j = 0; j < nm; ++j) {
          std::getline(f, line);
          EXPECT_TRUE(line.empty() || line.rfind("**", 0) == 0) << "mode " << j + 1 << ": header '" << line << "'";
          for (int k = 0; k < r.n_nodes * 6; ++k) f >> r.shapes[j * r.n_nodes * 6 + k];
          std::getline(f, line);  // rest of the last line of the mode
        }
        break;
      case 9:
        reals(nm * nm, &r.M);
        break;
      case 10:
        reals(nm * nm, &r.K);
        break;
      case 12:
        r.has12 = true;
        f >> r.mass >> r.cm[0] >> r.cm[1] >> r.cm[2];
        for (auto& v : r.J) f >> v;
        break;
      case 13:
        r.has13 = true;
        reals(nm * nm, &r.C);
        break;
      default:
        ADD_FAILURE() << "unexpected record group " << g;
    }
    EXPECT_FALSE(f.fail()) << path << ": record group " << g << " is short or malformed";
  }
  EXPECT_EQ(line.rfind("** END OF FILE", 0), 0u) << "no END OF FILE";
  for (int g : {1, 2, 5, 6, 7, 8, 9, 10})
    EXPECT_TRUE(r.groups.count(g)) << "record group " << g << " missing (required)";
  return r;
}

// ---------------------------------------------------------------------------------------------
// Nastran bulk data: large-field DMIG*, GRID*, small-field SPOINT.
double nastran_real(std::string s) {
  s = trim(s);
  for (auto& ch : s)
    if (ch == 'D' || ch == 'd') ch = 'E';
  // Nastran's exponent without letter: "1.5-3" = 1.5E-3.
  if (s.find('E') == std::string::npos)
    for (std::size_t k = 1; k < s.size(); ++k)
      if (s[k] == '+' || s[k] == '-') {
        s.insert(k, "E");
        break;
      }
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);  // not stod: subnormals set ERANGE
  EXPECT_EQ(*end, '\0') << "real field '" << s << "'";
  EXPECT_NE(s.find('.'), std::string::npos) << "a Nastran real needs a decimal point: '" << s << "'";
  return v;
}

struct Dmig {
  int ifo = 0, tin = 0;
  std::map<std::pair<long long, int>, std::map<std::pair<long long, int>, double>> columns;  // [col][row]
};
struct Deck {
  std::map<std::string, Dmig> dmig;
  std::set<long long> spoints;
  std::map<long long, std::array<double, 3>> grids;
};

void read_deck(const std::string& path, Deck* d) {
  std::ifstream f(path);
  EXPECT_TRUE(f) << path;
  std::string line, card;
  std::pair<long long, int> col{-1, -1};
  std::string name;
  long long grid = -1;
  auto field = [&](int k) { return line.size() > 8u + 16u * (k - 1) ? line.substr(8 + 16 * (k - 1), 16) : ""; };
  while (std::getline(f, line)) {
    EXPECT_LE(line.size(), 80u) << line;
    if (line.empty() || line[0] == '$') continue;
    const std::string head = trim(line.substr(0, 8));
    if (head == "SPOINT") {
      const long long a = std::stoll(line.substr(8, 8));
      if (line.size() > 16 && trim(line.substr(16, 8)) == "THRU") {
        const long long b = std::stoll(line.substr(24, 8));
        for (long long id = a; id <= b; ++id) d->spoints.insert(id);
      } else {
        d->spoints.insert(a);
      }
      card.clear();
    } else if (head == "DMIG*") {
      card = "DMIG";
      name = trim(field(1));
      const long long gj = std::stoll(trim(field(2)));
      if (gj == 0) {  // header: NAME 0 IFO TIN, continuation TOUT
        d->dmig[name].ifo = std::stoi(trim(field(3)));
        d->dmig[name].tin = std::stoi(trim(field(4)));
        col = {0, 0};
      } else {
        col = {gj, std::stoi(trim(field(3)))};
      }
    } else if (head == "GRID*") {
      card = "GRID";
      grid = std::stoll(trim(field(1)));
      EXPECT_EQ(trim(field(2)), "") << "CP";
      d->grids[grid] = {nastran_real(field(3)), nastran_real(field(4)), 0.0};
    } else if (head == "*") {
      if (card == "DMIG" && col.first > 0) {
        const std::pair<long long, int> row{std::stoll(trim(field(1))), std::stoi(trim(field(2)))};
        EXPECT_TRUE(d->dmig[name].columns[col].emplace(row, nastran_real(field(3))).second) << "entry twice";
      } else if (card == "GRID") {
        d->grids[grid][2] = nastran_real(field(1));
        EXPECT_EQ(trim(field(2)), "") << "CD";
      } else if (card == "DMIG") {
        EXPECT_EQ(std::stoi(trim(field(1))), 0) << "TOUT";
      }
    } else {
      ADD_FAILURE() << "unexpected card: " << line;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// MatrixMarket coordinate file (general or symmetric) as a dense row-major matrix.
Dense read_mtx(const std::string& path, int n) {
  std::ifstream f(path);
  EXPECT_TRUE(f) << path;
  std::string line;
  std::getline(f, line);
  const bool sym = line.find("symmetric") != std::string::npos;
  EXPECT_EQ(line.rfind("%%MatrixMarket matrix coordinate real", 0), 0u) << line;
  while (std::getline(f, line) && line[0] == '%') {
  }
  long long rows = 0, cols = 0, nnz = 0;
  std::istringstream(line) >> rows >> cols >> nnz;
  EXPECT_EQ(rows, n);
  EXPECT_EQ(cols, n);
  Dense A(static_cast<std::size_t>(n) * n, 0.0);
  for (long long k = 0; k < nnz; ++k) {
    long long i = 0, j = 0;
    double v = 0;
    f >> i >> j >> v;
    EXPECT_TRUE(f) << path << ": entry " << k;
    A[(i - 1) * n + (j - 1)] = v;
    if (sym) {
      EXPECT_GE(i, j) << "upper-triangle entry in a symmetric file";
      A[(j - 1) * n + (i - 1)] = v;
    }
  }
  return A;
}

Dense read_op4(const std::string& path, const std::string& name, int n) {
  io::Op4Reader r(path, name);
  EXPECT_EQ(r.header().nrows, n);
  EXPECT_EQ(r.header().ncols, n);
  Dense A(static_cast<std::size_t>(n) * n, 0.0);
  std::int64_t col;
  std::vector<std::int64_t> rows;
  Dense vals;
  while (r.next(&col, &rows, &vals))
    for (std::size_t k = 0; k < rows.size(); ++k) A[rows[k] * n + col] = vals[k];
  return A;
}

Dense h5(const std::string& file, const std::string& name) {
  Dense v;
  std::vector<hsize_t> d;
  std::string err;
  EXPECT_TRUE(io::read_doubles(file, name, &v, &d, &err)) << err;
  return v;
}

std::vector<std::int64_t> h5i(const std::string& file, const std::string& name) {
  std::vector<std::int64_t> v;
  std::vector<hsize_t> d;
  std::string err;
  EXPECT_TRUE(io::read_ints(file, name, &v, &d, &err)) << err;
  return v;
}

std::vector<std::string> files_in(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

void run(const std::string& command, const std::vector<std::pair<std::string, std::string>>& opts) {
  for (const auto& [k, v] : opts) MORSE_CALL(PetscOptionsSetValue(nullptr, k.c_str(), v.empty() ? nullptr : v.c_str()));
  try {
    app::run_command(PETSC_COMM_WORLD, command, {});
  } catch (...) {
    for (const auto& [k, v] : opts) PetscOptionsClearValue(nullptr, k.c_str());
    throw;
  }
  for (const auto& [k, v] : opts) MORSE_CALL(PetscOptionsClearValue(nullptr, k.c_str()));
}

}  // namespace

// Two superelements of one hex20 box, written once by `morse reduce` on every rank: `free_` with
// the boundary at x = 0 and nothing else clamped (it can move rigidly), with modal damping and the
// basis; `grounded_` clamped at x = 0 with the boundary at x = lx.
class ExportTest : public test::ScratchDirTest {
 protected:
  ExportTest() : ScratchDirTest("export") {}

  static void SetUpTestSuite() {
    base_ = std::make_unique<test::SharedScratchDir>("export");
    mesh_ = base_->path("box.msh");
    free_ = base_->path("free.h5");
    grounded_ = base_->path("grounded.h5");
    if (world_rank() == 0) {
      auto m = mesh::generate_box(test::box_spec(mesh::ElementType::Hex20, kLx, kLy, kLz, 4, 2, 1));
      mesh::write_gmsh(m, mesh_);
    }
    MPI_Barrier(PETSC_COMM_WORLD);
    const std::vector<std::pair<std::string, std::string>> material = {
        {"-material_E", "2.1e11"}, {"-material_nu", "0.3"}, {"-material_rho", cat(kRho)}};
    auto with = [&](std::vector<std::pair<std::string, std::string>> o) {
      o.insert(o.end(), material.begin(), material.end());
      return o;
    };
    run("reduce", with({{"-mesh", mesh_},
                        {"-boundary", "x0"},
                        {"-cb_num_fixed_modes", "6"},
                        {"-cb_damping", "0.02"},
                        {"-cb_write_basis", "true"},
                        {"-cb_xdmf", "false"},
                        {"-out", free_}}));
    run("reduce", with({{"-mesh", mesh_},
                        {"-clamp", "x0"},
                        {"-boundary", "x1"},
                        {"-cb_num_fixed_modes", "4"},
                        {"-out", grounded_}}));
  }
  static void TearDownTestSuite() { base_.reset(); }

  static std::unique_ptr<test::SharedScratchDir> base_;
  static std::string mesh_, free_, grounded_;
};
std::unique_ptr<test::SharedScratchDir> ExportTest::base_;
std::string ExportTest::mesh_, ExportTest::free_, ExportTest::grounded_;

TEST_F(ExportTest, ReadsTheRomOfTheFile) {
  const auto se = io::read_superelement(free_);
  const auto K = h5(free_, "/rom/K"), M = h5(free_, "/rom/M"), C = h5(free_, "/rom/C");
  const auto labels = h5i(free_, "/rom/boundary_dofs");
  EXPECT_EQ(se.K, K);
  EXPECT_EQ(se.M, M);
  EXPECT_EQ(se.C, C);
  ASSERT_EQ(se.n * se.n, static_cast<int>(K.size()));
  EXPECT_EQ(se.n_b, static_cast<int>(labels.size() / 2));
  EXPECT_EQ(se.n_modes(), 6);
  EXPECT_EQ(se.units, "SI");
  EXPECT_EQ(se.command, "reduce");
  EXPECT_TRUE(se.from_mesh);
  // The x = 0 face of a 4x2x1 hex20 box: 13 nodes, every one at x = 0.
  EXPECT_EQ(se.boundary_nodes.size(), 13u);
  EXPECT_EQ(se.n_b, 39);
  for (std::size_t k = 0; k < se.boundary_nodes.size(); ++k) EXPECT_EQ(se.boundary_xyz[3 * k], 0.0);
  // Modal frequencies from the diagonal of the fixed-interface block equal the file's.
  const auto fi = h5(free_, "/cb/fixed_interface/frequencies_hz");
  for (int k = 0; k < se.n_modes(); ++k) EXPECT_NEAR(se.modal_frequency_hz(k), fi[k], 1e-9 * fi[k]);
}

// io::write_superelement writes what read_superelement reads: every /rom dataset of the file of
// `morse reduce` the same to the last bit, and the fields of a select file (selected modes,
// selection method). Each rank writes and reads its own file (serial HDF5, PETSC_COMM_SELF).
TEST_F(ExportTest, WriteSuperelementRoundTrips) {
  const auto se = io::read_superelement(free_);
  EXPECT_EQ(se.frequencies_hz, h5(free_, "/rom/frequencies_hz"));
  EXPECT_EQ(se.damping_ratio, 0.02);
  EXPECT_TRUE(se.selected_modes.empty());
  auto written = se;
  written.selection_method = "EIM";
  written.selected_modes = {4, 0, 2, 1, 3, 5};
  const std::string file = path("rom.h5");
  {
    io::H5Output out(PETSC_COMM_SELF, file);
    io::write_superelement(out, written);
    out.commit();
  }
  const auto back = io::read_superelement(file);
  EXPECT_EQ(back.n, se.n);
  EXPECT_EQ(back.n_b, se.n_b);
  EXPECT_EQ(back.K, se.K);
  EXPECT_EQ(back.M, se.M);
  EXPECT_EQ(back.C, se.C);
  EXPECT_EQ(back.dof_node, se.dof_node);
  EXPECT_EQ(back.dof_component, se.dof_component);
  EXPECT_EQ(back.boundary_nodes, se.boundary_nodes);
  EXPECT_EQ(back.frequencies_hz, se.frequencies_hz);
  EXPECT_EQ(back.damping_ratio, se.damping_ratio);
  EXPECT_EQ(back.selection_method, "EIM");
  EXPECT_EQ(back.selected_modes, written.selected_modes);
  for (const char* name : {"/rom/K", "/rom/M", "/rom/C", "/rom/frequencies_hz"})
    EXPECT_EQ(h5(file, name), h5(free_, name)) << name;
  for (const char* name : {"/rom/boundary_dofs", "/rom/boundary_nodes"})
    EXPECT_EQ(h5i(file, name), h5i(free_, name)) << name;
  for (const char* a : {"n_boundary_dofs", "n_modes", "damping_ratio"}) {
    double x = -1, y = -2;
    std::string err;
    EXPECT_TRUE(io::read_attribute(file, "/rom", a, &x, &err)) << err;
    EXPECT_TRUE(io::read_attribute(free_, "/rom", a, &y, &err)) << err;
    EXPECT_EQ(x, y) << a;
  }
  EXPECT_EQ(io::read_string_attribute(file, "/rom", "dof_order"),
            io::read_string_attribute(free_, "/rom", "dof_order"));
  // Without C (no damping), no /rom/C.
  written.C.clear();
  const std::string undamped = path("undamped.h5");
  {
    io::H5Output out(PETSC_COMM_SELF, undamped);
    io::write_superelement(out, written);
    out.commit();
  }
  EXPECT_FALSE(io::has_object(undamped, "/rom/C"));
  EXPECT_TRUE(io::read_superelement(undamped).C.empty());
}

TEST_F(ExportTest, EveryFormatRoundTrips) {
  const auto se = io::read_superelement(free_);
  io::ExportOptions o;
  o.prefix = path("se");
  const auto res = io::export_superelement(se, o);
  EXPECT_EQ(files_in(dir_), (std::vector<std::string>{"se.fem", "se.op4", "se_C.mtx", "se_K.mtx", "se_M.mtx",
                                                      "se_dmig.bdf", "se_dofs.txt", "se_grids.bdf"}));
  EXPECT_EQ(res.files.size(), 8u);
  const int n = se.n, nb = se.n_b;
  const auto K = h5(free_, "/rom/K"), M = h5(free_, "/rom/M"), C = h5(free_, "/rom/C");

  // MBDyn: header counts, labels, coordinates, the constraint-mode pattern, the exact matrices.
  const Fem fem = read_fem(path("se.fem"));
  EXPECT_EQ(fem.n_nodes, 13);
  EXPECT_EQ(fem.n_modes, n);
  EXPECT_EQ(fem.n_constraint, nb);
  EXPECT_EQ(fem.n_normal, 6);
  EXPECT_EQ(fem.q0, Dense(n, 0.0));
  EXPECT_EQ(fem.v0, Dense(n, 0.0));
  for (int k = 0; k < fem.n_nodes; ++k) {
    EXPECT_EQ(fem.labels[k], cat(se.boundary_nodes[k]));
    EXPECT_EQ(fem.x[k], se.boundary_xyz[3 * k]);
    EXPECT_EQ(fem.y[k], se.boundary_xyz[3 * k + 1]);
    EXPECT_EQ(fem.z[k], se.boundary_xyz[3 * k + 2]);
  }
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < fem.n_nodes; ++k)
      for (int c = 0; c < 6; ++c) {
        const bool one = j < nb && se.dof_node[j] == se.boundary_nodes[k] && se.dof_component[j] == c + 1;
        EXPECT_EQ(fem.shapes[(j * fem.n_nodes + k) * 6 + c], one ? 1.0 : 0.0) << "mode " << j << " node " << k;
      }
  EXPECT_LE(rel_diff(M, fem.M), 1e-15);
  EXPECT_LE(rel_diff(K, fem.K), 1e-15);
  ASSERT_TRUE(fem.has13);
  EXPECT_LE(rel_diff(C, fem.C), 1e-15);
  EXPECT_TRUE(fem.has12);

  // OP4 (io::Op4Reader): KAA, MAA, BAA.
  EXPECT_EQ(io::Op4Reader::names_in_file(path("se.op4")), (std::vector<std::string>{"KAA", "MAA", "BAA"}));
  EXPECT_LE(rel_diff(K, read_op4(path("se.op4"), "KAA", n)), 1e-15);
  EXPECT_LE(rel_diff(M, read_op4(path("se.op4"), "MAA", n)), 1e-15);
  EXPECT_LE(rel_diff(C, read_op4(path("se.op4"), "BAA", n)), 1e-15);

  // MatrixMarket.
  EXPECT_LE(rel_diff(K, read_mtx(path("se_K.mtx"), n)), 1e-15);
  EXPECT_LE(rel_diff(M, read_mtx(path("se_M.mtx"), n)), 1e-15);
  EXPECT_LE(rel_diff(C, read_mtx(path("se_C.mtx"), n)), 1e-15);

  // DOF map: boundary rows by node and component, then the modal rows with their SPOINTs.
  {
    std::ifstream f(path("se_dofs.txt"));
    std::string line;
    int row = 0;
    while (std::getline(f, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream is(line);
      int r = 0;
      std::string kind;
      long long a = 0, b = 0;
      is >> r >> kind >> a >> b;
      EXPECT_EQ(r, ++row);
      if (r <= nb) {
        EXPECT_EQ(kind, "node");
        EXPECT_EQ(a, se.dof_node[r - 1]);
        EXPECT_EQ(b, se.dof_component[r - 1]);
      } else {
        EXPECT_EQ(kind, "modal");
        EXPECT_EQ(a, r - nb);
        EXPECT_EQ(b, res.spoint_offset + r - nb);
      }
    }
    EXPECT_EQ(row, n);
  }

  // DMIG: lower triangles of symmetric matrices on GRID/component and SPOINT/0, values to the
  // precision of a 16-character field.
  Deck deck;
  read_deck(path("se_dmig.bdf"), &deck);
  read_deck(path("se_grids.bdf"), &deck);
  // The mesh has 4*2*1 hex20 elements: 89 nodes; the default offset is the next power of ten.
  EXPECT_EQ(res.spoint_offset, 100);
  std::set<long long> sp;
  for (int k = 1; k <= 6; ++k) sp.insert(100 + k);
  EXPECT_EQ(deck.spoints, sp);
  std::map<std::pair<long long, int>, int> index;
  for (int j = 0; j < nb; ++j) index[{se.dof_node[j], se.dof_component[j]}] = j;
  for (int k = 0; k < se.n_modes(); ++k) index[{res.spoint_offset + k + 1, 0}] = nb + k;
  for (const auto& [name, ref] : std::map<std::string, const Dense*>{{"KAAX", &K}, {"MAAX", &M}, {"BAAX", &C}}) {
    ASSERT_TRUE(deck.dmig.count(name)) << name;
    const Dmig& d = deck.dmig[name];
    EXPECT_EQ(d.ifo, 6);
    EXPECT_EQ(d.tin, 2);
    Dense A(static_cast<std::size_t>(n) * n, 0.0);
    double worst = 0;
    for (const auto& [cj, rows] : d.columns)
      for (const auto& [ri, v] : rows) {
        ASSERT_TRUE(index.count(cj) && index.count(ri)) << name << ": unknown DOF";
        const int i = index[ri], j = index[cj];
        EXPECT_GE(i, j) << name << ": upper-triangle term";
        A[i * n + j] = A[j * n + i] = v;
        worst = std::max(worst, std::abs(v - (*ref)[i * n + j]) / std::abs((*ref)[i * n + j]));
      }
    for (std::size_t k = 0; k < A.size(); ++k)
      if ((*ref)[k] != 0.0) {
        EXPECT_NE(A[k], 0.0) << name << ": nonzero entry " << k << " missing";
      }
    EXPECT_LE(worst, 5e-10) << name;  // >= 10 significant digits per entry
    EXPECT_LE(rel_diff(*ref, A), 5e-10) << name;
  }
  ASSERT_EQ(deck.grids.size(), se.boundary_nodes.size());
  for (std::size_t k = 0; k < se.boundary_nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(deck.grids[se.boundary_nodes[k]][d], se.boundary_xyz[3 * k + d], 1e-11);
}

TEST_F(ExportTest, RigidBodyInertiaIsTheBoxs) {
  // Exported record group 12 (mass, centre of mass, inertia about it) ...
  const auto se = io::read_superelement(free_);
  io::ExportOptions o;
  o.prefix = path("se");
  o.op4 = o.dmig = o.mtx = false;
  io::export_superelement(se, o);
  const Fem fem = read_fem(path("se.fem"));
  ASSERT_TRUE(fem.has12);
  // ... against the closed form of the homogeneous box [0, lx] x [0, ly] x [0, lz] (the consistent
  // mass integrates the quadratic kinetic energy of a rigid motion exactly) ...
  const double m = kRho * kLx * kLy * kLz;
  const double Jref[3] = {m * (kLy * kLy + kLz * kLz) / 12, m * (kLx * kLx + kLz * kLz) / 12,
                          m * (kLx * kLx + kLy * kLy) / 12};
  // The constraint modes reproduce rigid motion to the accuracy of the K_ii solves (measured: 1e-12
  // to 3e-12 of the inertia on 1 and 2 ranks): the first moments are compared at 1e-11 m [m kg]
  // and the inertia at 1e-11 of its size about the origin, m (lx^2 + ly^2 + lz^2) / 3.
  const double stol = 1e-11 * m, jtol = 1e-11 * m * (kLx * kLx + kLy * kLy + kLz * kLz) / 3;
  EXPECT_NEAR(fem.mass, m, 1e-12 * m);
  EXPECT_NEAR(fem.cm[0], kLx / 2, 1e-12);
  EXPECT_NEAR(fem.cm[1], kLy / 2, 1e-12);
  EXPECT_NEAR(fem.cm[2], kLz / 2, 1e-12);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(fem.J[3 * a + b], a == b ? Jref[a] : 0.0, jtol) << a << b;

  // ... and against R^T M R of the full model, the rigid motions on every DOF (no superelement).
  MPI_Comm comm = PETSC_COMM_SELF;  // each rank its own serial model: the check is per rank
  auto lm = mesh::read_and_distribute(comm, mesh_);
  auto dofs = fe::number_dofs(lm, {});
  auto ops = fe::assemble(lm, dofs, test::steel());
  std::vector<UVec> r;
  for (int k = 0; k < 6; ++k)
    r.push_back(test::nodal_vector(lm, dofs, [k](double x, double y, double z, int d) {
      if (k < 3) return d == k ? 1.0 : 0.0;
      const double p[3] = {x, y, z};
      const int a = k - 3;  // (e_a x p)_d
      const double e[3] = {a == 0 ? 1.0 : 0.0, a == 1 ? 1.0 : 0.0, a == 2 ? 1.0 : 0.0};
      const double c[3] = {e[1] * p[2] - e[2] * p[1], e[2] * p[0] - e[0] * p[2], e[0] * p[1] - e[1] * p[0]};
      return c[d];
    }));
  double Mr[6][6];
  UVec Mx;
  MORSE_CALL(VecDuplicate(r[0].get(), Mx.ptr()));
  for (int b = 0; b < 6; ++b) {
    MORSE_CALL(MatMult(ops.M.get(), r[b].get(), Mx.get()));
    for (int a = 0; a < 6; ++a) MORSE_CALL(VecDot(Mx.get(), r[a].get(), &Mr[a][b]));
  }
  EXPECT_NEAR(fem.mass, Mr[0][0], 1e-12 * m);
  EXPECT_NEAR(fem.mass * fem.cm[0], Mr[5][1], stol);  // S = (M_r[5][1], M_r[3][2], M_r[4][0])
  EXPECT_NEAR(fem.mass * fem.cm[1], Mr[3][2], stol);
  EXPECT_NEAR(fem.mass * fem.cm[2], Mr[4][0], stol);
  // MBDyn turns J_cm into J about the origin as J_cm - m [c x][c x]; that must be R^T M R's block.
  const double* c = fem.cm.data();
  const double c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(fem.J[3 * a + b] + fem.mass * ((a == b ? c2 : 0.0) - c[a] * c[b]), Mr[3 + a][3 + b], jtol);
}

TEST_F(ExportTest, GroundedSuperelementHasNoRigidBodyRecord) {
  const auto se = io::read_superelement(grounded_);
  const auto in = io::rigid_body_inertia(se);
  EXPECT_FALSE(in.valid);
  EXPECT_GT(in.stiffness_residual, 1e-3);
  EXPECT_NE(in.reason.find("cannot move rigidly"), std::string::npos) << in.reason;
  io::ExportOptions o;
  o.prefix = path("g");
  const auto res = io::export_superelement(se, o);
  EXPECT_FALSE(res.mbdyn.inertia_written);
  const Fem fem = read_fem(path("g.fem"));
  EXPECT_FALSE(fem.has12);
  EXPECT_FALSE(fem.has13);  // no damping in this file
  EXPECT_LE(rel_diff(h5(grounded_, "/rom/K"), fem.K), 1e-15);
  EXPECT_FALSE(fs::exists(path("g_C.mtx")));
  // And the free one is valid to round-off.
  const auto free_in = io::rigid_body_inertia(io::read_superelement(free_));
  EXPECT_TRUE(free_in.valid) << free_in.reason;
  EXPECT_LT(free_in.stiffness_residual, 1e-10);
}

TEST_F(ExportTest, ShapesAtEveryNodeAreTheBasis) {
  const auto se = io::read_superelement(free_);
  io::ExportOptions o;
  o.prefix = path("all");
  o.op4 = o.dmig = o.mtx = false;
  o.mbdyn_all_nodes = true;
  io::export_superelement(se, o);
  const Fem fem = read_fem(path("all.fem"));
  const auto ids = h5i(free_, "/mesh/node_ids");
  const auto xyz = h5(free_, "/mesh/coordinates");
  const auto psi = h5(free_, "/cb/constraint_modes"), phi = h5(free_, "/cb/fixed_interface/mode_shapes");
  const int nn = static_cast<int>(ids.size());
  ASSERT_EQ(fem.n_nodes, nn);
  for (int k = 0; k < nn; ++k) {
    EXPECT_EQ(fem.labels[k], cat(ids[k]));
    EXPECT_EQ(fem.x[k], xyz[3 * k]);
    EXPECT_EQ(fem.z[k], xyz[3 * k + 2]);
  }
  std::map<std::int64_t, int> row;
  for (int k = 0; k < nn; ++k) row[ids[k]] = k;
  double worst_interface = 0;
  for (int j = 0; j < se.n; ++j)
    for (int k = 0; k < nn; ++k) {
      for (int d = 0; d < 3; ++d) {
        const double ref = j < se.n_b ? psi[(j * nn + k) * 3 + d] : phi[((j - se.n_b) * nn + k) * 3 + d];
        EXPECT_EQ(fem.shapes[(j * nn + k) * 6 + d], ref);
      }
      for (int d = 3; d < 6; ++d) EXPECT_EQ(fem.shapes[(j * nn + k) * 6 + d], 0.0);
    }
  // At the interface the basis is the unit pattern of the interface-only file.
  for (int j = 0; j < se.n; ++j)
    for (std::int64_t node : se.boundary_nodes)
      for (int d = 0; d < 3; ++d) {
        const bool one = j < se.n_b && se.dof_node[j] == node && se.dof_component[j] == d + 1;
        worst_interface =
            std::max(worst_interface, std::abs(fem.shapes[(j * nn + row[node]) * 6 + d] - (one ? 1.0 : 0.0)));
      }
  EXPECT_LT(worst_interface, 1e-12);
  // The grounded file has no basis: refused, naming the dataset and the option that writes it.
  test::expect_error_parts([&] { io::read_nodal_shapes(io::read_superelement(grounded_)); },
                           {grounded_, "/cb/constraint_modes", "-cb_write_basis"}, "shapes without a basis");
}

// A matrix-input file (/dofs instead of /mesh) as `reduce -matrices_K` writes it, made from the
// free superelement's /rom.
class ExportMatrixInputTest : public ExportTest {
 protected:
  std::string make(const std::string& name, bool interior_component) {
    const auto se = io::read_superelement(free_);
    const std::string file = path(name);
    io::H5Output out(MPI_COMM_SELF, file);
    io::write_provenance(out, "reduce", "mm-t-s");
    const auto n = static_cast<hsize_t>(se.n);
    out.write("/rom/K", se.K, {n, n});
    out.write("/rom/M", se.M, {n, n});
    std::vector<std::int64_t> labels, node, comp;
    for (int j = 0; j < se.n_b; ++j) {
      labels.push_back(se.dof_node[j]);
      labels.push_back(se.dof_component[j]);
      node.push_back(se.dof_node[j]);
      comp.push_back(se.dof_component[j]);
    }
    node.push_back(5000);  // an interior row of another node
    comp.push_back(1);
    if (interior_component) {  // a rotation of an interface node that is not a boundary DOF
      node.push_back(se.boundary_nodes[2]);
      comp.push_back(5);
    }
    out.write("/rom/boundary_dofs", labels, {static_cast<hsize_t>(se.n_b), 2});
    out.write("/rom/boundary_nodes", se.boundary_nodes);
    out.write("/dofs/node", node);
    out.write("/dofs/component", comp);
    out.commit();
    return file;
  }
};

TEST_F(ExportMatrixInputTest, NeedsCoordinatesForMbdyn) {
  const std::string file = make("mm.h5", false);
  auto se = io::read_superelement(file);
  EXPECT_FALSE(se.from_mesh);
  EXPECT_TRUE(se.boundary_xyz.empty());
  EXPECT_EQ(se.units, "mm-t-s");
  io::ExportOptions o;
  o.prefix = path("mm");
  test::expect_error_parts([&] { io::export_superelement(se, o); }, {file, "-export_coordinates"}, "no coordinates");
  EXPECT_EQ(files_in(dir_), std::vector<std::string>{"mm.h5"});  // nothing written
  // Without MBDyn: every other format, no GRID file; the SPOINTs clear node 5000 of /dofs.
  o.mbdyn = false;
  auto res = io::export_superelement(se, o);
  EXPECT_EQ(res.spoint_offset, 10000);
  EXPECT_EQ(files_in(dir_),
            (std::vector<std::string>{"mm.h5", "mm.op4", "mm_K.mtx", "mm_M.mtx", "mm_dmig.bdf", "mm_dofs.txt"}));
  // With a coordinates file: the FEM file, and the same inertia as the mesh file's.
  std::string text = "# node x y z\n";
  const auto ref = io::read_superelement(free_);
  for (std::size_t k = 0; k < ref.boundary_nodes.size(); ++k)
    text += cat(ref.boundary_nodes[k], " ", ref.boundary_xyz[3 * k], " ", ref.boundary_xyz[3 * k + 1], " ",
                ref.boundary_xyz[3 * k + 2], "\n");
  text += "777 1 2 3\n";  // not an interface node: ignored
  io::set_boundary_coordinates(&se, write("xyz.txt", text));
  o.mbdyn = true;
  o.op4 = o.dmig = o.mtx = false;
  o.prefix = path("mm2");
  res = io::export_superelement(se, o);
  ASSERT_TRUE(res.mbdyn.inertia_written) << res.mbdyn.inertia.reason;
  const auto in = io::rigid_body_inertia(ref);
  EXPECT_NEAR(res.mbdyn.inertia.mass, in.mass, 1e-12 * in.mass);
  EXPECT_LE(rel_diff(Dense(in.inertia_cm.begin(), in.inertia_cm.end()),
                     Dense(res.mbdyn.inertia.inertia_cm.begin(), res.mbdyn.inertia.inertia_cm.end())),
            1e-12);
  // Bad coordinate files.
  test::expect_error_parts([&] { io::set_boundary_coordinates(&se, write("bad.txt", "1 0 0\n")); },
                           {"bad.txt:1", "node x y z"}, "short line");
  test::expect_error_parts([&] { io::set_boundary_coordinates(&se, write("few.txt", "1 0 0 0\n")); },
                           {"few.txt", "no coordinates for interface node"}, "missing node");
  test::expect_error_parts([&] { io::set_boundary_coordinates(&se, write("twice.txt", "1 0 0 0\n1 0 0 0\n")); },
                           {"twice.txt:2", "given twice"}, "node twice");
}

TEST_F(ExportMatrixInputTest, InteriorComponentAtAnInterfaceNodeIsRefused) {
  const std::string file = make("rot.h5", true);
  auto se = io::read_superelement(file);
  const auto ref = io::read_superelement(free_);
  se.boundary_xyz = ref.boundary_xyz;
  io::ExportOptions o;
  o.prefix = path("rot");
  test::expect_error_parts([&] { io::export_superelement(se, o); },
                           {file, cat("interface node ", se.boundary_nodes[2]), "component 5", "interior"},
                           "interior rotation");
  EXPECT_EQ(files_in(dir_), std::vector<std::string>{"rot.h5"});
}

TEST_F(ExportTest, BadFilesAreRefusedNamingFileAndDataset) {
  test::expect_error_parts([&] { io::read_superelement(path("none.h5")); }, {"none.h5", "no such file"}, "missing");
  test::expect_error_parts([&] { io::read_superelement(write("text.h5", "not hdf5")); }, {"text.h5", "HDF5"},
                           "not HDF5");
  auto make = [&](const std::string& name, auto body) {
    io::H5Output out(MPI_COMM_SELF, path(name));
    body(out);
    out.commit();
    return path(name);
  };
  const auto norom = make("norom.h5", [](io::H5Output& out) { io::write_provenance(out, "modes", "SI"); });
  test::expect_error_parts([&] { io::read_superelement(norom); }, {norom, "no /rom/K", "not a superelement"},
                           "no /rom");
  const Dense eye4 = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const std::vector<std::int64_t> dofs2 = {7, 1, 7, 2};
  const auto rect = make("rect.h5", [&](io::H5Output& out) { out.write("/rom/K", Dense(6, 1.0), {2, 3}); });
  test::expect_error_parts([&] { io::read_superelement(rect); }, {rect, "/rom/K must be square", "[2][3]"}, "K");
  const auto msize = make("msize.h5", [&](io::H5Output& out) {
    out.write("/rom/K", eye4, {4, 4});
    out.write("/rom/M", Dense(9, 1.0), {3, 3});
  });
  test::expect_error_parts([&] { io::read_superelement(msize); }, {msize, "/rom/M is [3][3]", "/rom/K is [4][4]"}, "M");
  auto with_dofs = [&](const std::string& name, std::vector<std::int64_t> labels, std::vector<hsize_t> shape) {
    return make(name, [&](io::H5Output& out) {
      out.write("/rom/K", eye4, {4, 4});
      out.write("/rom/M", eye4, {4, 4});
      out.write("/rom/boundary_dofs", labels, shape);
    });
  };
  const auto big = with_dofs("big.h5", std::vector<std::int64_t>(10, 1), {5, 2});
  test::expect_error_parts([&] { io::read_superelement(big); }, {big, "/rom/boundary_dofs", "n_b <= 4", "[5][2]"},
                           "n_b");
  const auto comp = with_dofs("comp.h5", {7, 1, 7, 9}, {2, 2});
  test::expect_error_parts([&] { io::read_superelement(comp); }, {comp, "component 9", "1..6"}, "component");
  const auto twice = with_dofs("twice.h5", {7, 1, 7, 1}, {2, 2});
  test::expect_error_parts([&] { io::read_superelement(twice); }, {twice, "node 7 component 1", "twice"}, "twice");
  const auto nodes = make("nodes.h5", [&](io::H5Output& out) {
    out.write("/rom/K", eye4, {4, 4});
    out.write("/rom/M", eye4, {4, 4});
    out.write("/rom/boundary_dofs", dofs2, {2, 2});
    out.write("/rom/boundary_nodes", std::vector<std::int64_t>{7, 8});
  });
  test::expect_error_parts([&] { io::read_superelement(nodes); }, {nodes, "/rom/boundary_nodes", "/rom/boundary_dofs"},
                           "nodes");
  const auto nan = make("nan.h5", [&](io::H5Output& out) {
    Dense k = eye4;
    k[5] = std::nan("");
    out.write("/rom/K", k, {4, 4});
    out.write("/rom/M", eye4, {4, 4});
    out.write("/rom/boundary_dofs", dofs2, {2, 2});
  });
  test::expect_error_parts([&] { io::read_superelement(nan); }, {nan, "/rom/K[1][1]", "not finite"}, "nan");
  const auto nomesh = make("nomesh.h5", [&](io::H5Output& out) {
    out.write("/rom/K", eye4, {4, 4});
    out.write("/rom/M", eye4, {4, 4});
    out.write("/rom/boundary_dofs", dofs2, {2, 2});
    out.write("/mesh/node_ids", std::vector<std::int64_t>{1, 2});
    out.write("/mesh/coordinates", Dense(6, 0.0), {2, 3});
  });
  test::expect_error_parts([&] { io::read_superelement(nomesh); }, {nomesh, "boundary node 7", "/mesh/node_ids"},
                           "node not in mesh");
}

// A corrupt file whose dataset declares more values than the file holds (found by
// bench/fuzz/fuzz_h5_rom: the reader sized its buffer from the declared shape and asked for
// petabytes) is refused, naming the dataset, before anything is allocated. Built here as a chunked
// dataset of 10^12 doubles none of which is written.
TEST_F(ExportTest, DatasetLargerThanTheFileIsRefusedBeforeAllocating) {
  const std::string f = path("declared.h5");
  hid_t file = H5Fcreate(f.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  const hsize_t dims[2] = {1000000, 1000000}, chunk[2] = {64, 64};
  hid_t space = H5Screate_simple(2, dims, nullptr);
  hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(dcpl, 2, chunk);
  hid_t d = H5Dcreate2(file, "/rom/K", H5T_NATIVE_DOUBLE, space, lcpl, dcpl, H5P_DEFAULT);
  ASSERT_GE(d, 0);
  H5Dclose(d);
  H5Pclose(dcpl);
  H5Sclose(space);
  H5Pclose(lcpl);
  H5Fclose(file);
  test::expect_error_parts([&] { io::read_superelement(f); }, {f, "/rom/K", "declares 1000000000000 values", "bytes"},
                           "declared size");
}

TEST_F(ExportTest, OptionsAreChecked) {
  const auto se = io::read_superelement(free_);
  io::ExportOptions o;
  o.prefix = path("x");
  o.spoint_offset = 40;  // 41..46 hit mesh nodes
  test::expect_error_parts([&] { io::export_superelement(se, o); }, {"SPOINT ids 41..46", "collide with node 41"},
                           "spoint collision");
  o.spoint_offset = 99999998;
  test::expect_error_parts([&] { io::export_superelement(se, o); }, {"99999999"}, "spoint range");
  o.spoint_offset = 0;
  o.names.dmig_K = "9BAD";
  test::expect_error_parts([&] { io::export_superelement(se, o); }, {"DMIG name '9BAD'"}, "dmig name");
  o.names.dmig_K = "KAAX";
  o.names.op4_M = "TOOLONGNAME";
  test::expect_error_parts([&] { io::export_superelement(se, o); }, {"OP4 name 'TOOLONGNAME'"}, "op4 name");
  EXPECT_TRUE(files_in(dir_).empty());
  // Other names and offset are used as given.
  o.names = {};
  o.names.dmig_K = "KSTATOR";
  o.names.op4_K = "KSE";
  o.spoint_offset = 900000;
  o.mbdyn = o.mtx = false;
  io::export_superelement(se, o);
  Deck deck;
  read_deck(path("x_dmig.bdf"), &deck);
  EXPECT_TRUE(deck.dmig.count("KSTATOR"));
  EXPECT_EQ(*deck.spoints.begin(), 900001);
  EXPECT_EQ(io::Op4Reader::names_in_file(path("x.op4"))[0], "KSE");
}

TEST(ExportNastranReal, FitsSixteenColumnsAndKeepsTenDigits) {
  for (double v : {1.0, -1.0, 0.5, 6247390596.8456869, -1.9357422200969121e9, 8.8343018652852495e-07, 1e-100,
                   -1.234567890123456e-123, 9.999999999999999e99, 1.7976931348623157e308, 2.2250738585072014e-308,
                   -4.9406564584124654e-324, 3.0, 1.0 / 3.0, -2.0 / 3.0 * 1e-15}) {
    const std::string s = io::nastran_large_real(v);
    EXPECT_LE(s.size(), 16u) << s;
    EXPECT_NE(s.find('.'), std::string::npos) << s;
    EXPECT_NE(s.find('D'), std::string::npos) << s;
    const double back = nastran_real(s);
    // Subnormals carry fewer digits; every normal value keeps at least 9 significant digits
    // (10 below |exponent| 100).
    const double tol = std::abs(v) < 1e-300 ? 1e-5 : (std::abs(std::log10(std::abs(v))) >= 99.5 ? 5e-9 : 5e-10);
    EXPECT_LE(std::abs(back - v), tol * std::abs(v)) << v << " -> " << s;
  }
  EXPECT_EQ(io::nastran_large_real(0.0), "0.0");
  EXPECT_EQ(io::nastran_large_real(1.0), "1.0D+0");  // the shortest exact form
  EXPECT_EQ(io::nastran_large_real(-0.25), "-2.5D-1");
  EXPECT_EQ(io::nastran_large_real(1.0 / 3.0).size(), 16u);  // needs every column
}

// A superelement with rotational DOFs (matrix input): one node at p carrying a rigid body of mass
// m, centre of mass p + d and inertia J_cm, written as its 6 x 6 mass matrix about the node.
// R^T M R must give back the body: mass, centre and inertia about the centre.
TEST(ExportRigidBody, RotationalDofsCarryTheirInertia) {
  const double m = 3.5, p[3] = {0.4, -1.2, 2.0}, d[3] = {0.1, 0.25, -0.3};
  const double Jcm[9] = {2.0, 0.1, -0.2, 0.1, 3.0, 0.3, -0.2, 0.3, 4.0};
  io::Superelement se;
  se.source = "point body";
  se.n = se.n_b = 6;
  se.K.assign(36, 0.0);
  se.M.assign(36, 0.0);
  for (int c = 1; c <= 6; ++c) {
    se.dof_node.push_back(7);
    se.dof_component.push_back(c);
  }
  se.boundary_nodes = {7};
  se.boundary_xyz = {p[0], p[1], p[2]};
  // About the node: [[m I, [S x]^T], [[S x], J_node]], S = m d, J_node = J_cm + m (|d|^2 I - d
  // d^T).
  const double S[3] = {m * d[0], m * d[1], m * d[2]};
  const double Sx[3][3] = {{0, -S[2], S[1]}, {S[2], 0, -S[0]}, {-S[1], S[0], 0}};
  const double d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  for (int a = 0; a < 3; ++a) {
    se.M[a * 6 + a] = m;
    for (int b = 0; b < 3; ++b) {
      se.M[(3 + a) * 6 + b] = Sx[a][b];
      se.M[b * 6 + 3 + a] = Sx[a][b];
      se.M[(3 + a) * 6 + 3 + b] = Jcm[a * 3 + b] + m * ((a == b ? d2 : 0.0) - d[a] * d[b]);
    }
  }
  const auto in = io::rigid_body_inertia(se);
  ASSERT_TRUE(in.valid) << in.reason;
  EXPECT_NEAR(in.mass, m, 1e-14 * m);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(in.center[a], p[a] + d[a], 1e-14);
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(in.inertia_cm[k], Jcm[k], 1e-13) << k;
  // The MBDyn file shows the rotations of the constraint modes (rx ry rz columns).
  const test::ScratchDir scratch("export_point");
  io::write_mbdyn_fem(scratch.path("p.fem"), se);
  const Fem fem = read_fem(scratch.path("p.fem"));
  for (int j = 0; j < 6; ++j)
    for (int c = 0; c < 6; ++c) EXPECT_EQ(fem.shapes[j * 6 + c], j == c ? 1.0 : 0.0);
  EXPECT_NEAR(fem.mass, m, 1e-14 * m);
}

// The command on every rank: rank 0 writes, errors are collective.
TEST_F(ExportTest, CommandWritesTheChosenFormatsAndFailsCollectively) {
  const std::string prefix = base_->path("cli");
  run("export", {{"-export_from", free_}, {"-export_format", "mbdyn,op4"}, {"-out", prefix}});
  for (const char* ext : {".fem", ".op4", "_dofs.txt"}) EXPECT_TRUE(fs::exists(prefix + ext)) << ext;
  for (const char* ext : {"_dmig.bdf", "_K.mtx"}) EXPECT_FALSE(fs::exists(prefix + ext)) << ext;
  auto collective_error = [&](const std::vector<std::pair<std::string, std::string>>& opts,
                              std::initializer_list<std::string> parts, const std::string& what) {
    test::expect_error_parts([&] { run("export", opts); }, parts, what);
  };
  collective_error({{"-out", prefix + "_none"}}, {"no superelement given", "-export_from"}, "no -export_from");
  collective_error({{"-export_from", free_}, {"-export_format", "mbdyn,foo"}, {"-out", prefix + "_foo"}},
                   {"-export_format foo", "unknown format"}, "unknown format");
  collective_error({{"-export_from", mesh_}, {"-out", prefix + "_msh"}}, {mesh_, "HDF5"}, "not HDF5 (rank 0 only)");
  collective_error({{"-export_from", free_}, {"-export_mbdyn_nodes", "some"}, {"-out", prefix + "_n"}},
                   {"-export_mbdyn_nodes some"}, "nodes");
  MPI_Barrier(PETSC_COMM_WORLD);
  for (const char* p : {"_none", "_foo", "_msh", "_n"})
    for (const char* ext : {".fem", ".op4", "_dofs.txt", ".part.fem"}) EXPECT_FALSE(fs::exists(prefix + p + ext));
}
