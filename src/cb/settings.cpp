// cb/settings.cpp: the options of the Craig-Bampton settings (cb::CBSettings::set_from_options).
#include <petscsys.h>

#include <string>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/error.hpp"
#include "morse/core/options.hpp"

namespace morse::cb {

PetscErrorCode read_boundary_option(MPI_Comm comm, std::string* boundary) {
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse interface", "");
  PetscCall(MorseOptionsString("-boundary",
                               "Node set of the interface, kept as physical DOFs (its x,y,z: the boundary DOFs of the "
                               "superelement; nlrom: the contact nodes)",
                               "", buf, buf, sizeof buf, &set));
  PetscOptionsEnd();
  if (set) *boundary = buf;
  return PETSC_SUCCESS;
}

PetscErrorCode CBSettings::set_from_options(MPI_Comm comm) {
  PetscCall(read_boundary_option(comm, &boundary_set));
  PetscBool basis = keep_basis ? PETSC_TRUE : PETSC_FALSE, n_set = PETSC_FALSE, fmax_set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse reduce (Craig-Bampton) options", "");
  PetscCall(MorseOptionsInt("-cb_num_fixed_modes", "Number of fixed-interface modes (0 = Guyan)", "", n_fixed, &n_fixed,
                            &n_set));
  PetscCall(MorseOptionsReal("-cb_fmax",
                             "Keep every fixed-interface mode below this frequency [Hz] "
                             "(spectrum slicing; seed 000 uses 5x the top frequency of interest)",
                             "", fmax_hz, &fmax_hz, &fmax_set));
  PetscCall(MorseOptionsReal("-cb_damping", "Modal damping ratio xi of the fixed-interface modes", "", damping,
                             &damping, nullptr));
  PetscCall(MorseOptionsBool("-cb_write_basis", "Write the constraint and fixed-interface modes (Psi, Phi)", "", basis,
                             &basis, nullptr));
  PetscOptionsEnd();
  keep_basis = basis;
  // Unset, they are -1 ("not given"): a value given must not look like that.
  MORSE_CHECK(!n_set || n_fixed >= 0, "-cb_num_fixed_modes ", n_fixed, " must be >= 0 (0 = Guyan)");
  MORSE_CHECK(!fmax_set || fmax_hz > 0, "-cb_fmax ", fmax_hz, " must be > 0 [Hz]");
  return PETSC_SUCCESS;
}

}  // namespace morse::cb
