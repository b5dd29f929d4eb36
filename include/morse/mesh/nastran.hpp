// morse/mesh/nastran.hpp: reader and writer of Nastran bulk data (.bdf, .dat, .nas, .blk).
//
// Reading. read_nastran() turns the bulk data of an MSC / NX (Simcenter) Nastran input file into
// a serial Mesh. The reader is strict: whatever it cannot represent exactly is an error naming the
// file, the line and the card, except cards that do not change the structure (loads, output
// requests, solver settings...), which are skipped and counted.
//
// Sections. If the main file has a BEGIN BULK line, everything above it (executive and case
// control) is skipped with one notice; only a case-control PARAM,WTMASS is honoured there (it
// overrides a bulk data one, as in Nastran). Without BEGIN BULK the whole file is bulk data.
// ENDDATA ends the reading; BEGIN SUPER=, BEGIN AUXMODEL= ... are errors; a repeated BEGIN BULK
// is ignored.
//
// Formats (mixable card by card and line by line):
//   small field   field 1 = columns 1-8 (card name or continuation marker), fields 2-9 = eight
//                 8-column fields, field 10 = columns 73-80 (continuation marker).
//   large field   the name ends with '*' ("GRID*"); fields 2-5 are 16 columns wide; the next
//                 line, which starts with '*', holds fields 6-9. Two large lines make one small
//                 line.
//   free field    a comma within the first 10 characters: comma-separated fields, at most 10 per
//                 line (name, 8 data fields, continuation marker), or at most 6 (name, 4 data
//                 fields, marker) if the name ends with '*' (large free field). More is an error.
//   In fixed format a tab moves to the next 8-column stop (MSC's rule) and text beyond column
//   80 is ignored (one notice if it was not blank). '$' starts a comment anywhere; blank lines
//   are ignored; card names and keywords are case-insensitive. Replication ("=", "==", "*(1)")
//   is not supported (error).
// Continuations. A line continues the card above it if its field 1 is blank, or starts with '+'
// (small) or '*' (large), or, in free field, if the line starts with a comma. The continuation
// must follow its parent (comment and blank lines may come between). Old-style markers are
// checked: if field 10 of the parent and field 1 of the continuation both carry a marker
// (ignoring the leading '+' or '*'), they must match. Sorted-by-marker decks whose continuations
// are elsewhere in the file are not supported.
// INCLUDE 'file' (quotes optional; a quoted name may run over several lines, each piece trimmed
// of surrounding blanks and concatenated) reads the file in place; relative paths are relative to
// the directory of the including file; nesting is allowed (32 levels). A card ends at an INCLUDE
// and at the end of each file.
// Numbers. Integers: [sign]digits. Reals: every Nastran form, 1.0  1.  .5  -.5  1.E5  1.0D-3
// 1.-3 (= 1.0E-3)  1.+3  -2.5-4; an integer is accepted in a real field.
//
// Bulk data is unordered: every card may refer to cards further down. Cards read:
//   GRID ID CP X1 X2 X3 CD PS SEQ     coordinates converted from system CP to basic; blank CP,
//                                     CD, PS take the GRDSET values. PS fixes components like an
//                                     SPC. CD is kept only to check constraints (below).
//   GRDSET - CP - - - CD PS           defaults of GRID (at most one).
//   CORD2R, CORD2C, CORD2S CID RID A1 A2 A3 B1 B2 B3 / C1 C2 C3
//                                     A, B, C in system RID (recursively; a cycle is an error);
//                                     origin A, z axis A->B, C in the x-z plane. Cylindrical
//                                     (R, theta [deg], z), spherical (R, theta [deg], phi [deg]).
//                                     CORD1x and CORD3x are errors.
//   CTETRA EID PID G1..G4 [G5..G10], CPENTA EID PID G1..G6 [G7..G15],
//   CHEXA EID PID G1..G8 [G9..G20]    tet4/tet10, wedge6/wedge15, hex8/hex20. Midside grids must
//                                     be all present or all absent (blank or 0). Both corner
//                                     orientations are accepted: an element whose corners have a
//                                     negative volume is mirrored (one notice with the count).
//                                     Converted to morse (Gmsh) node ordering.
//   PSOLID PID MID ...                other fields ignored; a fluid FCTN is an error.
//   MAT1 MID E G NU RHO ...           E and NU from two or three of E, G, NU (Nastran's rules:
//                                     the missing one from E = 2 (1 + NU) G; all three are used as
//                                     given, with a notice if inconsistent by more than 1 %; E or
//                                     G alone is an error). Blank RHO = 0 (notice).
//   PARAM,WTMASS,w                    multiplies every density and CONM2 mass (notice). Other
//                                     PARAMs are skipped.
//   SPC SID G1 C1 D1 G2 C2 D2, SPC1 SID C G1 G2 ... (G1 THRU G2 allowed anywhere in the list)
//                                     components 1-3 set Mesh::fixed_dofs; 4-6 are ignored (solid
//                                     grids have no rotations; notice); D must be 0. All SIDs are
//                                     applied (case control, which selects one, is not read;
//                                     notice if there are several). SPCADD is ignored.
//   SET1 SID G1 G2 ... (THRU)         node set "SET1_<SID>".
//   ASET ID C ID C ..., ASET1 C G1 ... (THRU)
//                                     node set "ASET" (the Craig-Bampton boundary: -boundary ASET).
//                                     C must contain 1, 2 and 3: morse's boundary is whole nodes.
//   SPOINT ID ... (THRU)              scalar point ids (not nodes).
//   QSET ID C ..., QSET1 C ID ...     on SPOINTs only: a notice tells how many modal coordinates
//                                     they define (use -cb_num_fixed_modes N); on grids an error.
//   CONM2 EID G CID M X1 X2 X3 / I11 I21 I22 I31 I32 I33
//                                     M (times WTMASS) is added to Mesh::point_mass of grid G.
//                                     Offsets and inertias act on rotations, which solid grids
//                                     lack: ignored (one notice). G must be used by a solid.
//   ENDDATA                           stops reading.
// Errors: RBE1, RBE2, RBE3, RBAR, RBAR1, RROD, RTRPLT, RTRPLT1, RSPLINE, RSSCON, RJOINT, MPC
// (rigid elements and MPCs are not supported). Every other card is skipped; the skipped cards are
// listed once at the end with their counts. Elements or matrices that carry stiffness or mass
// (CQUAD4, CBAR, CBUSH, CELASi, CONM1, CMASSi, DMIG, ...) are errors, unless skip_unsupported
// (-mesh_skip_unsupported), which lists them separately as MISSING.
//
// Grid ids are 1..; grids and SPOINTs share one id space, solid elements and CONM2s another.
// THRU ranges may have gaps (not every id need exist) but must contain at least one grid; an
// explicitly listed id must exist. In a set, scalar points are errors; SPC on scalar points is
// ignored (notice). A constraint (SPC, SPC1, PS) on a grid with CD != 0 must fix all of 1, 2, 3
// or none of them: a strict subset would act along skewed axes, while morse works in the basic
// system. Component sets are digits 1-6 without repetition; "0" only for scalar points.
//
// The Mesh: nodes are all GRIDs in file order (ids kept), elements in file order (ids kept).
// One Material per PSOLID used by an element, named "PSOLID_<PID>", in increasing PID, with an
// element set of the same name; every element has a material. fixed_dofs is empty if nothing is
// fixed, point_mass empty without CONM2. units is "unknown" (Nastran carries no unit system),
// source is the path.
//
// Errors are morse::Error with a message "file:line: card NAME: what" (field errors name the
// field, e.g. "file:12: card GRID: field 4 ('abc') is not a real number (X1)").
//
// Writing. write_nastran() writes a bulk data file that read_nastran() reads back into the same
// mesh: a header comment, BEGIN BULK, GRID (basic system), CTETRA / CPENTA / CHEXA in Nastran
// node order, one PSOLID + MAT1 (E, blank G, NU, RHO) per material with PID = MID = material
// index + 1, SPC1 (SID 1) grouped by component set from fixed_dofs, every non-empty node set as a
// SET1 (SIDs 1, 2, ... in name order, each preceded by a comment "$ SET1 <sid> = <name>"), ASET1
// 123 for NastranWriteOptions::aset, CONM2 (CID 0, no offset) for point_mass, ENDDATA.
// Read back, node sets are named "SET1_<sid>" and "ASET" and materials "PSOLID_<pid>"; element
// sets other than the materials' are not written (Nastran has no element sets in the bulk data).
//
// Precision of reals: every real is written with the fewest digits that read back exactly, if
// they fit the field; otherwise rounded to as many significant digits as fit. Free field has no
// width limit, so a Free file round-trips bitwise. Large field (16 columns) is exact for any value
// whose shortest decimal has at most 14 significant digits and a magnitude in [0.1, 1e14) (15 if
// positive), which covers most hand-made and generated values but not all doubles: otherwise it
// keeps 14 to 15 digits in that range and at least 11 for decimal exponents below 100 in
// magnitude (relative error below 5e-11). Small field (8 columns) keeps 6 to 7 digits in
// [0.1, 1e5), fewer outside (-1.23-12 has 3): use it only for models that tolerate that.
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <string>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Reads the Nastran input file at path (serial, call on one rank) into a new Mesh owned by the
/// caller. An element or matrix card that carries stiffness or mass but is not supported (CQUAD4,
/// CBAR, CELASi, CONM1, DMIG, ...) is an error, unless skip_unsupported: then such cards are
/// skipped and listed in a WARNING (their stiffness and mass are MISSING). Notices (skipped sections and cards,
/// mirrored elements, WTMASS, ...) go to stderr if verbose. Throws morse::Error ("file:line: card NAME: what") on any
/// input error.
Mesh read_nastran(const std::string& path, bool verbose = true, bool skip_unsupported = false);

