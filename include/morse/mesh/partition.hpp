// morse/mesh/partition.hpp: METIS partition of a serial mesh and its scatter over the ranks.
//
// How a mesh is read and scattered: rank 0 reads the file (or runs a generator) into a serial
// Mesh, drops nodes that no solid element uses, partitions the element dual graph with METIS
// (corner nodes only, deterministic seed), decides node ownership (the lowest rank among the
// elements touching the node) and sends each rank its piece: its elements, the nodes they use
// (owned + ghost), the restriction of every set to those, and the materials. Rank 0 builds and
// sends one piece at a time and releases the serial mesh afterwards, so after distribute() no
// rank holds the whole mesh. (Rank 0 does hold it while reading; a ParMETIS-based parallel
// reader can replace this stage without changing LocalMesh.)
#pragma once

#include <mpi.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "morse/mesh/mesh.hpp"

namespace morse::mesh {

/// The piece of a distributed mesh held by one rank.
struct LocalMesh {
  MPI_Comm comm = MPI_COMM_NULL;
  /// Local elements and local nodes (owned and ghost), sorted by global node index. Sets are
  /// restricted to local nodes/elements; every rank knows every set name (possibly empty).
  Mesh mesh;
  std::vector<std::int64_t> global_node;  ///< global node index (0..n_global_nodes-1) per local node
  std::vector<int> node_owner;            ///< owning rank per local node
  std::vector<std::int64_t> global_elem;  ///< global element index per local element
  std::int64_t n_global_nodes = 0;
  std::int64_t n_global_elements = 0;
  /// Global number of nodes/elements in each set (after dropping unused nodes).
  std::map<std::string, std::int64_t> node_set_sizes;
  std::map<std::string, std::int64_t> elem_set_sizes;
  /// Number of elements per rank (for the summary).
  std::vector<std::int64_t> elements_per_rank;

  bool owns(std::int64_t local_node) const;
  /// Local index of a global node index, or -1 if the node is not local.
  std::int64_t local_of_global(std::int64_t global) const;
};

/// Checks that node set `name` exists and is not empty. Returns "" if so, else a message that
/// starts with `role` (e.g. "boundary node set") and lists the sets of the mesh. Not collective
/// (every rank knows every set name and global size, so every rank gets the same answer).
std::string check_node_set(const LocalMesh& lm, const std::string& name, const std::string& role);

/// Adds node set `name` made of the nodes with external ids `ids` (Nastran SET1 / Abaqus *NSET
/// given on the command line). Throws (collectively) if the name is taken, `ids` is empty, or an
/// id is not a node of the (distributed) mesh; `role` starts the message (e.g. the option name).
/// Collective.
void add_node_set(LocalMesh* lm, const std::string& name, const std::vector<std::int64_t>& ids,
                  const std::string& role);

/// How add_spiders joins a point to the nodes around it.
enum class SpiderType { Rigid, Interpolation };

/// Adds a spider at every node of each node set in `sets`: a six-DOF point at the node's
/// position (new ids above every node id of the mesh, in set order then node id order) joined
/// to every node within `radius` of it (the node included) by a rigid element (RBE2, all six
/// components) or an interpolation element (RBE3, weights 1, translations, reference 123456). The
/// points of set S form the new node set "S_spiders"; a point also joins "T_spiders" for every
/// other node set T (not in `sets`) that holds its centre node, so that the sets naming interface
/// nodes (a bearing seat, a lug) name their points. For meshes that cannot carry rigid elements
/// (Gmsh) and decks whose interface nodes are bare solid nodes. Throws (collectively) for an
/// unknown or empty set, a set holding points, a radius that is not positive and finite, or a
/// set name S_spiders or T_spiders that exists. Collective.
void add_spiders(LocalMesh* lm, const std::vector<std::string>& sets, double radius, SpiderType type);

/// Partitions *serial (significant on rank 0 only; emptied on return) and scatters it over comm.
/// Collective. Throws morse::Error (on every rank) if the mesh has no solid element.
LocalMesh distribute(MPI_Comm comm, Mesh* serial);

/// Reads a mesh on rank 0 by extension (.msh: Gmsh, .inp: Abaqus, .bdf/.dat/.nas/.blk: Nastran) and
/// distributes it. Errors (missing/truncated file, ...) are thrown on every rank. Collective.
/// skip_unsupported: Nastran element cards that morse cannot represent are skipped with a
/// warning instead of being an error (mesh/nastran.hpp).
LocalMesh read_and_distribute(MPI_Comm comm, const std::string& path, bool skip_unsupported = false);

/// Gathers the local pieces back into one serial mesh on rank 0 (owned elements only, nodes in
/// global order); other ranks get an empty Mesh. For output of small and medium meshes only:
/// O(mesh) memory on rank 0. Collective.
Mesh gather_to_rank0(const LocalMesh& lm);

}  // namespace morse::mesh
