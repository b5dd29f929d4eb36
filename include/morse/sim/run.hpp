// morse/sim/run.hpp: the options of the reduced runs (`morse simulate`, `morse sweep`) read by
// their settings (PETSc's XSetFromOptions habit), and what a run of `morse simulate` does besides
// integrating: the file name of each case, the snapshot plan of a fom file, the records of a run
// (SimRecord) and the cases run round robin over the ranks (docs/user-guide.md).
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "morse/dyn/dyn.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "morse/sim/sim.hpp"

namespace morse::sim {

/// Contact and rotation options shared by simulate and sweep.
struct ContactOptions {
  std::string set;
  Obstacle obstacle = Obstacle::Casing;
  Plane plane;
  Casing casing;
  double mu = 0.15;
  Sliding sliding = Sliding::Relative;  ///< -contact_sliding relative|rotation
  double revolutions = 0.0;             ///< 0: not given
  bool plane_given = false;             ///< -contact_plane_point or -contact_plane_normal given
  bool omega_given = false;             ///< -sim_omega given
  std::string error;                    ///< a bad value, naming the option (raised by the command after -help)

  /// Reads -contact_set SET, -contact_obstacle casing|plane, -contact_mu, -contact_sliding
  /// rotation|relative (the casing's friction direction, Sliding), -contact_plane_point
  /// x,y,z, -contact_plane_normal x,y,z (normalized here), -casing_clearance, -casing_bump_height
  /// (default 2 x clearance), -casing_lobes, -casing_width, -casing_alpha, -sim_omega and
  /// -sim_revolutions. A bad value (a non-finite one among them) is recorded in `error` (the first
  /// one). Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
  /// The contact settings of these options: the nodes of `set` in sm (contact_nodes, which throws
  /// alike on every rank for a node that is not a physical boundary node), the obstacle, plane,
  /// casing and friction. Not collective.
  void apply(const nlrom::StoredModel& sm, ContactSettings* c) const;
};

/// The options of `morse simulate`.
struct SimOptions {
  std::string rom, out = "simulate.h5", snapshots;
  Settings s;
  PetscBool linear = PETSC_FALSE;
  PetscBool energy_balance = PETSC_TRUE;  ///< -sim_energy_balance
  PetscInt every = 1;
  std::vector<std::string> monitor, cases;
  ContactOptions contact;
  std::vector<double> v0_uniform;  ///< 3 values, or empty
  /// -sim_divergence_limit [m] (Settings::divergence_limit); negative: divergence_radius() of the contact
  double divergence_limit = -1.0;
  bool tfinal_set = false;
  std::string error;  ///< a bad value, naming the option (raised by the command after -help)

