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

std::string xdmf_path_of(const std::string& h5) {
  auto dot = h5.rfind('.');
  return (dot == std::string::npos ? h5 : h5.substr(0, dot)) + ".xdmf";
}

std::string base_name(const std::string& p) {
  auto s = p.rfind('/');
  return s == std::string::npos ? p : p.substr(s + 1);
}

}  // namespace

void check_options(MPI_Comm comm, bool early) { options::check_unknown(comm, early); }

bool help_requested() {
  PetscBool h = PETSC_FALSE;
  PetscOptionsHasHelp(nullptr, &h);
  return h;
}

Model build_model(MPI_Comm comm, const CommonOptions& o, const char* needs_mesh) {
  o.check(needs_mesh);
  if (o.matrices_given()) {
    Model md;
    {
      StageTimer t(comm, "ReadMatrices");
      md = io::matrix_model(comm, o.matrices);
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
  Model md = fe::mesh_model(comm, o.mesh);
  int size = 1;
  MPI_Comm_size(comm, &size);
  print0(comm, "morse: mesh %s (%s units): %lld nodes, %lld elements on %d rank(s)\n", o.mesh.path.c_str(),
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

PetscErrorCode get_loads(MPI_Comm comm, std::vector<dyn::NodalLoad>* loads, std::string* error, const char* prefix) {
  std::vector<std::string> sets;
  PetscCall(options::get_string_list(comm, "-load_sets", "Node sets carrying a nodal load (force per node), comma separated",
                         &sets, prefix));
  const std::string pre = prefix ? cat("-", prefix) : std::string("-");
  PetscOptionsBegin(comm, prefix, "morse loads (F(t) = A sin(omega t + phase) per node; omega = 0: constant A)", "");
  for (const auto& name : sets) {
    dyn::NodalLoad l;
    l.set = name;
    const std::string p = "-load_" + name + "_";
    char buf[256] = "";
    PetscBool has_dir = PETSC_FALSE, has_amp = PETSC_FALSE;
    PetscCall(MorseOptionsString((p + "dir").c_str(), "Direction: x, y, z or vx,vy,vz (normalized)", "", buf, buf,
                                 sizeof buf, &has_dir));
    PetscCall(MorseOptionsReal((p + "amplitude").c_str(), "Force per node [N] (not a traction)", "", l.amplitude,
                               &l.amplitude, &has_amp));
    PetscCall(MorseOptionsReal((p + "omega").c_str(), "Angular frequency [rad/s]; 0 = constant load", "", l.omega,
                               &l.omega, nullptr));
    PetscCall(MorseOptionsReal((p + "phase").c_str(), "Phase [rad]", "", l.phase, &l.phase, nullptr));
    if (error->empty()) {
      if (!has_dir)
        *error = cat("load on set ", name, ": give its direction with ", pre, p.substr(1), "dir x|y|z|vx,vy,vz");
      else if (!has_amp)
        *error = cat("load on set ", name, ": give its force per node with ", pre, p.substr(1), "amplitude");
      else if (auto why = dyn::parse_direction(buf, l.dir); !why.empty())
        *error = cat(pre, p.substr(1), "dir: ", why);
      else if (l.omega < 0)
        *error = cat(pre, p.substr(1), "omega must be >= 0 (got ", l.omega, ")");
    }
    loads->push_back(l);
  }
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

PetscErrorCode get_load_history(MPI_Comm comm, LoadHistoryOptions* o) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE, outside_set = PETSC_FALSE;
  std::string outside = "error";
  PetscOptionsBegin(comm, nullptr, "morse tabulated load history (linear interpolation in time)", "");
  PetscCall(MorseOptionsString("-load_history",
                               "FILE[:/GROUP]: nodal forces on a time grid, added to the -load_* loads: a CSV "
                               "(time,node_id,fx,fy,fz), an HDF5 table (/load_history: time, node_ids, forces) or the "
                               "contact forces of a morse simulate file (/sim/contact)",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->spec = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-load_history_outside",
                               "Outside the table's time grid: error (checked before the run), zero or hold (end values)",
                               "", outside.c_str(), buf, sizeof buf, &outside_set));
  if (outside_set) outside = buf;
  PetscCall(MorseOptionsReal("-load_history_scale", "Factor on every force of the table", "", o->scale, &o->scale,
                             nullptr));
  PetscOptionsEnd();
  if (auto why = dyn::parse_outside(outside, &o->outside); !why.empty()) o->error = cat("-load_history_outside: ", why);
  if (o->error.empty() && !std::isfinite(o->scale)) o->error = "-load_history_scale must be finite";
  if (o->error.empty() && o->spec.empty() && outside_set) o->error = "-load_history_outside needs -load_history FILE";
  return PETSC_SUCCESS;
}

std::shared_ptr<const dyn::LoadHistory> make_load_history(MPI_Comm comm, const mesh::LocalMesh& lm,
                                                          const fe::DofLayout& dofs, const LoadHistoryOptions& o) {
  if (o.spec.empty()) return nullptr;
  StageTimer t(comm, "LoadHistory");
  dyn::LoadTable table;
  try {
    table = dyn::read_load_table(comm, o.spec);
  } catch (const Error& e) {
    throw Error(cat("-load_history ", e.what()));
  }
  auto h = std::make_shared<dyn::LoadHistory>(lm, dofs, table, o.outside, o.scale);
  double peak = 0.0;
  for (double f : table.forces) peak = std::max(peak, std::abs(f));
  print0(comm, "morse: load history %s: %zu nodes, %zu times in [%g, %g] s, max |force component| %.4g N (x %g)\n",
         table.source.c_str(), table.n_nodes(), table.n_times(), table.time.front(), table.time.back(), peak, o.scale);
  return h;
}

PetscErrorCode get_reduce_options(MPI_Comm comm, ReduceOptions* r) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse reduce output options", "");
  PetscCall(MorseOptionsBool("-cb_xdmf", "Write an XDMF file for ParaView (with -cb_write_basis)", "", r->xdmf,
                             &r->xdmf, &r->xdmf_set));
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

}  // namespace morse::app::detail

namespace morse::app::detail {

PetscErrorCode get_contact_options(MPI_Comm comm, ContactOptions* o) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE, bump_set = PETSC_FALSE;
  auto bad = [&](const std::string& e) {
    if (o->error.empty()) o->error = e;
  };
  auto& c = o->casing;
  PetscOptionsBegin(comm, nullptr, "morse contact (seed 003 §3.4: blade tip against a rigid obstacle)", "");
  PetscCall(MorseOptionsString("-contact_set",
                               "Node set in contact (physical boundary nodes of the reduced model: its -boundary set "
                               "or a subset); no contact if not given",
                               "", buf, buf, sizeof buf, &set));
  if (set) o->set = buf;
  const char* obstacles[] = {"plane", "casing", "Obstacle", "", nullptr};
  PetscEnum ob = static_cast<PetscEnum>(o->obstacle);
  PetscCall(MorseOptionsEnum("-contact_obstacle",
                             "casing (rigid, of revolution about z, two-lobe distortion growing in time: eq. 52-53) or "
                             "plane (-contact_plane_point, -contact_plane_normal)",
                             "", obstacles, ob, &ob, nullptr));
  o->obstacle = static_cast<sim::Obstacle>(ob);
  PetscCall(MorseOptionsReal("-contact_mu", "Coulomb friction coefficient", "", o->mu, &o->mu, nullptr));
  if (!(o->mu >= 0)) bad(cat("-contact_mu must be >= 0 (got ", o->mu, ")"));
  PetscInt n = 3;
  PetscCall(MorseOptionsRealArray("-contact_plane_point", "A point of the plane x,y,z [m]", "", o->plane.point, &n, &set));
  if (set && n != 3) bad("-contact_plane_point needs 3 values x,y,z");
  o->plane_given = set;
  n = 3;
  PetscCall(MorseOptionsRealArray("-contact_plane_normal", "Normal of the plane x,y,z, pointing to the free side", "",
                                  o->plane.normal, &n, &set));
  if (set && n != 3) bad("-contact_plane_normal needs 3 values x,y,z");
  o->plane_given = o->plane_given || set;
  const double nn = std::sqrt(o->plane.normal[0] * o->plane.normal[0] + o->plane.normal[1] * o->plane.normal[1] +
                              o->plane.normal[2] * o->plane.normal[2]);
  if (!(nn > 0)) bad("-contact_plane_normal must not be zero");
  else
    for (double& x : o->plane.normal) x /= nn;
  PetscCall(MorseOptionsReal("-casing_clearance", "Casing: nominal radial clearance c0 [m] (seed: 0.356 mm)", "",
                             c.clearance, &c.clearance, nullptr));
  c.bump_height = 2.0 * c.clearance;
  PetscCall(MorseOptionsReal("-casing_bump_height", "Casing: height h_b of each lobe [m] (default 2 c0, as the seed)", "",
                             c.bump_height, &c.bump_height, &bump_set));
  if (!bump_set) c.bump_height = 2.0 * c.clearance;
  PetscInt lobes = c.lobes;
  PetscCall(MorseOptionsInt("-casing_lobes", "Casing: number of lobes of the distortion (seed: 2)", "", lobes, &lobes,
                            nullptr));
  c.lobes = static_cast<int>(lobes);
  PetscCall(MorseOptionsReal("-casing_width", "Casing: angular width of each lobe [rad] (eq. 52)", "", c.width, &c.width,
                             nullptr));
  PetscCall(MorseOptionsReal("-casing_alpha",
                             "Casing: growth rate of the distortion [1/s]; 0 = 99% of h_b at 20% of the run", "",
                             c.alpha, &c.alpha, nullptr));
  PetscBool omega_set = PETSC_FALSE;
  PetscCall(MorseOptionsReal("-sim_omega", "Rotation speed of the blade [rad/s] (casing contact)", "", c.omega, &c.omega,
                             &omega_set));
  o->omega_given = omega_set;
  PetscCall(MorseOptionsReal("-sim_revolutions", "Run length in revolutions at -sim_omega (instead of -sim_tfinal)", "",
                             o->revolutions, &o->revolutions, &set));
  if (set && !(o->revolutions > 0)) bad(cat("-sim_revolutions must be positive (got ", o->revolutions, ")"));
  PetscOptionsEnd();
  if (!(c.clearance > 0)) bad(cat("-casing_clearance must be positive (got ", c.clearance, " m)"));
  if (!(c.bump_height >= 0)) bad(cat("-casing_bump_height must be >= 0 (got ", c.bump_height, " m)"));
  if (c.lobes < 1) bad(cat("-casing_lobes must be >= 1 (got ", c.lobes, ")"));
  if (!(c.width > 0)) bad(cat("-casing_width must be positive (got ", c.width, " rad)"));
  if (!(c.alpha >= 0)) bad(cat("-casing_alpha must be >= 0 (got ", c.alpha, " 1/s)"));
  return PETSC_SUCCESS;
}

}  // namespace morse::app::detail
