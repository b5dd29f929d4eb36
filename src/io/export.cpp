// io/export.cpp: a superelement exported to the codes that use superelements: MBDyn, Nastran
// (OUTPUT4, DMIG) and MatrixMarket (io/export.hpp, docs/export.md).
#include "morse/io/export.hpp"

#include <petscmat.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/handle.hpp"
#include "morse/io/matrices.hpp"
#include "morse/io/op4.hpp"

namespace morse::io {

namespace fs = std::filesystem;

namespace {

bool exactly_symmetric(const std::vector<double>& A, int n) {
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (A[static_cast<std::size_t>(i) * n + j] != A[static_cast<std::size_t>(j) * n + i]) return false;
  return true;
}

// Writes path through its temporary (files::temp_path): body(FILE*) prints the content; the
// rename happens only if every write succeeded.
template <class F>
void write_atomic(const std::string& path, F body) {
  const std::string tmp = files::temp_path(path);
  FILE* f = std::fopen(tmp.c_str(), "w");
  MORSE_CHECK(f, path, ": cannot write it (", std::strerror(errno), ")");
  try {
    body(f);
  } catch (...) {
    std::fclose(f);
    std::remove(tmp.c_str());
    throw;
  }
  bool bad = std::ferror(f) != 0;
  if (std::fclose(f) != 0) bad = true;
  if (bad) {
    std::remove(tmp.c_str());
    throw Error(cat(path, ": write error on ", tmp));
  }
  files::commit(tmp, path);
}

std::string comp_name(int c) {
  static const char* names[] = {"x", "y", "z", "rx", "ry", "rz"};
  return c >= 1 && c <= 6 ? names[c - 1] : cat(c);
}

// Prints text as comment lines of at most 80 columns ("$ " for Nastran, whose records are 80
// columns), breaking at blanks (a longer word, e.g. a path, is cut).
void comment(FILE* f, const char* lead, const std::string& text) {
  const std::size_t width = 80 - std::strlen(lead);
  std::istringstream words(text);
  std::string word, line;
  auto flush = [&] {
    std::fprintf(f, "%s%s\n", lead, line.c_str());
    line.clear();
  };
  while (words >> word) {
    if (!line.empty() && line.size() + 1 + word.size() > width) flush();
    while (word.size() > width) {
      if (!line.empty()) flush();
      line = word.substr(0, width);
      word.erase(0, width);
      flush();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty()) flush();
}

std::string source_line(const Superelement& se) {
  std::string s = cat(se.source, " (", se.command.empty() ? "morse" : "morse " + se.command);
  if (!se.selection_method.empty()) s += cat(", selection ", se.selection_method);
  return s + cat("), units ", se.units);
}

void check_name(const std::string& name, const char* what) {
  bool ok = !name.empty() && name.size() <= 8 && std::isalpha(static_cast<unsigned char>(name[0]));
  for (char ch : name) ok = ok && std::isalnum(static_cast<unsigned char>(ch));
  MORSE_CHECK(ok, what, " '", name, "': a Nastran matrix name is 1 to 8 letters or digits, a letter first");
}

// What an interface node's component is in the shapes written without the basis: true if it is
// a boundary DOF (a constraint mode column), false if it is known to be zero in every column (a
// clamped DOF or a component the model does not have). Throws if it is an interior DOF.
void check_interface_components(const Superelement& se) {
  std::map<std::int64_t, std::set<int>> boundary;
  for (int j = 0; j < se.n_b; ++j) boundary[se.dof_node[j]].insert(se.dof_component[j]);
  if (!se.model_dof_node.empty()) {
    for (std::size_t r = 0; r < se.model_dof_node.size(); ++r) {
      auto it = boundary.find(se.model_dof_node[r]);
      if (it != boundary.end() && !it->second.count(se.model_dof_component[r]))
        throw Error(cat(se.source, ": interface node ", it->first, " has component ", se.model_dof_component[r], " (",
                        comp_name(se.model_dof_component[r]),
                        ") as an interior DOF: its mode shapes there are not known without the "
                        "basis; put every "
                        "free component of the interface nodes in the boundary set"));
    }
    return;
  }
  if (se.from_mesh) return;  // solid mesh: no rotations; a translation missing from the boundary is clamped
  for (const auto& [node, comps] : boundary)
    for (int c = 1; c <= 3; ++c)
      MORSE_CHECK(comps.count(c), se.source, ": interface node ", node, " has no boundary component ", c, " (",
                  comp_name(c), ") and the file has neither /mesh nor /dofs to tell whether it is clamped");
}

void check_spoints(const Superelement& se, std::int64_t offset) {
  if (se.n_modes() == 0) return;
  MORSE_CHECK(offset >= 0 && offset + se.n_modes() <= 99999999, "SPOINT ids ", offset + 1, "..", offset + se.n_modes(),
              " are outside Nastran's 1..99999999 (-export_spoint_offset)");
  auto clash = [&](std::int64_t id) { return id > offset && id <= offset + se.n_modes(); };
  for (std::int64_t id : se.model_node_ids)
    MORSE_CHECK(!clash(id), "SPOINT ids ", offset + 1, "..", offset + se.n_modes(), " collide with node ", id, " of ",
                se.source, " (-export_spoint_offset)");
  for (std::int64_t id : se.boundary_nodes)
    MORSE_CHECK(!clash(id), "SPOINT ids ", offset + 1, "..", offset + se.n_modes(), " collide with node ", id, " of ",
                se.source, " (-export_spoint_offset)");
}

}  // namespace

MbdynInfo write_mbdyn_fem(const std::string& path, const Superelement& se, const NodalShapes* shapes) {
  const int n = se.n, nb = se.n_b;
  std::size_t n_nodes = 0;
  const std::vector<std::int64_t>* ids = nullptr;
  const std::vector<double>* xyz = nullptr;
  if (shapes) {
    ids = &shapes->node_ids;
    xyz = &shapes->xyz;
    n_nodes = ids->size();
    MORSE_CHECK(shapes->shapes.size() == static_cast<std::size_t>(n) * n_nodes * 3, se.source,
                ": the nodal shapes do not match /rom (", n, " columns)");
  } else {
    check_interface_components(se);
    MORSE_CHECK(se.boundary_xyz.size() == 3 * se.boundary_nodes.size(), se.source,
                ": the MBDyn FEM file needs the coordinates of the interface nodes, and the file "
                "has no /mesh "
                "(matrix input): give them with -export_coordinates FILE (lines 'node x y z')");
    ids = &se.boundary_nodes;
    xyz = &se.boundary_xyz;
    n_nodes = ids->size();
  }
  MbdynInfo info;
  info.n_nodes = static_cast<int>(n_nodes);
  info.inertia = rigid_body_inertia(se);
  info.inertia_written = info.inertia.valid;
  // Interface rows of the constraint modes: column j is 1 at DOF (dof_node[j], dof_component[j]).
  std::map<std::pair<std::int64_t, int>, int> column;
  for (int j = 0; j < nb; ++j) column[{se.dof_node[j], se.dof_component[j]}] = j;
  std::map<std::int64_t, std::size_t> node_row;
  for (std::size_t k = 0; k < n_nodes; ++k) node_row[(*ids)[k]] = k;

  write_atomic(path, [&](FILE* f) {
    // Numbers six to a line (ReadModal reads them as a stream; short lines keep the file readable
    // and clear of its getline buffer of BUFSIZ characters), each matrix row on new lines.
    auto numbers = [&](const double* v, int count) {
      for (int k = 0; k < count; ++k) std::fprintf(f, (k + 1) % 6 && k + 1 < count ? "%.17g " : "%.17g\n", v[k]);
    };
    auto row = [&](const std::vector<double>& A) {
      for (int i = 0; i < n; ++i) numbers(&A[static_cast<std::size_t>(i) * n], n);
    };
    std::fprintf(f, "** MBDyn MODAL DATA FILE (FEM file of the modal joint), written by morse %s\n", MORSE_VERSION);
    std::fprintf(f, "** source: %s\n", source_line(se).c_str());
    std::fprintf(f,
                 "** Craig-Bampton superelement: %d modal coordinates = %d constraint modes "
                 "(boundary DOFs, first) "
                 "+ %d fixed-interface modes\n",
                 n, nb, se.n_modes());
    std::fprintf(f, "** nodes: %s (%zu); generalized mass and stiffness: the full M_CB, K_CB of /rom\n",
                 shapes ? "every mesh node, shapes of the basis" : "the interface nodes", n_nodes);
    std::fprintf(f, "** RECORD GROUP 1, HEADER\n");
    std::fprintf(f, "**   REVISION, NODE, NORMAL, ATTACHMENT, CONSTRAINT, REJECTED MODES\n");
    std::fprintf(f, "REV0 %zu %d 0 %d 0\n**\n", n_nodes, se.n_modes(), nb);
    std::fprintf(f, "** RECORD GROUP 2, FINITE ELEMENT NODE LIST\n");
    for (std::size_t k = 0; k < n_nodes; ++k) std::fprintf(f, "%lld\n", static_cast<long long>((*ids)[k]));
    for (int g = 3; g <= 4; ++g) {
      std::fprintf(f, "**\n** RECORD GROUP %d, INITIAL MODAL %s\n", g, g == 3 ? "DISPLACEMENTS" : "VELOCITIES");
      const std::vector<double> zeros(static_cast<std::size_t>(n), 0.0);
      numbers(zeros.data(), n);
    }
    for (int d = 0; d < 3; ++d) {
      std::fprintf(f, "**\n** RECORD GROUP %d, NODAL %c COORDINATES\n", 5 + d, "XYZ"[d]);
      for (std::size_t k = 0; k < n_nodes; ++k) std::fprintf(f, "%.17g\n", (*xyz)[3 * k + d]);
    }
    std::fprintf(f, "**\n** RECORD GROUP 8, MODE SHAPES (x y z rx ry rz at each node)\n");
    for (int j = 0; j < n; ++j) {
      if (j < nb)
        std::fprintf(f, "**    CONSTRAINT MODE # %d: node %lld %s\n", j + 1, static_cast<long long>(se.dof_node[j]),
                     comp_name(se.dof_component[j]).c_str());
      else
        std::fprintf(f, "**    NORMAL MODE SHAPE # %d: fixed-interface mode %d, %.9g Hz\n", j + 1, j - nb + 1,
                     se.modal_frequency_hz(j - nb));
      for (std::size_t k = 0; k < n_nodes; ++k) {
        double v[6] = {0, 0, 0, 0, 0, 0};
        if (shapes) {
          for (int d = 0; d < 3; ++d) v[d] = shapes->shapes[(static_cast<std::size_t>(j) * n_nodes + k) * 3 + d];
        } else if (j < nb && se.dof_node[j] == (*ids)[k]) {
          v[se.dof_component[j] - 1] = 1.0;
        }
        std::fprintf(f, "%.17g %.17g %.17g %.17g %.17g %.17g\n", v[0], v[1], v[2], v[3], v[4], v[5]);
      }
    }
    std::fprintf(f, "**\n** RECORD GROUP 9, MODAL MASS MATRIX (M_CB, row by row, 6 values a line)\n");
    row(se.M);
    std::fprintf(f, "**\n** RECORD GROUP 10, MODAL STIFFNESS MATRIX (K_CB, row by row, 6 values a line)\n");
    row(se.K);
    const RigidBodyInertia& in = info.inertia;
    if (in.valid) {
      std::fprintf(f,
                   "**\n** RECORD GROUP 12, RIGID BODY INERTIA (mass, centre of mass, inertia "
                   "tensor about it)\n");
      std::fprintf(f, "%.17g\n%.17g %.17g %.17g\n", in.mass, in.center[0], in.center[1], in.center[2]);
      for (int a = 0; a < 3; ++a)
        std::fprintf(f, "%.17g %.17g %.17g\n", in.inertia_cm[3 * a], in.inertia_cm[3 * a + 1],
                     in.inertia_cm[3 * a + 2]);
    } else {
      std::fprintf(f, "**\n** no rigid-body inertia (record group 12): %s\n", in.reason.c_str());
    }
    if (!se.C.empty()) {
      std::fprintf(f,
                   "**\n** RECORD GROUP 13, MODAL DAMPING MATRIX (C of /rom, row by row, 6 values "
                   "a line)\n");
      row(se.C);
    }
    std::fprintf(f, "**\n** END OF FILE\n");
  });
  return info;
}

void write_op4_matrices(const std::string& path, const Superelement& se, const NastranNames& names) {
  check_name(names.op4_K, "OP4 name");
  check_name(names.op4_M, "OP4 name");
  if (!se.C.empty()) check_name(names.op4_C, "OP4 name");
  const std::string tmp = files::temp_path(path);
  const int n = se.n;
  std::vector<std::pair<const std::vector<double>*, std::string>> mats = {{&se.K, names.op4_K}, {&se.M, names.op4_M}};
  if (!se.C.empty()) mats.emplace_back(&se.C, names.op4_C);
  try {
    for (std::size_t m = 0; m < mats.size(); ++m) {
      const auto& A = *mats[m].first;
      std::vector<std::int64_t> col_ptr = {0}, row_idx;
      std::vector<double> val;
      for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
          const double v = A[static_cast<std::size_t>(i) * n + j];
          if (v != 0.0) {
            row_idx.push_back(i);
            val.push_back(v);
          }
        }
        col_ptr.push_back(static_cast<std::int64_t>(val.size()));
      }
      write_op4(tmp, mats[m].second, n, n, col_ptr, row_idx, val, Op4WriteOptions{}, m > 0);
    }
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
  files::commit(tmp, path);
}

std::int64_t default_spoint_offset(const Superelement& se) {
  std::int64_t top = 0;
  for (std::int64_t id : se.model_node_ids) top = std::max(top, id);
  for (std::int64_t id : se.boundary_nodes) top = std::max(top, id);
  std::int64_t p = 10;
  while (p <= top) p *= 10;
  return p;
}

std::string nastran_large_real(double v) {
  if (v == 0.0) return "0.0";
  MORSE_CHECK(std::isfinite(v), "cannot print ", v, " in a Nastran field");
  // The shortest mantissa that gives v back exactly, else the longest that fits in 16 characters
  // (lengths are not monotonic in the digits: rounding may add an exponent digit).
  std::string best;
  for (int p = 2; p <= 17; ++p) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*e", p - 1, v);
    const std::string s = buf;
    const auto e = s.find('e');
    const int ex = std::atoi(s.c_str() + e + 1);
    const std::string out = s.substr(0, e) + (ex < 0 ? "D-" : "D+") + std::to_string(std::abs(ex));
    if (out.size() > 16) continue;
    best = out;
    if (std::strtod((s.substr(0, e) + "e" + std::to_string(ex)).c_str(), nullptr) == v) break;
  }
  MORSE_CHECK(!best.empty(), "cannot print ", v, " in a 16-character Nastran field");
  std::string back = best;
  back[back.find('D')] = 'e';
  if (!std::isfinite(std::strtod(back.c_str(), nullptr))) {
    // Rounded past the largest double: truncate the full mantissa to the same length instead.
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.16e", v);
    const auto d = best.find('D');
    best = std::string(buf, d) + best.substr(d);
  }
  return best;
}