  /// Reads -sim_monitor, -sim_cases, -rom, -out, -sim_dt, -sim_tfinal, -sim_scheme,
  /// -sim_newton_rtol, -sim_newton_max_it, -sim_kernel, -sim_linear, -sim_output_every,
  /// -sim_snapshots, -sim_q0, -sim_v0, -sim_v0_uniform and the contact options
  /// (ContactOptions::set_from_options). A non-finite value (-sim_q0, -sim_v0, -sim_v0_uniform,
  /// -sim_dt, -sim_tfinal, -sim_newton_rtol), an empty -out, a case given twice or a case name
  /// that is empty or holds '/' or '..' (it would write outside -out's directory) is recorded in
  /// `error`; a bad contact value in contact.error. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
  /// Completes s for the stored model sm: the contact (-contact_set: central differences only),
  /// t_final from -sim_revolutions at -sim_omega, v0 fitted on the basis from -sim_v0_uniform
  /// (*v0_residual: the relative residual of the fit). Throws naming the option, alike on every
  /// rank. Not collective.
  void resolve(const nlrom::StoredModel& sm, double* v0_residual);
};

/// The most speeds one sweep takes: its file holds about 8 (15 + spectrum bins) bytes per speed
/// (14 values and the spectrum), 4 GB at the default 500 bins, and a checkpoint rewrites it whole
/// after every speed.
constexpr long kMaxSweepSpeeds = 1000000;

/// The options of `morse sweep`.
struct SweepOptions {
  std::string rom, out = "sweep.h5", monitor = "LE";
  double omega_min = 0, omega_max = 0, omega_step = 0, dt = 0, fmax = 10000.0;
  /// batch: -sweep_batch; unless given (batch_given), 16 where the potential kernel runs its
  /// AVX-512 build and 8 otherwise (default_sweep_batch; the fastest measured, bench/README.md).
  PetscInt bins = 500, batch = 8;
  PetscBool batch_given = PETSC_FALSE;
  PetscBool linear = PETSC_FALSE, restart = PETSC_FALSE, single = PETSC_FALSE;
  SweepKernel kernel = SweepKernel::Auto;  ///< -sweep_kernel
  /// -sweep_isa auto|avx512|avx2|baseline: the build of the batched potential kernel (-1: auto, the
  /// widest the processor runs; else a KernelIsa). avx512 and avx2 give the same bits.
  int isa = -1;
  PetscBool energy_balance = PETSC_TRUE;  ///< -sim_energy_balance
  PetscInt tangent_checks = 200;          ///< -sim_tangent_checks (per speed)
  /// -sweep_rotation: +1 (positive, default) the blade turns at +|omega| about +z, -1 at -|omega|
  /// (the sign of the speeds given to the casing: friction and the lobes' travel turn with it).
  int rotation = 1;
  /// Adaptive refinement (-sweep_refine_step D > 0): the speed grid is then the fine grid
  /// omega_min + i D, the coarse speeds (every omega_step = 2^k D) run first, and rounds of
  /// refine() bisect every pair of neighbouring finished speeds that differ, down to D.
  double refine_step = 0.0;
  double refine_rms = 0.2;         ///< -sweep_refine_rms: relative RMS jump that refines
  double refine_frequency = 0.05;  ///< -sweep_refine_frequency: relative change of the dominant frequency
  /// -sweep_refine_orders k1,k2,...: refine on these engine-order lines instead of the RMS and the
  /// dominant frequency (SpeedResult::orders; each k <= orders). Between two neighbours, a line
  /// refines where its amplitudes A, B differ by |A - B| > refine_order_jump max(A, B), and a local
  /// maximum of a line's amplitude is located to refine_step; a line counts only where max(A, B)
  /// (or the maximum) reaches refine_order_floor times its largest amplitude over the finished
  /// speeds, so that the noise of a line that is absent refines nothing. A failure beside a finished
  /// speed still refines. The RMS of a rubbing blade holds the casing's static push and hides a
  /// lock of one line, and its dominant line jumps between combination tones (docs/contact.md).
  std::vector<int> refine_orders;
  double refine_order_jump = 0.5, refine_order_floor = 0.1;
  /// refine_orders as given, "6,8" (empty: none).
  std::string refine_orders_text() const;
  /// -sweep_orders K: the amplitudes of engine orders 1..K written per speed (/sweep/order_amplitude).
  PetscInt orders = 24;
  /// -sweep_retries K: a speed that fails (a non-finite state, a contact or boundary solve that does
  /// not converge) runs again from rest at half its step, up to K times (dt / 2^K). Central
  /// differences with contact and a cubic force have no a-priori stable step: the stiffening under
  /// contact lowers the critical step during the run (docs/contact.md, "Longer runs").
  int retries = 1;
  /// -sweep_divergence_limit L [m]: a speed whose monitored displacement exceeds L has diverged
  /// (SweepSettings::divergence_limit). Default (negative): the largest radius of the contact
  /// nodes, a displacement no blade survives; 0: no limit.
  double divergence_limit = -1.0;
  /// -sweep_continuation up|down|both (+1, -1, 2; 0: none, every speed from rest on the growing casing):
  /// natural-parameter continuation. Each speed starts from the final state of its neighbour below
  /// (up) or above (down) in |Omega|, on the grown casing with its lobes where that run left them, so
  /// that a branch of solutions is followed across the speeds where another coexists (docs/contact.md,
  /// "Coexisting solutions"). The grid is cut into `chains` runs of neighbouring speeds (the first
  /// of each from rest), which run in parallel (one lane each); a failed speed ends its chain's
  /// branch: the next speed starts from rest. No retries, no refinement. Both: the up chains on
  /// the grid indices 0..n-1 and the down chains on n..2n-1 (index n + i is speed i again), run
  /// together, so that a rank's up and down speeds share the passes of the force kernel.
  int continuation = 0;
  PetscInt chains = 1;  ///< -sweep_chains
  ContactOptions contact;
  std::string error;  ///< a bad value, naming the option (raised by check())