/// Options of write_nastran().
struct NastranWriteOptions {
  /// Field format of every card (see the precision notes above).
  enum class Format { Small, Large, Free };
  Format format = Format::Large;
  /// Node set written as ASET1 123 (the Craig-Bampton boundary); empty: no ASET1.
  std::string aset;
  /// For `morse mesh`, not read by write_nastran: the MAT1 of the elements without a material
  /// (E, nu, rho -1: not given) and the node set whose translations SPC1 fixes (empty: none).
  Material material{"options", -1, -1, -1};
  std::string spc;
  std::string error;  ///< a bad option value, naming the option (set_from_options)

  /// Reads -material_E, -material_nu, -material_rho (the MAT1), -nastran_format
  /// large|small|free, -nastran_aset and -nastran_spc; an unknown format is recorded in `error`.
  /// Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
};

/// Writes m as Nastran bulk data to path (through its temporary files::temp_path(path), renamed when complete). Serial.
/// Throws morse::Error if an element has no material (elem_material < 0: Nastran needs a
/// PSOLID/MAT1 for every element), an id is not positive or does not fit its field (Small:
/// 8 digits), o.aset is not a node set of m, or the file cannot be written.
void write_nastran(const Mesh& m, const std::string& path, const NastranWriteOptions& o = {});

}  // namespace morse::mesh
