// app/commands.cpp: the public entry points of commands.hpp: the command names and run_command,
// which dispatches to the command (cmd_<name>.cpp) and prints the stage table. What several
// commands share is in common.hpp.
#include "morse/app/commands.hpp"

#include <mpi.h>

#include <algorithm>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"

namespace morse::app {

namespace {

double wall_seconds() {
  static const double t0 = MPI_Wtime();
  return MPI_Wtime() - t0;
}

void print_stage_table(MPI_Comm comm) {
  auto records = reduced_stage_records(comm);
  print0(comm, "\n  %-22s %10s %12s\n", "stage", "time [s]", "peak [MB]");
  double peak = 0;
  for (const auto& r : records) {
    print0(comm, "  %-22s %10.3f %12.1f\n", r.name.c_str(), r.seconds, r.peak_mb);
    peak = std::max(peak, r.peak_mb);
  }
  print0(comm, "  %-22s %10.3f %12.1f\n", "total (wall)", wall_seconds(), peak);
}

}  // namespace

void run_command(MPI_Comm comm, const std::string& command, const std::vector<std::string>& args) {
  stage_records().clear();
  options::clear();  // the registrations (and the unknown-option check) belong to one command
  read_factorization_options();
  wall_seconds();
  if (command == "modes")
    detail::run_modes(comm);
  else if (command == "reduce")
    detail::run_reduce(comm);
  else if (command == "select")
    detail::run_select(comm);
  else if (command == "static")
    detail::run_static(comm);
  else if (command == "fom")
    detail::run_fom(comm);
  else if (command == "nlrom")
    detail::run_nlrom(comm);
  else if (command == "simulate")
    detail::run_simulate(comm);
  else if (command == "sweep")
    detail::run_sweep(comm);
  else if (command == "stress")
    detail::run_stress(comm);
  else if (command == "compare")
    detail::run_compare(comm, args);
  else if (command == "export")
    detail::run_export(comm);
  else if (command == "mesh")
    detail::run_mesh(comm, args);
  else if (command == "rampup")
    detail::run_rampup(comm);
  else
    throw Error(cat("unknown command '", command,
                    "' (commands: modes, reduce, select, static, fom, nlrom, simulate, sweep, stress, compare, export, "
                    "mesh, rampup)"));
  if ((command != "mesh" || (!args.empty() && args[0] == "info")) && !detail::help_requested()) print_stage_table(comm);
}

}  // namespace morse::app
