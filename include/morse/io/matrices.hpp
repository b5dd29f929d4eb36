// morse/io/matrices.hpp: the matrix formats of a model given by its assembled operators (Nastran
// DMAP export, another FE code, or morse itself): parallel readers and writers of sparse
// matrices and the DOF map that names each row. The model made of them (clamp, sets, symmetry
// checks, labels) is io/matrix_model.hpp.
//
// Matrix files, chosen by extension (docs/user-guide.md "From Nastran"):
//   .mtx .mm      MatrixMarket coordinate real|integer, general|symmetric (either triangle of a
//                 symmetric file; an entry given twice is an error). Every rank parses its own
//                 byte range of the file, in blocks, and sends each entry to the owner of its row.
//   .petsc .bin   PETSc binary (MatLoad: rank 0 reads and sends row blocks).
//   .op4          Nastran OUTPUT4, ASCII or binary, dense or sparse (io/op4.hpp). A file holding
//                 several matrices is read as FILE.op4:NAME (e.g. stator.op4:KAA); without :NAME
//                 the first matrix is read. Rank 0 streams the columns and sends them, in blocks,
//                 to the owners of their rows.
// No rank ever holds the whole matrix: rows are owned in contiguous blocks (PETSc's default
// split), and entries travel in rounds of at most kRouteBlock entries per rank.
//
// DOF map (-matrices_dofmap): what each row is.
//   text  one line per row, in row order: `node component [set ...]`, component 1..6 (1..3 the
//         x, y, z translations, 4..6 rotations); '#' starts a comment. The optional set names put
//         the row in those row sets (e.g. `1001 1 interface`).
//   .h5   /dofmap/node (int64, n), /dofmap/component (int64, n), and optionally
//         /dofmap/sets/<name> (int64 row indices, 0-based).
// Without a DOF map, row r (0-based) is node r/3 + 1, component r%3 + 1 (three translations per
// node, nodes numbered from 1).
#pragma once

#include <petscmat.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "morse/core/handle.hpp"
#include "morse/fe/model.hpp"
#include "morse/mesh/partition.hpp"

namespace morse::io {

enum class MatrixFormat { MatrixMarket, PetscBinary, Op4 };

/// Format of a matrix file (or FILE.op4:NAME) from its extension. Throws morse::Error naming the
/// file for an unknown extension.
MatrixFormat matrix_format(const std::string& spec);
/// The file of a matrix spec: FILE of FILE.op4:NAME, else the spec itself. Not collective.
std::string matrix_file(const std::string& spec);

/// Reads a square matrix into an MPIAIJ matrix whose rows are split in contiguous blocks
/// (n_local rows here; PETSC_DECIDE: PETSc's default split). `what` names the matrix in messages
/// (e.g. "-matrices_K"). Throws (collectively) naming the file (and line for text formats) on a
/// missing file, a malformed or unsupported header, an entry out of range, a duplicate entry, a
/// non-finite value or a non-square matrix. Collective.
UMat read_matrix(MPI_Comm comm, const std::string& spec, const std::string& what, PetscInt n_local = PETSC_DECIDE);

/// Writes A as MatrixMarket (.mtx/.mm; `symmetric`: the lower triangle with the symmetric header,
/// else general) or PETSc binary (.petsc/.bin). Values round-trip exactly (%.17g). Rank 0 writes
/// to a temporary file, receiving one rank's rows at a time, and renames it at the end.
/// Collective.
void write_matrix(Mat A, const std::string& path, bool symmetric);

/// The DOF map of a matrix model (see the file comment).
struct DofMapFile {
  std::vector<std::int64_t> node;                         ///< node id per row
  std::vector<int> component;                             ///< 1..6 per row
  std::map<std::string, std::vector<std::int64_t>> sets;  ///< row sets, 0-based rows, ascending
};

/// Reads a DOF map on the calling rank (serial). n_rows is the matrix size: a map with more or
/// fewer rows, a bad component, a (node, component) pair given twice or a set row out of range
/// is an error naming the file and line (or dataset).
DofMapFile read_dof_map(const std::string& path, std::int64_t n_rows);

/// Writes a DOF map as text (serial).
void write_dof_map(const std::string& path, const DofMapFile& map);

/// The DOF map of a mesh model's free DOFs (row = global free DOF: node id, component 1..3) with
/// every node set as a row set, on rank 0 (other ranks get an empty map). Collective.
DofMapFile mesh_dof_map(const mesh::LocalMesh& lm, const fe::DofLayout& dofs);

}  // namespace morse::io
