// morse/dyn/dyn.hpp: loads, nonlinear statics and full-order nonlinear dynamics of the
// distributed model (seed 003 eq. 1 without contact):
//
//   M u'' + C u' + K u + g_nl(u) = f_e(t).
//
// Loads are nodal: each names a node set, a direction, a force per node (newtons per node, not a
// traction) and a harmonic time law F(t) = A sin(omega t + phase); omega = 0 means the constant
// load A (the phase is then ignored). A tabulated history (LoadHistory: a force vector per node
// on a time grid, linearly interpolated; e.g. the contact forces of a `morse simulate` run) may
// be added to them.
//
// Statics: Newton (PETSc SNES, line search, MUMPS) on f_int(u) = lambda f_e(t_s), with load
// stepping in lambda and cut-back of failed increments.
//
// Dynamics: an implicit, fixed-step, second-order, non-dissipative scheme in midpoint form
//   M (v1 - v0)/h + C (v0 + v1)/2 + f_alg(u0, u1) = (f_e(t0) + f_e(t1))/2,
//   (u1 - u0)/h = (v0 + v1)/2,
// with f_alg either the energy-momentum midpoint force of St Venant–Kirchhoff (scheme "energy",
// Simo & Tarnow 1992: exact discrete energy balance) or (f_int(u0) + f_int(u1))/2 (scheme
// "trapezoidal", exactly Newmark's average acceleration rule). Both reduce to the same
// trapezoidal rule for a linear model. Newton iterations with MUMPS on the symmetric iteration
// matrix K_T + (2/h) C + (4/h^2) M; the factorization may be reused across iterations and steps
// (modified Newton); the residual tolerance holds either way. Modal damping is a low-rank
// operator, solved by the Sherman–Morrison–Woodbury formula, never a dense matrix.
#pragma once

#include <petscmat.h>
#include <petscvec.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "morse/core/handle.hpp"
#include "morse/fe/model.hpp"
#include "morse/fe/nonlinear.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::io {
class H5Output;
class H5SliceWriter;
}  // namespace morse::io

