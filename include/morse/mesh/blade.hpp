// morse/mesh/blade.hpp: a rotor-37-like compressor blade generator (quadratic 15-node wedges).
//
// The blade of seed 003 (§2.1, Figs. 2 and 15): a solid blade of NASA rotor 37 built from six
// published sections, clamped at the hub, rotating about the machine axis z. docs/blade.md gives
// the section tables, the construction and the calibration in full.
//
// Frame and units (SI, metres): machine axis z (axial, flow towards +z), span along the radial
// line x (the stacking line is the x axis), y circumferential. Every section is a planar profile
// in (axial z, circumferential arc length s) wrapped on the cylinder of its radius r:
// (x, y, z) = (r cos(s/r), r sin(s/r), z). The hub section lies on the cylinder r = 0.178 m, the
// tip section on r = 0.252 m (a circular casing has a uniform clearance to the tip).
//
// Sections. The published mean-section parameters (radius 0.1826 ... 0.2486 m: chord, stagger
// from the axial direction, maximum thickness-to-chord ratio t/c) and a chosen camber (40, 26,
// 14, 7, 4, 3 degrees hub to tip; not published) are interpolated along the span by monotone
// cubic Hermite (PCHIP) interpolation, extended linearly to the hub and the tip. A section is a
// circular-arc camber line (turning theta, chord c, the chord line at the stagger angle from z,
// the leading edge upstream at -z, the convex side towards +s) carrying a thickness symmetric
// about mid-chord: at the arc-length fraction u from the leading edge, the half thickness normal
// to the camber line is (T/2) F(w), w = 4u(1-u), F = sqrt(w (0.9 w^2 + 0.1)), with the maximum
// T = thickness_scale * (t/c)(r) * c(r) at mid-chord. F is a biconvex profile (like the
// circular-arc w) thinned towards the edges, which are round with radius ~0.05 T^2 / c. Sections
// are stacked on their area centroids (every section's centroid lies on the x axis).
//
// Mesh. A structured grid on the profile: n_chord cells along the camber line (uniform in phi,
// clustered towards the edges by u(phi) = (phi + ((1-2phi)^5 - 1)/10)/0.8), n_thick uniform cells
// across the thickness; the grid collapses into a single node at the leading and at the trailing
// edge (a fan of n_thick triangles), every other cell is cut into two triangles. The same
// triangulation on every section layer; the triangles of layer k extruded to layer k+1 are the
// wedge15 elements (node ordering of fe/element.hpp, positive Jacobian). Section layers: the hub,
// the six published sections and the tip are layers, the n_span cells are shared among the
// seven intervals in proportion to their length (at least one each, largest remainders first).
// Mid-edge nodes are shared and lie on the exact geometry (the parametric map evaluated at the
// parametric midpoint), except on the interior edges of the leading/trailing-edge fans, which
// are straight.
//
// Numbering: nodes layer by layer (hub first; the mid-span-edge nodes between two layers form
// their own layer), within a layer from the leading to the trailing edge, then from the concave
// (pressure) to the convex (suction) side; node ids 1..N, element ids 1..E, elements span cell by
// span cell. One material, "maraging steel" (E = 180 GPa, nu = 0.3, rho = 8000 kg/m^3, seed 003),
// assigned to every element; units "SI".
//
// Sets (sorted node indices): "root" every node of the hub section (the clamped surface);
// "tip" the 8 nodes of the tip camber line nearest to equal chord fractions 0, 1/7, ..., 1, so
// that their indices increase from LE to TE (the contact interface of seed 003); "LE" and "TE"
// the tip's leading- and trailing-edge nodes (both also in "tip"). Element set "blade": all.
//
// Sizes: "default" 40 x 4 x 22 cells (20,549 nodes, 6,864 wedges, as the seed's 20,657 nodes);
// "coarse" 16 x 2 x 7 cells (1,553 nodes, 420 wedges) for fast tests, with frequencies within 2% of
// the default's.
#pragma once

#include <petscsys.h>

#include <string>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Smallest n_chord (the 8 tip nodes need distinct camber-line nodes).
inline constexpr int kMinBladeChordCells = 6;
/// Smallest n_span: one cell between consecutive layers hub, 6 sections, tip.
inline constexpr int kMinBladeSpanCells = 7;
/// Largest cell count in any direction.
inline constexpr int kMaxBladeCells = 2000;
/// Largest accepted thickness_scale (the profile stays valid well beyond).
inline constexpr double kMaxBladeThicknessScale = 4.0;
/// Number of nodes of the "tip" set.
inline constexpr int kBladeTipNodes = 8;
/// The calibrated thickness scale (docs/blade.md): the clamped default blade's first three
/// modes are 1B, 1T, 2B at 5,573.6, 16,711.2, 21,023.5 rad/s (-2.1%, -2.1%, +2.2% from seed
/// 003's 5,691.5, 17,062.9, 20,564.2 rad/s).
inline constexpr double kBladeThicknessScale = 1.34;

/// Parameters of the blade generator (options prefix -blade_).
struct BladeSpec {
  int n_chord = 0;               ///< cells along the chord (0 = default for the size: 40 / 16)
  int n_thick = 0;               ///< cells across the thickness (0 = default for the size: 4 / 2)
  int n_span = 0;                ///< cells along the span, >= 7 (0 = default for the size: 22 / 7)
  std::string size = "default";  ///< "default" (~20k nodes) or "coarse" (fast tests)
  /// Factor on the published thickness-to-chord ratios (calibration, see docs/blade.md).
  double thickness_scale = kBladeThicknessScale;
};

/// Builds the blade (see the top of this header). Deterministic: the same spec gives the same
/// mesh, bit for bit. Throws morse::Error if the size is unknown, a cell count is out of range
/// (n_chord in [6, 2000], n_thick in [1, 2000], n_span in [7, 2000]; 0 = size default) or
/// thickness_scale is not in (0, 4].
Mesh generate_blade(const BladeSpec& spec);

/// Reads the -blade_* options into spec: -blade_size default|coarse, -blade_n_chord,
/// -blade_n_thick, -blade_n_span (0 = from the size) and -blade_thickness_scale. Values not given
/// keep those of spec. Errors (PETSC_ERR_ARG_OUTOFRANGE) on an unknown size or an out-of-range
/// value. PETSc error zone; collective on comm.
PetscErrorCode blade_spec_from_options(MPI_Comm comm, BladeSpec* spec);

}  // namespace morse::mesh
