// app/cmd_export.cpp: `morse export`, a superelement file of `morse reduce` / `morse select`
// written for other codes: MBDyn's modal joint (.fem), Nastran (OP4 and a DMIG deck) and
// MatrixMarket (io/export.hpp, docs/export.md). Serial: rank 0 reads and writes; its
// errors reach every rank through collective_check, so no rank waits alone.
#include <petscsys.h>

#include <algorithm>
#include <string>
#include <vector>

#include "app/common.hpp"
#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/io/export.hpp"
#include "morse/io/superelement.hpp"

namespace morse::app::detail {

void run_export(MPI_Comm comm) {
  io::ExportOptions eo;
  MORSE_CALL(eo.set_from_options(comm));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(eo.error.empty(), eo.error);
  MORSE_CHECK(!eo.from.empty(),
              "no superelement given: use -export_from FILE (a file of morse reduce or morse select)");
  const auto output_lock = files::prepare_outputs(comm, io::export_files(eo),
                                                  {{"-export_from", eo.from}, {"-export_coordinates", eo.coordinates}});
  check_options(comm, false);

  std::string err;
  io::Superelement se;
  io::ExportResult res;
  {
    StageTimer t(comm, "Export");
    if (rank_of(comm) == 0) try {
        se = io::read_superelement(eo.from);
        if (!eo.coordinates.empty()) io::set_boundary_coordinates(&se, eo.coordinates);
        res = io::export_superelement(se, eo);
      } catch (const std::exception& e) {
        err = message_of(e);
      }
    collective_check(comm, err);
  }
  print0(comm,
         "morse export: %s: %d DOFs = %d boundary DOFs (%zu nodes) + %d fixed-interface modes%s, "
         "units %s\n",
         eo.from.c_str(), se.n, se.n_b, se.boundary_nodes.size(), se.n_modes(), se.C.empty() ? "" : ", with C",
         se.units.c_str());
  if (eo.mbdyn) {
    const auto& in = res.mbdyn.inertia;
    print0(comm, "  MBDyn: %d FEM nodes (%s)\n", res.mbdyn.n_nodes,
           eo.mbdyn_all_nodes ? "every mesh node" : "interface");
    if (res.mbdyn.inertia_written) {
      print0(comm,
             "  rigid-body inertia (from M_CB, record group 12): mass %.10g, centre of mass "
             "(%.10g, %.10g, %.10g)\n",
             in.mass, in.center[0], in.center[1], in.center[2]);
      print0(comm,
             "    inertia about the centre of mass: [%.10g %.10g %.10g; %.10g %.10g %.10g; %.10g "
             "%.10g %.10g]\n",
             in.inertia_cm[0], in.inertia_cm[1], in.inertia_cm[2], in.inertia_cm[3], in.inertia_cm[4], in.inertia_cm[5],
             in.inertia_cm[6], in.inertia_cm[7], in.inertia_cm[8]);
    } else {
      print0(comm, "  no rigid-body inertia in the FEM file: %s\n", in.reason.c_str());
    }
  }
  if (eo.dmig) print0(comm, "  DMIG: modal coordinate k is SPOINT %lld+k\n", static_cast<long long>(res.spoint_offset));
  for (const auto& f : res.files) print0(comm, "morse: wrote %s\n", f.c_str());
}

}  // namespace morse::app::detail
