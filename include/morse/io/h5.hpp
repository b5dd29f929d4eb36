// morse/io/h5.hpp: the output file of a run, written by rank 0 with serial HDF5, atomically.
//
// The file is created as the temporary files::temp_path(comm, path) ("<path>.tmp.<pid of rank 0>")
// and renamed to <path> by commit(); a run that fails before commit() leaves no output file (the
// destructor removes the temporary). Distributed data
// is gathered to rank 0 before writing (gather_nodal), one mode at a time.
#pragma once

#include <hdf5.h>
#include <mpi.h>
#include <petscmat.h>
#include <petscvec.h>

#include <cstdint>
#include <string>
#include <vector>

#include "morse/fe/model.hpp"

namespace morse::io {

class H5Output {
 public:
  /// Creates the temporary file on rank 0. Collective; throws on every rank if it cannot.
  H5Output(MPI_Comm comm, const std::string& path);
  ~H5Output();
  H5Output(const H5Output&) = delete;
  H5Output& operator=(const H5Output&) = delete;

  /// Dataset writers; data significant on rank 0 only. dims empty = 1-D of data.size().
  /// Intermediate groups are created. Not collective.
  void write(const std::string& name, const std::vector<double>& data, std::vector<hsize_t> dims = {});
  void write(const std::string& name, const std::vector<std::int64_t>& data, std::vector<hsize_t> dims = {});
  void write_string(const std::string& name, const std::string& value);
  /// A dataset of doubles of shape dims written one row (first index) at a time, so that rank 0
  /// never holds all of it: create_rows, then write_row for each row (data = the row, of the
  /// product of the other dims). Rank 0 data; not collective.
  void create_rows(const std::string& name, const std::vector<hsize_t>& dims);
  void write_row(const std::string& name, hsize_t row, const std::vector<double>& data);
  /// Attribute on a group or dataset (created if missing as a group). Not collective.
  void attribute(const std::string& object, const std::string& name, const std::string& value);
  void attribute(const std::string& object, const std::string& name, double value);
  void attribute_int(const std::string& object, const std::string& name, std::int64_t value);

  /// Closes and renames the file into place. Collective; throws on every rank if rank 0 met an
  /// HDF5 error in any write.
  void commit();

  const std::string& path() const { return path_; }
  /// The temporary file being written (renamed to path() by commit()).
  const std::string& tmp_path() const { return tmp_; }

  /// Closes rank 0's handle so that all ranks can open tmp_path() with H5SliceWriter (parallel
  /// HDF5), and reopens it. Collective; throws on every rank if rank 0 cannot.
  void suspend();
  void resume();

 private:
  hid_t ensure_group(const std::string& name);
  hid_t open_object(const std::string& object);
  void note_error(const std::string& what);
  MPI_Comm comm_;
  int rank_ = 0;
  std::string path_, tmp_;
  hid_t file_ = -1;
  std::string error_;
  bool committed_ = false;
};

/// Parallel writer of distributed data into an existing HDF5 file (between H5Output::suspend()
/// and resume()): all ranks open the file with MPI-IO, and each rank writes its contiguous slice
/// [first, first + n_local) of every row of 2-D datasets (n_rows x n_global) or of 1-D datasets.
/// No rank holds more than its own slice. Collective throughout; HDF5 failures throw on every
/// rank.
class H5SliceWriter {
 public:
  H5SliceWriter(MPI_Comm comm, const std::string& file, std::int64_t n_global, std::int64_t first,
                std::int64_t n_local);
  ~H5SliceWriter();
  H5SliceWriter(const H5SliceWriter&) = delete;
  H5SliceWriter& operator=(const H5SliceWriter&) = delete;

  /// Creates a dataset of doubles (n_rows x n_global; n_rows = 0: 1-D of n_global). Returns its index.
  int create(const std::string& name, std::int64_t n_rows);
  /// Creates a 1-D int64 dataset of n_global and writes this rank's slice of it.
  void write_int(const std::string& name, const std::vector<std::int64_t>& local);
  /// Writes this rank's slice of row `row` (ignored for 1-D) from a PETSc vector with the layout
  /// (first, n_local).
  void write_row(int dataset, std::int64_t row, Vec x);
  void attribute(const std::string& object, const std::string& name, const std::string& value);
  /// Closes the file. Collective.
  void close();

