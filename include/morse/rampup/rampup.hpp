// morse/rampup/rampup.hpp: the rotor–stator assembly of seed 000 §3 and its unbalance ramp-up.
//
// A flexible multibody model in the sense of seed 000 §1 and §3.1–3.3 (Fig. 1–2, model A):
//  - stators: Craig–Bampton superelements written by `morse reduce` / `morse select` (/rom), each
//    turned into its own modal basis under the assembly's boundary conditions (mount nodes
//    clamped, bearing nodes free) and truncated at a frequency, by default 2.5x the top
//    frequency of interest (seed 000 §1 and §3.3);
//  - rotors: Timoshenko shaft elements with rotary inertia and gyroscopic matrices (Nelson &
//    McVaugh 1976; Nelson 1980), rigid disks, an unbalance on a named disk, each rotor turning at
//    its own ratio of the driving speed;
//  - bearings: linear springs and dampers per direction between a rotor station and a stator
//    interface node (or the ground).
// The load case is the seed's speed ramp-up with unbalance (§3.1); the time integration is
// implicit Newmark (average acceleration) or HHT-alpha with a fixed step. The outputs are the
// bearing forces and the displacements at the bearings, the features of eq. 24.
//
// Conventions (docs/rampup-theory.md derives everything):
//  - Frame: the rotor axis is the stator's z axis (the basic system of the superelement). A
//    rotor station carries 4 DOFs (u_x, u_y, theta_x, theta_y) [m, m, rad, rad]: translations of
//    the shaft axis and small rotations of the cross-section about the fixed x and y axes
//    (right-hand rule). With Euler–Bernoulli kinematics theta_y = +du_x/dz and theta_x = -du_y/dz;
//    with shear the rotations are the section rotations, not the slopes.
//  - Spin: a positive speed turns the rotor about +z (counter-clockwise seen from +z). A rotor
//    with speed ratio s spins at Omega_r = s Omega(t), Omega the driving speed; s < 0 is a
//    counter-rotating spool.
//  - Equations of motion of the assembly (coordinates x = [stator modal coordinates of each
//    superelement in order; rotor DOFs of each rotor in order]):
//        M x'' + (C + Omega(t) G) x' + K x = f(t),
//    G the gyroscopic matrix per unit driving speed (skew-symmetric, each rotor's block scaled
//    by its speed ratio). For a disk: Id theta_x'' + Omega_r Ip theta_y' = M_x,
//    Id theta_y'' - Omega_r Ip theta_x' = M_y (forward whirl stiffens, backward softens).
//  - Units: SI throughout (m, kg, s, N, rad, rad/s); frequencies named *_hz are in Hz.
//  - Matrices are dense, row-major.
//
// Parallelism: nothing here is collective. Every function works on the calling rank's own data
// (HDF5 files are read with serial HDF5 on the calling rank); the command runs the ramp-up on
// rank 0. Errors throw morse::Error (not collective; the caller makes them collective).
#pragma once

#include <array>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "morse/io/superelement.hpp"

namespace morse::io {
class H5Output;
}

