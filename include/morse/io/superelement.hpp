// morse/io/superelement.hpp: the superelement files of `morse reduce` / `morse select` (/rom,
// docs/hdf5-schema.md): written (write_superelement) and read back (read_superelement). Their
// exports to MBDyn, Nastran and MatrixMarket are in io/export.hpp.
//
// Reading is serial: call it on one rank (the commands run it on rank 0); it uses serial HDF5
// (io::read_doubles and friends). Writing goes through the run's io::H5Output (rank 0 data).
//
// The coordinates of a superelement are ordered as in /rom: the n_b boundary DOFs first (labelled
// by node id and component 1..6: 1..3 the x, y, z translations in the basic system, 4..6
// rotations, matrix input only), then the n - n_b fixed-interface modal coordinates by ascending
// frequency. In the Craig-Bampton basis T = [Psi Phi] (seed 000 eq. 5), a boundary DOF's column
// is its constraint mode: a unit displacement of that DOF, zero at the other boundary DOFs, and
// the fixed-interface modes are zero at every boundary DOF. This is what the exports use to write
// mode shapes at the interface nodes exactly, without the basis.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace morse::io {

/// A Craig-Bampton superelement as read from a morse HDF5 file.
struct Superelement {
  std::string source;                        ///< the file (for messages and provenance comments)
  std::string units = "unknown";             ///< /meta/units ("unknown" if absent)
  std::string command;                       ///< /meta/command (reduce, select), empty if absent
  std::string selection_method;              ///< /rom@selection_method (select files), empty otherwise
  int n = 0;                                 ///< reduced size n = n_b + n_modes
  int n_b = 0;                               ///< boundary DOFs
  std::vector<double> K, M, C;               ///< row-major n x n; C empty if the file has no /rom/C
  std::vector<std::int64_t> dof_node;        ///< n_b: node id of each boundary DOF
  std::vector<int> dof_component;            ///< n_b: its component 1..6
  std::vector<std::int64_t> boundary_nodes;  ///< ascending, unique (/rom/boundary_nodes)
  /// Coordinates of boundary_nodes (3 per node, same order): from /mesh (mesh input) or
  /// set_boundary_coordinates(); empty if unknown (matrix input).
  std::vector<double> boundary_xyz;
  bool from_mesh = false;  ///< the file has /mesh (mesh input)
  /// Matrix input only (/dofs): node id and component of every free row of the original model,
  /// used to tell a clamped component from an interior one at a boundary node.
  std::vector<std::int64_t> model_dof_node;
  std::vector<int> model_dof_component;
  /// Every node id the file names (/mesh/node_ids or /dofs/node), sorted and unique; empty if it
  /// has neither. Used to keep SPOINT ids clear of them.
  std::vector<std::int64_t> model_node_ids;
  /// /rom/frequencies_hz: the n frequencies of the superelement (K_CB, M_CB) [Hz], ascending;
  /// empty if the file has none.
  std::vector<double> frequencies_hz;
  double damping_ratio = 0;  ///< /rom@damping_ratio (0 if absent)
  /// /rom/selected_modes (select files): the fixed-interface mode (0-based, of
  /// /cb/fixed_interface) of each modal coordinate; empty otherwise.
  std::vector<std::int64_t> selected_modes;

  int n_modes() const { return n - n_b; }
  /// Frequency [Hz] of modal coordinate k (0-based, k < n_modes()): sqrt(K_jj / M_jj) / 2 pi of
  /// its diagonal entry j = n_b + k (the fixed-interface block of K_CB, M_CB is diagonal).
  double modal_frequency_hz(int k) const;
};

/// Reads /rom/K, /rom/M, /rom/C (optional), /rom/boundary_dofs, /rom/boundary_nodes (derived from
/// boundary_dofs if absent), /meta/units, /meta/command, /rom@selection_method, and the boundary
/// node coordinates from /mesh/node_ids + /mesh/coordinates when the file has /mesh (/dofs/node +
/// /dofs/component otherwise). Throws morse::Error naming the file and the dataset if the file is
/// missing or not HDF5, has no /rom, or if shapes disagree (K not square, M or C not the size of
/// K, boundary_dofs not [n_b][2] with n_b <= n, a component outside 1..6 or a (node, component)
/// pair given twice, boundary_nodes not the nodes of boundary_dofs, a boundary node missing from
/// /mesh, a non-finite matrix entry). Serial.
Superelement read_superelement(const std::string& file);