 private:
  void check(bool ok, const std::string& what);
  MPI_Comm comm_;
  std::string file_name_;
  hid_t file_ = -1, dxpl_ = -1;
  std::vector<hid_t> sets_;
  std::vector<bool> two_d_;
  std::int64_t n_global_, first_, n_local_;
};

/// Reads a nodal field (dataset of shape [..][n_nodes][3] or [n_nodes][3]; the last field is
/// taken) and its node ids (/mesh/node_ids) from a morse HDF5 file, and scatters it onto the free
/// DOFs of x by node id. Rank 0 reads and broadcasts (O(nodes) memory per rank). Throws
/// (collectively) naming the file and dataset if either is missing, or if the file lacks a node
/// of the mesh. Collective.
void read_nodal_field(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::string& file,
                      const std::string& dataset, Vec x);

/// Reads the full-field rows of a `morse fom` snapshot dataset (e.g. /fom/snapshots/u, shaped
/// n_rows x n_file_dofs, with /<group>/dof_node_ids and /dof_components beside it) into an
/// MPIDENSE matrix X (n_free x n_rows, K's row layout): column k is row k, mapped onto this
/// model's free DOFs by node id and component, so the writing run's rank count and partition do
/// not matter. Every rank reads one row at a time (no rank holds the snapshot matrix). Throws
/// (collectively) naming the file and dataset if either is missing or the file lacks a free DOF
/// of the model. Collective.
UMat read_dof_rows(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::string& file,
                   const std::string& dataset);

/// Serial reads of one dataset (any rank, no communication): the values and the shape. Return
/// false and set *error (naming the file and dataset) if the file or dataset is missing, or, for
/// read_ints, if a floating-point dataset holds a value that is not an integer.
bool read_doubles(const std::string& file, const std::string& name, std::vector<double>* out,
                  std::vector<hsize_t>* dims, std::string* error);
bool read_ints(const std::string& file, const std::string& name, std::vector<std::int64_t>* out,
               std::vector<hsize_t>* dims, std::string* error);
/// True if `file` opens as HDF5 and holds the object (group or dataset) `name` (every link on
/// its path existing). Serial, any rank; never prints HDF5's error stack.
bool has_object(const std::string& file, const std::string& name);
/// A scalar string dataset (as written by H5Output::write_string, e.g. /meta/units).
bool read_string(const std::string& file, const std::string& name, std::string* out, std::string* error);
/// A scalar numeric attribute `name` of `object` (a group or dataset), as a double.
bool read_attribute(const std::string& file, const std::string& object, const std::string& name, double* out,
                    std::string* error);
/// A string attribute `name` of `object` (fixed or variable length), or "" if the file, the
/// object or the attribute is missing or not a string. Serial, any rank.
std::string read_string_attribute(const std::string& file, const std::string& object, const std::string& name);
/// Row `row` of a 2-D dataset of doubles (one hyperslab, not the whole dataset).
bool read_double_row(const std::string& file, const std::string& name, std::int64_t row, std::vector<double>* out,
                     std::string* error);

/// Gathers a free-DOF vector into nodal displacements on rank 0: 3 values per global node in
/// global node order, 0 for eliminated DOFs. Other ranks get an empty vector. Collective.
std::vector<double> gather_nodal(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, Vec x);

/// Writes the standard provenance of every morse file: /meta (version, command line, options,
/// units, date) and a units attribute at the root. Rank 0 data. Not collective.
void write_provenance(H5Output& out, const std::string& command, const std::string& units);

/// Writes /mesh/coordinates, /mesh/node_ids, /mesh/topology (XDMF mixed), /mesh/element_ids
/// from a mesh gathered on rank 0 (gather_to_rank0). Not collective.
void write_mesh(H5Output& out, const mesh::Mesh& m);

/// Every node set of the distributed mesh as a dataset <group>/<SET> of external node ids,
/// ascending (e.g. /mesh/node_sets, read back by `morse rampup` for bearing and clamp nodes;
/// /nlrom/node_sets, read by nlrom::read_stored_model). Collective (gathers on rank 0).
void write_node_sets(H5Output& out, const mesh::LocalMesh& lm, const std::string& group);

/// Columns first .. first + count - 1 of V (MPIDENSE, rows = the model's free DOFs) as dataset
/// `name`: [count][node][x,y,z] for a mesh model (nodes in global order, 0 at eliminated DOFs),
/// [count][row] for a matrix model (rows as /dofs), gathered and written one column at a time, so
/// that rank 0 never holds more than one (mode shapes, constraint modes). Collective.
void write_modes_dataset(H5Output& out, const std::string& name, const fe::Model& md, Mat V, PetscInt first,
                         PetscInt count);

/// The modes of the full model (`morse modes`): <group>/frequencies_hz, <group>/eigenvalues
/// (omega2, ascending) and <group>/mode_shapes (the columns of V as in write_modes_dataset,
/// mass-normalized, with its description). Collective.
void write_modes(H5Output& out, const std::string& group, const fe::Model& md, const std::vector<double>& omega2,
                 Mat V);

/// The model description of an output file: /mesh and /mesh/node_sets (mesh model) or /dofs
/// (matrix model: write_dof_labels of its rows and matrix files). Collective.
void write_model(H5Output& out, const fe::Model& md);

/// /dofs of a model given by its matrices (matrix input, docs/hdf5-schema.md): the node id and
/// component (1..6) of every free row in row order (gathered on rank 0), the matrix files
/// (source) and the number of rows of the files. Rank 0 data; not collective.
void write_dof_labels(H5Output& out, const std::vector<std::int64_t>& node, const std::vector<std::int64_t>& component,
                      const std::string& source, std::int64_t n_rows_file);

/// Writes an XDMF file next to the HDF5 file that shows the mesh and, for each listed dataset
/// (shape [count][n][components], n = nodes or, with cell, elements), one field per entry, named
/// label_k: a vector (3 components), a scalar (1; the dataset is then [count][n]) or a symmetric
/// tensor (6, XDMF Tensor6, which ParaView reads in the order xx xy xz yy yz zz). Rank 0 only.
struct XdmfField {
  std::string dataset;
  std::string label;
  int count = 0;
  int components = 3;
  bool cell = false;
};
void write_xdmf(const std::string& xdmf_path, const std::string& h5_name, const mesh::Mesh& m,
                const std::vector<XdmfField>& fields);

}  // namespace morse::io
