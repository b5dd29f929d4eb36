// morse/app/commands.hpp: the commands of the morse executable, callable from C++.
//
// Each command reads its options from the PETSc options database (-help lists them with their
// defaults), runs its stages, prints a summary on rank 0 and writes one HDF5 file atomically.
//   morse modes  -mesh FILE -clamp SET -modes_nev N [-out FILE.h5]
//   morse reduce -mesh FILE -clamp SET -boundary SET (-cb_num_fixed_modes N | -cb_fmax HZ)
//                [-cb_damping XI] [-cb_write_basis] [-out FILE.h5]
//   morse mesh box [-box_type hex20 -box_lx .. -box_nx ..] -out FILE.msh
// Unknown options are an error.
#pragma once

#include <mpi.h>

#include <string>
#include <vector>

namespace morse::app {

/// Runs a command (args are the words after the command name that are not options, e.g. "box"
/// for `morse mesh box`). Collective. Throws morse::Error on bad input.
void run_command(MPI_Comm comm, const std::string& command, const std::vector<std::string>& args);

}  // namespace morse::app