namespace morse::dyn {

/// One nodal load: F(t) = amplitude * sin(omega t + phase) * dir on every node of `set`
/// (omega = 0: constant amplitude * dir). dir is normalized by Loads.
struct NodalLoad {
  std::string set;
  double dir[3] = {0, 0, 0};
  double amplitude = 0.0;  ///< newtons per node
  double omega = 0.0;      ///< rad/s
  double phase = 0.0;      ///< rad
};

/// The time law of a harmonic load, shared by the full model (Loads::factor) and the reduced one
/// (sim::ReducedLoad): amplitude sin(omega t + phase), or amplitude if omega = 0. Not collective.
inline double harmonic_factor(double amplitude, double omega, double phase, double t) {
  return omega == 0.0 ? amplitude : amplitude * std::sin(omega * t + phase);
}

/// Parses a direction: x, y, z or vx,vy,vz. Returns "" or an error message.
std::string parse_direction(const std::string& text, double dir[3]);

/// Reads the nodal loads of the options (docs/user-guide.md): -load_sets SET[,SET...] and, per
/// set, -load_<SET>_dir x|y|z|vx,vy,vz, -load_<SET>_amplitude (newtons per node, required),
/// -load_<SET>_omega (rad/s, 0 = constant) and -load_<SET>_phase (rad), under `prefix` if given
/// (e.g. a case of `morse simulate -sim_cases`: -<prefix>load_sets ...). Appends one NodalLoad per
/// set to *loads. A missing direction or amplitude, a bad direction or a negative omega is recorded
/// in *error (if it is empty) as a message naming the option, for the caller to raise after -help.
/// Uses PetscOptionsBegin: returns a PETSc error code. Collective.
PetscErrorCode get_loads(MPI_Comm comm, std::vector<NodalLoad>* loads, std::string* error,
                         const char* prefix = nullptr);

// ------------------------------------------------------------------------------------------
// Tabulated nodal load histories (Nastran TABLED1 / Code_Aster DEFI_FONCTION, per node and
// component): a force vector per node at each time of a grid t_0 < t_1 < ... < t_{n-1},
// linearly interpolated in time in between,
//
//   f_k(t) = F_{i,k} + (t - t_i) / (t_{i+1} - t_i) (F_{i+1,k} - F_{i,k}),   t_i <= t <= t_{i+1}.
//
// Outside [t_0, t_{n-1}] the history is an error by default (Code_Aster's PROLONGEMENT='EXCLU'),
// checked before a run starts; Outside::Zero and Outside::Hold give zero or the end values.

/// What a LoadHistory gives outside its time grid.
enum class Outside {
  Error,  ///< throw (check_covers() before a run, evaluate() during it)
  Zero,   ///< no force before t_0 and after t_{n-1}
  Hold,   ///< the first / last row (constant extrapolation)
};
/// Parses error|zero|hold. Returns "" or an error message.
std::string parse_outside(const std::string& text, Outside* out);

/// A tabulated nodal force history, held whole (the same on every rank).
struct LoadTable {
  std::vector<double> time;            ///< n_t strictly increasing times [s]
  std::vector<std::int64_t> node_ids;  ///< n_nodes mesh node ids (file labels), distinct
  std::vector<double> forces;          ///< [time][node][x,y,z], n_t * n_nodes * 3 [N], global axes
  std::string source;                  ///< where it came from (file and group), for messages
  std::size_t n_times() const { return time.size(); }
  std::size_t n_nodes() const { return node_ids.size(); }
  /// "" if the table is consistent: at least one time and one node, sizes that match, strictly
  /// increasing finite times, finite forces, distinct node ids; else a message naming source and
  /// the first offending time row / node / value.
  std::string validate() const;
  /// Interval and weight of t: f(t) = (1 - w) F_i + w F_{i+1} (i + 1 < n_t; a one-row table gives
  /// i = 0, w = 0). Outside the grid (beyond a relative 1e-9 of its span): *inside = false and
  /// (i, w) are those of Outside::Hold. Not collective.
  void locate(double t, std::size_t* i, double* w, bool* inside) const;
};

/// Reads a load table from a file (serial, any rank; no communication). `spec` is FILE or
/// FILE:GROUP:
///  - FILE ending in .csv (any case): lines "time, node_id, fx, fy, fz" (commas and/or blanks;
///    '#' starts a comment; one optional header line of words). Rows come in blocks of one time,
///    times increasing; every block lists every node of the table exactly once (any order).
///  - HDF5, group with `time` (n_t), `node_ids` (n_nodes, integer) and `forces` (n_t, n_nodes, 3):
///    the generic table (docs/hdf5-schema.md, "/load_history").
///  - HDF5, a `morse simulate` contact group (/sim/contact): its `mean_force` (the mean contact
///    force of each output interval, normal + friction, in global axes) at `mean_force_time`
///    (interval centres), node_ids as written.
///  Without GROUP, /load_history is tried, then /sim/contact. Returns "" or an error naming the file,
///  the dataset (or CSV line) and the fault (missing file / dataset, bad shape, non-increasing
///  times, NaN, duplicate node, ...); the table is validated.
std::string read_load_table(const std::string& spec, LoadTable* table);
/// The same, read on rank 0 and broadcast: every rank returns the table, or every rank throws
/// the reader's message. Collective.
LoadTable read_load_table(MPI_Comm comm, const std::string& spec);

/// A tabulated nodal load history applied to a distributed model: the table's forces on the free
/// DOFs of its nodes (clamped DOFs are dropped: they are reactions), scaled by `scale`.
class LoadHistory {
 public:
  /// Collective. Throws (collectively) if the table does not validate or if a node id is not a
  /// node of the mesh (naming up to 10 of them and the table's source). Every rank keeps the
  /// columns of the nodes it owns only.
  LoadHistory(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const LoadTable& table,
              Outside outside = Outside::Error, double scale = 1.0);
  /// F += scale f(t) on the owned DOFs. Not collective (the same time on every rank gives the same
  /// verdict). Throws if t is outside the grid and outside() is Error.
  void add_to(double t, Vec F) const;
  /// Throws (on every rank alike) if outside() is Error and [t_begin, t_end] is not inside the
  /// grid (to its relative 1e-9 tolerance), naming the source and both intervals.
  void check_covers(double t_begin, double t_end) const;
  double t_first() const { return grid_.time.front(); }
  double t_last() const { return grid_.time.back(); }
  std::size_t n_nodes() const { return n_nodes_; }
  Outside outside() const { return outside_; }
  const std::string& source() const { return grid_.source; }
  /// Sum over the table's nodes of scale * f(t), clamped DOFs included (3 values). Not collective.
  std::vector<double> total(double t) const;

