// io/model_input.cpp: io::ModelInput, the model options of the commands (a mesh or assembled
// operators) read into fe::MeshInput and io::MatrixInput.
#include <petscsys.h>

#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/options.hpp"
#include "morse/io/matrices.hpp"
#include "morse/io/matrix_model.hpp"

namespace morse::io {

namespace {

// "1,2,10-12" -> {1, 2, 10, 11, 12}; "" on success, else the reason.
std::string parse_id_list(const std::string& text, std::vector<std::int64_t>* ids) {
  std::size_t p = 0;
  while (p <= text.size()) {
    std::size_t q = text.find(',', p);
    if (q == std::string::npos) q = text.size();
    const std::string item = text.substr(p, q - p);
    char* end = nullptr;
    const long long a = std::strtoll(item.c_str(), &end, 10);
    long long b = a;
    if (end != item.c_str() && *end == '-') b = std::strtoll(end + 1, &end, 10);
    if (item.empty() || *end != '\0' || b < a || b - a > 10000000)
      return cat("'", item, "' is not a node id or a range a-b");
    for (long long v = a; v <= b; ++v) ids->push_back(v);
    p = q + 1;
  }
  return {};
}

}  // namespace

PetscErrorCode ModelInput::set_from_options(MPI_Comm comm, const char* default_out) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  char* sets[16];
  PetscInt n_sets = 16;
  PetscBool set = PETSC_FALSE, skip = mesh.skip_unsupported ? PETSC_TRUE : PETSC_FALSE;
  auto& material = mesh.material;
  material.name = "options";
  material.E = material.nu = material.rho = -1;
  PetscOptionsBegin(comm, nullptr, "morse model options", "");
  PetscCall(MorseOptionsString(
      "-mesh", "Mesh file: .msh (Gmsh 4.1/2.2 ASCII), .inp (Abaqus/CalculiX) or .bdf/.dat/.nas (Nastran bulk data)", "",
      buf, buf, sizeof buf, &set));
  if (set) mesh.path = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-mesh_units",
                               "Unit system of the mesh, recorded in the output (e.g. SI, mm-t-s); "
                               "default: from the mesh (Gmsh: SI, Abaqus: unknown)",
                               "", buf, buf, sizeof buf, &set));
  if (set) mesh.units = matrices.units = buf;
  PetscCall(
      MorseOptionsBool("-mesh_skip_unsupported",
                       "Nastran: skip element cards morse cannot represent (CQUAD4, CBAR, CELAS, ...) with a warning "
                       "instead of an error (their stiffness and mass are then missing)",
                       "", skip, &skip, nullptr));
  mesh.skip_unsupported = skip;
  PetscCall(MorseOptionsStringArray("-clamp",
                                    "Node sets whose DOFs are eliminated, comma separated; *BOUNDARY = "
                                    "the DOFs fixed by *BOUNDARY in the deck",
                                    "", sets, &n_sets, &set));
  if (set)
    for (PetscInt i = 0; i < n_sets; ++i) {
      mesh.clamp.emplace_back(sets[i]);
      PetscCall(PetscFree(sets[i]));
    }
  matrices.clamp = mesh.clamp;
  // A material value given must be usable: E and rho positive, with squares that are normal
  // doubles (E = 1e-300 ends in a LAPACK failure far away), nu in (-1, 0.5).
  auto check_material = [&](const std::string& p, const morse::mesh::Material& m, const PetscBool given[3]) {
    const double v[3] = {m.E, m.nu, m.rho};
    const char* what[3] = {"E", "nu", "rho"};
    for (int i = 0; i < 3 && error.empty(); ++i) {
      if (!given[i]) continue;
      if (i == 1)
        error = v[i] > -1 && v[i] < 0.5 ? "" : cat(p, what[i], " ", v[i], " must be in (-1, 0.5)");
      else
        error = options::magnitude_error(p + what[i], v[i]);
    }
  };
  PetscBool given[3] = {PETSC_FALSE, PETSC_FALSE, PETSC_FALSE};
  PetscCall(MorseOptionsReal("-material_E", "Young's modulus for elements without material in the mesh", "", material.E,
                             &material.E, &given[0]));
  PetscCall(MorseOptionsReal("-material_nu", "Poisson's ratio for elements without material in the mesh", "",
                             material.nu, &material.nu, &given[1]));
  PetscCall(MorseOptionsReal("-material_rho", "Density for elements without material in the mesh", "", material.rho,
                             &material.rho, &given[2]));
  check_material("-material_", material, given);
  n_sets = 16;
  PetscCall(MorseOptionsStringArray("-material_sets",
                                    "Element sets given their own material by -material_<set>_E, _nu, _rho "
                                    "(overrides the mesh's material for those elements)",
                                    "", sets, &n_sets, &set));
  if (set)
    for (PetscInt i = 0; i < n_sets; ++i) {
      morse::mesh::Material m;
      m.name = sets[i];
      m.E = m.nu = m.rho = -1;
      PetscCall(PetscFree(sets[i]));
      const std::string p = "-material_" + m.name + "_";
      PetscBool has[3] = {PETSC_FALSE, PETSC_FALSE, PETSC_FALSE};
      PetscCall(MorseOptionsReal((p + "E").c_str(), "Young's modulus of the element set", "", m.E, &m.E, &has[0]));
      PetscCall(MorseOptionsReal((p + "nu").c_str(), "Poisson's ratio of the element set", "", m.nu, &m.nu, &has[1]));
      PetscCall(MorseOptionsReal((p + "rho").c_str(), "Density of the element set", "", m.rho, &m.rho, &has[2]));
      // The set's material replaces the mesh's: all three values are needed.
      const char* what[3] = {"E", "nu", "rho"};
      for (int k = 0; k < 3 && error.empty(); ++k)
        if (!has[k])
          error = cat("-material_sets ", m.name, ": ", p, what[k], " is missing (an element set's material needs ", p,
                      "E, ", p, "nu and ", p, "rho)");
      check_material(p, m, has);
      mesh.set_materials.push_back(m);
    }
  n_sets = 16;
  PetscCall(MorseOptionsStringArray("-mesh_node_sets",
                                    "Node sets added to the mesh, comma separated; their nodes are given by "
                                    "-mesh_node_set_<name> id,id,a-b,... (external node ids, a-b = a range)",
                                    "", sets, &n_sets, &set));
  if (set)
    for (PetscInt i = 0; i < n_sets; ++i) {
      std::string name = sets[i];
      PetscCall(PetscFree(sets[i]));
      const std::string opt = "-mesh_node_set_" + name;
      char list[4096] = "";
      PetscBool has = PETSC_FALSE;
      PetscCall(
          MorseOptionsString(opt.c_str(), "External node ids of the node set", "", list, list, sizeof list, &has));
      std::vector<std::int64_t> ids;
      std::string err = has ? parse_id_list(list, &ids) : cat("give the node ids of set ", name, " with ", opt);
      if (!err.empty() && error.empty()) error = has ? cat(opt, ": ", err) : err;
      mesh.node_sets.emplace_back(name, std::move(ids));
    }
  matrices.node_sets = mesh.node_sets;
  n_sets = 16;
  PetscCall(MorseOptionsStringArray(
      "-mesh_spiders",
      "Node sets whose every node gets a spider: a six-DOF point at the node joined to the nodes within "
      "-mesh_spider_radius (set <name>_spiders holds the points)",
      "", sets, &n_sets, &set));
  if (set)
    for (PetscInt i = 0; i < n_sets; ++i) {
      mesh.spider_sets.emplace_back(sets[i]);
      PetscCall(PetscFree(sets[i]));
    }
  PetscBool has_radius = PETSC_FALSE;
  PetscCall(MorseOptionsReal("-mesh_spider_radius", "Reach of the spiders [mesh length unit]", "", mesh.spider_radius,
                             &mesh.spider_radius, &has_radius));
  {
    const char* types[] = {"rbe2", "rbe3", "SpiderType", "", nullptr};
    PetscEnum t =
        mesh.spider_type == morse::mesh::SpiderType::Rigid ? static_cast<PetscEnum>(0) : static_cast<PetscEnum>(1);
    PetscCall(MorseOptionsEnum("-mesh_spider_type",
                               "rbe3: the point moves as the least-squares fit of its nodes (no stiffness added); "
                               "rbe2: the nodes follow the point rigidly",
                               "", types, t, &t, nullptr));
    mesh.spider_type =
        t == static_cast<PetscEnum>(0) ? morse::mesh::SpiderType::Rigid : morse::mesh::SpiderType::Interpolation;
  }
  if (!mesh.spider_sets.empty() && !has_radius && error.empty())
    error = "-mesh_spiders needs -mesh_spider_radius R (the nodes within R of each node are joined to its point)";
  struct {
    const char* name;
    const char* help;
    std::string* dest;
  } files[] = {
      {"-matrices_K",
       "Stiffness matrix instead of a mesh (reduce, select): .mtx/.mm MatrixMarket, .petsc/.bin PETSc binary, "
       ".op4[:NAME] Nastran OUTPUT4",
       &matrices.K},
      {"-matrices_M", "Mass matrix (same formats as -matrices_K)", &matrices.M},
      {"-matrices_C", "Viscous damping matrix, projected on the superelement (optional)", &matrices.C},
      {"-matrices_dofmap", "DOF map of the matrices: text 'node component [set ...]' per row, or .h5 /dofmap",
       &matrices.dofmap},
  };
  for (auto& f : files) {
    buf[0] = 0;
    PetscCall(MorseOptionsString(f.name, f.help, "", buf, buf, sizeof buf, &set));
    if (set) *f.dest = buf;
  }
  PetscCall(MorseOptionsReal("-matrices_symmetry_tol",
                             "Largest |A - A^T| / max|A| accepted in K, M, C (then symmetrized)", "",
                             matrices.symmetry_tol, &matrices.symmetry_tol, nullptr));
  PetscCall(PetscStrncpy(buf, default_out, sizeof buf));
  PetscCall(MorseOptionsString("-out", "Output file", "", buf, buf, sizeof buf, nullptr));
  out = buf;
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

