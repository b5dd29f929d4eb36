// app/common.cpp: the parts of the morse commands that several of them share (declared in
// common.hpp): option getters, the unknown-option check, model building and the output writers.
#include "app/common.hpp"

#include <petscmat.h>
#include <petscsys.h>

#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/fe/model.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/mesh.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::app::detail {

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

std::string xdmf_path_of(const std::string& h5) {
  auto dot = h5.rfind('.');
  return (dot == std::string::npos ? h5 : h5.substr(0, dot)) + ".xdmf";
}

std::string base_name(const std::string& p) {
  auto s = p.rfind('/');
  return s == std::string::npos ? p : p.substr(s + 1);
}

}  // namespace

PetscErrorCode get_common(MPI_Comm comm, const char* default_out, CommonOptions* o) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  char* sets[16];
  PetscInt n_sets = 16;
  PetscBool set = PETSC_FALSE;
  o->material.name = "options";
  o->material.E = o->material.nu = o->material.rho = -1;
  PetscOptionsBegin(comm, nullptr, "morse model options", "");
  PetscCall(MorseOptionsString("-mesh", "Mesh file: .msh (Gmsh 4.1/2.2 ASCII), .inp (Abaqus/CalculiX) or .bdf/.dat/.nas (Nastran bulk data)", "",
                               buf, buf, sizeof buf, &set));
  if (set) o->mesh = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-mesh_units",
                               "Unit system of the mesh, recorded in the output (e.g. SI, mm-t-s); "
                               "default: from the mesh (Gmsh: SI, Abaqus: unknown)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->units = buf;
  PetscCall(MorseOptionsBool("-mesh_skip_unsupported",
                             "Nastran: skip element cards morse cannot represent (CQUAD4, CBAR, CELAS, ...) with a warning "
                             "instead of an error (their stiffness and mass are then missing)",
                             "", o->skip_unsupported, &o->skip_unsupported, nullptr));
  PetscCall(MorseOptionsStringArray("-clamp",
                                    "Node sets whose DOFs are eliminated, comma separated; *BOUNDARY = "
                                    "the DOFs fixed by *BOUNDARY in the deck",
                                    "", sets, &n_sets, &set));
  if (set)
    for (PetscInt i = 0; i < n_sets; ++i) {
      o->clamp.emplace_back(sets[i]);
      PetscCall(PetscFree(sets[i]));
    }
  PetscCall(MorseOptionsReal("-material_E", "Young's modulus for elements without material in the mesh", "",
                             o->material.E, &o->material.E, nullptr));
  PetscCall(MorseOptionsReal("-material_nu", "Poisson's ratio for elements without material in the mesh",
                             "", o->material.nu, &o->material.nu, nullptr));
  PetscCall(MorseOptionsReal("-material_rho", "Density for elements without material in the mesh", "",
                             o->material.rho, &o->material.rho, nullptr));
  n_sets = 16;
  PetscCall(MorseOptionsStringArray("-material_sets",
                                    "Element sets given their own material by -material_<set>_E, _nu, _rho "
                                    "(overrides the mesh's material for those elements)",
                                    "", sets, &n_sets, &set));
  if (set)
    for (PetscInt i = 0; i < n_sets; ++i) {
      mesh::Material m;
      m.name = sets[i];
      m.E = m.nu = m.rho = -1;
      PetscCall(PetscFree(sets[i]));
      const std::string p = "-material_" + m.name + "_";
      PetscCall(MorseOptionsReal((p + "E").c_str(), "Young's modulus of the element set", "", m.E, &m.E, nullptr));
      PetscCall(MorseOptionsReal((p + "nu").c_str(), "Poisson's ratio of the element set", "", m.nu, &m.nu, nullptr));
      PetscCall(MorseOptionsReal((p + "rho").c_str(), "Density of the element set", "", m.rho, &m.rho, nullptr));
      o->set_materials.push_back(m);
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
      PetscCall(MorseOptionsString(opt.c_str(), "External node ids of the node set", "", list, list, sizeof list, &has));
      std::vector<std::int64_t> ids;
      std::string err = has ? parse_id_list(list, &ids) : cat("give the node ids of set ", name, " with ", opt);
      if (!err.empty() && o->error.empty()) o->error = has ? cat(opt, ": ", err) : err;
      o->node_sets.emplace_back(name, std::move(ids));
    }
  struct {
    const char* name;
    const char* help;
    std::string* dest;
  } files[] = {
      {"-matrices_K", "Stiffness matrix instead of a mesh (reduce, select): .mtx/.mm MatrixMarket, .petsc/.bin PETSc binary, "
                      ".op4[:NAME] Nastran OUTPUT4", &o->matrices.K},
      {"-matrices_M", "Mass matrix (same formats as -matrices_K)", &o->matrices.M},
      {"-matrices_C", "Viscous damping matrix, projected on the superelement (optional)", &o->matrices.C},
      {"-matrices_dofmap", "DOF map of the matrices: text 'node component [set ...]' per row, or .h5 /dofmap", &o->matrices.dofmap},
  };
  for (auto& f : files) {
    buf[0] = 0;
    PetscCall(MorseOptionsString(f.name, f.help, "", buf, buf, sizeof buf, &set));
    if (set) *f.dest = buf;
  }
  PetscCall(MorseOptionsReal("-matrices_symmetry_tol", "Largest |A - A^T| / max|A| accepted in K, M, C (then symmetrized)",
                             "", o->matrices.symmetry_tol, &o->matrices.symmetry_tol, nullptr));
  PetscCall(PetscStrncpy(buf, default_out, sizeof buf));
  PetscCall(MorseOptionsString("-out", "Output file", "", buf, buf, sizeof buf, nullptr));
  o->out = buf;
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