  /// Reads -rom, -out, -sweep_omega_min, -sweep_omega_max, -sweep_omega_step, -sim_dt,
  /// -sim_linear, -sweep_monitor, -sweep_spectrum_fmax, -sweep_spectrum_bins, -sweep_batch,
  /// -sweep_kernel, -sweep_isa, -sweep_float, -sweep_restart, -sweep_rotation, -sweep_retries, -sweep_divergence_limit
  /// and the contact options (ContactOptions::set_from_options). A non-finite speed, step, -sim_dt or
  /// -sweep_spectrum_fmax, -sweep_retries outside 0..20, or a grid of more than kMaxSweepSpeeds speeds (the message
  /// gives the file size it would need) is recorded in `error`. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
  /// Throws (alike on every rank) on options a sweep refuses: `error`, no -rom or -contact_set, a
  /// plane obstacle, -sim_omega, a bad speed grid, batch or spectrum. Not collective.
  void check() const;
  /// Refuses (alike on every rank) a sweep whose spectra cannot fit in the memory available: the
  /// frequency grid of -sweep_spectrum_bins and one spectrum per speed (all of them on rank 0,
  /// which writes the file), before anything is allocated. Collective.
  void check_memory(MPI_Comm comm) const;
  /// The sweep settings for the stored model sm: dt, linear, the casing contact of -contact_set,
  /// -sim_revolutions (default 200), the spectrum, batch, the radial row of -sweep_monitor and the
  /// divergence limit (default: the largest radius of the contact nodes).
  SweepSettings settings(const nlrom::StoredModel& sm) const;
  /// The size of the speed grid omega_min, omega_min + step, ..., omega_max (with refinement: of
  /// the fine grid of step refine_step up to the last coarse speed).
  long grid_speeds() const;
  /// The indices of a sweep: grid_speeds() times directions().
  long n_speeds() const;
  /// The directions a continuation runs: 2 for both ways, else 1 (every speed once).
  int directions() const { return continuation == 2 ? 2 : 1; }
  /// The signed speed of index i (i modulo grid_speeds()) [rad/s].
  double omega_of(long index) const;
  /// Grid points per coarse step: omega_step / refine_step (1 without refinement).
  long stride() const;
  /// The (coarse) speeds of the grid not in done_idx (indices of finished speeds), in grid order.
  std::vector<SpeedTask> todo(const std::vector<std::int64_t>& done_idx) const;
  /// The next refinement round after the finished speeds `done` (all coarse speeds among them):
  /// for every two neighbouring finished speeds (by index) at least two grid points apart that
  /// differ (speeds_differ), or of which one is a local maximum of the RMS (an interaction, located
  /// to refine_step), the speed midway. With refine_orders, the jumps and peaks of those engine-order
  /// lines instead of the RMS and the dominant frequency. Empty: the refinement is over (or there
  /// is none). freqs: the spectrum's frequencies.
  std::vector<SpeedTask> refine(const std::vector<SpeedResult>& done, const std::vector<double>& freqs) const;
  /// The retries due among the finished speeds `done` (those of a resumed file included): every
  /// failed speed with fewer than `retries` halvings, at one more, in index order.
  std::vector<SpeedTask> retry(const std::vector<SpeedResult>& done) const;
  /// Continuation: the grid indices of each chain in the order they run (up: increasing |Omega|).
  /// Chain k holds the speeds k n / chains .. (k + 1) n / chains - 1 of the n of the grid.
  std::vector<std::vector<long>> chain_order() const;
  /// Continuation: the next speed of every chain after the finished speeds `done` (those of a
  /// resumed file included): the first speed of the chain's order not in done, continued from the
  /// final state of the speed before it (SpeedResult::q_end, phase_end) if that one finished with
  /// a state, else from rest. Empty: every chain is done.
  std::vector<SpeedTask> next_in_chains(const std::vector<SpeedResult>& done) const;
};

/// The lanes per rank of a sweep with no -sweep_batch: 16 if isa (a KernelIsa, or -1: the widest
/// this processor runs) is Avx512, else 8.
int default_sweep_batch(int isa);

/// The predicted cost of a sweep, from a measured step rate (measure_step_rate, every rank for
/// `seconds` at the lowest speed of todo, the mean taken).
struct SweepCost {
  double steps = 0.0;         ///< of the speeds of todo
  double rate = 0.0;          ///< steps per second per rank
  double core_hours = 0.0;    ///< steps / rate
  double wall_seconds = 0.0;  ///< core_hours over the ranks (perfect balance)
  double refine_steps = 0.0;  ///< refinement: at most this many more (every fine speed not done)
  double refine_core_hours = 0.0;
  /// The tangent checks of the speeds of todo (Settings::tangent_checks; none for linear and
  /// massless models) and the measured time of one (tangent_step at rest): in core_hours. A check
  /// costs thousands of steps at r = 79, so a short sweep's cost is mostly its checks.
  double checks = 0.0, check_seconds = 0.0;
};
/// Collective. With nothing to run, the rate is not measured (all zero).
SweepCost predict_sweep_cost(MPI_Comm comm, const nlrom::ReducedModel& m, const SweepSettings& s,
                             const SweepOptions& so, const std::vector<SpeedTask>& todo,
                             const std::vector<std::int64_t>& done_idx, double seconds = 0.3);

/// Runs the speeds of todo (sim::sweep), then the refinement rounds of so.refine() until none is
/// left. A continuation sweep (so.continuation) instead runs rounds of so.next_in_chains(), one
/// speed of every chain per round, each from its predecessor's final state (todo is not used). Every speed that fails
/// is run again at half its step (so.retry(), up to so.retries halvings; those due in a resumed file first), before the
/// next refinement round; s.base.dt is the step of a speed with no halving. done (rank 0): the finished speeds, those
/// of a resumed file included; each new result replaces the one of the same index or is appended to it before
/// on_result(result) runs (the checkpoint). freqs: the spectrum's frequencies. *n_run: the speed
/// runs (retries included). Prints each round and each retry on rank 0. Collective.
SweepStats sweep_rounds(MPI_Comm comm, const nlrom::ReducedModel& m, const SweepSettings& s, const SweepOptions& so,
                        std::vector<SpeedTask> todo, std::vector<SpeedResult>* done, const std::vector<double>& freqs,
                        const std::function<void(const SpeedResult&)>& on_result, std::size_t* n_run);

/// Whether two speeds of a sweep differ enough to refine between them: one failed and not the
/// other; RMS values a relative rms_jump apart (|a - b| > rms_jump max(a, b)); or dominant spectral
/// frequencies (the largest amplitude above f = 0) a relative frequency_jump apart and more than
/// two frequency bins.
bool speeds_differ(const SpeedResult& a, const SpeedResult& b, const std::vector<double>& freqs, double rms_jump,
                   double frequency_jump);

/// The "key=value" lines that define a sweep (SweepRecord::settings): a resumed sweep must match
/// them exactly. They include the model's fingerprint (nlrom::fingerprint), so that a model
/// rebuilt at the same path is not resumed into the old one's file. Not collective.
std::string settings_text(const SweepOptions& o, const SweepSettings& s, const nlrom::ReducedModel& m);

/// Resumes a sweep: rank 0 reads `out` (unless restart) and, if it holds a sweep with the settings
/// of rec, takes its finished speeds into rec; then writes rec as the first checkpoint (which also
/// proves that `out` is writable). Returns the indices of the finished speeds on every rank.
/// Throws collectively if `out` holds another sweep or cannot be read or written. Collective.
/// The settings that differ between a sweep file's stored settings text and the current one, as
/// "key: stored in the file, current now; ..." (empty: the same sweep). The reduced model (rom)
/// counts as the same when it is the same file (files::same_file). Not collective.
std::string settings_difference(const std::string& stored, const std::string& now);

std::vector<std::int64_t> resume_sweep(MPI_Comm comm, const std::string& out, bool restart, SweepRecord* rec);

/// The options of `morse stress`.
struct StressOptions {
  std::string rom, sim, fom, monitor = "LE", measure;
  double time = -1.0;
  PetscBool time_set = PETSC_FALSE, xdmf = PETSC_TRUE;
  std::string error;  ///< a bad value, naming the option (raised by the command after -help)

