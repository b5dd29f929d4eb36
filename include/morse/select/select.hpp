// morse/select/select.hpp: ranking and selection of fixed-interface modes (seed 000 §2.2–2.3).
//
// Notation (seed 000): boundary (master) DOFs m = b, interior (slave) DOFs s = i, fixed-interface
// modes phi_i with eigenvalue lambda_i = omega_i^2, constraint modes Psi. Per mode i, three
// interface vectors (length n_b) carry everything the a-priori methods need:
//   a_i = M_sm^T phi_i   (interior-boundary mass coupling)
//   c_i = K_sm^T phi_i   (interior-boundary stiffness coupling)
//   g_i = Psi^T M_ss phi_i (LPF participation factor L_mi, eq. 9)
// and P_i = -(a_i + g_i) is row i of Kammer's participation matrix P (eq. 10).
// They are computed from the distributed basis (a sparse x dense product with n_b columns and
// one local product per rank, summed), so no rank holds Phi whole.
//
// Scalar scores (docs/select/*.md gives the derivations):
//   LPF    tr(L_mi L_mi^T) = |g_i|^2                       (a mass; comparable with EIM)
//   EIM    tr(P_i^T P_i)  = |P_i|^2                         (eq. 11–12)
//   VEIM   |P_i|^2 / lambda_i,  DEIM |P_i|^2 / lambda_i^2   (eq. 13–14)
//   OMR    tr(lambda_i a a^T - a c^T - c a^T + c c^T / lambda_i)   (eq. 15, "omega_i" = lambda_i)
//   CMSchi tr((M_sm + M_ss Psi)^T phi phi^T (M_sm + M_ss Psi)) / lambda_i  (eq. 16, sign
//          consistent with eq. 10 and 17)
//   EBR    mean energy of mode i under a periodic boundary force (eq. 18–20)
//   IMR    contribution of mode i to chosen modes of the full system (eq. 21–22)
// Unnormalized, these satisfy eq. 17 exactly: EIM = lambda VEIM = lambda^2 DEIM = lambda CMSchi
// = OMR / lambda. Fractions are scores divided by their sum over the candidate modes.
#pragma once

#include <complex>
#include <string>
#include <vector>

#include "morse/cb/craig_bampton.hpp"
#include "morse/io/h5.hpp"