void check_options(MPI_Comm comm, bool early) { options::check_unknown(comm, early); }

bool help_requested() {
  PetscBool h = PETSC_FALSE;
  PetscOptionsHasHelp(nullptr, &h);
  return h;
}

Model build_model(MPI_Comm comm, const CommonOptions& o, const char* needs_mesh) {
  MORSE_CHECK(o.error.empty(), o.error);
  MORSE_CHECK(!needs_mesh || !o.matrices_given(),
              needs_mesh, "; -matrices_K/-matrices_M/-matrices_C/-matrices_dofmap give none (use -mesh)");
  MORSE_CHECK(!(o.matrices_given() && !o.mesh.empty()), "give either -mesh or -matrices_K/-matrices_M, not both");
  if (o.matrices_given()) {
    MORSE_CHECK(o.set_materials.empty() && o.material.E < 0 && o.material.nu < 0 && o.material.rho < 0,
                "-material_* options need a mesh: the matrices already hold the material");
    io::MatrixInput in = o.matrices;
    in.clamp = o.clamp;
    in.node_sets = o.node_sets;
    in.units = o.units;
    Model md;
    {
      StageTimer t(comm, "ReadMatrices");
      md = io::matrix_model(comm, in);
    }
    MatInfo ik, im;
    MORSE_CALL(MatGetInfo(md.K.get(), MAT_GLOBAL_SUM, &ik));
    MORSE_CALL(MatGetInfo(md.M.get(), MAT_GLOBAL_SUM, &im));
    print0(comm, "morse: matrices K %s (%.0f entries), M %s (%.0f entries)%s%s: %lld rows, %lld clamped, %lld free\n",
           o.matrices.K.c_str(), ik.nz_used, o.matrices.M.c_str(), im.nz_used, md.C ? ", C " : "",
           md.C ? o.matrices.C.c_str() : "", (long long)(md.dofs.n_global + md.dofs.n_clamped_global),
           (long long)md.dofs.n_clamped_global, (long long)md.dofs.n_global);
    print0(comm, "morse: symmetry: max|K - K^T| / max|K| = %.3g, max|M - M^T| / max|M| = %.3g (symmetrized)\n",
           md.asymmetry_K, md.asymmetry_M);
    return md;
  }
  MORSE_CHECK(!o.mesh.empty(), !needs_mesh ? "no model given: use -mesh FILE (.msh, .inp, .bdf) or -matrices_K FILE -matrices_M FILE"
                                           : "no mesh given: use -mesh FILE (.msh, .inp or .bdf)");
  fe::MeshInput in;
  in.path = o.mesh;
  in.units = o.units;
  in.skip_unsupported = o.skip_unsupported;
  in.clamp = o.clamp;
  in.material = o.material;
  in.set_materials = o.set_materials;
  in.node_sets = o.node_sets;
  Model md = fe::mesh_model(comm, in);
  int size = 1;
  MPI_Comm_size(comm, &size);
  print0(comm, "morse: mesh %s (%s units): %lld nodes, %lld elements on %d rank(s)\n", o.mesh.c_str(),
         md.units.c_str(), (long long)md.mesh->n_global_nodes, (long long)md.mesh->n_global_elements, size);
  print0(comm, "morse: %lld free DOFs, %lld clamped; volume %.6g, mass %.6g\n", (long long)md.dofs.n_global,
         (long long)md.dofs.n_clamped_global, md.volume, md.mass);
  return md;
}