void write_dmig_deck(const std::string& path, const std::string& grids_path, const Superelement& se,
                     std::int64_t offset, const NastranNames& names) {
  check_name(names.dmig_K, "DMIG name");
  check_name(names.dmig_M, "DMIG name");
  if (!se.C.empty()) check_name(names.dmig_C, "DMIG name");
  check_spoints(se, offset);
  const int n = se.n, nb = se.n_b;
  auto point = [&](int i, long long* id, int* comp) {
    if (i < nb) {
      *id = se.dof_node[i];
      *comp = se.dof_component[i];
    } else {
      *id = offset + (i - nb) + 1;
      *comp = 0;
    }
  };
  const bool grids = !grids_path.empty() && se.boundary_xyz.size() == 3 * se.boundary_nodes.size();
  write_atomic(path, [&](FILE* f) {
    comment(f, "$ ", cat("Craig-Bampton superelement, written by morse ", MORSE_VERSION, " (morse export)"));
    comment(f, "$ ", cat("source: ", source_line(se)));
    comment(f, "$ ",
            cat(n, " DOFs: ", nb,
                " boundary DOFs (GRID, component in the basic system: the residual's "
                "boundary GRIDs need CD = 0), then ",
                se.n_modes(), " modal coordinates on SPOINTs ", offset + 1, "..", offset + se.n_modes(),
                " (modal coordinate k = SPOINT ", offset, "+k)"));
    comment(f, "$ ",
            cat("case control: K2GG = ", names.dmig_K, ", M2GG = ", names.dmig_M,
                se.C.empty() ? std::string() : cat(", B2GG = ", names.dmig_C)));
    comment(f, "$ ",
            "values: 16-character large fields, 10 to 12 significant digits (9 when |exponent| >= "
            "100); "
            "the exact values are in the OP4 file");
    if (grids) {
      // export_superelement writes "<stem>.part<ext>" files and renames them at the end: name the
      // final file.
      std::string g = fs::path(grids_path).filename().string();
      if (const auto k = g.rfind(".part."); k != std::string::npos) g.erase(k, 5);
      comment(f, "$ ", cat("GRID cards of the boundary nodes: ", g, " (include it if the model lacks them)"));
    }
    for (int k = 0; k < se.n_modes(); ++k)
      std::fprintf(f, "$ SPOINT %lld: fixed-interface mode %d, %.9g Hz\n", static_cast<long long>(offset + k + 1),
                   k + 1, se.modal_frequency_hz(k));
    if (se.n_modes() == 1)
      std::fprintf(f, "SPOINT  %8lld\n", static_cast<long long>(offset + 1));
    else if (se.n_modes() > 1)
      std::fprintf(f, "SPOINT  %8lld    THRU%8lld\n", static_cast<long long>(offset + 1),
                   static_cast<long long>(offset + se.n_modes()));
    auto dmig = [&](const std::vector<double>& A, const std::string& name, const char* what) {
      const bool sym = exactly_symmetric(A, n);
      std::fprintf(f, "$ %s: %s (IFO %d, TIN 2)\n", name.c_str(), what, sym ? 6 : 1);
      std::fprintf(f, "DMIG*   %-16s%16d%16d%16d\n*       %16d\n", name.c_str(), 0, sym ? 6 : 1, 2, 0);
      for (int j = 0; j < n; ++j) {
        bool started = false;
        for (int i = sym ? j : 0; i < n; ++i) {
          const double v = A[static_cast<std::size_t>(i) * n + j];
          if (v == 0.0) continue;
          long long id;
          int comp;
          if (!started) {
            point(j, &id, &comp);
            std::fprintf(f, "DMIG*   %-16s%16lld%16d\n", name.c_str(), id, comp);
            started = true;
          }
          point(i, &id, &comp);
          std::fprintf(f, "*       %16lld%16d%16s\n", id, comp, nastran_large_real(v).c_str());
        }
      }
    };
    dmig(se.K, names.dmig_K, "stiffness K_CB");
    dmig(se.M, names.dmig_M, "mass M_CB");
    if (!se.C.empty()) dmig(se.C, names.dmig_C, "viscous damping C");
  });
  if (!grids) return;
  write_atomic(grids_path, [&](FILE* f) {
    comment(
        f, "$ ",
        cat("GRID cards of the boundary nodes of ", se.source, " (basic system), written by morse ", MORSE_VERSION));
    for (std::size_t k = 0; k < se.boundary_nodes.size(); ++k) {
      const double* x = &se.boundary_xyz[3 * k];
      std::fprintf(f, "GRID*   %16lld%16s%16s%16s\n*       %16s\n", static_cast<long long>(se.boundary_nodes[k]), "",
                   nastran_large_real(x[0]).c_str(), nastran_large_real(x[1]).c_str(),
                   nastran_large_real(x[2]).c_str());
    }
  });
}

