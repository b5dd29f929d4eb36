// morse: the command-line driver. Thin: parses the command word and hands over to
// morse::app::run_command. Errors are printed once (rank 0) and give a non-zero exit status.
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "morse/app/commands.hpp"
#include "morse/core/error.hpp"
#include "morse/core/session.hpp"

static const char kHelp[] =
    "morse: Model Order Reduction for Structural Elastodynamics\n"
    "usage: mpirun -n N morse <command> [options]   (or -options_file case.opts)\n"
    "  modes     lowest eigenpairs of the clamped full model\n"
    "  reduce    Craig-Bampton superelement\n"
    "  select    rank and select fixed-interface modes (LPF EIM VEIM DEIM OMR CMSchi EBR IMR)\n"
    "  static    nonlinear (St Venant-Kirchhoff) static solution under nodal loads\n"
    "  fom       full-order nonlinear implicit dynamics under nodal loads (the reference)\n"
    "  nlrom     nonlinear reduced model (CB, modal derivatives, POD; STEP or exact tensors)\n"
    "  simulate  integrate a reduced model (explicit, contact with a casing or a plane)\n"
    "  sweep     contact runs over rotation speeds, spread over the ranks (resumable)\n"
    "  stress    stresses from a reduced or full run\n"
    "  compare   a reduced run against the full run (seed 003 indicator)\n"
    "  rampup    rotor-stator unbalance ramp-up on stator superelements, bearing loads\n"
    "  export    superelement to MBDyn (.fem), Nastran (OP4, DMIG) and MatrixMarket\n"
    "  mesh box|blade|stator  write a generated mesh (box/beam, rotor-37-like blade, stator)\n"
    "  mesh info -mesh FILE   read a mesh and report its content and quality\n";

// After an exception: if every rank failed (a collective error), rank 0 prints and all return
// normally; if the other ranks do not join within a few seconds (an error on this rank only,
// the others are blocked in a collective call), print here and abort the whole job.
static int handle_error(MPI_Comm err_comm, const char* what) {
  MPI_Request req;
  MPI_Ibarrier(err_comm, &req);
  int done = 0;
  auto t0 = std::chrono::steady_clock::now();
  while (!done && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(5)) {
    MPI_Test(&req, &done, MPI_STATUS_IGNORE);
    if (!done) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  int rank = morse::world_rank();
  if (done) {
    if (rank == 0) std::fprintf(stderr, "morse: error: %s\n", what);
    return 1;
  }
  std::fprintf(stderr, "morse: error (rank %d): %s\n", rank, what);
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, 1);
  return 1;
}

int main(int argc, char** argv) {
  morse::use_huge_pages(argv);
  // The command words come before the first option.
  std::vector<std::string> words;
  for (int i = 1; i < argc && argv[i][0] != '-'; ++i) words.emplace_back(argv[i]);
  int status = 0;
  try {
    morse::Session session(&argc, &argv, kHelp);
    MPI_Comm err_comm;
    MPI_Comm_dup(PETSC_COMM_WORLD, &err_comm);
    try {
      if (words.empty()) {
        PetscBool help = PETSC_FALSE;
        PetscOptionsHasHelp(nullptr, &help);
        if (!help)
          throw morse::Error(
              "no command given (commands: modes, reduce, select, static, fom, nlrom, simulate, sweep, stress, "
              "compare, export, mesh, rampup); see -help");
      } else {
        morse::app::run_command(PETSC_COMM_WORLD, words[0], {words.begin() + 1, words.end()});
      }
    } catch (const std::exception& e) {
      // morse::Error, and anything else (std::bad_alloc: "out of memory: ...") as one line.
      status = handle_error(err_comm, morse::message_of(e).c_str());
    }
    MPI_Comm_free(&err_comm);
  } catch (const std::exception& e) {
    // The session failed (e.g. an options file that includes itself): every rank has the same
    // message, and MPI is down again.
    if (morse::world_rank() == 0) std::fprintf(stderr, "morse: error: %s\n", morse::message_of(e).c_str());
    return 1;
  }
  return status;
}