namespace morse::rampup {

// ------------------------------------------------------------------------------------------
// Shaft element and disk

/// Isotropic linear elastic material: Young's modulus E [Pa], Poisson ratio nu, density rho
/// [kg/m^3]. rho = 0 is allowed (a massless shaft, for checks against closed forms).
struct Material {
  double E = 2.1e11, nu = 0.3, rho = 7800.0;
};

/// Shear coefficient of a hollow circular section (Cowper 1966):
///   kappa = 6 (1 + nu) (1 + m^2)^2 / [(7 + 6 nu) (1 + m^2)^2 + (20 + 12 nu) m^2],
/// m = d_inner / d_outer (solid: 6 (1 + nu) / (7 + 6 nu)). Throws unless 0 <= d_inner < d_outer.
double shear_coefficient(double nu, double d_outer, double d_inner);

/// The matrices of one Timoshenko shaft element of length L between stations 1 and 2, DOF order
/// (u_x1, u_y1, theta_x1, theta_y1, u_x2, u_y2, theta_x2, theta_y2), 8 x 8 row-major:
///   Mt  translational mass  int rho A N_u^T N_u dz
///   Mr  rotary inertia      int rho I N_theta^T N_theta dz
///   G   gyroscopic (per unit spin speed, skew-symmetric exactly)
///       int rho Ip (N_thx^T N_thy - N_thy^T N_thx) dz, Ip = 2 I the polar area moment
///   K   stiffness           int E I N_theta'^T N_theta' dz + int kappa G A gamma^T gamma dz
/// with the shear-deformable Hermite shape functions of Nelson 1980 (exact static solution of a
/// Timoshenko beam under end loads; shear parameter phi = 12 E I / (kappa G A L^2)), so K is
/// exact and phi -> 0 gives the Euler–Bernoulli element of Nelson & McVaugh 1976. The integrals
/// are evaluated exactly (Gauss–Legendre, 5 points). The element's equation of motion is
/// (Mt + Mr) q'' + Omega G q' + K q = f.
struct ShaftElement {
  std::array<double, 64> Mt{}, Mr{}, G{}, K{};
  double phi = 0.0;    ///< shear parameter
  double kappa = 0.0;  ///< shear coefficient (shear_coefficient())
};
/// Throws unless L > 0, 0 <= d_inner < d_outer, E > 0, -1 < nu < 0.5, rho >= 0.
ShaftElement shaft_element(double L, double d_outer, double d_inner, const Material& mat);

/// A rigid disk at a station: mass [kg], polar Ip and diametral Id moments of inertia [kg m^2].
/// It adds diag(m, m, Id, Id) to the station's mass and Ip [[0, 1], [-1, 0]] on (theta_x,
/// theta_y) to its gyroscopic matrix (per unit spin speed).
struct Disk {
  std::string name;  ///< unique within the model (unbalances name it)
  int station = 0;   ///< index into RotorSpec::z
  double mass = 0.0, Ip = 0.0, Id = 0.0;
};

/// An unbalance m e [kg m] on a named disk, at angle `phase` [rad] from +x at t = 0. Its angle
/// is theta(t) = s int_0^t Omega dt + phase (s the rotor's speed ratio), and the force it exerts
/// on the disk in the fixed frame is
///   F_x = m e (Omega_r^2 cos theta + Omega_r' sin theta),
///   F_y = m e (Omega_r^2 sin theta - Omega_r' cos theta),   Omega_r = s Omega,
/// i.e. minus the mass times the acceleration of the point at e (cos theta, sin theta).
struct Unbalance {
  std::string disk;
  double me = 0.0;
  double phase = 0.0;
};

/// Shaft section and material of the element between stations k and k + 1.
struct ShaftSection {
  double d_outer = 0.0, d_inner = 0.0;  ///< [m]
  Material material;
};

/// One rotor: stations along z, one shaft element between consecutive stations, rigid disks.
/// One station and no element is a rigid rotor (a disk alone). Rotor damping is Rayleigh on the
/// rotor's own matrices: C_r = alpha M_r + beta K_r.
struct RotorSpec {
  std::string name;
  std::vector<double> z;               ///< station positions [m], strictly increasing
  std::vector<ShaftSection> sections;  ///< z.size() - 1 entries, or 1 (uniform shaft)
  std::vector<Disk> disks;
  std::vector<Unbalance> unbalances;
  double speed_ratio = 1.0;     ///< Omega_r / Omega
  double rayleigh_alpha = 0.0;  ///< [1/s]
  double rayleigh_beta = 0.0;   ///< [s]
};

/// The assembled matrices of one rotor alone (4 DOFs per station, station-major), row-major.
/// G is per unit spin speed of this rotor (not scaled by the speed ratio).
struct RotorMatrices {
  int n = 0;
  std::vector<double> M, K, G, C;
};
/// Assembles one rotor (validates the spec; throws naming the rotor and the bad entry).
RotorMatrices rotor_matrices(const RotorSpec& r);

/// The torsion of one rotor (docs/rampup-theory.md §4.3): one DOF per station, the twist phi [rad]
/// of the section about +z relative to the rigid rotation s int_0^t Omega dt. Shaft element of
/// length L: stiffness G J / L [1 -1; -1 1] (G = E / 2 (1 + nu), J = pi (d_o^4 - d_i^4) / 32) and
/// consistent mass rho J L / 6 [2 1; 1 2]; a disk adds Ip at its station; C = alpha M + beta K
/// (the rotor's Rayleigh damping, on the twist only). n = stations, row-major n x n; G empty.
RotorMatrices torsion_matrices(const RotorSpec& r);

// ------------------------------------------------------------------------------------------
// Stator superelements and their modal bases

/// A superelement as `morse reduce` / `morse select` write it (docs/hdf5-schema.md, /rom):
/// dense n x n K, M (and C if present), the first n_b DOFs physical boundary DOFs labelled by
/// (node id, component 1..6), then fixed-interface modal coordinates. The reader is the io
/// module's (io/superelement.hpp; it throws naming the file and dataset if there is no /rom or the
/// shapes disagree).
using Superelement = io::Superelement;
using io::read_superelement;

/// The modal basis of one superelement under the assembly's boundary conditions: every DOF of
/// the clamped nodes removed, then the eigenpairs of (K, M) of what remains, mass-normalized
/// (phi^T M phi = I), those with frequency <= f_cut_hz kept, ascending. Only the rows of the
/// basis at the free boundary DOFs are kept (the bearings and the outputs need no more).
struct StatorModes {
  std::string name;  ///< source file or label
  int n_modes = 0;   ///< modes kept (seed 000 Table 1's stator modes)
  int n_total = 0;   ///< size of the clamped eigenproblem
  double f_cut_hz = 0.0;
  std::vector<double> omega;           ///< n_modes natural angular frequencies [rad/s]
  std::vector<double> damping;         ///< n_modes modal damping c_i = phi_i^T C phi_i [1/s]
  std::vector<std::int64_t> dof_node;  ///< free boundary DOFs: node id
  std::vector<int> dof_component;      ///< and component
  std::vector<double> phi;             ///< dof_node.size() x n_modes row-major: boundary rows
  double damping_offdiag = 0.0;        ///< ||offdiag(Phi^T C Phi)||_F / ||Phi^T C Phi||_F dropped
  std::vector<std::int64_t> clamped_nodes;
};
/// Computes the clamped, truncated modal basis (dense LAPACK sygv/sygvx via
/// eigen::dense_eigenvalues; O(n^3)). Damping: damping_ratio >= 0 gives c_i = 2 xi omega_i;
/// damping_ratio < 0 takes the diagonal of Phi^T C Phi from the superelement's C (0 without
/// C), and reports the relative size of its dropped off-diagonal part (the stator block is kept
/// diagonal, see integrate()). Throws if a clamped node is not a boundary node, if f_cut_hz <= 0
/// or if M is not positive definite on the free DOFs.
StatorModes stator_modes(const Superelement& se, const std::vector<std::int64_t>& clamped_nodes, double f_cut_hz,
                         double damping_ratio = -1.0);

/// The node ids of `spec` for a superelement file: each entry of the list is either a node id
/// (digits) or the name of a node set of the mesh the superelement was made from
/// (/mesh/node_sets/<NAME>, written by every command that writes /mesh). Ids are returned in
/// the order given, duplicates removed. Throws naming `who` (e.g. the option), the file and the
/// entry if a set is missing (listing the sets the file has).
std::vector<std::int64_t> resolve_nodes(const std::string& file, const std::vector<std::string>& spec,
                                        const std::string& who);

/// The seed's truncation frequency of the stator modal bases (seed 000 §1, §3.3): factor times
/// the top frequency of interest, taken as the top spin speed max_r |s_r| omega_max / 2 pi [Hz].
double default_cut_hz(const std::vector<RotorSpec>& rotors, double omega_max, double factor = 2.5);

// ------------------------------------------------------------------------------------------
// Assembly

/// A bearing: springs and dampers in x and y between station `station` of rotor `rotor` (its u_x,
/// u_y) and the x, y translations (components 1, 2) of the housing point of stator `stator` (an
/// index into the assembly's stators; -1 = the ground), or, for an intershaft bearing
/// (rotor2 >= 0), station `station2` of rotor `rotor2` (then stator must be -1 and nodes empty;
/// the "housing" is that station). Its force on the rotor is -F, on the housing +F:
///   F_x = kxx (u_x,rotor - u_x,housing) + cxx (v_x,rotor - v_x,housing), F_y likewise.
/// The housing point is node `node`, or, if `nodes` is not empty, the mean of the x, y
/// translations of those nodes with equal weights (a bearing seat spread over several interface
/// nodes, as a Nastran RBE3 with equal weights on translations does): each node then carries F /
/// nodes.size(). A node may appear once.
struct Bearing {
  std::string name;
  int rotor = 0, station = 0;
  int stator = -1;
  std::int64_t node = -1;
  double kxx = 0.0, kyy = 0.0, cxx = 0.0, cyy = 0.0;  ///< [N/m], [N s/m], >= 0
  std::vector<std::int64_t> nodes;                    ///< several housing nodes (overrides node)
  int rotor2 = -1, station2 = -1;                     ///< intershaft bearing: the other rotor's station
};

// ------------------------------------------------------------------------------------------
// Torsion: drives, gearboxes and resistive torques (docs/rampup-theory.md §4.3)

/// The imposed speed law acts at station `station` of rotor `rotor`: its absolute angle is
/// s int_0^t Omega dt exactly (twist 0); the torque the drive applies is an output.
struct Drive {
  std::string name;
  int rotor = 0, station = 0;
};
/// A linearized gear stage (a planetary gearbox with its ring fixed, sun on the input shaft,
/// carrier on the output shaft, or any gear train of fixed ratio): the input station turns `ratio`
/// times as fast as the output station (ratio = s_input / s_output, checked against the rotors'
/// speed ratios), and the mesh stiffness k [N m/rad] at the input (the input's torsional stiffness
/// with the output held) and damping c [N m s/rad] act on the twist mismatch: potential
/// (k / 2) (phi_in - ratio phi_out)^2. The mesh torque on the input is -T, on the output
/// +ratio T, T = k (phi_in - ratio phi_out) + c (phi_in' - ratio phi_out'). Its lateral stiffness
/// is not here: give it as an intershaft bearing between the two stations (Bearing::rotor2).
struct Gearbox {
  std::string name;
  int input = 0, input_station = 0, output = 0, output_station = 0;
  double ratio = 1.0, k = 0.0, c = 0.0;
};
/// A resistive torque at a station, aerodynamic: T = -coefficient Omega_r |Omega_r| [N m] about
/// +z, Omega_r = s Omega the rotor's spin speed (it opposes the rotation, in proportion to its
/// square). coefficient [N m s^2] >= 0.
struct Torque {
  std::string name;
  int rotor = 0, station = 0;
  double coefficient = 0.0;
};
/// The torsional model of an assembly. Empty (no drive, gearbox or torque): no torsion is
/// modelled, as before. Otherwise every rotor has a twist DOF per station and every rotor must be
/// driven, directly or through gearboxes (else its rigid rotation would be free).
struct Torsion {
  std::vector<Drive> drives;
  std::vector<Gearbox> gearboxes;
  std::vector<Torque> torques;
  bool empty() const { return drives.empty() && gearboxes.empty() && torques.empty(); }
};

/// Dense assembled matrices of the model (for checks and the frequency-domain solution).
struct AssembledMatrices {
  int n = 0, n_stator = 0;         ///< n = n_stator + rotor DOFs
  std::vector<double> M, C, K, G;  ///< row-major n x n; G per unit driving speed
};

class Assembly {
 public:
  /// Validates and assembles: every rotor (rotor_matrices()), every bearing (rotor, station,
  /// stator index, node: the node must carry free boundary DOFs x and y in that stator's modes;
  /// stiffness and damping >= 0). Keeps copies of everything. Throws naming the bad entry.
  /// The torsional model (drives, gearboxes, torques) is checked here too: every rotor driven
  /// (through gearboxes or directly), gearbox ratios equal to the rotors' speed ratios, stations
  /// in range, k, c, coefficients finite and >= 0. Torsion is uncoupled from the lateral model
  /// (docs/rampup-theory.md §4.3), so it changes no bearing load.
  Assembly(std::vector<RotorSpec> rotors, std::vector<StatorModes> stators, std::vector<Bearing> bearings,
           Torsion torsion = {});