void ModelInput::check(const char* needs_mesh) const {
  MORSE_CHECK(error.empty(), error);
  MORSE_CHECK(!needs_mesh || !matrices_given(), needs_mesh,
              "; -matrices_K/-matrices_M/-matrices_C/-matrices_dofmap give none (use -mesh)");
  MORSE_CHECK(!(matrices_given() && !mesh.path.empty()), "give either -mesh or -matrices_K/-matrices_M, not both");
  if (matrices_given()) {
    MORSE_CHECK(mesh.set_materials.empty() && mesh.material.E < 0 && mesh.material.nu < 0 && mesh.material.rho < 0,
                "-material_* options need a mesh: the matrices already hold the material");
    return;
  }
  MORSE_CHECK(!mesh.path.empty(),
              !needs_mesh ? "no model given: use -mesh FILE (.msh, .inp, .bdf) or -matrices_K FILE -matrices_M FILE"
                          : "no mesh given: use -mesh FILE (.msh, .inp or .bdf)");
}

std::vector<files::Named> ModelInput::inputs() const {
  return {{"-mesh", mesh.path},
          {"-matrices_K", matrix_file(matrices.K)},
          {"-matrices_M", matrix_file(matrices.M)},
          {"-matrices_C", matrix_file(matrices.C)},
          {"-matrices_dofmap", matrices.dofmap}};
}

}  // namespace morse::io
