// io/export_options.cpp: the options of `morse export` (io::ExportOptions::set_from_options).
#include <petscsys.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <tuple>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/options.hpp"
#include "morse/io/export.hpp"

namespace morse::io {

PetscErrorCode ExportOptions::set_from_options(MPI_Comm comm) {
  std::vector<std::string> formats, op4_names, dmig_names;
  PetscCall(options::get_string_list(
      comm, "-export_format", "Formats to write, comma separated: mbdyn, op4, dmig, mtx (default: all)", &formats));
  PetscCall(options::get_string_list(comm, "-export_op4_names",
                                     "Names of K, M, C in the OP4 file (default KAA,MAA,BAA)", &op4_names));
  PetscCall(options::get_string_list(
      comm, "-export_dmig_names",
      "Names of the K, M, C DMIG matrices (case control K2GG, M2GG, B2GG; default KAAX,MAAX,BAAX)", &dmig_names));
  char buf[PETSC_MAX_PATH_LEN] = "";
  PetscBool set = PETSC_FALSE;
  std::string nodes = mbdyn_all_nodes ? "all" : "interface";
  PetscInt offset = static_cast<PetscInt>(spoint_offset);
  PetscOptionsBegin(comm, nullptr, "morse export options", "");
  PetscCall(MorseOptionsString("-export_from", "Superelement file of morse reduce or morse select (required)", "", buf,
                               buf, sizeof buf, &set));
  if (set) from = buf;
  buf[0] = 0;
  PetscCall(
      MorseOptionsString("-out",
                         "Output prefix: PREFIX.fem, PREFIX.op4, PREFIX_dmig.bdf, PREFIX_grids.bdf, PREFIX_K.mtx, "
                         "PREFIX_M.mtx, PREFIX_C.mtx, PREFIX_dofs.txt (default: -export_from without .h5)",
                         "", buf, buf, sizeof buf, &set));
  if (set) prefix = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-export_coordinates",
                               "Text file 'node x y z' per line: interface node coordinates for a file without /mesh "
                               "(matrix input); replaces those of /mesh",
                               "", buf, buf, sizeof buf, &set));
  if (set) coordinates = buf;
  buf[0] = 0;
  PetscCall(MorseOptionsString("-export_mbdyn_nodes",
                               "Nodes of the MBDyn FEM file: interface, or all (every mesh node; needs a file of "
                               "morse reduce -cb_write_basis)",
                               "", nodes.c_str(), buf, sizeof buf, &set));
  if (set) nodes = buf;
  PetscCall(MorseOptionsInt("-export_spoint_offset",
                            "DMIG: modal coordinate k is SPOINT offset+k (default: the smallest power of ten above "
                            "every node id of the file)",
                            "", offset, &offset, nullptr));
  PetscOptionsEnd();
  if (prefix.empty()) {
    prefix = from;
    if (prefix.size() > 3 && prefix.compare(prefix.size() - 3, 3, ".h5") == 0) prefix.resize(prefix.size() - 3);
  }
  auto bad = [&](const std::string& e) {
    if (error.empty()) error = e;
  };
  if (!formats.empty()) {
    auto has = [&](const char* f) { return std::find(formats.begin(), formats.end(), f) != formats.end(); };
    mbdyn = has("mbdyn");
    op4 = has("op4");
    dmig = has("dmig");
    mtx = has("mtx");
  }
  static const std::vector<std::string> known = {"mbdyn", "op4", "dmig", "mtx"};
  for (const auto& f : formats)
    if (std::find(known.begin(), known.end(), f) == known.end())
      bad(cat("-export_format ", f, ": unknown format (mbdyn, op4, dmig, mtx)"));
  if (nodes != "interface" && nodes != "all") bad(cat("-export_mbdyn_nodes ", nodes, ": expected interface or all"));
  mbdyn_all_nodes = nodes == "all";
  if (offset < 0) bad(cat("-export_spoint_offset must be >= 0 (got ", offset, ")"));
  spoint_offset = offset;
  for (const auto* list : {&op4_names, &dmig_names})
    if (!list->empty() && (list->size() < 2 || list->size() > 3))
      bad(cat(list == &op4_names ? "-export_op4_names" : "-export_dmig_names", " takes 2 or 3 names: K,M[,C]"));
  if (op4_names.size() >= 2 && op4_names.size() <= 3) {
    names.op4_K = op4_names[0];
    names.op4_M = op4_names[1];
    if (op4_names.size() > 2) names.op4_C = op4_names[2];
  }
  if (dmig_names.size() >= 2 && dmig_names.size() <= 3) {
    names.dmig_K = dmig_names[0];
    names.dmig_M = dmig_names[1];
    if (dmig_names.size() > 2) names.dmig_C = dmig_names[2];
  }
  // One file holds K, M and C: a reader finds matrices by name (Nastran ignores case).
  auto upper = [](std::string n) {
    for (char& c : n) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return n;
  };
  for (const auto& [option, k, m, c] :
       {std::make_tuple("-export_op4_names", names.op4_K, names.op4_M, names.op4_C),
        std::make_tuple("-export_dmig_names", names.dmig_K, names.dmig_M, names.dmig_C)}) {
    const std::string n[3] = {k, m, c};
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j)
        if (upper(n[i]) == upper(n[j]))
          bad(cat(option, ": the names of K, M, C (", k, ", ", m, ", ", c, ") must differ: ", n[j], " is given twice"));
  }
  return PETSC_SUCCESS;
}

}  // namespace morse::io
