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
#include "morse/core/log.hpp"
#include "morse/core/options.hpp"
#include "morse/io/export.hpp"
#include "morse/io/superelement.hpp"

namespace morse::app::detail {

namespace {

struct ExportCommandOptions {
  std::string from, out, coordinates, nodes = "interface";
  std::vector<std::string> formats = {"mbdyn", "op4", "dmig", "mtx"};
  PetscInt spoint_offset = 0;
  std::vector<std::string> op4_names, dmig_names;
  std::string error;  ///< a bad value, naming the option (raised after -help)
};

PetscErrorCode get_export_options(MPI_Comm comm, ExportCommandOptions* o) {
  std::vector<std::string> formats;
  PetscCall(options::get_string_list(comm, "-export_format",
                         "Formats to write, comma separated: mbdyn, op4, dmig, mtx (default: all)",
                         &formats));
  if (!formats.empty()) o->formats = formats;
  PetscCall(options::get_string_list(comm, "-export_op4_names",
                         "Names of K, M, C in the OP4 file (default KAA,MAA,BAA)", &o->op4_names));
  PetscCall(options::get_string_list(
      comm, "-export_dmig_names",
      "Names of the K, M, C DMIG matrices (case control K2GG, M2GG, B2GG; default KAAX,MAAX,BAAX)",
      &o->dmig_names));
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse export options", "");
  PetscCall(MorseOptionsString("-export_from",
                               "Superelement file of morse reduce or morse select (required)", "",
                               buf, buf, sizeof buf, &set));
  if (set) o->from = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString(
      "-out",
      "Output prefix: PREFIX.fem, PREFIX.op4, PREFIX_dmig.bdf, PREFIX_grids.bdf, PREFIX_K.mtx, "
      "PREFIX_M.mtx, PREFIX_C.mtx, PREFIX_dofs.txt (default: -export_from without .h5)",
      "", buf, buf, sizeof buf, &set));
  if (set) o->out = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString(
      "-export_coordinates",
      "Text file 'node x y z' per line: interface node coordinates for a file without /mesh "
      "(matrix input); replaces those of /mesh",
      "", buf, buf, sizeof buf, &set));
  if (set) o->coordinates = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString(
      "-export_mbdyn_nodes",
      "Nodes of the MBDyn FEM file: interface, or all (every mesh node; needs a file of "
      "morse reduce -cb_write_basis)",
      "", o->nodes.c_str(), buf, sizeof buf, &set));
  if (set) o->nodes = buf;
  PetscCall(MorseOptionsInt(
      "-export_spoint_offset",
      "DMIG: modal coordinate k is SPOINT offset+k (default: the smallest power of ten above "
      "every node id of the file)",
      "", o->spoint_offset, &o->spoint_offset, nullptr));
  PetscOptionsEnd();
  static const std::vector<std::string> known = {"mbdyn", "op4", "dmig", "mtx"};
  for (const auto& f : o->formats)
    if (std::find(known.begin(), known.end(), f) == known.end() && o->error.empty())
      o->error = cat("-export_format ", f, ": unknown format (mbdyn, op4, dmig, mtx)");
  if (o->nodes != "interface" && o->nodes != "all" && o->error.empty())
    o->error = cat("-export_mbdyn_nodes ", o->nodes, ": expected interface or all");
  if (o->spoint_offset < 0 && o->error.empty())
    o->error = cat("-export_spoint_offset must be >= 0 (got ", o->spoint_offset, ")");
  for (const auto* names : {&o->op4_names, &o->dmig_names})
    if (!names->empty() && (names->size() < 2 || names->size() > 3) && o->error.empty())
      o->error = cat(names == &o->op4_names ? "-export_op4_names" : "-export_dmig_names",
                     " takes 2 or 3 names: K,M[,C]");
  return PETSC_SUCCESS;
}

}  // namespace

void run_export(MPI_Comm comm) {
  ExportCommandOptions co;
  MORSE_CALL(get_export_options(comm, &co));
  if (help_requested()) return;
  check_options(comm, true);
  MORSE_CHECK(co.error.empty(), co.error);
  MORSE_CHECK(
      !co.from.empty(),
      "no superelement given: use -export_from FILE (a file of morse reduce or morse select)");
  check_options(comm, false);

  io::ExportOptions eo;
  eo.prefix = co.out;
  if (eo.prefix.empty()) {
    eo.prefix = co.from;
    if (eo.prefix.size() > 3 && eo.prefix.compare(eo.prefix.size() - 3, 3, ".h5") == 0)
      eo.prefix.resize(eo.prefix.size() - 3);
  }
  auto has = [&](const char* f) {
    return std::find(co.formats.begin(), co.formats.end(), f) != co.formats.end();
  };
  eo.mbdyn = has("mbdyn");
  eo.op4 = has("op4");
  eo.dmig = has("dmig");
  eo.mtx = has("mtx");
  eo.mbdyn_all_nodes = co.nodes == "all";
  eo.spoint_offset = co.spoint_offset;
  if (!co.op4_names.empty()) {
    eo.names.op4_K = co.op4_names[0];
    eo.names.op4_M = co.op4_names[1];
    if (co.op4_names.size() > 2) eo.names.op4_C = co.op4_names[2];
  }
  if (!co.dmig_names.empty()) {
    eo.names.dmig_K = co.dmig_names[0];
    eo.names.dmig_M = co.dmig_names[1];
    if (co.dmig_names.size() > 2) eo.names.dmig_C = co.dmig_names[2];
  }

  std::string err;
  io::Superelement se;
  io::ExportResult res;
  {
    StageTimer t(comm, "Export");
    if (rank_of(comm) == 0) try {
        se = io::read_superelement(co.from);
        if (!co.coordinates.empty()) io::set_boundary_coordinates(&se, co.coordinates);
        res = io::export_superelement(se, eo);
      } catch (const std::exception& e) {
        err = e.what();
      }
    collective_check(comm, err);
  }
  print0(comm,
         "morse export: %s: %d DOFs = %d boundary DOFs (%zu nodes) + %d fixed-interface modes%s, "
         "units %s\n",
         co.from.c_str(), se.n, se.n_b, se.boundary_nodes.size(), se.n_modes(),
         se.C.empty() ? "" : ", with C", se.units.c_str());
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
             in.inertia_cm[0], in.inertia_cm[1], in.inertia_cm[2], in.inertia_cm[3],
             in.inertia_cm[4], in.inertia_cm[5], in.inertia_cm[6], in.inertia_cm[7],
             in.inertia_cm[8]);
    } else {
      print0(comm, "  no rigid-body inertia in the FEM file: %s\n", in.reason.c_str());
    }
  }
  if (eo.dmig)
    print0(comm, "  DMIG: modal coordinate k is SPOINT %lld+k\n",
           static_cast<long long>(res.spoint_offset));
  for (const auto& f : res.files) print0(comm, "morse: wrote %s\n", f.c_str());
}

}  // namespace morse::app::detail