 private:
  LoadTable grid_;               // the time grid and source only (the forces are kept per owned DOF below)
  std::vector<PetscInt> local_;  // local index in F of each owned, free entry
  std::vector<double> values_;   // [time][entry], scaled
  std::vector<double> sum_;      // [time][x,y,z], scaled total over every node
  Outside outside_;
  std::size_t n_nodes_ = 0;
};

/// The options of a tabulated load history (`morse fom`, docs/user-guide.md).
struct LoadHistoryOptions {
  std::string spec;                  ///< -load_history FILE[:/GROUP]; empty: none
  Outside outside = Outside::Error;  ///< -load_history_outside error|zero|hold
  double scale = 1.0;                ///< -load_history_scale S (finite)
  std::string error;                 ///< a bad value, naming the option (raised by the caller, after -help)
  /// Reads -load_history, -load_history_outside and -load_history_scale. A bad outside value, a
  /// non-finite scale or -load_history_outside without -load_history is recorded in `error`.
  /// Uses PetscOptionsBegin: returns a PETSc error code. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
  /// The file of spec (FILE of FILE:/GROUP); empty without -load_history. Not collective.
  std::string file() const;
};

/// Reads the table of o (read_load_table, rank 0, broadcast) and applies it to the model; null
/// without -load_history. Prints a one-line summary on rank 0. Throws collectively on bad input
/// (the reader's message, prefixed by "-load_history "). Collective.
std::shared_ptr<const LoadHistory> make_load_history(MPI_Comm comm, const mesh::LocalMesh& lm,
                                                     const fe::DofLayout& dofs, const LoadHistoryOptions& o);

/// The load vectors of a list of nodal loads on a distributed model. Collective.
class Loads {
 public:
  /// Throws (collectively) if a set does not exist (the message lists the sets), is empty, or
  /// a direction is zero. Loads on clamped DOFs are dropped (they are reactions).
  Loads(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::vector<NodalLoad>& loads);
  /// The loads on a mesh model's DOFs: with constraints (u = T u_bar), the nodal forces of the
  /// nodes' layout, f_bar = T^T f (a dependent node's force goes to the DOFs it follows, the lever
  /// rule of a rigid element). Collective.
  Loads(const fe::Model& md, const std::vector<NodalLoad>& loads);
  /// F = f_e(t) (F has the DOF layout): the harmonic loads plus the tabulated history, if any.
  /// Collective.
  void evaluate(double t, Vec F) const;
  const std::vector<NodalLoad>& loads() const { return loads_; }
  /// Adds a tabulated history to f_e (at most one; replaces a previous one). factor(), pattern()
  /// and max_omega() describe the harmonic loads only. Loads built on a model with constraints
  /// take a history on the nodes' layout (fe::node_layout) and apply T^T to it.
  void set_history(std::shared_ptr<const LoadHistory> history) { history_ = std::move(history); }
  const LoadHistory* history() const { return history_.get(); }
  bool empty() const { return loads_.empty() && !history_; }
  /// Time factor of load i: amplitude sin(omega t + phase) (amplitude if omega = 0).
  double factor(std::size_t i, double t) const;
  /// Unit-amplitude spatial pattern of load i (f_e(t) = sum_i factor(i, t) pattern(i)).
  Vec pattern(std::size_t i) const { return patterns_[i].get(); }
  /// Largest omega of the loads (0 if none is harmonic).
  double max_omega() const;

