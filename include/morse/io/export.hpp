// morse/io/export.hpp: a superelement read back from its /rom file (io/superelement.hpp)
// exported to the codes that use superelements: MBDyn's modal joint (.fem), Nastran (OUTPUT4 and a
// DMIG bulk-data deck) and MatrixMarket (docs/export.md).
//
// Everything here is serial: call it on one rank (`morse export` runs it on rank 0). Every writer
// writes its temporary "<path>.tmp.<pid>" (files::temp_path) and renames it to <path> when
// complete, so a failed write leaves no partial file. The coordinates of the superelement are ordered as in /rom
// (io/superelement.hpp).
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <cstdint>
#include <string>
#include <vector>

#include "morse/core/files.hpp"
#include "morse/io/superelement.hpp"

namespace morse::io {

// ---------------------------------------------------------------------------------------------
// Writers. Each writes its temporary (files::temp_path) and renames it to <path>; throws
// morse::Error naming the file on an I/O failure or on input it cannot represent.

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
MbdynInfo write_mbdyn_fem(const std::string& path, const Superelement& se, const NodalShapes* shapes = nullptr);

/// Names of the Nastran matrices (OP4 and DMIG), 1-8 characters, a letter first.
struct NastranNames {
  std::string op4_K = "KAA", op4_M = "MAA", op4_C = "BAA";
  std::string dmig_K = "KAAX", dmig_M = "MAAX", dmig_C = "BAAX";
};

/// OUTPUT4 ASCII file of K, M (and C as a third matrix) in /rom order, double precision
/// ("1P,3E23.16": exact round trip), form 6 when exactly symmetric; written by io::write_op4.
void write_op4_matrices(const std::string& path, const Superelement& se, const NastranNames& names = {});

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
void write_matrix_market(const std::string& path_K, const std::string& path_M, const std::string& path_C,
                         const Superelement& se);

/// Text DOF map of the exported matrices: one line per row, `row node <id> <component>` for a
/// boundary DOF and `row modal <k> <spoint id>` for modal coordinate k (1-based), with the
/// frequency as a comment.
void write_dof_map_text(const std::string& path, const Superelement& se, std::int64_t spoint_offset);

// ---------------------------------------------------------------------------------------------
// The whole export (what `morse export` does).

struct ExportOptions {
  std::string prefix;  ///< output prefix: <prefix>.fem, .op4, _dmig.bdf, _K.mtx, ...
  bool mbdyn = true, op4 = true, dmig = true, mtx = true;
  bool mbdyn_all_nodes = false;    ///< shapes at every mesh node (needs the basis)
  std::int64_t spoint_offset = 0;  ///< 0: default_spoint_offset()
  NastranNames names;
  std::string from;         ///< the superelement file to export (-export_from; not used by export_superelement)
  std::string coordinates;  ///< interface node coordinates file (-export_coordinates; set_boundary_coordinates)
  std::string error;        ///< a bad option value, naming the option (set_from_options)

  /// Reads -export_from, -out (prefix; default: -export_from without .h5), -export_format
  /// (mbdyn,op4,dmig,mtx; default all), -export_op4_names and -export_dmig_names (K,M[,C]),
  /// -export_coordinates, -export_mbdyn_nodes interface|all and -export_spoint_offset. An unknown
  /// format, a bad node choice, a negative offset or a wrong number of names is recorded in
  /// `error`. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
};
struct ExportResult {
  std::vector<std::string> files;  ///< written, in order
  MbdynInfo mbdyn;
  std::int64_t spoint_offset = 0;
};
/// Checks everything each requested format needs first (coordinates, components, names, ids),
/// then writes the files; if a write fails, the files of this call already written are removed.
ExportResult export_superelement(const Superelement& se, const ExportOptions& o);
/// Every file export_superelement may write with the options o (those of a C or of the grids
/// included), named by the option that makes them (-out), for files::prepare_outputs; an empty
/// prefix gives {-out, ""}. Not collective.
std::vector<files::Named> export_files(const ExportOptions& o);

}  // namespace morse::io