  /// Reads -rom, -sim, -fom (a morse fom file with snapshots: its snapshot nearest -stress_time,
  /// instead of -rom and -sim), -stress_time, -stress_monitor, -stress_measure linear|nonlinear
  /// (another value is recorded in `error`) and -stress_xdmf. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
};

/// The state of a simulate file whose stress `morse stress` recovers.
struct StressState {
  std::vector<double> q;               ///< r: the reduced coordinates of the state
  double time = 0.0;                   ///< its time
  std::int64_t step = 0, n_steps = 0;  ///< its output row, and the rows of the file
  double radial = 0.0;                 ///< the largest |radial displacement| at the monitor (no -stress_time)
  StressMeasure measure = StressMeasure::Nonlinear;  ///< -stress_measure, else the file's (/sim@linear)
};
/// Rank 0 reads /sim/time and /sim/q of so.sim (and /sim@linear without -stress_measure) and picks
/// the stored time nearest so.time (so.time_set), else the time of the largest |radial
/// displacement| at so.monitor (StoredModel::radial_row); every rank receives that state. Throws
/// collectively naming the file or the option on bad input. Collective.
StressState stress_state(MPI_Comm comm, const StressOptions& so, const nlrom::StoredModel& sm);

/// The displacement u ([k][3] at the nodes node_ids) in the node order of the gathered mesh gm
/// (rec->displacement), and the largest nodal von Mises of f with its node's id. Rank 0 (gm and f
/// are rank 0 data); not collective.
void nodal_fields(const std::vector<std::int64_t>& node_ids, const std::vector<double>& u, const mesh::Mesh& gm,
                  const StressField& f, StressRecord* rec);

/// The file of case `c` of a run writing `out`: <out stem>_<c><extension> (<out>_<c>.h5 if out
/// has no extension).
std::string case_path(const std::string& out, const std::string& c);

/// The snapshot times and the DOF map of a fom file (-sim_snapshots), with the rows of those DOFs
/// in a stored model.
struct SnapshotPlan {
  std::string fom;  ///< empty: no snapshots
  std::vector<double> time;
  std::vector<std::int64_t> ids, comps;
  std::vector<std::size_t> rows;
};
/// Reads the snapshot plan of fom file `fom` for stored model sm; an error names -sim_snapshots.
/// Collective on comm (every rank throws alike).
SnapshotPlan read_snapshot_plan(MPI_Comm comm, const std::string& fom, const nlrom::StoredModel& sm);

/// Integrates the reduced model of sm under `loads` (sim::integrate) and records the run in
/// *rec: every `every`-th step the time, energy, q, the contact histories (the mean contact force
/// of every output interval, so that the history can drive another model) and the displacements
/// of the monitored sets; the full fields at the snapshot steps of plan (the step nearest each
/// snapshot time within [0, t_final]); the final state; the node ids of the monitored sets and of
/// the contact set `contact_set` (s.contact has its nodes) and the loads. A record that cannot fit
/// in the memory available is refused before the run starts (morse::Error naming
/// -sim_output_every). Serial.
Stats simulate(const nlrom::StoredModel& sm, const std::vector<dyn::NodalLoad>& loads, const Settings& s, long every,
               const std::vector<std::string>& monitor, const std::string& contact_set, const SnapshotPlan& plan,
               SimRecord* rec);

/// Runs task(i) for every case i, round robin over the ranks of comm (case i on rank i % size). A
/// failed case does not stop the others: at the end every rank throws one morse::Error naming
/// every failure in rank order ("case <name>: <message>", or the message alone for an unnamed
/// case). Collective.
void run_cases(MPI_Comm comm, const std::vector<std::string>& names, const std::function<void(std::size_t)>& task);

}  // namespace morse::sim