 private:
  std::vector<NodalLoad> loads_;
  std::vector<UVec> patterns_;  // unit-amplitude spatial pattern of each load
  std::shared_ptr<const LoadHistory> history_;
  Mat T_ = nullptr;  // the model's constraints (not owned), else null
  UVec nodal_;       // with T_: the history's forces on the nodes
};

// ------------------------------------------------------------------------------------------
// The load description stored with a run (/fom/load of `morse fom`, /sim/load of `morse
// simulate`; docs/hdf5-schema.md), so that `morse compare` reads the load of the runs it compares
// instead of taking it on the command line again.

struct LoadDescription {
  std::vector<NodalLoad> loads;  ///< the harmonic (and constant) nodal loads, in option order
  std::string history;  ///< the tabulated history's source (FILE or FILE:/GROUP, as -load_history takes it), "" if none
  double history_scale = 1.0;                ///< -load_history_scale
  Outside history_outside = Outside::Error;  ///< -load_history_outside
};

/// t_max of seed 003's criterion e1: the first maximum (t >= 0) of the first harmonic load
/// (omega > 0), (pi/2 - phase mod 2 pi) / omega; -1 if no load is harmonic.
double first_maximum(const std::vector<NodalLoad>& loads);

/// Writes d into `group` (e.g. "/fom/load"): the attribute n_loads; if n_loads > 0 the datasets
/// sets (the set names, one per line), direction [n][3] (as given; Loads normalizes it), amplitude,
/// omega and phase [n]; with a history the attributes history, history_scale and history_outside.
/// Rank 0 data (io::H5Output); not collective.
void write_load_description(io::H5Output& out, const std::string& group, const LoadDescription& d);

/// Reads what write_load_description wrote. Returns false (d untouched) if the file has no
/// `group` (a file written before the load was stored); throws naming the file and the dataset if
/// the group is inconsistent. Serial, any rank.
bool read_load_description(const std::string& file, const std::string& group, LoadDescription* d);

/// The displacements of the nodes of one node set, sampled from distributed vectors onto rank 0
/// (one small reduction per sample; the set's nodes only). Collective.
class SetProbe {
 public:
  /// Throws (collectively) if the set does not exist or is empty.
  SetProbe(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::string& set);
  /// Node ids of the set (file labels), ascending global node order. Rank 0 only.
  const std::vector<std::int64_t>& node_ids() const { return ids_; }
  /// x, y, z per node (n_nodes x 3, row-major) on rank 0; empty elsewhere. Clamped DOFs are 0.
  std::vector<double> sample(Vec u) const;
  const std::string& name() const { return name_; }

 private:
  MPI_Comm comm_;
  std::string name_;
  std::vector<std::int64_t> ids_;
  std::vector<std::pair<int, PetscInt>> local_;  // (slot 3 i + d, local index in u) of owned DOFs
  std::size_t n_ = 0;
};

// ------------------------------------------------------------------------------------------
// Statics

struct StaticSettings {
  double time = 0.0;               ///< loads evaluated at this time
  double load_factor = 1.0;        ///< final load factor lambda
  PetscInt steps = 1;              ///< initial number of equal load increments
  PetscInt max_cutbacks = 10;      ///< halvings of a failed increment before giving up
  bool linear = false;             ///< solve K u = lambda f (no g_nl)
  double rtol = 1e-9;              ///< converged when ||R|| <= rtol max(||lambda f||, ||K u||)
  PetscInt max_it = 25;            ///< Newton iterations per increment
  std::string prefix = "static_";  ///< options prefix of the SNES (and its KSP/PC)
  std::string error;               ///< a bad option value, naming the option (set_from_options)