namespace morse::select {

enum class Method { Frequency, LPF, EIM, VEIM, DEIM, OMR, CMSChi, EBR, IMR };

/// Parses frequency lpf eim veim deim omr cmschi ebr imr; false if unknown.
bool parse_method(const std::string& name, Method* m);

/// Per-mode interface vectors, each n_phi x n_b row-major, identical on every rank.
struct InterfaceCoupling {
  PetscInt n_b = 0, n_phi = 0;
  std::vector<double> lambda;  ///< omega_i^2 of the fixed-interface modes
  std::vector<double> a, c, g;
  /// Kammer's P (eq. 10), n_phi x n_b.
  std::vector<double> P() const;
};

/// Computes a, c, g from the Craig–Bampton result (which must keep its basis T) and the
/// model's K and M. Collective.
InterfaceCoupling interface_coupling(MPI_Comm comm, Mat K, Mat M, const cb::CBResult& cb);

/// Periodic boundary excitation for EBR (eq. 18): harmonic k has angular frequency omega_k and
/// a complex force amplitude on the boundary DOFs. With all_components, each boundary DOF is
/// loaded alone (unit amplitude) at each frequency: the seed's "force containing all possible
/// components" when nothing is known. Otherwise harmonic k is load[k] (n_b complex amplitudes,
/// f(t) = Re(f e^{i omega t}), per DOF amplitude and phase), or, when load is empty, amplitude[k]
/// with phase_deg[k] on every boundary DOF.
struct Excitation {
  std::vector<double> freq_hz;
  std::vector<double> amplitude;                        ///< per harmonic, applied to every boundary DOF (load empty)
  std::vector<double> phase_deg;                        ///< per harmonic (load empty)
  std::vector<std::vector<std::complex<double>>> load;  ///< per harmonic, n_b values, or empty
  bool all_components = true;
};

/// Reads a per-DOF EBR load table (-select_ebr_load): one line per loaded DOF,
///   freq_hz  node_id  component  amplitude  [phase_deg]
/// with component x|y|z or 1|2|3; lines with the same frequency form one harmonic; '#' starts a
/// comment. The node must belong to the boundary set. Rank 0 reads; errors name the file and
/// line. Collective (identical result on every rank).
Excitation read_ebr_load(MPI_Comm comm, const std::string& path, const cb::CBResult& cb);

/// Full-system modes for IMR: their eigenvalues and the projections on the fixed-interface
/// modes. X1 = Phi^T M_sb v_b, X2 = Phi^T M_ss v_s (n_phi x n_zeta), vb = boundary part of each
/// mode (n_zeta x n_b), all on every rank.
struct ImrData {
  std::vector<double> lambda;
  std::vector<double> X1, X2, vb;
  bool clamped = false;                 ///< the system modes are the fixed-interface modes themselves
  std::vector<PetscInt> clamped_modes;  ///< with clamped: the chosen fixed-interface modes
  double shift = 0.01;                  ///< omega_f = (1 + shift) omega_zeta
};

/// Score of every candidate mode (length n_phi, >= 0). cb.M / cb.K are the full Craig–Bampton
/// operators (for EBR, whose harmonics are spread over the ranks of comm). Frequency returns
/// the EIM scores (the cumulative curve of frequency order is drawn with them, as in seed 000
/// Fig. 3). Collective (identical result on every rank). Throws for EBR without excitation or
/// an excitation frequency at a resonance of the superelement, and for IMR without data.
std::vector<double> scores(MPI_Comm comm, Method m, const InterfaceCoupling& ic, const cb::CBResult& cb,
                           const Excitation& ex, const ImrData* imr);

/// Ranking and truncation.
struct Selection {
  std::vector<PetscInt> ranking;   ///< candidate indices, best first
  std::vector<double> cumulative;  ///< cumulative fraction of the total score along ranking
  std::vector<PetscInt> selected;  ///< kept candidates, ascending (i.e. by frequency)
  double retained = 0;             ///< fraction of the total score kept
};

/// Ranks by decreasing score (Frequency: by ascending frequency) and keeps the first `count`
/// (if count >= 0) or the shortest prefix reaching `fraction` of the total score.
Selection truncate(Method m, const std::vector<double>& score, PetscInt count, double fraction);

/// Modal effective-mass fractions of each mode for a rigid translation of the whole interface in
/// direction d: (P_i r_d)^2 / total_mass, n_phi x 3 row-major.
std::vector<double> directional_mass_fractions(const InterfaceCoupling& ic, double total_mass);

/// IMR data from system modes V (MPIDENSE over the free DOFs, columns `modes` used, with
/// eigenvalues lambda). Collective.
ImrData imr_data(MPI_Comm comm, Mat M, const cb::CBResult& cb, Mat V, const std::vector<double>& lambda,
                 const std::vector<PetscInt>& modes, double shift);

/// Projections needed by the MAC of superelement modes against full-model modes V, computed
/// once per run with BLAS-3 products on the local rows: V^T T, (M V)^T T, T^T T, v^T v and
/// v^T M v, all on every rank. Collective.
struct MacBasis {
  PetscInt n_v = 0, n_r = 0;
  std::vector<double> VT, WT, TT;  ///< n_v x n_r, n_v x n_r, n_r x n_r, row-major
  std::vector<double> vv, vmv;     ///< n_v
};
MacBasis mac_basis(MPI_Comm comm, Mat V, Mat MV, Mat T);

/// MAC between the full-model modes and the expanded superelement modes u_k = T q_k, where Q is
/// n_r x n_q row-major (rows of unselected modes are zero). Plain: seed 000 eq. 23 in its
/// standard form |v^T u|^2 / (v^T v u^T u). Mass-weighted: (v^T M u)^2 / (v^T M v u^T M u) with
/// u^T M u = q^T M_CB q; it sums to the squared projection over a set of M-orthonormal modes,
/// so it measures how well a cluster of near-repeated modes is represented. Returns n_v x n_q
/// row-major. Not collective.
std::vector<double> mac_matrix(const MacBasis& b, const std::vector<double>& Q, PetscInt n_q,
                               const std::vector<double>* M_cb = nullptr);

/// The superelement restricted to the boundary DOFs and the selected modes (rows/columns of
/// the full Craig–Bampton operators), row-major. Not collective.
std::vector<double> restrict_operator(const std::vector<double>& A, PetscInt n_b, PetscInt n,
                                      const std::vector<PetscInt>& selected);

// ------------------------------------------------------------------------------------------
// The whole selection and its check against the full model (what `morse select` does between
// building the candidate superelement and writing): for each method its scores, ranking and
// truncation, then the restricted superelement's modes in the analysis band compared with the
// full model's by MAC (pairwise, and mass-weighted over the band's modal space for clusters of
// near-repeated modes).

struct VerifySettings {
  std::vector<Method> methods;     ///< the ranking methods, in order (distinct)
  std::vector<std::string> names;  ///< their names (stage names and results), same order
  PetscInt num_modes = -1;         ///< keep this many modes (truncate count); -1: by fraction
  double fraction = 0.95;          ///< keep up to this cumulative score fraction (num_modes < 0)
  double fmax_analysis_hz = 0;     ///< the analysis cutoff [Hz] (superelement modes in band, MAC)
  PetscInt fom_modes = -1;         ///< full-model modes for the MAC (> 0), else all below the cutoff
  double mac_threshold = 0.98;     ///< MAC above which a full-model mode counts as matched
  /// The check against the full model (-select_check): its modes and the MAC of every method's
  /// superelement. false skips both (the full model's eigen solve is the costliest part of select
  /// on a large mesh); the ranking, truncation and superelements are the same. IMR on the free
  /// system still solves the full model's modes it needs.
  bool check = true;
  /// EBR excitation: a load table file (read_ebr_load), or harmonics on every boundary DOF
  /// (ebr_given: ebr_freq, with ebr_amp (default 1) and ebr_phase [deg] (default 0)), or every
  /// boundary DOF loaded alone at 8 frequencies across the analysis band.
  std::string ebr_load;
  bool ebr_given = false;  ///< use ebr_freq, ebr_amp, ebr_phase (any of them given)
  std::vector<double> ebr_freq, ebr_amp, ebr_phase;
  /// IMR (if methods has it): full-system modes with the interface free, on springs of
  /// imr_stiffness on every boundary DOF ("spring"), or the fixed-interface modes ("clamped");
  /// imr_modes the modes of interest (1-based; empty: all below the cutoff); imr_shift the relative
  /// frequency shift of the fictitious force.
  std::string imr_support = "free";
  double imr_stiffness = -1;
  std::vector<PetscInt> imr_modes;
  double imr_shift = 0.01;
};

/// The options of `morse select`: the verification settings and what the command does with them.
struct Settings {
  VerifySettings verify;   ///< methods, names, num_modes, fraction, fom_modes, mac_threshold, ebr_*, imr_*;
                           ///< fmax_analysis_hz: -select_fmax_analysis as given (-1: not given)
  std::string from;        ///< -select_from: a `morse reduce -cb_write_basis` file (empty: compute the modes)
  std::string rom_method;  ///< the method whose superelement is written to /rom (default: the first)
  std::string error;       ///< a bad option value, naming the option (raised after -help)

