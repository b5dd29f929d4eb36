// app/cmd_compare.cpp: `morse compare FOM.h5 ROM.h5`, the performance indicator of seed 003
// (eq. 43–51; eval/compare.hpp) of a `morse simulate` run against a `morse fom` run of the same
// case. Serial (rank 0). t_max comes from the load stored in the files (/fom/load, /sim/load;
// -load_* overrides it). Prints a table and writes /compare into ROM.h5 (atomically: a copy is
// modified, then renamed).
#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/eval/compare.hpp"

namespace morse::app::detail {

void run_compare(MPI_Comm comm, const std::vector<std::string>& args) {
  eval::CompareSettings co;
  MORSE_CALL(co.set_from_options(comm));
  MORSE_CHECK(co.error.empty(), co.error);
  std::vector<dyn::NodalLoad> load_list;
  std::string load_error;
  MORSE_CALL(dyn::get_loads(comm, &load_list, &load_error));
  if (help_requested()) return;
  check_options(comm, true);
  collective_check(comm, load_error);
  MORSE_CHECK(args.size() == 2, "usage: morse compare FOM.h5 ROM.h5 (a morse fom file, a morse simulate file)");
  const std::string fom = args[0], rom = args[1];
  // ROM.h5 is rewritten with /compare (a copy renamed onto it): it must not be an input too.
  const auto output_lock =
      files::prepare_outputs(comm, {{"ROM.h5", rom}}, {{"FOM.h5", fom}, {"-compare_rom_model", co.rom_model}});
  double ws = 0;
  for (double x : co.w) ws += x;
  MORSE_CHECK(std::abs(ws - 1.0) < 1e-12 && *std::min_element(co.w.begin(), co.w.end()) >= 0,
              "-compare_weights must be >= 0 and sum to 1");
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  std::string err;
  if (co.tmax < 0) {
    // t_max from the load: the -load_* options if given (they override the load the files
    // store), else the load stored in the fom file (/fom/load), else in the simulate file.
    double tmax = -1;
    std::string stored;  // the file whose stored load is used or overridden
    if (rank == 0) try {
        tmax = eval::load_tmax(fom, rom, load_list, &stored);
      } catch (const std::exception& e) {
        err = message_of(e);
      }
    collective_check(comm, err);
    MPI_Bcast(&tmax, 1, MPI_DOUBLE, 0, comm);
    co.tmax = tmax;
    if (!load_list.empty() && !stored.empty())
      print0(comm, "morse compare: the -load_* options override the load stored in %s\n", stored.c_str());
    MORSE_CHECK(co.tmax >= 0, "compare: give -compare_tmax T or the harmonic load (-load_*) that defines t_max",
                load_list.empty() ? " (neither file stores a harmonic load: /fom/load, /sim/load)" : "");
  }
  eval::Indicator ind;
  double tsnap = 0;
  if (rank == 0) try {
      ind = eval::compare_runs(fom, rom, co, &tsnap);
    } catch (const std::exception& e) {
      err = message_of(e);
    }
  collective_check(comm, rank == 0 && !err.empty() ? err : std::string());
  check_options(comm, false);
  print0(comm, "morse compare: %s against %s (seed 003 eq. 43-51)\n", rom.c_str(), fom.c_str());
  print0(comm, "  %-34s %8s %8s\n", "criterion", "e", "w");
  const char* names[4] = {"e1 covariance at t_max", "e2 energy (eq. 46)", "e3 tip peak-to-peak", "e4 tip displacement"};
  for (int i = 0; i < 4; ++i) print0(comm, "  %-34s %8.4f %8.3f\n", names[i], ind.e[i], ind.w[i]);
  print0(comm, "  %-34s %8.4f\n", "performance indicator I", ind.I());
  print0(comm, "  (t_max %.6g s, nearest snapshot %.6g s)\n", co.tmax, tsnap);
  std::string werr;
  if (rank == 0) try {
      eval::write_compare(rom, ind, co.tmax, tsnap, fom, co.tip);
    } catch (const std::exception& e) {
      werr = message_of(e);
    }
  collective_check(comm, werr);
  print0(comm, "\nmorse: wrote /compare into %s\n", rom.c_str());
}

}  // namespace morse::app::detail