  const std::vector<RotorSpec>& rotors() const { return rotors_; }
  const std::vector<StatorModes>& stators() const { return stators_; }
  const std::vector<Bearing>& bearings() const { return bearings_; }
  int n() const { return n_stator_ + n_rotor_; }
  int n_stator() const { return n_stator_; }  ///< stator modes of all superelements
  int n_rotor() const { return n_rotor_; }
  int stator_offset(int s) const { return stator_offset_[s]; }
  /// Index of DOF `dof` (0..3 = u_x, u_y, theta_x, theta_y) of a rotor station in x.
  int rotor_dof(int rotor, int station, int dof) const { return n_stator_ + rotor_offset_[rotor] + 4 * station + dof; }

  /// Dense M, C, K, G in the coordinates x. Cost O(n^2) memory.
  AssembledMatrices dense() const;

  /// The unbalance forces at driving speed omega, acceleration omega_dot and driving angle
  /// angle = int_0^t Omega dt (added into f, size n()).
  void add_unbalance(double omega, double omega_dot, double angle, double* f) const;

  /// Bearing outputs of a state: per bearing b, F[2b], F[2b+1] = F_x, F_y (as in Bearing), and
  /// the displacements x, y of the rotor station and of the stator node (0 for the ground).
  /// Any pointer may be null.
  void bearing_state(const double* x, const double* v, double* force, double* rotor_disp, double* stator_disp) const;