  /// Reads -select_from, -select_method (default eim), -select_num_modes, -select_fraction
  /// (default 0.95 without -select_num_modes), -select_fmax_analysis, -select_fom_modes,
  /// -select_mac_threshold, -select_rom_method, -select_ebr_freq/_amp/_phase, -select_ebr_load,
  /// -select_imr_support free|spring|clamped, -select_imr_support_stiffness, -select_imr_modes
  /// and -select_imr_shift. Records in `error`: an unknown or repeated method, both
  /// -select_num_modes and -select_fraction, a negative count, a fraction outside (0, 1], both
  /// EBR forms, a bad IMR support or a spring without stiffness, a -select_rom_method not among
  /// the methods. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
};

/// One method's selection and check.
struct MethodCheck {
  std::string name;
  std::vector<double> score;  ///< per candidate mode
  Selection sel;
  std::vector<double> rom_f;      ///< frequencies [Hz] of the restricted superelement, ascending
  PetscInt in_band = 0;           ///< of them below the cutoff
  PetscInt matches = 0;           ///< full-model modes with best pairwise MAC above the threshold
  PetscInt subspace_matches = 0;  ///< full-model modes with subspace MAC above the threshold
  double worst_err = 0;           ///< largest relative frequency error of a matched pair
  std::vector<double> mac;        ///< [full-model mode][in-band superelement mode] (n_fom x max(in_band, 1))
  std::vector<double> best_mac, subspace_mac;  ///< per full-model mode
  std::vector<double> M, K;                    ///< the restricted superelement (restrict_operator), row-major
};

struct VerifyResult {
  double fmax_analysis_hz = 0;
  InterfaceCoupling ic;
  Excitation excitation;
  std::vector<double> fom_omega2;     ///< the full-model eigenvalues of the MAC reference, ascending (none unchecked)
  bool checked = true;                ///< VerifySettings::check
  std::vector<MethodCheck> methods;   ///< same order as the settings' methods
  PetscInt cb_in_band = 0;            ///< superelement modes in band with every candidate (plain Craig-Bampton)
  std::vector<double> eim_fractions;  ///< EIM score of each candidate over their sum (effective mass)
};

/// Ranks and truncates the candidate modes of cb (built with keep_basis) by every method of s and
/// checks each restricted superelement against the full model (K, M: the model's free-DOF
/// operators; w: the sign reference of its modes, as cb::sign_reference, or null). Eigen solves
/// read the options of prefixes select_fom_ (full model) and select_imr_ (spring-supported system).
/// Throws (collectively) on an IMR mode out of range. Collective.
VerifyResult verify(MPI_Comm comm, Mat K, Mat M, const cb::CBResult& cb, Vec w, const VerifySettings& s);

/// Writes /select (docs/hdf5-schema.md): the full-model frequencies, the analysis cutoff, the MAC
/// threshold, the effective-mass fractions (directional, of a model of total mass total_mass, and
/// the EIM trace fractions), and per method /select/<name> (scores, ranking, selection, the
/// restricted superelement's frequencies and the MAC check). Rank 0 data; not collective.
void write_selection(io::H5Output& out, const VerifyResult& v, double mac_threshold, double total_mass);

}  // namespace morse::select
