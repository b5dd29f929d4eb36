// morse/io/superelement.hpp: the superelement files of `morse reduce` / `morse select` (/rom,
// docs/hdf5-schema.md) read back, and exported to the codes that use superelements: MBDyn's modal
// joint (.fem), Nastran (OUTPUT4 and a DMIG bulk-data deck) and MatrixMarket (docs/export.md).
//
// Everything here is serial: call it on one rank (the command runs it on rank 0). Reading uses
// serial HDF5 (io::read_doubles and friends); every writer writes "<path>.tmp" and renames it to
// <path> when complete, so a failed write leaves no partial file.
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
  std::string source;                  ///< the file (for messages and provenance comments)
  std::string units = "unknown";       ///< /meta/units ("unknown" if absent)
  std::string command;                 ///< /meta/command (reduce, select), empty if absent
  std::string selection_method;        ///< /rom@selection_method (select files), empty otherwise
  int n = 0;                           ///< reduced size n = n_b + n_modes
  int n_b = 0;                         ///< boundary DOFs
  std::vector<double> K, M, C;         ///< row-major n x n; C empty if the file has no /rom/C
  std::vector<std::int64_t> dof_node;  ///< n_b: node id of each boundary DOF
  std::vector<int> dof_component;      ///< n_b: its component 1..6
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
  bool valid = false;              ///< the superelement can move rigidly (stiffness_residual small)
  std::string reason;              ///< why not, if !valid
  double stiffness_residual = 0;   ///< max_k ||K_CB r_k|| / (||K_CB||_F ||r_k||) over the 6 motions
  double mass = 0;                 ///< total mass
  std::array<double, 3> center{};  ///< centre of mass
  std::array<double, 9> inertia_cm{};      ///< inertia tensor about the centre of mass, row-major
  std::array<double, 9> inertia_origin{};  ///< about the origin of the basic system
  std::array<double, 36> rigid_mass{};     ///< R^T M_CB R (6 x 6, row-major; about the origin)
};
/// Needs se.boundary_xyz (throws naming the file otherwise). A superelement that cannot move
/// rigidly (K_CB R != 0, e.g. clamped besides the interface) gives valid = false with the
/// reason; it is not an error. Serial.
RigidBodyInertia rigid_body_inertia(const Superelement& se);

// ---------------------------------------------------------------------------------------------
// Writers. Each writes "<path>.tmp" and renames it to <path>; throws morse::Error naming the file
// on an I/O failure or on input it cannot represent.

/// MBDyn modal joint FEM file (MBDyn input manual, "Modal Element", "FEM File Format"; the
/// parser is ReadModal in mbdyn/struct/modal.cc). Record groups written:
///   1 header: REV0, NNODES, NNORMAL = n_modes, NATTACHED = 0, NCONSTRAINT = n_b, NREJECTED = 0
///   2 FEM node labels (node ids), 3 and 4 initial modal displacements and velocities (zeros),
///   5, 6, 7 x, y, z of the nodes, 8 the n mode shapes (x y z rx ry rz per node, one "**" header
///   line per mode), 9 generalized mass M_CB, 10 generalized stiffness K_CB (full, row by row),
///   12 rigid-body inertia (mass, centre of mass, inertia tensor about it) if the superelement
///   can move rigidly, 13 the damping matrix C if the file has one; then "** END OF FILE".
/// Record 11 (lumped nodal masses) is not written (see docs/export.md). Nodes: the interface
/// nodes, or with `shapes` every mesh node (the exact shapes of the basis). Values print with 17
/// significant digits. Needs coordinates; throws naming the node if an interface node has only
/// some of its components in the boundary while the others are interior DOFs (matrix input).
struct MbdynInfo {
  int n_nodes = 0;
  bool inertia_written = false;
  RigidBodyInertia inertia;
};
MbdynInfo write_mbdyn_fem(const std::string& path, const Superelement& se,
                          const NodalShapes* shapes = nullptr);

/// Names of the Nastran matrices (OP4 and DMIG), 1-8 characters, a letter first.
struct NastranNames {
  std::string op4_K = "KAA", op4_M = "MAA", op4_C = "BAA";
  std::string dmig_K = "KAAX", dmig_M = "MAAX", dmig_C = "BAAX";
};

/// OUTPUT4 ASCII file of K, M (and C as a third matrix) in /rom order, double precision
/// ("1P,3E23.16": exact round trip), form 6 when exactly symmetric; written by io::write_op4.
void write_op4_matrices(const std::string& path, const Superelement& se,
                        const NastranNames& names = {});

/// Default id offset of the SPOINTs that carry the modal coordinates in the DMIG deck: the
/// smallest power of ten above every node id the file names (its mesh or DOF map, else the
/// boundary), so modal coordinate k (1-based) is SPOINT offset + k.
std::int64_t default_spoint_offset(const Superelement& se);

/// Nastran bulk-data deck: comments naming the source, SPOINTs offset+1..offset+n_modes, and one
/// DMIG per matrix (large field DMIG*, IFO 6 symmetric with the lower triangle when the matrix is
/// exactly symmetric, else IFO 1 with every nonzero; TIN 2; boundary DOFs as GRID/component,
/// modal coordinates as SPOINT/0). Each value takes the 16-character field with as many
/// significant digits as fit (D exponent: 10 to 12 digits, 9 when |exponent| >= 100; the exact
/// round trip is the OP4's job). If grids_path is not empty and coordinates are known, GRID*
/// cards of the boundary nodes (basic system) go to that file. Throws if a SPOINT id would
/// collide with a node id of the file or exceed 99999999.
void write_dmig_deck(const std::string& path, const std::string& grids_path, const Superelement& se,
                     std::int64_t spoint_offset, const NastranNames& names = {});

/// A value in a Nastran 16-character large field: the most significant digits that fit, with a
/// "D" exponent without leading zeros (e.g. "-1.2345678901D-5"); "0.0" for zero. Exposed for tests.
std::string nastran_large_real(double v);

/// MatrixMarket coordinate files of K, M (and C) at 17 significant digits (io::write_matrix:
/// "symmetric" with the lower triangle when exactly symmetric, else "general").
void write_matrix_market(const std::string& path_K, const std::string& path_M,
                         const std::string& path_C, const Superelement& se);

/// Text DOF map of the exported matrices: one line per row, `row node <id> <component>` for a
/// boundary DOF and `row modal <k> <spoint id>` for modal coordinate k (1-based), with the
/// frequency as a comment.
void write_dof_map_text(const std::string& path, const Superelement& se,
                        std::int64_t spoint_offset);

// ---------------------------------------------------------------------------------------------
// The whole export (what `morse export` does).

struct ExportOptions {
  std::string prefix;  ///< output prefix: <prefix>.fem, .op4, _dmig.bdf, _K.mtx, ...
  bool mbdyn = true, op4 = true, dmig = true, mtx = true;
  bool mbdyn_all_nodes = false;    ///< shapes at every mesh node (needs the basis)
  std::int64_t spoint_offset = 0;  ///< 0: default_spoint_offset()
  NastranNames names;
};
struct ExportResult {
  std::vector<std::string> files;  ///< written, in order
  MbdynInfo mbdyn;
  std::int64_t spoint_offset = 0;
};
/// Checks everything each requested format needs first (coordinates, components, names, ids),
/// then writes the files; if a write fails, the files of this call already written are removed.
ExportResult export_superelement(const Superelement& se, const ExportOptions& o);

}  // namespace morse::io