  /// Structured operator y = (cM M + cD (C + omega G) + cK K) x, without forming the matrices:
  /// O(n_stator + rotor DOFs x bandwidth + bearings x stator modes).
  void apply(double cM, double cD, double cK, double omega, const double* x, double* y) const;

  /// v^T M v / 2 + x^T K x / 2.
  double energy(const double* x, const double* v) const;

  // Torsion (empty when torsion().empty()): twist DOFs, one per station of every rotor in order.
  const Torsion& torsion() const { return torsion_; }
  int n_torsion() const { return n_twist_; }
  /// Index of the twist DOF of a rotor station.
  int twist_dof(int rotor, int station) const { return twist_offset_[rotor] + station; }
  /// Dense torsional matrices (n_torsion()^2, row-major): shafts, disks, gear meshes; no drive
  /// condition applied.
  const std::vector<double>& torsion_M() const { return tM_; }
  const std::vector<double>& torsion_C() const { return tC_; }
  const std::vector<double>& torsion_K() const { return tK_; }
  /// Twist DOFs held by the drives (ascending) and the free ones.
  const std::vector<int>& driven_twists() const { return driven_; }
  const std::vector<int>& free_twists() const { return free_; }
  /// Torsional load at driving speed omega and acceleration omega_dot (n_torsion()):
  /// the resistive torques minus M (s Omega') (the inertia of the imposed rigid rotation,
  /// s the speed ratio of each DOF's rotor).
  void torsion_load(double omega, double omega_dot, double* f) const;
  /// Torques of a torsional state (twist, its rate and acceleration): per drive the torque it
  /// applies [N m] (the residual of its held DOF's equation), per gearbox its mesh torque T.
  /// Either output may be null.
  void torsion_state(const double* phi, const double* dphi, const double* ddphi, double omega, double omega_dot,
                     double* drive_torque, double* gearbox_torque) const;
  /// Natural angular frequencies [rad/s] of the torsion with the drives held (ascending; the
  /// undamped problem on the free twists). Empty without torsion.
  std::vector<double> torsion_frequencies() const;

