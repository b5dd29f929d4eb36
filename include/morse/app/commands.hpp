// morse/app/commands.hpp: the commands of the morse executable, callable from C++.
//
// Each command (modes, reduce, select, static, fom, nlrom, simulate, sweep, stress, compare,
// export, mesh, rampup; `morse -help` lists them, `morse <command> -help` their options with
// defaults) reads its options from the PETSc options database through the settings readers of the
// library modules, refuses an unknown or misspelled option before any work (core/options.hpp),
// calls the library, prints a summary on rank 0 and writes one HDF5 file atomically (a temporary
// file renamed at the end). The commands are thin: what they compute and write is in the library
// (docs/architecture.md).
#pragma once

#include <mpi.h>

#include <string>
#include <vector>

namespace morse::app {

/// Runs a command (args are the words after the command name that are not options, e.g. "box"
/// for `morse mesh box`). Collective. Throws morse::Error on bad input.
void run_command(MPI_Comm comm, const std::string& command, const std::vector<std::string>& args);

}  // namespace morse::app