int rank_of(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

void write_xdmf_collective(MPI_Comm comm, const std::string& h5, const mesh::Mesh& gm,
                           const std::vector<io::XdmfField>& fields) {
  std::string err;
  if (rank_of(comm) == 0) try {
      io::write_xdmf(xdmf_path_of(h5), base_name(h5), gm, fields);
    } catch (const Error& e) {
      err = e.what();
    }
  collective_check(comm, err);
}

io::Superelement rom_superelement(const cb::CBResult& cb, const std::vector<double>& M, const std::vector<double>& K,
                                  const std::vector<double>* C, const std::vector<double>& freq_hz, double damping) {
  io::Superelement se;
  se.n = static_cast<int>(freq_hz.size());
  se.n_b = static_cast<int>(cb.n_b);
  se.M = M;
  se.K = K;
  if (C) se.C = *C;
  se.boundary_nodes = cb.boundary_node_ids;
  se.dof_node.assign(cb.boundary_dof_node.begin(), cb.boundary_dof_node.begin() + cb.n_b);
  se.dof_component.assign(cb.boundary_dof_component.begin(), cb.boundary_dof_component.begin() + cb.n_b);
  se.frequencies_hz = freq_hz;
  se.damping_ratio = damping;
  return se;
}

PetscErrorCode get_boundary(MPI_Comm comm, std::string* boundary) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse interface", "");
  PetscCall(MorseOptionsString("-boundary",
                               "Node set of the interface, kept as physical DOFs (its x,y,z: the boundary DOFs of the "
                               "superelement; nlrom: the contact nodes)",
                               "", buf, buf, sizeof buf, &set));
  PetscOptionsEnd();
  if (set) *boundary = buf;
  return PETSC_SUCCESS;
}

PetscErrorCode get_reduce_options(MPI_Comm comm, ReduceOptions* r) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscCall(get_boundary(comm, &r->boundary));
  PetscOptionsBegin(comm, nullptr, "morse reduce (Craig-Bampton) options", "");
  PetscCall(MorseOptionsInt("-cb_num_fixed_modes", "Number of fixed-interface modes (0 = Guyan)", "", r->n_fixed,
                            &r->n_fixed, nullptr));
  PetscCall(MorseOptionsReal("-cb_fmax", "Keep every fixed-interface mode below this frequency [Hz] "
                             "(spectrum slicing; seed 000 uses 5x the top frequency of interest)",
                             "", r->fmax, &r->fmax, nullptr));
  PetscCall(MorseOptionsReal("-cb_damping", "Modal damping ratio xi of the fixed-interface modes", "", r->damping,
                             &r->damping, nullptr));
  PetscCall(MorseOptionsBool("-cb_write_basis", "Write the constraint and fixed-interface modes (Psi, Phi)", "",
                             r->write_basis, &r->write_basis, nullptr));
  PetscCall(MorseOptionsBool("-cb_xdmf", "Write an XDMF file for ParaView (with -cb_write_basis)", "", r->xdmf,
                             &r->xdmf, &r->xdmf_set));
  buf[0] = 0;
  PetscCall(MorseOptionsString("-matrices_write",
                               "Also write the model's free-DOF K and M and its DOF map as PREFIX_K.EXT, PREFIX_M.EXT, "
                               "PREFIX_dofmap.txt (mesh input)",
                               "", buf, buf, sizeof buf, &set));
  if (set) r->write_matrices = buf;
  PetscCall(PetscStrncpy(buf, r->write_format.c_str(), sizeof buf));
  PetscCall(MorseOptionsString("-matrices_write_format", "Format of -matrices_write: mtx (MatrixMarket) or petsc (binary)",
                               "", buf, buf, sizeof buf, nullptr));
  r->write_format = buf;
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

cb::CBSettings cb_settings(const ReduceOptions& r) {
  cb::CBSettings s;
  s.boundary_set = r.boundary;
  s.n_fixed = r.n_fixed;
  s.fmax_hz = r.fmax;
  s.damping = r.damping;
  s.keep_basis = r.write_basis;
  return s;
}

}  // namespace morse::app::detail