  /// Reads -static_linear, -static_time, -static_load_factor, -static_steps,
  /// -static_max_cutbacks, -static_rtol and -static_max_it; a bad value (steps <= 0,
  /// max_cutbacks < 0, rtol or max_it <= 0) is recorded in `error`. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
};

/// One converged (or failed) load increment.
struct StaticIncrement {
  double lambda = 0.0;
  PetscInt newton_iterations = 0;
  double residual = 0.0;  ///< final ||f_int - lambda f||
  bool converged = false;
  std::string reason;  ///< SNES converged reason
};

struct StaticResult {
  UVec u;
  std::vector<StaticIncrement> history;  ///< every increment tried, failed ones included
  double load_norm = 0.0;                ///< ||f_e(time)|| (lambda = 1)
};

/// Nonlinear (or linear) static solution. Throws morse::Error (collectively) when an increment
/// still fails after max_cutbacks halvings, naming the load factor reached. Collective.
StaticResult solve_static(const fe::Svk& svk, const Loads& loads, const StaticSettings& s);

/// Writes /static (docs/hdf5-schema.md): the displacement at every node (/static/u, [1][node][3],
/// nodes in global order), the displacements of the probes' sets (/static/sets/<SET>), the
/// increments tried (/static/history) and the settings as attributes. /meta and /mesh are the
/// command's. Collective (gathers u).
void write_static(io::H5Output& out, const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const StaticResult& res,
                  const std::vector<SetProbe>& probes, const StaticSettings& s);

// ------------------------------------------------------------------------------------------
// Dynamics

enum class Scheme { Energy, Trapezoidal };

/// Newton variant of each step.
///  - Krylov (default; trapezoidal scheme): exact Newton directions by preconditioned CG on the
///    matrix-free Jacobian J(u) = 4/h^2 M + 2/h C + K_T(u) (Svk::tangent_apply), preconditioned by
///    the last MUMPS factor of J, which is kept across iterations and steps and refreshed only when
///    CG needs more than krylov_refactor_its iterations (or fails). Inexact-Newton forcing term
///    eta = max(krylov_rtol, tol / (2 ||R||)), capped at 0.1; full steps (no line search).
///  - Modified: the factor itself is the Newton matrix (modified Newton), refreshed as
///    refactor_every / refactor_ratio say. The energy scheme and the linear twin always use it.
enum class Newton { Krylov, Modified };
struct FomSettings {
  double dt = 0.0;
  double t_final = 0.0;
  Scheme scheme = Scheme::Trapezoidal;
  bool linear = false;    ///< g_nl = 0 (the linear twin, same everything else)
  double modal_xi = 0.0;  ///< modal damping ratio on the first damping_modes modes
  PetscInt damping_modes = 0;
  double rayleigh_alpha = 0.0;  ///< C += alpha M
  double rayleigh_beta = 0.0;   ///< C += beta K
  double newton_rtol = 1e-8;    ///< ||R|| <= rtol * force scale + atol
  double newton_atol = 1e-12;
  PetscInt newton_max_it = 25;
  /// Refactor the iteration matrix every `refactor_every` iterations within a step (1 = full
  /// Newton); 0 = only when the residual does not fall by at least `refactor_ratio` in one
  /// iteration (modified Newton, factor kept across steps).
  PetscInt refactor_every = 0;
  double refactor_ratio = 0.25;
  Newton newton = Newton::Krylov;
  double krylov_rtol = 1e-2;          ///< smallest forcing term of the inexact Newton solves
  PetscInt krylov_max_it = 60;        ///< CG iterations before the factor is refreshed and CG rerun
  PetscInt krylov_refactor_its = 12;  ///< refresh the factor for the next solve above this count
  std::string prefix = "fom_";        ///< options prefix of the KSP/PC and of the damping eigen solve
  // What a `morse fom` run records and starts from (read by set_from_options; integrate() does
  // not use them).
  std::vector<std::string> monitor;           ///< -fom_monitor: node sets whose histories are written
  PetscInt snapshot_every = 0;                ///< -fom_snapshot_every K: full fields every K steps (0: none)
  std::string initial;                        ///< -fom_initial FILE: initial displacement ("" = zero)
  std::string initial_dataset = "/static/u";  ///< -fom_initial_dataset: the nodal dataset of -fom_initial
  std::string error;  ///< a bad option value, naming the option (raised by the caller, after -help)

