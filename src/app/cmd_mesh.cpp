// app/cmd_mesh.cpp: `morse mesh box|blade|stator`, which generates a mesh and writes it as Gmsh
// 4.1, and `morse mesh info`, which reads and distributes a mesh and reports its content and
// quality.
#include <petscsys.h>

#include <cctype>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/fe/model.hpp"
#include "morse/mesh/blade.hpp"
#include "morse/mesh/generator.hpp"
#include "morse/mesh/gmsh.hpp"
#include "morse/mesh/mesh.hpp"
#include "morse/mesh/nastran.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/mesh/stator.hpp"

namespace morse::app::detail {

namespace {

PetscErrorCode get_mesh_out(MPI_Comm comm, char* out, size_t len) {
  PetscOptionsBegin(comm, nullptr, "morse mesh options", "");
  PetscCall(MorseOptionsString("-out", "Output mesh file: .msh (Gmsh 4.1) or .bdf/.dat/.nas (Nastran bulk data)", "",
                               out, out, len, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

PetscErrorCode get_mesh_in(MPI_Comm comm, std::string* path) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse mesh info options", "");
  PetscCall(MorseOptionsString(
      "-mesh", "Mesh file: .msh (Gmsh 4.1/2.2 ASCII), .inp (Abaqus/CalculiX) or .bdf/.dat/.nas (Nastran bulk data)", "",
      buf, buf, sizeof buf, &set));
  PetscOptionsEnd();
  if (set) *path = buf;
  return PETSC_SUCCESS;
}

// `morse mesh info -mesh FILE`: reads and distributes a mesh and reports its content and
// quality (a check before a long run, and the read benchmark).
void run_mesh_info(MPI_Comm comm) {
  std::string path;
  MORSE_CALL(get_mesh_in(comm, &path));
  if (help_requested()) return;
  check_options(comm, false);
  MORSE_CHECK(!path.empty(), "no mesh given: use -mesh FILE (.msh or .inp)");
  mesh::LocalMesh lm;
  {
    StageTimer t(comm, "ReadDistribute");
    lm = mesh::read_and_distribute(comm, path);
  }
  StageTimer t(comm, "Check");
  const auto& m = lm.mesh;
  const fe::MeshQuality q = fe::mesh_quality(comm, lm);
  print0(comm, "morse: mesh %s (%s units): %lld nodes, %lld elements\n", path.c_str(), m.units.c_str(),
         (long long)lm.n_global_nodes, (long long)lm.n_global_elements);
  for (int k = 0; k < mesh::kNumElementTypes; ++k)
    if (q.per_type[k])
      print0(comm, "  %-8s %lld\n", mesh::element_name(static_cast<mesh::ElementType>(k)), (long long)q.per_type[k]);
  print0(comm, "  volume %.10g; smallest Jacobian determinant %.6g (element %lld); %lld inverted elements\n", q.volume,
         q.min_jacobian, (long long)q.worst_element, (long long)q.n_inverted);
  for (const auto& [name, n] : lm.node_set_sizes)
    print0(comm, "  node set    %-20s %lld nodes\n", name.c_str(), (long long)n);
  for (const auto& [name, n] : lm.elem_set_sizes)
    print0(comm, "  element set %-20s %lld elements\n", name.c_str(), (long long)n);
  for (const auto& mat : m.materials)
    print0(comm, "  material %-20s E %.6g nu %.6g rho %.6g\n", mat.name.c_str(), mat.E, mat.nu, mat.rho);
  if (q.n_fixed_nodes) print0(comm, "  *BOUNDARY fixes DOFs of %lld nodes\n", (long long)q.n_fixed_nodes);
  const auto& cs = m.constraints;
  if (!cs.empty()) {
    print0(comm, "  constraints: %s\n", cs.summary().c_str());
    std::size_t n_dep = 0, n_terms = 0;
    for (const auto& r : cs.rigid) n_dep += r.dependent.size();
    for (const auto& r : cs.interpolation) n_terms += r.nodes.size();
    print0(comm, "    rigid elements tie %zu dependent nodes; interpolation elements hold %zu nodes in all\n", n_dep,
           n_terms);
    for (std::size_t p = 0; p < cs.point_ids.size() && p < 20; ++p)
      print0(comm, "    point %lld at (%.6g, %.6g, %.6g)%s\n", (long long)cs.point_ids[p], cs.point_coords[3 * p],
             cs.point_coords[3 * p + 1], cs.point_coords[3 * p + 2],
             cs.point_mass.size() > p && cs.point_mass[p] != 0 ? cat(", mass ", cs.point_mass[p]).c_str() : "");
    if (cs.point_ids.size() > 20) print0(comm, "    ... (%zu points)\n", cs.point_ids.size());
  }
}

}  // namespace

void run_mesh(MPI_Comm comm, const std::vector<std::string>& args) {
  const std::string what = args.size() == 1 ? args[0] : "";
  if (what == "info") return run_mesh_info(comm);
  MORSE_CHECK(what == "box" || what == "blade" || what == "stator",
              "usage: morse mesh (box|blade|stator) [-box_*|-blade_*|-stator_* options] -out FILE.msh, "
              "or morse mesh info -mesh FILE");
  char out[PETSC_MAX_PATH_LEN] = "";
  mesh::BoxSpec box;
  mesh::BladeSpec blade;
  mesh::StatorSpec stator;
  std::strcpy(out, (what + ".msh").c_str());
  MORSE_CALL(get_mesh_out(comm, out, sizeof out));
  if (what == "box") {
    std::string error;
    MORSE_CALL(mesh::box_spec_from_options(comm, &box, &error));
    MORSE_CHECK(error.empty(), error);
  } else {
    if (what == "blade")
      MORSE_CALL(mesh::blade_spec_from_options(comm, &blade));
    else
      MORSE_CALL(mesh::stator_spec_from_options(comm, &stator));
  }
  // Nastran output: the material of the deck and its format.
  mesh::NastranWriteOptions nw;
  MORSE_CALL(nw.set_from_options(comm));
  const mesh::Material& mat = nw.material;
  if (help_requested()) return;
  check_options(comm, false);
  const std::string out_s = out;
  auto dot = out_s.rfind('.');
  std::string ext = dot == std::string::npos ? "" : out_s.substr(dot + 1);
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const bool nastran = ext == "bdf" || ext == "dat" || ext == "nas";
  MORSE_CHECK(nastran || ext == "msh", "-out ", out_s, ": expected .msh (Gmsh) or .bdf/.dat/.nas (Nastran)");
  MORSE_CHECK(!nastran || (mat.E > 0 && mat.nu > -1 && mat.nu < 0.5 && mat.rho > 0), "-out ", out_s,
              ": a Nastran deck carries its material: give -material_E, -material_nu and -material_rho");
  MORSE_CHECK(nw.error.empty(), nw.error);
  const auto output_lock = files::prepare_outputs(comm, {{"-out", out_s}}, {});
  std::string err;
  if (rank_of(comm) == 0) try {
      auto m = what == "box"     ? mesh::generate_box(box)
               : what == "blade" ? mesh::generate_blade(blade)
                                 : mesh::generate_stator(stator);
      if (nastran) {
        m.materials.push_back(mat);
        for (auto& em : m.elem_material)
          if (em < 0) em = static_cast<int>(m.materials.size()) - 1;
        if (!nw.spc.empty()) {
          auto it = m.node_sets.find(nw.spc);
          MORSE_CHECK(it != m.node_sets.end(), "-nastran_spc ", nw.spc, ": the mesh has no such node set");
          m.fixed_dofs.assign(m.num_nodes(), 0);
          for (auto k : it->second) m.fixed_dofs[k] = 7;
        }
        mesh::write_nastran(m, out, nw);
      } else {
        mesh::write_gmsh(m, out);
      }
      print0(comm, "morse: wrote %s: %lld nodes, %lld elements (%s)\n", out, (long long)m.num_nodes(),
             (long long)m.num_elements(), m.source.c_str());
    } catch (const std::exception& e) {  // e.g. std::bad_alloc: every rank reports it
      err = message_of(e);
    }
  collective_check(comm, err);
}

}  // namespace morse::app::detail