void write_matrix_market(const std::string& path_K, const std::string& path_M, const std::string& path_C,
                         const Superelement& se) {
  const int n = se.n;
  auto one = [&](const std::vector<double>& A, const std::string& path) {
    UMat S;
    MORSE_CALL(MatCreateSeqAIJ(PETSC_COMM_SELF, n, n, n, nullptr, S.ptr()));
    std::vector<PetscInt> cols;
    std::vector<PetscScalar> vals;
    for (PetscInt i = 0; i < n; ++i) {
      cols.clear();
      vals.clear();
      for (PetscInt j = 0; j < n; ++j)
        if (A[static_cast<std::size_t>(i) * n + j] != 0.0) {
          cols.push_back(j);
          vals.push_back(A[static_cast<std::size_t>(i) * n + j]);
        }
      MORSE_CALL(
          MatSetValues(S.get(), 1, &i, static_cast<PetscInt>(cols.size()), cols.data(), vals.data(), INSERT_VALUES));
    }
    MORSE_CALL(MatAssemblyBegin(S.get(), MAT_FINAL_ASSEMBLY));
    MORSE_CALL(MatAssemblyEnd(S.get(), MAT_FINAL_ASSEMBLY));
    write_matrix(S.get(), path, exactly_symmetric(A, n));
  };
  one(se.K, path_K);
  one(se.M, path_M);
  if (!se.C.empty() && !path_C.empty()) one(se.C, path_C);
}