  /// Reads -fom_monitor, -fom_dt, -fom_tfinal, -fom_linear, -fom_scheme energy|trapezoidal,
  /// -fom_snapshot_every, -fom_damping_modal, -fom_damping_modes, -fom_rayleigh alpha,beta,
  /// -fom_newton_rtol, -fom_newton_atol, -fom_newton_max_it, -fom_refactor_every,
  /// -fom_refactor_ratio, -fom_newton krylov|modified, -fom_krylov_rtol, -fom_krylov_max_it,
  /// -fom_krylov_refactor_its, -fom_initial and -fom_initial_dataset (docs/user-guide.md), then
  /// validates them: the first bad value (unknown scheme or Newton variant, dt or t_final not
  /// positive, t_final < dt, damping ratio outside [0, 1), ...) is recorded in `error`. Uses
  /// PetscOptionsBegin: returns a PETSc error code. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
};

/// Energies at one instant (seed 003 eq. 46 is kinetic + strain_linear).
struct Energies {
  double kinetic = 0.0;
  double strain_linear = 0.0;
  double strain_nonlinear = 0.0;
  double external_work = 0.0;  ///< work of f_e since t = 0
  double damping_loss = 0.0;   ///< energy dissipated by C since t = 0
  double eq46() const { return kinetic + strain_linear; }
  /// kinetic + strain + damping loss - external work: constant in an exact balance.
  double balance() const { return kinetic + strain_linear + strain_nonlinear + damping_loss - external_work; }
};

struct StepInfo {
  PetscInt step = 0;  ///< 0 = initial state
  double t = 0.0;
  Vec u = nullptr, v = nullptr;  ///< lent for the callback's duration
  Energies energy;
  PetscInt newton_iterations = 0;
  double residual = 0.0;
};

struct FomStats {
  PetscInt steps = 0;
  PetscInt newton_iterations = 0;
  PetscInt factorizations = 0;
  PetscInt rejected_steps = 0;     ///< Newton steps with a stale factor undone and refactored (modified Newton)
  PetscInt krylov_iterations = 0;  ///< CG iterations (Newton = Krylov)
  double seconds_force = 0, seconds_tangent = 0, seconds_factor = 0, seconds_solve = 0, seconds_total = 0;
  std::vector<double> damping_omega;  ///< natural angular frequencies of the damped modes
};

/// Integrates from (u0, v0) (null: zero) to t_final in steps of dt. callback(info) runs after
/// the initial state and after every step (collectively; may write output). Throws
/// morse::Error (collectively) naming the time reached when Newton diverges or a NaN appears.
/// Collective.
FomStats integrate(const fe::Svk& svk, Mat M, const Loads& loads, const FomSettings& s, Vec u0, Vec v0,
                   const std::function<void(const StepInfo&)>& callback);

/// Registers the options prefixes of the solvers integrate() creates (core/options.hpp): the
/// iteration KSP/PC under s.prefix, the Krylov (CG) KSP under <prefix>krylov_ and the modal
/// damping eigen solve under <prefix>damping_. integrate() calls it; a command calls it before its
/// early unknown-option check. Not collective.
void add_option_prefixes(const FomSettings& s);

// ------------------------------------------------------------------------------------------
// The file of a full-order run (/fom of `morse fom`, docs/hdf5-schema.md), written and read here.

/// The histories of a run, one entry per step from the initial state.
struct FomHistory {
  std::vector<double> time, energy;  ///< energy: seed 003 eq. 46 (Energies::eq46)
  std::vector<double> kinetic, strain_linear, strain_nonlinear, external_work, damping_loss, balance;
  std::vector<std::int64_t> newton_iterations;
  std::vector<double> residual;
  /// Displacements of monitored node sets: u is [time][node][x,y,z] (SetProbe::sample per step).
  struct Set {
    std::string name;
    std::vector<std::int64_t> node_ids;
    std::vector<double> u;
  };
  std::vector<Set> sets;
  /// Appends step i: its time, energies, Newton iterations and residual (not the sets). Not
  /// collective.
  void record(const StepInfo& i);
};

/// Full-field snapshots of a run, /fom/snapshots/{u,v} ([snapshot][free DOF], with the DOF map
/// dof_node_ids, dof_components), written in parallel into the temporary file of `out` while the
/// run goes on (no rank holds more than its own rows). Collective throughout.
class FomSnapshotWriter {
 public:
  /// Suspends out (io::H5Output::suspend) and creates the datasets for `rows` snapshots.
  FomSnapshotWriter(io::H5Output& out, const mesh::LocalMesh& lm, const fe::DofLayout& dofs, std::int64_t rows);
  ~FomSnapshotWriter();
  FomSnapshotWriter(const FomSnapshotWriter&) = delete;
  FomSnapshotWriter& operator=(const FomSnapshotWriter&) = delete;
  /// Writes u and v of step i as the next snapshot.
  void write(const StepInfo& i);
  /// Closes the parallel file and resumes out. Call once, before write_fom.
  void close();
  /// The times of the snapshots written (for write_fom).
  const std::vector<double>& times() const { return times_; }

