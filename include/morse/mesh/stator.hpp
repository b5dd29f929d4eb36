// morse/mesh/stator.hpp: an engine-stator-like component generator (quadratic elements).
//
// The part (machine axis z, SI units, all dimensions overridable in StatorSpec):
//
//   hub ring      r in [hub_bore_radius, hub_outer_radius]          (0.29 .. 0.30 m), z in [0, L]
//   casing ring   r in [casing_inner_radius, casing_outer_radius]   (0.60 .. 0.605 m), z in [0, L]
//   two flanges   r in [casing_outer_radius, flange_outer_radius]   (0.605 .. 0.65 m), radial lips
//                 at the ends of the casing: z in [0, t_f] (front) and [L - t_f, L] (rear)
//   N vanes       flat plates of constant thickness t_v (3 mm), centred on the planes through the
//                 axis at angles 2 pi p / N (p = 0..N-1, the first one in the x-z plane, +x),
//                 spanning radially from the hub's outer cylinder to the casing's inner cylinder
//                 and axially z in [t_f, L - t_f]
//
// with L = length (0.15 m) and t_f = flange_thickness (10 mm). The vane ends are the exact
// intersections of the plates with the two cylinders.
//
// Meshing: 20-node hexahedra only, from structured blocks that share their nodes at the vane
// joints (conforming, no tied contact): the hub and the casing (with its flanges) are
// cylindrical blocks on an (r, theta, z) lattice, each vane is a flat (x, s, z) block whose end
// faces are the hub and casing nodes. All nodes, mid-edge ones included, lie on the exact
// geometry (curved edges on their circles). Every element is positively oriented.
//
// Sets (node sets are what morse clamps and reduces on):
//   mount          every node of the rear face z = L of the casing and its rear flange
//                  (the engine mount, to be clamped: -clamp mount)
//   bearing1..10   one node each on the hub bore: bearing1..5 in the plane z = t_f (front
//                  bearing), bearing6..10 in z = L - t_f (rear bearing), at 0, 72, 144, 216 and
//                  288 degrees (the bore node nearest to each angle)
//   suspension1..3 one node each on the rim of the front flange (r = flange_outer_radius,
//                  z = t_f / 2) at 90, 210 and 330 degrees (nearest rim node): suspension lugs
//   interface      the 13 nodes above: the seed's 13 master nodes. Solid elements carry the 3
//                  translations only, so they give 39 boundary DOFs (the seed's 78 = 13 x 6
//                  count nodes with rotations)
//   element sets   hub, casing, flanges, vanes
// No interface node belongs to mount.
//
// Node ids are 1..N in order of creation, element ids 1..E (hub, then casing and flanges, then
// the vanes one after the other). One material (steel, E = 210 GPa, nu = 0.3, rho = 7800 kg/m^3,
// or StatorSpec::material) is stored in Mesh::materials and assigned to every element. Note that
// a Gmsh file does not store materials (gmsh.hpp): give -material_E 2.1e11 -material_nu 0.3
// -material_rho 7800 when running morse on the written .msh file.
#pragma once

#include <petscsys.h>

#include <string>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// Parameters of the stator generator (options prefix -stator_). Zero resolution fields take
/// the value of the size preset:
///
///   size      n_vanes  h [m]    n_thick  nodes   DOFs     elements  committed as (meshes/)
///   default   14       0.0175   1        52066   156198   7084      stator.msh (4.2 MB)
///   coarse    8        0.075    1        4832    14496    608       stator_coarse.msh (0.36 MB)
///
/// The cell counts follow from h (StatorLayout): each wall length is cut into ceil(length / h)
/// equal cells; the walls have n_thick elements through their thickness.
struct StatorSpec {
  std::string size = "default";  ///< "default" (100-200k DOF) or "coarse" (fast tests)
  int n_vanes = 0;               ///< number of radial vanes (0 = default for the size)
  double h = 0.0;                ///< target element edge length along the walls [m] (0 = preset)
  int n_thick = 0;               ///< elements through each wall thickness (0 = preset, 1)

  // --- geometry [m]
  double hub_bore_radius = 0.29;
  double hub_outer_radius = 0.30;
  double casing_inner_radius = 0.60;
  double casing_outer_radius = 0.605;
  double flange_outer_radius = 0.65;
  double flange_thickness = 0.01;  ///< axial thickness t_f of each flange
  double length = 0.15;            ///< axial length L of hub and casing
  double vane_thickness = 0.003;   ///< t_v

  /// Material of every element.
  Material material{"steel", 2.1e11, 0.3, 7800.0};
};

/// Resolution of a spec once the size preset is applied (see resolve_stator_spec()).
struct StatorLayout {
  int n_vanes = 0;
  double h = 0.0;
  int n_thick = 0;
  int n_hub_gap = 0;     ///< hub cells along the circumference between two vanes
  int n_casing_gap = 0;  ///< casing cells along the circumference between two vanes
  int n_vane_span = 0;   ///< vane cells from hub to casing
  int n_vane_chord = 0;  ///< vane (and ring) cells along z between the flanges
  int n_flange = 0;      ///< flange cells along the radius
};

/// Applies the size preset to the zero fields of spec and derives the cell counts. Throws
/// morse::Error with a message naming the option at fault if spec is invalid (unknown size,
/// fewer than 3 vanes or vanes that overlap at the hub, non-positive or non-finite lengths,
/// radii not increasing, flanges thicker than half the length, h or n_thick out of range, or a
/// mesh of more than 10 million elements).
StatorLayout resolve_stator_spec(const StatorSpec& spec);

/// Closed-form volume of the part described by spec (rings, flanges and vanes; the vane ends are
/// the exact cylinder intersections). The mesh volume converges to it under refinement.
double stator_volume(const StatorSpec& spec);

/// Builds the stator (see the top of this file). Deterministic: the same spec gives the same
/// mesh, bit for bit, and hence the same file. Throws morse::Error as resolve_stator_spec().
Mesh generate_stator(const StatorSpec& spec);

/// Reads the -stator_* options into spec (-stator_size, -stator_n_vanes, -stator_h,
/// -stator_n_thick, -stator_vane_thickness) and checks them. PETSc error zone.
PetscErrorCode stator_spec_from_options(MPI_Comm comm, StatorSpec* spec);

}  // namespace morse::mesh