void write_dof_map_text(const std::string& path, const Superelement& se, std::int64_t offset) {
  write_atomic(path, [&](FILE* f) {
    std::fprintf(f, "# DOF map of the exported matrices (rows and columns, 1-based), written by morse %s\n",
                 MORSE_VERSION);
    std::fprintf(f, "# source: %s\n", source_line(se).c_str());
    std::fprintf(f, "# row node <node id> <component 1..6: x y z rx ry rz, basic system>\n");
    std::fprintf(f,
                 "# row modal <k: fixed-interface mode, ascending frequency> <its SPOINT id in the "
                 "DMIG deck>\n");
    for (int j = 0; j < se.n_b; ++j)
      std::fprintf(f, "%d node %lld %d\n", j + 1, static_cast<long long>(se.dof_node[j]), se.dof_component[j]);
    for (int k = 0; k < se.n_modes(); ++k)
      std::fprintf(f, "%d modal %d %lld  # %.9g Hz\n", se.n_b + k + 1, k + 1, static_cast<long long>(offset + k + 1),
                   se.modal_frequency_hz(k));
  });
}

ExportResult export_superelement(const Superelement& se, const ExportOptions& o) {
  MORSE_CHECK(o.mbdyn || o.op4 || o.dmig || o.mtx, "no export format chosen");
  MORSE_CHECK(!o.prefix.empty(), "no output prefix given");
  ExportResult res;
  res.spoint_offset = o.spoint_offset > 0 ? o.spoint_offset : default_spoint_offset(se);
  // Everything a format needs is checked before the first file is written.
  NodalShapes shapes;
  if (o.mbdyn) {
    if (o.mbdyn_all_nodes)
      shapes = read_nodal_shapes(se);
    else {
      check_interface_components(se);
      MORSE_CHECK(se.boundary_xyz.size() == 3 * se.boundary_nodes.size(), se.source,
                  ": the MBDyn FEM file needs the coordinates of the interface nodes, and the file "
                  "has no /mesh "
                  "(matrix input): give them with -export_coordinates FILE (lines 'node x y z'), "
                  "or leave mbdyn "
                  "out of -export_format");
    }
  }
  if (o.op4) {
    check_name(o.names.op4_K, "OP4 name");
    check_name(o.names.op4_M, "OP4 name");
    check_name(o.names.op4_C, "OP4 name");
  }
  if (o.dmig) {
    check_name(o.names.dmig_K, "DMIG name");
    check_name(o.names.dmig_M, "DMIG name");
    check_name(o.names.dmig_C, "DMIG name");
    check_spoints(se, res.spoint_offset);
  }
  // Every file is written as "<stem>.part<ext>" first (the extension stays last: write_matrix picks
  // the format by it) and renamed once all of them are complete, so a failure leaves none of this
  // call's outputs.
  const std::string& p = o.prefix;
  std::vector<std::pair<std::string, std::string>> names;  // final, part
  auto part = [&](const std::string& name) {
    const auto dot = name.rfind('.');
    names.emplace_back(name, name.substr(0, dot) + ".part" + name.substr(dot));
    return names.back().second;
  };
  try {
    if (o.mbdyn) res.mbdyn = write_mbdyn_fem(part(p + ".fem"), se, o.mbdyn_all_nodes ? &shapes : nullptr);
    if (o.op4) write_op4_matrices(part(p + ".op4"), se, o.names);
    if (o.dmig) {
      const std::string deck = part(p + "_dmig.bdf");
      const bool grids = se.boundary_xyz.size() == 3 * se.boundary_nodes.size();
      write_dmig_deck(deck, grids ? part(p + "_grids.bdf") : "", se, res.spoint_offset, o.names);
    }
    if (o.mtx) {
      const std::string k = part(p + "_K.mtx"), m = part(p + "_M.mtx");
      write_matrix_market(k, m, se.C.empty() ? "" : part(p + "_C.mtx"), se);
    }
    if (o.op4 || o.mtx || o.dmig) write_dof_map_text(part(p + "_dofs.txt"), se, res.spoint_offset);
    for (const auto& [name, tmp] : names) {
      files::commit(tmp, name);
      res.files.push_back(name);
    }
  } catch (...) {
    std::error_code ec;
    for (const auto& [name, tmp] : names) fs::remove(tmp, ec);
    for (const auto& name : res.files) fs::remove(name, ec);
    throw;
  }
  return res;
}

std::vector<files::Named> export_files(const ExportOptions& o) {
  const std::string& p = o.prefix;
  if (p.empty()) return {{"-out", ""}};
  std::vector<std::string> names;
  if (o.mbdyn) names.push_back(p + ".fem");
  if (o.op4) names.push_back(p + ".op4");
  if (o.dmig) names.insert(names.end(), {p + "_dmig.bdf", p + "_grids.bdf"});
  if (o.mtx) names.insert(names.end(), {p + "_K.mtx", p + "_M.mtx", p + "_C.mtx"});
  if (o.op4 || o.mtx || o.dmig) names.push_back(p + "_dofs.txt");
  std::vector<files::Named> out;
  for (auto& n : names) out.push_back({"-out", n});
  return out;
}

}  // namespace morse::io