 private:
  io::H5Output* out_;
  std::unique_ptr<io::H5SliceWriter> w_;
  int u_ = -1, v_ = -1;
  std::vector<double> times_;
};

/// Writes /fom: the histories h (time, energy, energies/*, newton_iterations, residual,
/// sets/<SET>/{node_ids,u}), the snapshot times (snapshot_every > 0: /fom/snapshots/time and
/// @every), the damped frequencies of stats, the load description (/fom/load and, with a history,
/// /fom@load_history, @load_history_scale) and the settings and statistics of the run as
/// attributes. /meta and /mesh are the command's. Rank 0 data; not collective.
void write_fom(io::H5Output& out, const FomHistory& h, const std::vector<double>& snapshot_times,
               PetscInt snapshot_every, const FomSettings& s, const FomStats& stats, const LoadDescription& load);

/// Reads the histories of a fom file (what write_fom writes of h) with the monitored sets `sets`
/// (each must be in /fom/sets). Throws naming the file and the missing or inconsistent dataset.
/// Serial, any rank.
FomHistory read_fom(const std::string& file, const std::vector<std::string>& sets);

/// One full-field snapshot of a fom file as nodal displacements.
struct SnapshotField {
  double time = 0.0;                   ///< of the snapshot
  std::int64_t index = 0;              ///< its row in /fom/snapshots/u
  std::int64_t n_rows = 0;             ///< the snapshots of the file
  std::vector<std::int64_t> node_ids;  ///< the nodes with a free DOF, ascending
  std::vector<double> u;               ///< [node][3]; a constrained component is 0
};
/// The snapshot of a fom file nearest to `time` (/fom/snapshots/{time,u,dof_node_ids,
/// dof_components}). Throws naming the file if it has no snapshots, if the DOF map and the rows
/// disagree, or if a component is not 0, 1 or 2. Serial, any rank.
SnapshotField read_fom_snapshot(const std::string& file, double time);
/// The same snapshot as stored: u[j] is the value of DOF (node_ids[j], components[j]). Throws as
/// read_fom_snapshot, except on components (not checked). Serial, any rank.
struct SnapshotRow {
  double time = 0.0;
  std::int64_t index = 0, n_rows = 0;
  std::vector<std::int64_t> node_ids, components;
  std::vector<double> u;
};
SnapshotRow read_fom_snapshot_row(const std::string& file, double time);

/// The snapshots of a fom file (/fom/snapshots/u) as the columns of an MPIDENSE matrix with the
/// DOF layout of dofs (io::read_dof_rows: rows matched by node id and component). Collective.
UMat read_fom_snapshots(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::string& file);
/// The snapshots on md's DOFs: read on the nodes' layout (fe::node_layout) and, for a model with
/// rigid or interpolation elements or MPCs, restricted to its DOFs (fe::restrict_columns: the
/// independent DOFs and the six-DOF points' motions of each snapshot). Collective.
UMat read_fom_snapshots(const fe::Model& md, const std::string& file);

}  // namespace morse::dyn
