#include "morse/app/commands.hpp"

#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/fe/model.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/blade.hpp"
#include "morse/mesh/generator.hpp"
#include "morse/mesh/stator.hpp"
#include "morse/mesh/gmsh.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::app {

namespace {

constexpr double kTwoPi = 6.283185307179586;

struct CommonOptions {
  std::string mesh;
  std::string units;
  std::vector<std::string> clamp;
  mesh::Material material;
  std::string out;
};

PetscErrorCode get_common(MPI_Comm comm, const char* default_out, CommonOptions* o) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  char* sets[16];
  PetscInt n_sets = 16;
  PetscBool set = PETSC_FALSE;
  o->material.name = "options";
  o->material.E = o->material.nu = o->material.rho = -1;
  PetscOptionsBegin(comm, nullptr, "morse model options", "");
  PetscCall(PetscOptionsString("-mesh", "Mesh file: .msh (Gmsh 4.1/2.2 ASCII) or .inp (Abaqus/CalculiX)", "",
                               buf, buf, sizeof buf, &set));
  if (set) o->mesh = buf;
  buf[0] = 0;
  PetscCall(PetscOptionsString("-mesh_units",
                               "Unit system of the mesh, recorded in the output (e.g. SI, mm-t-s); "
                               "default: from the mesh (Gmsh: SI, Abaqus: unknown)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->units = buf;
  PetscCall(PetscOptionsStringArray("-clamp",
                                    "Node sets whose DOFs are eliminated, comma separated; *BOUNDARY = "
                                    "the DOFs fixed by *BOUNDARY in the deck",
                                    "", sets, &n_sets, &set));
  if (set)
    for (PetscInt i = 0; i < n_sets; ++i) {
      o->clamp.emplace_back(sets[i]);
      PetscCall(PetscFree(sets[i]));
    }
  PetscCall(PetscOptionsReal("-material_E", "Young's modulus for elements without material in the mesh", "",
                             o->material.E, &o->material.E, nullptr));
  PetscCall(PetscOptionsReal("-material_nu", "Poisson's ratio for elements without material in the mesh",
                             "", o->material.nu, &o->material.nu, nullptr));
  PetscCall(PetscOptionsReal("-material_rho", "Density for elements without material in the mesh", "",
                             o->material.rho, &o->material.rho, nullptr));
  PetscCall(PetscStrncpy(buf, default_out, sizeof buf));
  PetscCall(PetscOptionsString("-out", "Output file", "", buf, buf, sizeof buf, nullptr));
  o->out = buf;
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

// Options owned by inner PETSc/SLEPc objects of a command: accepted by the early check.
bool inner_option(const std::string& name) {
  static const char* inner[] = {"cb_eps_", "cb_st_", "cb_bv_", "cb_ds_", "cb_rg_", "modes_eps_", "modes_st_",
                                "modes_bv_", "modes_ds_", "modes_rg_"};
  for (const char* p : inner)
    if (name.rfind(p, 0) == 0) return true;
  return false;
}

// Unknown-option check. early: only options with a morse prefix that no command option matched
// (a typo of a morse option); final: every option nobody used.
void check_options(MPI_Comm comm, bool early) {
  PetscInt n = 0;
  char** names = nullptr;
  char** values = nullptr;
  MORSE_CALL(PetscOptionsLeftGet(nullptr, &n, &names, &values));
  std::string bad;
  static const char* morse_prefixes[] = {"cb_", "modes_", "material_", "mesh", "box_", "clamp", "boundary", "out",
                                         "blade_", "stator_", "select_", "nlrom_", "step_", "sim_", "sweep_"};
  for (PetscInt i = 0; i < n; ++i) {
    std::string name = names[i];
    if (name == "help" || name == "options_left" || name.rfind("log_", 0) == 0) continue;
    bool flag = !early;
    if (early)
      for (const char* p : morse_prefixes)
        if (name.rfind(p, 0) == 0 && !inner_option(name)) flag = true;
    if (flag) bad += " -" + name;
  }
  MORSE_CALL(PetscOptionsLeftRestore(nullptr, &n, &names, &values));
  collective_check(comm, bad.empty() ? "" : cat("unknown option(s):", bad, " (see -help)"));
}

bool help_requested() {
  PetscBool h = PETSC_FALSE;
  PetscOptionsHasHelp(nullptr, &h);
  return h;
}

double wall_seconds() {
  static const double t0 = MPI_Wtime();
  return MPI_Wtime() - t0;
}

void print_stage_table(MPI_Comm comm) {
  auto records = reduced_stage_records(comm);
  print0(comm, "\n  %-22s %10s %12s\n", "stage", "time [s]", "peak [MB]");
  double peak = 0;
  for (const auto& r : records) {
    print0(comm, "  %-22s %10.3f %12.1f\n", r.name.c_str(), r.seconds, r.peak_mb);
    peak = std::max(peak, r.peak_mb);
  }
  print0(comm, "  %-22s %10.3f %12.1f\n", "total (wall)", wall_seconds(), peak);
}

struct Model {
  mesh::LocalMesh lm;
  fe::DofMap dofs;
  fe::Operators ops;
};

Model build_model(MPI_Comm comm, const CommonOptions& o) {
  MORSE_CHECK(!o.mesh.empty(), "no mesh given: use -mesh FILE (.msh or .inp)");
  Model md;
  {
    StageTimer t(comm, "ReadDistribute");
    md.lm = mesh::read_and_distribute(comm, o.mesh);
    if (!o.units.empty()) md.lm.mesh.units = o.units;
  }
  {
    StageTimer t(comm, "NumberDofs");
    md.dofs = fe::number_dofs(md.lm, o.clamp);
  }
  md.ops = fe::assemble(md.lm, md.dofs, o.material);
  int size = 1;
  MPI_Comm_size(comm, &size);
  print0(comm, "morse: mesh %s (%s units): %lld nodes, %lld elements on %d rank(s)\n", o.mesh.c_str(),
         md.lm.mesh.units.c_str(), (long long)md.lm.n_global_nodes, (long long)md.lm.n_global_elements, size);
  print0(comm, "morse: %lld free DOFs, %lld clamped; volume %.6g, mass %.6g\n", (long long)md.dofs.n_global,
         (long long)md.dofs.n_clamped_global, md.ops.volume, md.ops.mass);
  return md;
}

void write_modes_dataset(io::H5Output& out, const std::string& name, const Model& md, Mat V, PetscInt first,
                         PetscInt count) {
  std::vector<double> all;
  for (PetscInt j = 0; j < count; ++j) {
    Vec x;
    MORSE_CALL(MatDenseGetColumnVecRead(V, first + j, &x));
    auto nodal = io::gather_nodal(md.lm, md.dofs, x);
    MORSE_CALL(MatDenseRestoreColumnVecRead(V, first + j, &x));
    all.insert(all.end(), nodal.begin(), nodal.end());
  }
  out.write(name, all, {static_cast<hsize_t>(count), static_cast<hsize_t>(md.lm.n_global_nodes), 3});
}

std::string xdmf_path_of(const std::string& h5) {
  auto dot = h5.rfind('.');
  return (dot == std::string::npos ? h5 : h5.substr(0, dot)) + ".xdmf";
}

std::string base_name(const std::string& p) {
  auto s = p.rfind('/');
  return s == std::string::npos ? p : p.substr(s + 1);
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

// ---------------------------------------------------------------- modes
PetscErrorCode get_modes_options(MPI_Comm comm, PetscInt* nev, PetscReal* shift, PetscBool* xdmf) {
  PetscOptionsBegin(comm, nullptr, "morse modes options", "");
  PetscCall(PetscOptionsInt("-modes_nev", "Number of lowest eigenpairs of the clamped model", "", *nev, nev, nullptr));
  PetscCall(PetscOptionsReal("-modes_shift", "Shift-invert target (rad/s)^2; negative for free-free models", "",
                             *shift, shift, nullptr));
  PetscCall(PetscOptionsBool("-modes_xdmf", "Write an XDMF file for ParaView next to the HDF5 file", "", *xdmf, xdmf,
                             nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

void run_modes(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "modes.h5", &o));
  PetscInt nev = 10;
  PetscReal shift = 0;
  PetscBool xdmf = PETSC_TRUE;
  MORSE_CALL(get_modes_options(comm, &nev, &shift, &xdmf));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(nev > 0, "-modes_nev must be positive (got ", nev, ")");
  Model md = build_model(comm, o);
  cb::EigenSettings es;
  es.nev = nev;
  es.shift = shift;
  es.prefix = "modes_";
  es.what = "full-model modes";
  auto w = cb::sign_reference(md.lm, md.dofs);
  auto eig = cb::solve_eigen(md.ops.K.get(), md.ops.M.get(), es, w.get());
  check_options(comm, false);

  std::vector<double> f_hz;
  for (double l : eig.omega2) f_hz.push_back(std::sqrt(std::max(0.0, l)) / kTwoPi);
  print0(comm, "\n  %-6s %16s %16s\n", "mode", "frequency [Hz]", "omega [rad/s]");
  for (std::size_t i = 0; i < f_hz.size(); ++i)
    print0(comm, "  %-6zu %16.6f %16.6f\n", i + 1, f_hz[i], kTwoPi * f_hz[i]);

  StageTimer t(comm, "Write");
  io::H5Output out(comm, o.out);
  io::write_provenance(out, "modes", md.lm.mesh.units);
  auto gm = mesh::gather_to_rank0(md.lm);
  io::write_mesh(out, gm);
  out.write("/fom/frequencies_hz", f_hz);
  out.write("/fom/eigenvalues", eig.omega2);
  write_modes_dataset(out, "/fom/mode_shapes", md, eig.V.get(), 0, static_cast<PetscInt>(f_hz.size()));
  out.attribute("/fom/mode_shapes", "description", "[mode][node][x,y,z], mass-normalized, nodes as /mesh/node_ids");
  out.attribute("/fom", "clamp", [&] {
    std::string s;
    for (auto& c : o.clamp) s += (s.empty() ? "" : ",") + c;
    return s;
  }());
  out.commit();
  if (xdmf) write_xdmf_collective(comm, o.out, gm, {{"/fom/mode_shapes", "mode", (int)f_hz.size()}});
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

// ---------------------------------------------------------------- reduce
struct ReduceOptions {
  std::string boundary;
  PetscInt n_fixed = -1;
  PetscReal fmax = -1;
  PetscReal damping = 0;
  PetscBool write_basis = PETSC_FALSE;
  PetscBool xdmf = PETSC_TRUE;
};

PetscErrorCode get_reduce_options(MPI_Comm comm, ReduceOptions* r) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse reduce (Craig-Bampton) options", "");
  PetscCall(PetscOptionsString("-boundary", "Node set of the interface (boundary DOFs: its x,y,z)", "", buf, buf,
                               sizeof buf, &set));
  if (set) r->boundary = buf;
  PetscCall(PetscOptionsInt("-cb_num_fixed_modes", "Number of fixed-interface modes (0 = Guyan)", "", r->n_fixed,
                            &r->n_fixed, nullptr));
  PetscCall(PetscOptionsReal("-cb_fmax", "Keep every fixed-interface mode below this frequency [Hz] "
                             "(spectrum slicing; seed 000 uses 5x the top frequency of interest)",
                             "", r->fmax, &r->fmax, nullptr));
  PetscCall(PetscOptionsReal("-cb_damping", "Modal damping ratio xi of the fixed-interface modes", "", r->damping,
                             &r->damping, nullptr));
  PetscCall(PetscOptionsBool("-cb_write_basis", "Write the constraint and fixed-interface modes (Psi, Phi)", "",
                             r->write_basis, &r->write_basis, nullptr));
  PetscCall(PetscOptionsBool("-cb_xdmf", "Write an XDMF file for ParaView (with -cb_write_basis)", "", r->xdmf,
                             &r->xdmf, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

void run_reduce(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "superelement.h5", &o));
  ReduceOptions r;
  MORSE_CALL(get_reduce_options(comm, &r));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(!r.boundary.empty(), "no boundary set given: use -boundary SET");
  MORSE_CHECK(r.n_fixed >= 0 || r.fmax > 0, "give -cb_num_fixed_modes N or -cb_fmax HZ");
  MORSE_CHECK(!(r.n_fixed >= 0 && r.fmax > 0), "give only one of -cb_num_fixed_modes and -cb_fmax");
  MORSE_CHECK(r.damping >= 0 && r.damping < 1, "-cb_damping must be in [0, 1) (got ", r.damping, ")");
  Model md = build_model(comm, o);
  cb::CBSettings s;
  s.boundary_set = r.boundary;
  s.n_fixed = r.n_fixed;
  s.fmax_hz = r.fmax;
  s.damping = r.damping;
  s.keep_basis = r.write_basis;
  auto res = cb::craig_bampton(md.lm, md.dofs, md.ops.K.get(), md.ops.M.get(), s);
  check_options(comm, false);

  const int n = static_cast<int>(res.n());
  std::vector<double> rom_f;
  {
    StageTimer t(comm, "ReducedEigen");
    for (double l : cb::dense_eigenvalues(n, res.K, res.M)) rom_f.push_back(std::sqrt(std::max(0.0, l)) / kTwoPi);
  }
  std::vector<double> fi_hz;
  for (double l : res.fixed_omega2) fi_hz.push_back(std::sqrt(std::max(0.0, l)) / kTwoPi);
  print0(comm, "morse: Craig-Bampton superelement: %d boundary DOFs (%zu nodes) + %d fixed-interface modes = %d\n",
         (int)res.n_b, res.boundary_node_ids.size(), (int)res.n_phi, n);
  print0(comm, "morse: K_ii factored once%s (%.3f s)\n", res.factor_reused ? ", shared by the eigen solver and the constraint modes" : "",
         res.factor_seconds);
  print0(comm, "\n  %-6s %20s %20s\n", "mode", "fixed-interface [Hz]", "superelement [Hz]");
  const std::size_t rows = std::min<std::size_t>(std::max(fi_hz.size(), rom_f.size()), 20);
  for (std::size_t i = 0; i < rows; ++i)
    print0(comm, "  %-6zu %20s %20s\n", i + 1, i < fi_hz.size() ? cat(fi_hz[i]).c_str() : "",
           i < rom_f.size() ? cat(rom_f[i]).c_str() : "");

  StageTimer t(comm, "Write");
  io::H5Output out(comm, o.out);
  io::write_provenance(out, "reduce", md.lm.mesh.units);
  auto gm = mesh::gather_to_rank0(md.lm);
  io::write_mesh(out, gm);
  const hsize_t hn = static_cast<hsize_t>(n);
  out.write("/cb/fixed_interface/frequencies_hz", fi_hz);
  out.write("/cb/fixed_interface/eigenvalues", res.fixed_omega2);
  out.write("/rom/M", res.M, {hn, hn});
  out.write("/rom/K", res.K, {hn, hn});
  if (r.damping > 0) out.write("/rom/C", res.C, {hn, hn});
  out.write("/rom/boundary_nodes", res.boundary_node_ids);
  out.write("/rom/frequencies_hz", rom_f);
  out.attribute("/rom", "n_boundary_dofs", static_cast<double>(res.n_b));
  out.attribute("/rom", "n_modes", static_cast<double>(res.n_phi));
  out.attribute("/rom", "damping_ratio", r.damping);
  out.attribute("/rom", "dof_order",
                "boundary DOFs first (nodes of /rom/boundary_nodes by ascending id, then x,y,z), then "
                "fixed-interface modal coordinates by ascending frequency");
  out.attribute("/cb", "boundary_set", r.boundary);
  std::vector<io::XdmfField> fields;
  if (r.write_basis) {
    write_modes_dataset(out, "/cb/constraint_modes", md, res.T.get(), 0, res.n_b);
    write_modes_dataset(out, "/cb/fixed_interface/mode_shapes", md, res.T.get(), res.n_b, res.n_phi);
    out.attribute("/cb/constraint_modes", "description", "Psi: [boundary DOF][node][x,y,z]");
    out.attribute("/cb/fixed_interface/mode_shapes", "description", "Phi: [mode][node][x,y,z], M_ii-normalized");
    fields = {{"/cb/constraint_modes", "psi", (int)res.n_b}, {"/cb/fixed_interface/mode_shapes", "phi", (int)res.n_phi}};
  }
  out.commit();
  if (r.xdmf && r.write_basis) write_xdmf_collective(comm, o.out, gm, fields);
  print0(comm, "\nmorse: wrote %s\n", o.out.c_str());
}

// ---------------------------------------------------------------- mesh box
PetscErrorCode get_box_options(MPI_Comm comm, mesh::BoxSpec* b, char* out, size_t len, std::string* type_out) {
  char type[64] = "hex20";
  PetscOptionsBegin(comm, nullptr, "morse mesh box options", "");
  PetscCall(PetscOptionsString("-box_type", "Element type: tet4 tet10 wedge6 wedge15 hex8 hex20", "", type, type,
                               sizeof type, nullptr));
  PetscCall(PetscOptionsReal("-box_lx", "Length in x", "", b->lx, &b->lx, nullptr));
  PetscCall(PetscOptionsReal("-box_ly", "Length in y", "", b->ly, &b->ly, nullptr));
  PetscCall(PetscOptionsReal("-box_lz", "Length in z", "", b->lz, &b->lz, nullptr));
  PetscCall(PetscOptionsInt("-box_nx", "Cells in x", "", b->nx, &b->nx, nullptr));
  PetscCall(PetscOptionsInt("-box_ny", "Cells in y", "", b->ny, &b->ny, nullptr));
  PetscCall(PetscOptionsInt("-box_nz", "Cells in z", "", b->nz, &b->nz, nullptr));
  PetscCall(PetscOptionsReal("-box_distortion", "Random vertex displacement / cell size", "", b->distortion,
                             &b->distortion, nullptr));
  PetscCall(PetscOptionsString("-out", "Output mesh file (.msh, Gmsh 4.1)", "", out, out, len, nullptr));
  PetscOptionsEnd();
  *type_out = type;
  return PETSC_SUCCESS;
}

PetscErrorCode get_mesh_out(MPI_Comm comm, char* out, size_t len) {
  PetscOptionsBegin(comm, nullptr, "morse mesh options", "");
  PetscCall(PetscOptionsString("-out", "Output mesh file (.msh, Gmsh 4.1)", "", out, out, len, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

void run_mesh(MPI_Comm comm, const std::vector<std::string>& args) {
  const std::string what = args.size() == 1 ? args[0] : "";
  MORSE_CHECK(what == "box" || what == "blade" || what == "stator",
              "usage: morse mesh (box|blade|stator) [-box_*|-blade_*|-stator_* options] -out FILE.msh");
  char out[PETSC_MAX_PATH_LEN] = "";
  mesh::BoxSpec box;
  mesh::BladeSpec blade;
  mesh::StatorSpec stator;
  if (what == "box") {
    std::strcpy(out, "box.msh");
    std::string type;
    MORSE_CALL(get_box_options(comm, &box, out, sizeof out, &type));
    MORSE_CHECK(mesh::parse_element_name(type, &box.type), "-box_type ", type,
                ": unknown element type (tet4 tet10 wedge6 wedge15 hex8 hex20)");
  } else {
    std::strcpy(out, (what + ".msh").c_str());
    MORSE_CALL(get_mesh_out(comm, out, sizeof out));
    if (what == "blade")
      MORSE_CALL(mesh::blade_spec_from_options(comm, &blade));
    else
      MORSE_CALL(mesh::stator_spec_from_options(comm, &stator));
  }
  if (help_requested()) return;
  check_options(comm, false);
  if (what == "box")
    MORSE_CHECK(box.nx > 0 && box.ny > 0 && box.nz > 0 && box.lx > 0 && box.ly > 0 && box.lz > 0,
                "-box_n* and -box_l* must be positive");
  std::string err;
  if (rank_of(comm) == 0) try {
      auto m = what == "box" ? mesh::generate_box(box) : what == "blade" ? mesh::generate_blade(blade)
                                                                          : mesh::generate_stator(stator);
      mesh::write_gmsh(m, out);
      print0(comm, "morse: wrote %s: %lld nodes, %lld elements (%s)\n", out, (long long)m.num_nodes(),
             (long long)m.num_elements(), m.source.c_str());
    } catch (const Error& e) {
      err = e.what();
    }
  collective_check(comm, err);
}

}  // namespace

const std::vector<std::string>& command_names() {
  static const std::vector<std::string> names = {"modes", "reduce", "mesh"};
  return names;
}

void run_command(MPI_Comm comm, const std::string& command, const std::vector<std::string>& args) {
  stage_records().clear();
  wall_seconds();
  if (command == "modes")
    run_modes(comm);
  else if (command == "reduce")
    run_reduce(comm);
  else if (command == "mesh")
    run_mesh(comm, args);
  else
    throw Error(cat("unknown command '", command, "' (commands: modes, reduce, mesh)"));
  if (command != "mesh" && !help_requested()) print_stage_table(comm);
}

}  // namespace morse::app
