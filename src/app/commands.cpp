#include "morse/app/commands.hpp"

#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <numeric>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/fe/element.hpp"
#include "morse/fe/model.hpp"
#include "morse/io/h5.hpp"
#include "morse/mesh/blade.hpp"
#include "morse/mesh/generator.hpp"
#include "morse/mesh/stator.hpp"
#include "morse/select/select.hpp"
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
  std::vector<mesh::Material> set_materials;  ///< name = element set
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
  n_sets = 16;
  PetscCall(PetscOptionsStringArray("-material_sets",
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
      PetscCall(PetscOptionsReal((p + "E").c_str(), "Young's modulus of the element set", "", m.E, &m.E, nullptr));
      PetscCall(PetscOptionsReal((p + "nu").c_str(), "Poisson's ratio of the element set", "", m.nu, &m.nu, nullptr));
      PetscCall(PetscOptionsReal((p + "rho").c_str(), "Density of the element set", "", m.rho, &m.rho, nullptr));
      o->set_materials.push_back(m);
    }
  PetscCall(PetscStrncpy(buf, default_out, sizeof buf));
  PetscCall(PetscOptionsString("-out", "Output file", "", buf, buf, sizeof buf, nullptr));
  o->out = buf;
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

// Options owned by inner PETSc/SLEPc objects of a command: accepted by the early check.
bool inner_option(const std::string& name) {
  static const char* inner[] = {"cb_eps_",         "cb_st_",         "cb_bv_",         "cb_ds_",       "cb_rg_",
                                "modes_eps_",      "modes_st_",      "modes_bv_",      "modes_ds_",    "modes_rg_",
                                "select_fom_eps_", "select_fom_st_", "select_fom_bv_", "select_fom_ds_", "select_imr_eps_",
                                "select_imr_st_",  "select_imr_bv_", "select_imr_ds_"};
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
    for (const auto& sm : o.set_materials) mesh::assign_set_material(&md.lm.mesh, sm);
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

// /rom as every superelement-writing command writes it (docs/hdf5-schema.md).
void write_rom(io::H5Output& out, const std::vector<double>& M, const std::vector<double>& K,
               const std::vector<double>* C, const std::vector<std::int64_t>& boundary_nodes,
               const std::vector<double>& freq_hz, PetscInt n_b, double damping) {
  const auto n = static_cast<hsize_t>(freq_hz.size());
  out.write("/rom/M", M, {n, n});
  out.write("/rom/K", K, {n, n});
  if (C) out.write("/rom/C", *C, {n, n});
  out.write("/rom/boundary_nodes", boundary_nodes);
  out.write("/rom/frequencies_hz", freq_hz);
  out.attribute_int("/rom", "n_boundary_dofs", n_b);
  out.attribute_int("/rom", "n_modes", static_cast<std::int64_t>(n) - n_b);
  out.attribute("/rom", "damping_ratio", damping);
  out.attribute("/rom", "dof_order",
                "boundary DOFs first (nodes of /rom/boundary_nodes by ascending id, then x,y,z), then the "
                "fixed-interface modal coordinates by ascending frequency (select: those of /rom/selected_modes)");
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
  out.write("/cb/fixed_interface/frequencies_hz", fi_hz);
  out.write("/cb/fixed_interface/eigenvalues", res.fixed_omega2);
  write_rom(out, res.M, res.K, r.damping > 0 ? &res.C : nullptr, res.boundary_node_ids, rom_f, res.n_b, r.damping);
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

// ---------------------------------------------------------------- select
struct SelectOptions {
  std::string from;
  std::vector<std::string> methods;
  PetscInt num_modes = -1;
  PetscReal fraction = -1;
  PetscBool num_modes_set = PETSC_FALSE, fraction_set = PETSC_FALSE;
  PetscReal fmax_analysis = -1;
  PetscInt fom_modes = -1;
  PetscReal mac_threshold = 0.98;
  std::string rom_method;
  std::vector<double> ebr_freq, ebr_amp, ebr_phase;
  bool ebr_given = false;
  std::string ebr_load;
  std::string imr_support = "free";
  PetscReal imr_stiffness = -1;
  std::vector<PetscInt> imr_modes;
  PetscReal imr_shift = 0.01;
};

PetscErrorCode get_select_options(MPI_Comm comm, SelectOptions* o) {
  char* names[16];
  PetscInt n = 16;
  PetscBool set = PETSC_FALSE;
  char buf[256] = "";
  PetscReal vals[256];
  PetscInt ivals[256];
  PetscOptionsBegin(comm, nullptr, "morse select options", "");
  PetscCall(PetscOptionsString("-select_from",
                               "Start from a `morse reduce -cb_write_basis` file of the same mesh and boundary instead "
                               "of computing the modes",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->from = buf;
  buf[0] = 0;
  PetscCall(PetscOptionsStringArray("-select_method",
                                    "Ranking methods, comma separated: frequency lpf eim veim deim omr cmschi ebr imr",
                                    "", names, &n, &set));
  if (set)
    for (PetscInt i = 0; i < n; ++i) {
      o->methods.emplace_back(names[i]);
      PetscCall(PetscFree(names[i]));
    }
  else
    o->methods = {"eim"};
  PetscCall(PetscOptionsInt("-select_num_modes", "Keep this many fixed-interface modes (best first)", "",
                            o->num_modes, &o->num_modes, &o->num_modes_set));
  PetscCall(PetscOptionsReal("-select_fraction",
                             "Keep the best modes up to this cumulative fraction of the method's total score "
                             "(default 0.95 when -select_num_modes is not given)",
                             "", o->fraction, &o->fraction, &o->fraction_set));
  PetscCall(PetscOptionsReal("-select_fmax_analysis",
                             "Analysis cutoff [Hz] for superelement modes in band and the MAC check "
                             "(default: -cb_fmax / 2, seed 000's 2.5x vs 5x; or half the top candidate frequency)",
                             "", o->fmax_analysis, &o->fmax_analysis, nullptr));
  PetscCall(PetscOptionsInt("-select_fom_modes",
                            "Number of full-model modes for the MAC check (default: all below the analysis cutoff)",
                            "", o->fom_modes, &o->fom_modes, nullptr));
  PetscCall(PetscOptionsReal("-select_mac_threshold", "MAC above which a full-model mode counts as matched", "",
                             o->mac_threshold, &o->mac_threshold, nullptr));
  PetscCall(PetscOptionsString("-select_rom_method", "Method whose superelement is written to /rom (default: the first)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->rom_method = buf;
  PetscInt nv = 256;
  PetscCall(PetscOptionsRealArray("-select_ebr_freq",
                                  "EBR harmonic frequencies [Hz] (default: every boundary DOF loaded alone at 8 "
                                  "frequencies across the analysis band)",
                                  "", vals, &nv, &set));
  if (set) o->ebr_freq.assign(vals, vals + nv), o->ebr_given = true;
  nv = 256;
  PetscCall(PetscOptionsRealArray("-select_ebr_amp", "EBR force amplitude per harmonic (on every boundary DOF)", "",
                                  vals, &nv, &set));
  if (set) o->ebr_amp.assign(vals, vals + nv), o->ebr_given = true;
  nv = 256;
  PetscCall(PetscOptionsRealArray("-select_ebr_phase", "EBR phase per harmonic [deg] (uniform: no effect on the scores)",
                                  "", vals, &nv, &set));
  if (set) o->ebr_phase.assign(vals, vals + nv), o->ebr_given = true;
  buf[0] = 0;
  PetscCall(PetscOptionsString("-select_ebr_load",
                               "EBR load table: lines 'freq_hz node component amplitude [phase_deg]' on boundary "
                               "nodes, one harmonic per frequency (instead of -select_ebr_freq/amp/phase)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->ebr_load = buf;
  buf[0] = 0;
  PetscCall(PetscStrncpy(buf, o->imr_support.c_str(), sizeof buf));
  PetscCall(PetscOptionsString("-select_imr_support",
                               "IMR: full-system modes with the interface free, spring (-select_imr_support_stiffness) or "
                               "clamped",
                               "", buf, buf, sizeof buf, nullptr));
  o->imr_support = buf;
  PetscCall(PetscOptionsReal("-select_imr_support_stiffness", "IMR: spring stiffness on every boundary DOF", "",
                             o->imr_stiffness, &o->imr_stiffness, nullptr));
  nv = 256;
  PetscCall(PetscOptionsIntArray("-select_imr_modes",
                                 "IMR: full-system modes of interest, 1-based (default: all below the analysis cutoff)",
                                 "", ivals, &nv, &set));
  if (set) o->imr_modes.assign(ivals, ivals + nv);
  PetscCall(PetscOptionsReal("-select_imr_shift", "IMR: relative frequency shift of the fictitious force", "",
                             o->imr_shift, &o->imr_shift, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

std::string hz_of(double lambda) { return cat(std::sqrt(std::max(0.0, lambda)) / kTwoPi); }

void run_select(MPI_Comm comm) {
  CommonOptions o;
  MORSE_CALL(get_common(comm, "select.h5", &o));
  ReduceOptions r;
  MORSE_CALL(get_reduce_options(comm, &r));
  SelectOptions so;
  MORSE_CALL(get_select_options(comm, &so));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(!r.boundary.empty(), "no boundary set given: use -boundary SET");
  MORSE_CHECK(!so.from.empty() || r.n_fixed >= 0 || r.fmax > 0,
              "give the candidate modes: -cb_num_fixed_modes N or -cb_fmax HZ (or -select_from FILE.h5)");
  MORSE_CHECK(so.from.empty() || (r.n_fixed < 0 && r.fmax < 0),
              "-select_from reads the candidate modes from its file: drop -cb_num_fixed_modes / -cb_fmax");
  MORSE_CHECK(!(r.n_fixed >= 0 && r.fmax > 0), "give only one of -cb_num_fixed_modes and -cb_fmax");
  std::vector<select::Method> methods;
  for (const auto& name : so.methods) {
    select::Method m;
    MORSE_CHECK(select::parse_method(name, &m), "-select_method ", name,
                ": unknown method (frequency lpf eim veim deim omr cmschi ebr imr)");
    methods.push_back(m);
  }
  for (std::size_t i = 0; i < methods.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      MORSE_CHECK(methods[i] != methods[j], "-select_method lists ", so.methods[i], " twice");
  MORSE_CHECK(!(so.num_modes_set && so.fraction_set), "give only one of -select_num_modes and -select_fraction");
  MORSE_CHECK(!so.num_modes_set || so.num_modes >= 0, "-select_num_modes ", so.num_modes, " must be >= 0");
  if (!so.num_modes_set && !so.fraction_set) so.fraction = 0.95;
  MORSE_CHECK(so.num_modes_set || (so.fraction > 0 && so.fraction <= 1), "-select_fraction ", so.fraction,
              " must be in (0, 1]");
  MORSE_CHECK(so.ebr_load.empty() || !so.ebr_given,
              "give the EBR excitation either as -select_ebr_load FILE or as -select_ebr_freq/-select_ebr_amp/"
              "-select_ebr_phase, not both");
  MORSE_CHECK(!r.write_basis, "-cb_write_basis is a reduce option: select writes the selected superelement only");
  MORSE_CHECK(so.imr_support == "free" || so.imr_support == "spring" || so.imr_support == "clamped",
              "-select_imr_support ", so.imr_support, ": expected free, spring or clamped");
  MORSE_CHECK(so.imr_support != "spring" || so.imr_stiffness > 0,
              "-select_imr_support spring needs -select_imr_support_stiffness > 0");
  std::string rom_name = so.rom_method.empty() ? so.methods[0] : so.rom_method;
  MORSE_CHECK(std::find(so.methods.begin(), so.methods.end(), rom_name) != so.methods.end(), "-select_rom_method ",
              rom_name, " is not one of -select_method");

  Model md = build_model(comm, o);
  cb::CBSettings cs;
  cs.boundary_set = r.boundary;
  cs.n_fixed = r.n_fixed;
  cs.fmax_hz = r.fmax;
  cs.damping = r.damping;
  cs.keep_basis = true;
  auto res = so.from.empty() ? cb::craig_bampton(md.lm, md.dofs, md.ops.K.get(), md.ops.M.get(), cs)
                             : cb::load_basis(md.lm, md.dofs, md.ops.K.get(), md.ops.M.get(), so.from, r.boundary,
                                              r.damping);
  MORSE_CHECK(res.n_phi > 0, "no candidate fixed-interface mode to select from");
  const PetscInt nb = res.n_b, nr = res.n(), nphi = res.n_phi;
  double f_an = so.fmax_analysis > 0 ? so.fmax_analysis
                : r.fmax > 0       ? 0.5 * r.fmax
                                   : 0.5 * std::sqrt(res.fixed_omega2.back()) / kTwoPi;
  const double l_an = std::pow(kTwoPi * f_an, 2);

  select::InterfaceCoupling ic;
  {
    StageTimer t(comm, "InterfaceCoupling");
    ic = select::interface_coupling(comm, md.ops.K.get(), md.ops.M.get(), res);
  }
  // Full-model modes with the real boundary conditions (clamp only): MAC reference and IMR.
  cb::Eigenpairs fom;
  {
    cb::EigenSettings es;
    es.prefix = "select_fom_";
    es.what = "full-model modes";
    if (so.fom_modes > 0)
      es.nev = so.fom_modes;
    else
      es.omega2_max = l_an;
    auto w = cb::sign_reference(md.lm, md.dofs);
    fom = cb::solve_eigen(md.ops.K.get(), md.ops.M.get(), es, w.get());
  }
  const PetscInt n_fom = static_cast<PetscInt>(fom.omega2.size());

  select::Excitation ex;
  if (!so.ebr_load.empty()) {
    ex = select::read_ebr_load(comm, so.ebr_load, res);
  } else if (so.ebr_given) {
    ex.freq_hz = so.ebr_freq;
    ex.amplitude = so.ebr_amp.empty() ? std::vector<double>(ex.freq_hz.size(), 1.0) : so.ebr_amp;
    ex.phase_deg = so.ebr_phase.empty() ? std::vector<double>(ex.freq_hz.size(), 0.0) : so.ebr_phase;
    ex.all_components = false;
  } else {
    for (int k = 1; k <= 8; ++k) ex.freq_hz.push_back(f_an * (k - 0.5) / 8.0);
    ex.amplitude.assign(8, 1.0);
    ex.phase_deg.assign(8, 0.0);
  }
  std::unique_ptr<select::ImrData> imr;
  if (std::find(methods.begin(), methods.end(), select::Method::IMR) != methods.end()) {
    StageTimer t(comm, "ImrSystemModes");
    std::vector<PetscInt> modes;
    for (auto m1 : so.imr_modes) modes.push_back(m1 - 1);
    if (so.imr_support == "clamped") {
      imr = std::make_unique<select::ImrData>();
      imr->clamped = true;
      if (modes.empty())
        for (PetscInt i = 0; i < nphi && res.fixed_omega2[i] <= l_an; ++i) modes.push_back(i);
      for (auto m : modes)
        MORSE_CHECK(m >= 0 && m < nphi, "-select_imr_modes ", m + 1, " is out of range (1..", nphi,
                    " fixed-interface modes)");
      imr->clamped_modes = modes;
    } else {
      cb::Eigenpairs sys;
      Mat Ks = md.ops.K.get();
      UMat Kspring;
      cb::Eigenpairs* use = &fom;
      if (so.imr_support == "spring") {
        MORSE_CALL(MatDuplicate(md.ops.K.get(), MAT_COPY_VALUES, Kspring.ptr()));
        for (auto g : res.boundary_dofs) {
          PetscInt rs, re;
          MORSE_CALL(MatGetOwnershipRange(Kspring.get(), &rs, &re));
          if (g >= rs && g < re) MORSE_CALL(MatSetValue(Kspring.get(), g, g, so.imr_stiffness, ADD_VALUES));
        }
        MORSE_CALL(MatAssemblyBegin(Kspring.get(), MAT_FINAL_ASSEMBLY));
        MORSE_CALL(MatAssemblyEnd(Kspring.get(), MAT_FINAL_ASSEMBLY));
        Ks = Kspring.get();
        cb::EigenSettings es;
        es.prefix = "select_imr_";
        es.what = "IMR system modes";
        es.omega2_max = l_an;
        sys = cb::solve_eigen(Ks, md.ops.M.get(), es, nullptr);
        use = &sys;
      }
      const PetscInt n_sys = static_cast<PetscInt>(use->omega2.size());
      if (modes.empty())
        for (PetscInt i = 0; i < n_sys; ++i) modes.push_back(i);
      for (auto m : modes)
        MORSE_CHECK(m >= 0 && m < n_sys, "-select_imr_modes ", m + 1, " is out of range (1..", n_sys,
                    " system modes", so.fom_modes > 0 && so.imr_support == "free" ? "" : cat(" below ", f_an, " Hz"),
                    ")");
      imr = std::make_unique<select::ImrData>(
          select::imr_data(comm, md.ops.M.get(), res, use->V.get(), use->omega2, modes, so.imr_shift));
    }
  }
  check_options(comm, false);

  struct MethodResult {
    std::string name;
    std::vector<double> score;
    select::Selection sel;
    std::vector<double> rom_f;
    PetscInt in_band = 0, matches = 0, subspace_matches = 0;
    double worst_err = 0;
    std::vector<double> mac, best_mac, subspace_mac;
    std::vector<double> M, K;
  };
  std::vector<MethodResult> results;
  UMat MV;
  MORSE_CALL(MatMatMult(md.ops.M.get(), fom.V.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, MV.ptr()));
  select::MacBasis mac_basis;
  {
    StageTimer t(comm, "MacProjections");
    mac_basis = select::mac_basis(comm, fom.V.get(), MV.get(), res.T.get());
  }
  auto f_fom = [&](PetscInt j) { return std::sqrt(std::max(0.0, fom.omega2[j])) / kTwoPi; };
  for (std::size_t mi = 0; mi < methods.size(); ++mi) {
    StageTimer t(comm, cat("Select_", so.methods[mi]));
    MethodResult mr;
    mr.name = so.methods[mi];
    mr.score = select::scores(comm, methods[mi], ic, res, ex, imr.get());
    mr.sel = select::truncate(methods[mi], mr.score, so.num_modes, so.fraction);
    mr.M = select::restrict_operator(res.M, nb, nr, mr.sel.selected);
    mr.K = select::restrict_operator(res.K, nb, nr, mr.sel.selected);
    const int n = static_cast<int>(nb + mr.sel.selected.size());
    std::vector<double> vec;
    auto lam = cb::dense_eigenvalues(n, mr.K, mr.M, &vec);
    for (double l : lam) mr.rom_f.push_back(std::sqrt(std::max(0.0, l)) / kTwoPi);
    while (mr.in_band < n && lam[mr.in_band] <= l_an) ++mr.in_band;
    // Expand the in-band superelement modes on the full CB basis and compare with the FOM.
    const PetscInt nq = std::max<PetscInt>(mr.in_band, 1);
    std::vector<double> Q(static_cast<std::size_t>(nr) * nq, 0.0);
    std::vector<PetscInt> idx(nb);
    std::iota(idx.begin(), idx.end(), 0);
    for (auto sidx : mr.sel.selected) idx.push_back(nb + sidx);
    for (PetscInt k = 0; k < mr.in_band; ++k)
      for (int row = 0; row < n; ++row) Q[idx[row] * nq + k] = vec[static_cast<std::size_t>(row) * n + k];
    mr.mac = select::mac_matrix(mac_basis, Q, nq);
    auto wmac = select::mac_matrix(mac_basis, Q, nq, &res.M);
    mr.best_mac.assign(n_fom, 0.0);
    mr.subspace_mac.assign(n_fom, 0.0);
    for (PetscInt j = 0; j < n_fom; ++j) {
      // Near-repeated modes (cyclic parts) mix freely inside their cluster, which pairwise MAC
      // cannot follow: the mass-weighted MAC summed over the in-band superelement modes is the
      // squared projection of the full-model mode on the superelement's in-band modal space.
      for (PetscInt k = 0; k < mr.in_band; ++k) mr.subspace_mac[j] += wmac[j * nq + k];
      if (mr.subspace_mac[j] > so.mac_threshold) ++mr.subspace_matches;
      PetscInt best = -1;
      for (PetscInt k = 0; k < mr.in_band; ++k)
        if (mr.mac[j * nq + k] > mr.best_mac[j]) mr.best_mac[j] = mr.mac[j * nq + k], best = k;
      if (best >= 0 && mr.best_mac[j] > so.mac_threshold) {
        ++mr.matches;
        mr.worst_err = std::max(mr.worst_err, std::abs(mr.rom_f[best] / f_fom(j) - 1.0));
      }
    }
    if (mr.in_band == 0) mr.mac.assign(n_fom, 0.0);
    results.push_back(std::move(mr));
  }

  // Plain frequency-ordered Craig-Bampton for the same candidate set: reference row.
  PetscInt cb_in_band = 0;
  {
    auto lam = cb::dense_eigenvalues(static_cast<int>(nr), res.K, res.M);
    while (cb_in_band < nr && lam[cb_in_band] <= l_an) ++cb_in_band;
  }
  print0(comm, "\nmorse select: %d candidate fixed-interface modes (%s .. %s Hz), %d boundary DOFs; analysis band "
               "%.6g Hz: %d full-model modes\n",
         (int)nphi, hz_of(res.fixed_omega2.front()).c_str(), hz_of(res.fixed_omega2.back()).c_str(), (int)nb, f_an,
         (int)n_fom);
  print0(comm, "  all candidates (plain Craig-Bampton): %d superelement modes in band\n", (int)cb_in_band);
  print0(comm, "\n  %-10s %6s %10s %14s %12s %14s %14s\n", "method", "N", "retained%", "SE modes<fan", "MAC>thr",
         "subspace MAC", "worst df [%]");
  for (const auto& mr : results)
    print0(comm, "  %-10s %6d %10.2f %14d %7d/%-4d %9d/%-4d %14.4f\n", mr.name.c_str(), (int)mr.sel.selected.size(),
           100 * mr.sel.retained, (int)mr.in_band, (int)mr.matches, (int)n_fom, (int)mr.subspace_matches, (int)n_fom,
           100 * mr.worst_err);

  StageTimer t(comm, "Write");
  io::H5Output out(comm, o.out);
  io::write_provenance(out, "select", md.lm.mesh.units);
  auto gm = mesh::gather_to_rank0(md.lm);
  io::write_mesh(out, gm);
  std::vector<double> fi_hz, fom_hz;
  for (double l : res.fixed_omega2) fi_hz.push_back(std::sqrt(std::max(0.0, l)) / kTwoPi);
  for (PetscInt j = 0; j < n_fom; ++j) fom_hz.push_back(f_fom(j));
  out.write("/cb/fixed_interface/frequencies_hz", fi_hz);
  out.write("/cb/fixed_interface/eigenvalues", res.fixed_omega2);
  out.write("/select/fom/frequencies_hz", fom_hz);
  out.attribute("/select", "fmax_analysis_hz", f_an);
  out.attribute("/select", "mac_threshold", so.mac_threshold);
  out.attribute_int("/select", "cb_modes_in_band", static_cast<std::int64_t>(cb_in_band));
  out.write("/select/effective_mass/directional_fractions", select::directional_mass_fractions(ic, md.ops.mass),
            {static_cast<hsize_t>(nphi), 3});
  out.attribute("/select/effective_mass/directional_fractions", "description",
                "(P_i r_d)^2 / total mass for a rigid translation r_d of the interface in x, y, z");
  auto eim = select::scores(comm, select::Method::EIM, ic, res, ex, nullptr);
  double eim_total = 0;
  for (double v : eim) eim_total += v;
  std::vector<double> eim_frac;
  for (double v : eim) eim_frac.push_back(v / eim_total);
  out.write("/select/effective_mass/trace_fractions", eim_frac);
  for (const auto& mr : results) {
    const std::string g = "/select/" + mr.name;
    const double total = std::accumulate(mr.score.begin(), mr.score.end(), 0.0);
    std::vector<double> frac;
    for (double v : mr.score) frac.push_back(total > 0 ? v / total : 0.0);
    std::vector<std::int64_t> rank(mr.sel.ranking.begin(), mr.sel.ranking.end()),
        sel(mr.sel.selected.begin(), mr.sel.selected.end());
    out.write(g + "/scores", mr.score);
    out.write(g + "/score_fractions", frac);
    out.write(g + "/ranking", rank);
    out.write(g + "/cumulative", mr.sel.cumulative);
    out.write(g + "/selected", sel);
    out.write(g + "/rom_frequencies_hz", mr.rom_f);
    out.write(g + "/mac", mr.mac, {static_cast<hsize_t>(n_fom), static_cast<hsize_t>(std::max<PetscInt>(mr.in_band, 1))});
    out.write(g + "/best_mac", mr.best_mac);
    out.write(g + "/subspace_mac", mr.subspace_mac);
    out.attribute(g, "retained_fraction", mr.sel.retained);
    out.attribute_int(g, "n_selected", static_cast<std::int64_t>(mr.sel.selected.size()));
    out.attribute_int(g, "n_rom_modes_in_band", static_cast<std::int64_t>(mr.in_band));
    out.attribute_int(g, "n_mac_matches", static_cast<std::int64_t>(mr.matches));
    out.attribute_int(g, "n_subspace_mac_matches", static_cast<std::int64_t>(mr.subspace_matches));
    out.attribute(g, "worst_frequency_error", mr.worst_err);
    if (mr.name == rom_name) {
      auto C = select::restrict_operator(res.C, nb, nr, mr.sel.selected);
      write_rom(out, mr.M, mr.K, r.damping > 0 ? &C : nullptr, res.boundary_node_ids, mr.rom_f, nb, r.damping);
      out.write("/rom/selected_modes", sel);
      out.attribute("/rom", "selection_method", mr.name);
    }
  }
  out.attribute("/cb", "boundary_set", r.boundary);
  out.commit();
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

PetscErrorCode get_mesh_in(MPI_Comm comm, std::string* path) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse mesh info options", "");
  PetscCall(PetscOptionsString("-mesh", "Mesh file: .msh (Gmsh 4.1/2.2 ASCII) or .inp (Abaqus/CalculiX)", "", buf,
                               buf, sizeof buf, &set));
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
  std::vector<std::int64_t> per_type(mesh::kNumElementTypes, 0);
  double volume = 0, min_jac = 1e300, xyz[3 * fe::kMaxNodes];
  std::int64_t worst = -1, n_bad = 0;
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    const auto type = m.elem_types[e];
    ++per_type[static_cast<int>(type)];
    const auto off = m.elem_offsets[e];
    for (int a = 0; a < mesh::nodes_per_element(type); ++a)
      for (int d = 0; d < 3; ++d) xyz[3 * a + d] = m.coords[3 * m.elem_nodes[off + a] + d];
    const double j = fe::min_jacobian(type, xyz);
    if (j <= 0) ++n_bad;
    if (j < min_jac) min_jac = j, worst = m.elem_ids[e];
    volume += fe::element_volume(type, xyz);
  }
  MPI_Allreduce(MPI_IN_PLACE, per_type.data(), mesh::kNumElementTypes, MPI_INT64_T, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &volume, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &n_bad, 1, MPI_INT64_T, MPI_SUM, comm);
  struct {
    double v;
    int r;
  } in{min_jac, rank_of(comm)}, outv;
  MPI_Allreduce(&in, &outv, 1, MPI_DOUBLE_INT, MPI_MINLOC, comm);
  MPI_Bcast(&worst, 1, MPI_INT64_T, outv.r, comm);
  print0(comm, "morse: mesh %s (%s units): %lld nodes, %lld elements\n", path.c_str(), m.units.c_str(),
         (long long)lm.n_global_nodes, (long long)lm.n_global_elements);
  for (int k = 0; k < mesh::kNumElementTypes; ++k)
    if (per_type[k]) print0(comm, "  %-8s %lld\n", mesh::element_name(static_cast<mesh::ElementType>(k)), (long long)per_type[k]);
  print0(comm, "  volume %.10g; smallest Jacobian determinant %.6g (element %lld); %lld inverted elements\n", volume,
         outv.v, (long long)worst, (long long)n_bad);
  for (const auto& [name, n] : lm.node_set_sizes) print0(comm, "  node set    %-20s %lld nodes\n", name.c_str(), (long long)n);
  for (const auto& [name, n] : lm.elem_set_sizes) print0(comm, "  element set %-20s %lld elements\n", name.c_str(), (long long)n);
  for (const auto& mat : m.materials)
    print0(comm, "  material %-20s E %.6g nu %.6g rho %.6g\n", mat.name.c_str(), mat.E, mat.nu, mat.rho);
  std::int64_t fixed = 0;
  for (std::int64_t k = 0; k < m.num_nodes(); ++k)
    if (lm.node_owner[k] == rank_of(comm) && !m.fixed_dofs.empty() && m.fixed_dofs[k]) ++fixed;
  MPI_Allreduce(MPI_IN_PLACE, &fixed, 1, MPI_INT64_T, MPI_SUM, comm);
  if (fixed) print0(comm, "  *BOUNDARY fixes DOFs of %lld nodes\n", (long long)fixed);
}

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
  static const std::vector<std::string> names = {"modes", "reduce", "select", "mesh"};
  return names;
}

void run_command(MPI_Comm comm, const std::string& command, const std::vector<std::string>& args) {
  stage_records().clear();
  wall_seconds();
  if (command == "modes")
    run_modes(comm);
  else if (command == "reduce")
    run_reduce(comm);
  else if (command == "select")
    run_select(comm);
  else if (command == "mesh")
    run_mesh(comm, args);
  else
    throw Error(cat("unknown command '", command, "' (commands: modes, reduce, select, mesh)"));
  if ((command != "mesh" || (!args.empty() && args[0] == "info")) && !help_requested()) print_stage_table(comm);
}

}  // namespace morse::app
