#include <algorithm>
#include <cctype>

#include "morse/core/error.hpp"
#include "morse/mesh/abaqus.hpp"
#include "morse/mesh/gmsh.hpp"
#include "morse/mesh/nastran.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::mesh {

LocalMesh read_and_distribute(MPI_Comm comm, const std::string& path, bool skip_unsupported) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  Mesh serial;
  std::string err;
  if (rank == 0) {
    try {
      auto dot = path.rfind('.');
      std::string ext = dot == std::string::npos ? "" : path.substr(dot + 1);
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      if (ext == "msh")
        serial = read_gmsh(path);
      else if (ext == "inp")
        serial = read_abaqus(path, true);
      else if (ext == "bdf" || ext == "dat" || ext == "nas" || ext == "blk")
        serial = read_nastran(path, true, skip_unsupported);
      else
        err = cat("mesh file ", path, ": unknown format (expected .msh for Gmsh, .inp for",
                  " Abaqus/CalculiX or .bdf, .dat, .nas, .blk for Nastran bulk data)");
    } catch (const Error& e) {
      err = e.what();
    } catch (const std::exception& e) {
      err = cat("reading ", path, ": ", message_of(e));
    }
  }
  collective_check(comm, err);
  return distribute(comm, &serial);
}

}  // namespace morse::mesh