class H5Output;
/// Writes /rom (docs/hdf5-schema.md) from se: /rom/M, /rom/K, /rom/C (if se.C is not empty),
/// /rom/boundary_nodes, /rom/boundary_dofs (se.dof_node, se.dof_component), /rom/frequencies_hz,
/// the attributes n_boundary_dofs, n_modes, damping_ratio and dof_order, and for a select file
/// (se.selection_method not empty) /rom/selected_modes and /rom@selection_method. se.source,
/// units, command and the model and coordinate fields are not written (/meta, /mesh and /dofs
/// are the command's). The data is significant on rank 0 (H5Output); not collective.
/// read_superelement(out.path()) reads back what is written here.
void write_superelement(H5Output& out, const Superelement& se);

/// Writes the candidate fixed-interface modes of a Craig-Bampton superelement (reduce, select):
/// /cb/fixed_interface/frequencies_hz and /cb/fixed_interface/eigenvalues (omega2, ascending).
/// Rank 0 data; not collective.
void write_fixed_interface(H5Output& out, const std::vector<double>& omega2);

/// Reads boundary node coordinates from a text file (one `node x y z` per line, '#' starts a
/// comment; other nodes are ignored) into se->boundary_xyz, replacing those of /mesh. Throws
/// naming the file and line for a malformed line or a node given twice, and naming the node if a
/// boundary node is missing. Serial.
void set_boundary_coordinates(Superelement* se, const std::string& path);

/// Mode shapes at every mesh node, from a file of `morse reduce -cb_write_basis`: the columns of
/// the Craig-Bampton basis in /rom order (/cb/constraint_modes, then the fixed-interface shapes of
/// /cb/fixed_interface/mode_shapes, those of /rom/selected_modes for a select file).
struct NodalShapes {
  std::vector<std::int64_t> node_ids;  ///< /mesh/node_ids
  std::vector<double> xyz;             ///< 3 per node
  std::vector<double> shapes;          ///< [column][node][x,y,z], n columns
};
/// Reads the basis of se.source (the whole datasets are held in memory: 24 n n_nodes bytes).
/// Throws naming the file and dataset if the file has no basis or its shapes disagree with /rom.
NodalShapes read_nodal_shapes(const Superelement& se);

/// Rigid-body inertia of a superelement from its reduced mass matrix. The six rigid-body motions
/// (translations, and rotations about the origin of the basic system) are written in the
/// superelement's coordinates: r_b at the boundary DOFs (unit translation, or theta x x_node for
/// a rotation, theta at rotation DOFs), 0 at the modal coordinates. This is exact when the
/// superelement can move rigidly (no DOF clamped besides the interface): then the constraint
/// modes reproduce rigid motion in the interior (Psi r_b = r_i, since K r = 0), the modal
/// coordinates of rigid motion vanish, and R^T M_CB R is the rigid-body mass matrix of the full
/// model (the Guyan mass is exact for rigid motion). K_CB R = 0 checks it.
struct RigidBodyInertia {
  bool valid = false;                      ///< the superelement can move rigidly (stiffness_residual small)
  std::string reason;                      ///< why not, if !valid
  double stiffness_residual = 0;           ///< max_k ||K_CB r_k|| / (||K_CB||_F ||r_k||) over the 6 motions
  double mass = 0;                         ///< total mass
  std::array<double, 3> center{};          ///< centre of mass
  std::array<double, 9> inertia_cm{};      ///< inertia tensor about the centre of mass, row-major
  std::array<double, 9> inertia_origin{};  ///< about the origin of the basic system
  std::array<double, 36> rigid_mass{};     ///< R^T M_CB R (6 x 6, row-major; about the origin)
};
/// Needs se.boundary_xyz (throws naming the file otherwise). A superelement that cannot move
/// rigidly (K_CB R != 0, e.g. clamped besides the interface) gives valid = false with the
/// reason; it is not an error. Serial.
RigidBodyInertia rigid_body_inertia(const Superelement& se);

}  // namespace morse::io
