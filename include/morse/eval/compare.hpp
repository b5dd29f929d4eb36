// morse/eval/compare.hpp: the comparison of a `morse simulate` run with a `morse fom` run of the
// same case (`morse compare`, seed 003 eq. 43-51; the criteria are in eval/indicator.hpp): its
// settings and options, t_max of criterion e1 from the load stored in the files, and the
// indicator computed from the two files.
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <string>
#include <vector>

#include "morse/dyn/dyn.hpp"
#include "morse/eval/indicator.hpp"

namespace morse::eval {

struct CompareSettings {
  std::string tip = "tip";  ///< -compare_tip: the node set of the blade tip (e3, e4), monitored in both runs
  double tmax = -1;         ///< -compare_tmax: the time of e1 [s]; < 0: from the load (load_tmax)
  std::vector<double> w = {0.25, 0.25, 0.25, 0.25};  ///< -compare_weights w1,w2,w3,w4 (eq. 43)
  std::string rom_model;                             ///< -compare_rom_model: the nlrom file ("" = the one /sim names)
  std::string error;                                 ///< a bad option value (not four weights), naming the option
  /// Reads -compare_tip, -compare_tmax, -compare_weights and -compare_rom_model; a weight list
  /// that is not four values (w unchanged) or a given -compare_tmax that is not a finite time >= 0
  /// is recorded in `error`. Uses PetscOptionsBegin:
  /// returns a PETSc error code. Collective.
  PetscErrorCode set_from_options(MPI_Comm comm);
};

/// t_max of criterion e1 (dyn::first_maximum) from the load of the runs: `loads` if not empty
/// (the -load_* options, which override what the files store), else the load stored in `fom`
/// (/fom/load), else in `rom` (/sim/load); -1 if that load has no harmonic part. *stored receives
/// the file whose stored load was found ("" if neither stores one), so that the caller can say
/// what `loads` overrides. Throws naming the file if a stored load is inconsistent. Serial.
double load_tmax(const std::string& fom, const std::string& rom, const std::vector<dyn::NodalLoad>& loads,
                 std::string* stored);

/// The indicator of the simulate file `rom` against the fom file `fom` (s.tmax >= 0 resolved):
/// e2, e3, e4 from the energy and tip histories (the tip rows matched by node id, the ROM's
/// samples interpolated on the FOM's), e1 from the FOM snapshot nearest to t_max and the reduced
/// coordinates q interpolated there, reconstructed with the basis of the nlrom file (s.rom_model,
/// or the one /sim names). *tsnap receives the snapshot time. Throws naming the file and the
/// fault (different tip nodes, a ROM run shorter than the FOM's, no snapshots, t_max after the
/// end, a basis that does not match q, ...). Serial (one rank).
Indicator compare_runs(const std::string& fom, const std::string& rom, const CompareSettings& s, double* tsnap);

}  // namespace morse::eval