  // Internal data used by the integrator (documented in docs/rampup-theory.md §4).
  struct Coupling {          // one bearing direction
    int rotor_index = 0;     // into the rotor block (0..n_rotor - 1)
    int rotor_index2 = -1;   // intershaft: the other rotor DOF (its k, c are in the band matrices)
    int stator_offset = -1;  // first modal coordinate of the stator, -1 = ground or intershaft
    int n_modes = 0;
    std::vector<double> phi;  // row of the stator's basis at the bearing DOF (n_modes)
    double k = 0.0, c = 0.0;
  };
  const std::vector<Coupling>& couplings() const { return couplings_; }
  int rotor_bandwidth() const { return bw_; }
  /// Rotor block in band storage: (2 bw + 1) x n_rotor, element (i, j) at [(bw + i - j) + (2 bw +
  /// 1) j].
  const std::vector<double>& band_M() const { return bM_; }
  const std::vector<double>& band_C() const { return bC_; }
  const std::vector<double>& band_K() const { return bK_; }
  const std::vector<double>& band_G() const { return bG_; }          ///< speed ratios included
  const std::vector<double>& stator_omega2() const { return om2_; }  ///< n_stator
  const std::vector<double>& stator_damping() const { return cs_; }  ///< n_stator

 private:
  std::vector<RotorSpec> rotors_;
  std::vector<StatorModes> stators_;
  std::vector<Bearing> bearings_;
  int n_stator_ = 0, n_rotor_ = 0, bw_ = 0;
  std::vector<int> stator_offset_, rotor_offset_;
  std::vector<double> bM_, bC_, bK_, bG_, om2_, cs_;
  std::vector<Coupling> couplings_;
  Torsion torsion_;
  int n_twist_ = 0;
  std::vector<int> twist_offset_, twist_rotor_, driven_, free_;
  std::vector<double> tM_, tC_, tK_;
  std::vector<double> tMs_;  // M_t s: the torsional inertia of the rigid rotation, per unit Theta''
  void build_torsion();
  struct Force {
    int dof_x;
    double ratio, me, phase;
  };
  std::vector<Force> unbalance_;
};

/// Free whirl of the assembly at driving speed omega: the finite eigenvalues lambda of
/// (lambda^2 M + lambda (C + omega G) + K) x = 0 (LAPACK dggev on the first-order pencil, so a
/// singular M, e.g. a massless shaft, is allowed), sorted by ascending |Im|; only those with
/// Im >= 0 are returned (the others are their conjugates). Im lambda is the whirl frequency
/// [rad/s]. O(n^3) on 2n: for checks and Campbell diagrams of small models.
std::vector<std::complex<double>> whirl_eigenvalues(const Assembly& a, double omega);

/// Steady-state unbalance response at constant driving speed omega to the unbalances of rotor
/// `rotor`: x(t) = Re(X exp(i s omega t)) with s its speed ratio, by a dense solve of
/// (K - w^2 M + i w (C + omega G)) X = F, w = s omega (the frequency-domain solution of the same
/// assembled system). O(n^3).
std::vector<std::complex<double>> unbalance_response(const Assembly& a, double omega, int rotor);

// ------------------------------------------------------------------------------------------
// Load case and time integration

/// Driving speed law: Ramp: Omega(t) = omega_max t / ramp_time for t < ramp_time, then
/// omega_max; Constant: omega_max from t = 0 (for checks).
struct LoadCase {
  enum class Kind { Ramp, Constant } kind = Kind::Ramp;
  double omega_max = 0.0;  ///< [rad/s] driving speed
  double ramp_time = 0.0;  ///< [s]
  double speed(double t) const;
  double acceleration(double t) const;
  double angle(double t) const;  ///< int_0^t Omega dt
};

/// Time scheme: HHT-alpha with alpha in [-1/3, 0] (gamma = 1/2 - alpha, beta = (1 - alpha)^2 / 4;
/// alpha = 0 is Newmark average acceleration, energy conserving for the undamped, unforced
/// system even with the gyroscopic term).
struct IntegratorSettings {
  double dt = 0.0;       ///< fixed step [s]
  double t_final = 0.0;  ///< 0: the ramp time
  double alpha = 0.0;
  int output_every = 1;        ///< callback after every k-th step (and the initial state)
  bool dense = false;          ///< LU of the dense n x n effective matrix every step (reference, O(n^3))
  std::vector<double> x0, v0;  ///< initial state (empty: zero)
};

/// The end of the run: t_final, or the ramp time if t_final is 0.
inline double end_time(const LoadCase& load, const IntegratorSettings& s) {
  return s.t_final > 0.0 ? s.t_final : load.ramp_time;
}

/// What the callback sees after a step. Pointers are valid during the callback only.
struct StepOutput {
  long step = 0;
  double t = 0.0, speed = 0.0;
  const double* drive_torque = nullptr;    ///< one per drive [N m] (null without torsion)
  const double* gearbox_torque = nullptr;  ///< one per gearbox [N m] (null without torsion)
  const double* x = nullptr;               ///< n
  const double* v = nullptr;               ///< n
  const double* force = nullptr;           ///< 2 per bearing: F_x, F_y [N]
  const double* rotor_disp = nullptr;      ///< 2 per bearing [m]
  const double* stator_disp = nullptr;     ///< 2 per bearing [m]
};

struct IntegratorStats {
  long steps = 0;
  double seconds = 0.0;               ///< time loop (callbacks included)
  std::vector<std::string> warnings;  ///< e.g. a step too coarse for the top spin speed
};

/// Integrates M x'' + (C + Omega(t) G) x' + K x = f_unbalance(t) from the initial state to
/// t_final with step dt. Each step solves the effective system
///   [a0 M + (1 + alpha)(a1 (C + Omega_{n+1} G) + K)] x_{n+1} = rhs
/// by static condensation of the stator modal block (diagonal plus bearing couplings, constant)
/// onto the bearing DOFs and a banded LU of the rotor block at the current speed: cost per step
/// O(N m + R b^2 + R m b + m^3) for N stator modes, m = 2 x bearings, R rotor DOFs, b rotor
/// bandwidth, i.e. linear in N (docs/rampup-theory.md §5 has the derivation and the
/// measurements). Throws if dt <= 0, alpha is outside [-1/3, 0], the initial mass matrix is
/// singular, or the state becomes non-finite (naming the time). Warns (stats.warnings) if dt
/// gives fewer than 20 steps per revolution at the top spin speed. With torsion, the twist of the
/// free stations is integrated beside it by the same scheme (its effective matrix is constant:
/// one LU), loaded by torsion_load(), and the drive and gearbox torques are passed to the
/// callback. Serial; not collective.
IntegratorStats integrate(const Assembly& a, const LoadCase& load, const IntegratorSettings& s,
                          const std::function<void(const StepOutput&)>& callback);

/// The time histories of a ramp-up (the outputs of `morse rampup`, docs/hdf5-schema.md /rampup):
/// every output step (IntegratorSettings::output_every, the initial state included), per
/// bearing b its F_x, F_y and the x, y displacements of the rotor station and of the housing.
struct History {
  std::vector<double> t, omega;                        ///< n_out: time [s], driving speed [rad/s]
  std::vector<double> force, rotor_disp, stator_disp;  ///< n_out x bearings x 2, row-major
  int n_bearings = 0;
  std::vector<double> drive_torque, gearbox_torque;  ///< n_out x drives, n_out x gearboxes (torsion)
  int n_drives = 0, n_gearboxes = 0;
  std::size_t n_out() const { return t.size(); }
};
/// Integrates (integrate()) and records the history. `progress`, if given, is called after every
/// output step with the fraction of the run done (for a progress line). Serial; not collective.
History record(const Assembly& a, const LoadCase& load, const IntegratorSettings& s, IntegratorStats* stats,
               const std::function<void(double)>& progress = nullptr);

/// Seed 000 eq. 24: the maximum over the run of |x - x_ref| / (max x_ref - min x_ref), for one
/// feature sampled n times with the given stride (x[i * stride], x_ref[i * stride]). Returns 0 if
/// both histories are identical, +inf if x_ref is constant and x differs. Throws if n == 0.
double feature_error(const double* x, const double* x_ref, std::size_t n, std::size_t stride);

/// Writes the history as <group>/time, omega, bearing_force, rotor_displacement,
/// stator_displacement (docs/hdf5-schema.md); reads it back (throws naming the file and dataset).
void write_history(io::H5Output& out, const std::string& group, const History& h);
History read_history(const std::string& file, const std::string& group = "/rampup");

/// Seed 000 Table 1's error columns: eq. 24 for each load feature (F_x, F_y of each bearing,
/// in bearing order) and each displacement feature (x, y of the rotor at each bearing), and
/// their worst, best and mean. Throws unless both histories have the same bearings and the same
/// output times (same dt and output interval).
///
/// Beside eq. 24 (each feature against its own range), the same deviations against the largest
/// range of any bearing (force_global, displacement_global: max |x - x_ref| / max over every
/// bearing and direction of (max x_ref - min x_ref)), so that a lightly loaded bearing, whose own
/// range is tiny, cannot set the verdict alone; *_scale is that largest range, *_dominant the
/// feature (2 bearing + direction) of the worst eq. 24 error.
struct HistoryErrors {
  std::vector<double> force, displacement;  ///< 2 per bearing
  double force_worst = 0, force_best = 0, force_mean = 0;
  double displacement_worst = 0, displacement_best = 0, displacement_mean = 0;
  std::vector<double> force_global, displacement_global;  ///< 2 per bearing
  double force_global_worst = 0, force_global_mean = 0;
  double displacement_global_worst = 0, displacement_global_mean = 0;
  double force_scale = 0, displacement_scale = 0;
  int force_dominant = -1, displacement_dominant = -1;
};
HistoryErrors compare(const History& h, const History& ref);

/// Writes <group>/error (docs/hdf5-schema.md): the errors per bearing and direction
/// (bearing_force, displacement, [n_bearings][2]) and their worst, best and mean as attributes,
/// with the reference file's name. Rank 0 data; not collective.
void write_errors(io::H5Output& out, const std::string& group, const HistoryErrors& he, const std::string& reference);

/// Writes <group>/stators/<name> of a stator superelement: the frequencies [Hz] of its kept modes,
/// its clamped nodes, and as attributes its file, mode counts, boundary DOFs (n_boundary_dofs),
/// cut-off and the dropped off-diagonal damping. Rank 0 data; not collective.
void write_stator(io::H5Output& out, const std::string& group, const StatorModes& sm, const std::string& file,
                  std::int64_t n_boundary_dofs);

/// Writes <group>/matrices: the dense M, C, K, G of the assembly (AssembledMatrices). Rank 0 data;
/// not collective.
void write_matrices(io::H5Output& out, const std::string& group, const AssembledMatrices& A);

/// Seed 000 §3.3's score S = S1 + S2 out of 20: S1 = 10 - eps_mean [%] if eps_mean < 10 %, else
/// 0 (error_mean is a fraction); S2 = 10 (1 - t / t_ref) if t < t_ref, else 0. (The seed's
/// printed rule for S2 reads "10 t / t_ref"; every row of its Table 1 fits 10 (1 - t / t_ref).)
double score(double error_mean, double t, double t_ref);

}  // namespace morse::rampup
