// A model given by its assembled operators: parallel matrix readers and writers, DOF maps, the
// matrix model (io/matrices.hpp).
#include "morse/io/matrices.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numeric>
#include <set>
#include <sstream>
#include <unordered_set>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/io/h5.hpp"
#include "morse/io/op4.hpp"

namespace morse::io {

namespace {

namespace fs = std::filesystem;

/// Entries per rank and round of the routing of matrix entries to their row owners.
constexpr std::size_t kRouteBlock = std::size_t(1) << 21;

struct Entry {
  PetscInt i, j;
  double v;
};

int comm_rank(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}
int comm_size(MPI_Comm comm) {
  int s = 1;
  MPI_Comm_size(comm, &s);
  return s;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

/// The file part and the optional matrix name of FILE.op4:NAME.
std::pair<std::string, std::string> split_spec(const std::string& spec) {
  auto colon = spec.rfind(':');
  if (colon != std::string::npos && spec.find('/', colon) == std::string::npos && !fs::exists(spec)) {
    std::string file = spec.substr(0, colon);
    if (lower(fs::path(file).extension().string()) == ".op4") return {file, spec.substr(colon + 1)};
  }
  return {spec, ""};
}

/// Contiguous row blocks: ranges[r]..ranges[r+1] are the rows of rank r.
std::vector<PetscInt> row_ranges(MPI_Comm comm, PetscInt n_global, PetscInt n_local) {
  MORSE_CALL(PetscSplitOwnership(comm, &n_local, &n_global));
  const int size = comm_size(comm);
  std::vector<PetscInt> counts(size);
  MPI_Allgather(&n_local, 1, MPIU_INT, counts.data(), 1, MPIU_INT, comm);
  std::vector<PetscInt> ranges(size + 1, 0);
  for (int r = 0; r < size; ++r) ranges[r + 1] = ranges[r] + counts[r];
  return ranges;
}

/// Sends matrix entries to the owners of their rows, in rounds. Every rank calls run() with its
/// producer: produce(&buf) appends at most kRouteBlock entries and returns true while it has more.
class Router {
 public:
  Router(MPI_Comm comm, std::vector<PetscInt> ranges) : comm_(comm), ranges_(std::move(ranges)) {}

  template <class Produce>
  void run(Produce produce) {
    bool more = true;
    std::vector<Entry> buf;
    while (any_rank(comm_, more)) {
      buf.clear();
      if (more) more = produce(&buf);
      exchange(buf);
    }
  }
  std::vector<Entry>& received() { return mine_; }

 private:
  int owner(PetscInt i) const {
    return static_cast<int>(std::upper_bound(ranges_.begin(), ranges_.end(), i) - ranges_.begin()) - 1;
  }
  void exchange(const std::vector<Entry>& buf) {
    const int size = comm_size(comm_);
    std::vector<std::vector<Entry>> out(size);
    for (const auto& e : buf) out[owner(e.i)].push_back(e);
    std::vector<int> sc(size), rc(size), sd(size, 0), rd(size, 0);
    for (int r = 0; r < size; ++r) sc[r] = static_cast<int>(out[r].size() * sizeof(Entry));
    MPI_Alltoall(sc.data(), 1, MPI_INT, rc.data(), 1, MPI_INT, comm_);
    std::vector<Entry> send;
    send.reserve(buf.size());
    for (int r = 0; r < size; ++r) {
      sd[r] = static_cast<int>(send.size() * sizeof(Entry));
      send.insert(send.end(), out[r].begin(), out[r].end());
    }
    std::size_t total = 0;
    for (int r = 0; r < size; ++r) rd[r] = static_cast<int>(total), total += rc[r];
    const std::size_t old = mine_.size();
    mine_.resize(old + total / sizeof(Entry));
    MPI_Alltoallv(send.data(), sc.data(), sd.data(), MPI_BYTE, reinterpret_cast<char*>(mine_.data() + old), rc.data(),
                  rd.data(), MPI_BYTE, comm_);
  }

  MPI_Comm comm_;
  std::vector<PetscInt> ranges_;
  std::vector<Entry> mine_;
};

/// Builds the MPIAIJ matrix of the entries received by each rank (rows ranges[rank].., sorted
/// here). An entry given twice is an error naming the file. Collective.
UMat build_matrix(MPI_Comm comm, const std::vector<PetscInt>& ranges, PetscInt n, std::vector<Entry>& mine,
                  const std::string& file) {
  const int rank = comm_rank(comm);
  const PetscInt first = ranges[rank], m = ranges[rank + 1] - first;
  std::sort(mine.begin(), mine.end(),
            [](const Entry& a, const Entry& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; });
  std::string err;
  for (std::size_t k = 1; k < mine.size() && err.empty(); ++k)
    if (mine[k].i == mine[k - 1].i && mine[k].j == mine[k - 1].j)
      err = cat(file, ": entry (", mine[k].i + 1, ", ", mine[k].j + 1,
                ") is given twice (for a symmetric file: in both triangles)");
  collective_check(comm, err);
  std::vector<PetscInt> ia(m + 1, 0), ja(mine.size());
  std::vector<PetscScalar> va(mine.size());
  for (std::size_t k = 0; k < mine.size(); ++k) {
    ++ia[mine[k].i - first + 1];
    ja[k] = mine[k].j;
    va[k] = mine[k].v;
  }
  for (PetscInt r = 0; r < m; ++r) ia[r + 1] += ia[r];
  std::vector<Entry>().swap(mine);
  UMat A;
  MORSE_CALL(MatCreateMPIAIJWithArrays(comm, m, m, n, n, ia.data(), ja.data(), va.data(), A.ptr()));
  return A;
}

/// Line number (1-based) of byte `offset` of a file: counts the newlines before it.
long line_of_offset(const std::string& path, std::int64_t offset) {
  std::ifstream f(path, std::ios::binary);
  long line = 1;
  std::vector<char> buf(1 << 16);
  std::int64_t left = offset;
  while (left > 0 && f) {
    f.read(buf.data(), static_cast<std::streamsize>(std::min<std::int64_t>(left, buf.size())));
    auto got = f.gcount();
    line += static_cast<long>(std::count(buf.data(), buf.data() + got, '\n'));
    left -= got;
  }
  return line;
}

struct MmHeader {
  std::int64_t rows = 0, cols = 0, nnz = 0, data_offset = 0, file_size = 0;
  int symmetric = 0;
};

// Rank 0: the banner, comments and size line of a MatrixMarket file.
std::string read_mm_header(const std::string& path, MmHeader* h) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return cat(path, ": cannot open the file");
  std::string line;
  long ln = 1;
  if (!std::getline(f, line)) return cat(path, ":1: empty file (expected a %%MatrixMarket banner)");
  std::istringstream is(line);
  std::string banner, object, format, field, symmetry;
  is >> banner >> object >> format >> field >> symmetry;
  if (lower(banner) != "%%matrixmarket")
    return cat(path, ":1: not a MatrixMarket file (the first line must start with %%MatrixMarket)");
  if (lower(object) != "matrix") return cat(path, ":1: MatrixMarket object '", object, "': only 'matrix' is supported");
  if (lower(format) != "coordinate")
    return cat(path, ":1: MatrixMarket format '", format, "': only 'coordinate' (sparse) is supported");
  field = lower(field);
  if (field != "real" && field != "integer" && field != "double")
    return cat(path, ":1: MatrixMarket field '", field,
               "': only real and integer are supported (not complex or pattern)");
  symmetry = lower(symmetry);
  if (symmetry != "general" && symmetry != "symmetric")
    return cat(path, ":1: MatrixMarket symmetry '", symmetry, "': only general and symmetric are supported");
  h->symmetric = symmetry == "symmetric";
  while (std::getline(f, line)) {
    ++ln;
    auto p = line.find_first_not_of(" \t\r");
    if (p == std::string::npos || line[p] == '%') continue;
    std::istringstream s(line);
    std::string extra;
    if (!(s >> h->rows >> h->cols >> h->nnz) || (s >> extra) || h->rows < 1 || h->cols < 1 || h->nnz < 0)
      return cat(path, ":", ln, ": expected the size line 'rows columns entries', found '", line, "'");
    h->data_offset = f.tellg();
    if (h->data_offset < 0) {  // the size line was the last line, without a newline
      f.clear();
      f.seekg(0, std::ios::end);
      h->data_offset = f.tellg();
    }
    f.seekg(0, std::ios::end);
    h->file_size = f.tellg();
    return {};
  }
  return cat(path, ": no size line after the banner");
}

UMat read_matrix_market(MPI_Comm comm, const std::string& path, const std::string& what, PetscInt n_local) {
  MmHeader h;
  std::string err;
  if (comm_rank(comm) == 0) err = read_mm_header(path, &h);
  collective_check(comm, err.empty() ? err : cat(what, " ", err));
  MPI_Bcast(&h, sizeof h, MPI_BYTE, 0, comm);
  MORSE_CHECK(h.rows == h.cols, what, " ", path, ": the matrix is ", h.rows, " x ", h.cols, ", not square");
  const auto ranges = row_ranges(comm, static_cast<PetscInt>(h.rows), n_local);
  // This rank parses the lines that start in its byte range.
  const int rank = comm_rank(comm), size = comm_size(comm);
  const std::int64_t len = h.file_size - h.data_offset;
  std::int64_t begin = h.data_offset + len * rank / size, end = h.data_offset + len * (rank + 1) / size;
  std::ifstream f(path, std::ios::binary);
  std::int64_t pos = begin;
  if (!f) err = cat(what, " ", path, ": cannot open the file");
  if (err.empty() && rank > 0 && begin > h.data_offset) {
    f.seekg(begin - 1);
    char c = 0;
    f.get(c);
    if (c != '\n') {
      std::string skip;
      std::getline(f, skip);
      pos = begin + static_cast<std::int64_t>(skip.size()) + 1;
    }
  } else if (err.empty()) {
    f.seekg(begin);
  }
  std::int64_t count = 0, bad_offset = -1;
  std::string bad;
  Router router(comm, ranges);
  router.run([&](std::vector<Entry>* buf) {
    std::string line;
    while (err.empty() && bad.empty() && pos < end && buf->size() + 2 <= kRouteBlock) {
      const std::int64_t at = pos;
      if (!std::getline(f, line)) break;
      pos += static_cast<std::int64_t>(line.size()) + 1;
      const char* s = line.c_str();
      while (*s == ' ' || *s == '\t') ++s;
      if (*s == '\0' || *s == '\r' || *s == '%') continue;
      char* e1 = nullptr;
      char* e2 = nullptr;
      char* e3 = nullptr;
      long long i = std::strtoll(s, &e1, 10);
      long long j = std::strtoll(e1, &e2, 10);
      double v = std::strtod(e2, &e3);
      while (*e3 == ' ' || *e3 == '\t' || *e3 == '\r') ++e3;
      if (e1 == s || e2 == e1 || e3 == e2 || *e3 != '\0') {
        bad = cat("expected 'row column value', found '", line, "'");
      } else if (i < 1 || i > h.rows || j < 1 || j > h.cols) {
        bad = cat("entry (", i, ", ", j, ") is outside the ", h.rows, " x ", h.cols, " matrix");
      } else if (!std::isfinite(v)) {
        bad = cat("entry (", i, ", ", j, ") is not finite (", v, ")");
      }
      if (!bad.empty()) {
        bad_offset = at;
        break;
      }
      ++count;
      buf->push_back({static_cast<PetscInt>(i - 1), static_cast<PetscInt>(j - 1), v});
      if (h.symmetric && i != j) buf->push_back({static_cast<PetscInt>(j - 1), static_cast<PetscInt>(i - 1), v});
    }
    return err.empty() && bad.empty() && pos < end && f.good();
  });
  if (!bad.empty()) err = cat(what, " ", path, ":", line_of_offset(path, bad_offset), ": ", bad);
  collective_check(comm, err);
  std::int64_t total = 0;
  MPI_Allreduce(&count, &total, 1, MPI_INT64_T, MPI_SUM, comm);
  MORSE_CHECK(total == h.nnz, what, " ", path, ": the size line announces ", h.nnz, " entries but the file holds ",
              total);
  return build_matrix(comm, ranges, static_cast<PetscInt>(h.rows), router.received(), cat(what, " ", path));
}

UMat read_petsc_binary(MPI_Comm comm, const std::string& path, const std::string& what, PetscInt n_local) {
  std::int64_t head[4] = {0, 0, 0, 0};
  std::string err;
  if (comm_rank(comm) == 0) {
    std::ifstream f(path, std::ios::binary);
    unsigned char b[16];
    if (!f) {
      err = cat(what, " ", path, ": cannot open the file");
    } else if (!f.read(reinterpret_cast<char*>(b), 16)) {
      err = cat(what, " ", path, ": truncated PETSc binary header");
    } else {
      for (int k = 0; k < 4; ++k)  // big-endian int32
        head[k] = static_cast<std::int32_t>((std::uint32_t(b[4 * k]) << 24) | (std::uint32_t(b[4 * k + 1]) << 16) |
                                            (std::uint32_t(b[4 * k + 2]) << 8) | std::uint32_t(b[4 * k + 3]));
      if (head[0] != 1211216)
        err = cat(what, " ", path, ": not a PETSc binary matrix (class id ", head[0], ", expected 1211216)");
      else if (head[1] != head[2])
        err = cat(what, " ", path, ": the matrix is ", head[1], " x ", head[2], ", not square");
    }
  }
  collective_check(comm, err);
  MPI_Bcast(head, 4, MPI_INT64_T, 0, comm);
  const auto ranges = row_ranges(comm, static_cast<PetscInt>(head[1]), n_local);
  const int rank = comm_rank(comm);
  const PetscInt m = ranges[rank + 1] - ranges[rank];
  UMat A;
  PetscViewer v = nullptr;
  MORSE_CALL(PetscViewerBinaryOpen(comm, path.c_str(), FILE_MODE_READ, &v));
  MORSE_CALL(MatCreate(comm, A.ptr()));
  MORSE_CALL(MatSetType(A.get(), MATAIJ));
  MORSE_CALL(MatSetSizes(A.get(), m, m, static_cast<PetscInt>(head[1]), static_cast<PetscInt>(head[1])));
  PetscErrorCode ierr = MatLoad(A.get(), v);
  PetscViewerDestroy(&v);
  MORSE_CHECK(ierr == 0, what, " ", path, ": PETSc could not load the matrix (truncated or corrupt file)");
  // Non-finite values.
  PetscInt rs = 0, re = 0;
  MORSE_CALL(MatGetOwnershipRange(A.get(), &rs, &re));
  for (PetscInt i = rs; i < re && err.empty(); ++i) {
    PetscInt nc;
    const PetscInt* cols;
    const PetscScalar* vals;
    MORSE_CALL(MatGetRow(A.get(), i, &nc, &cols, &vals));
    for (PetscInt k = 0; k < nc; ++k)
      if (!std::isfinite(vals[k])) {
        err = cat(what, " ", path, ": entry (", i + 1, ", ", cols[k] + 1, ") is not finite");
        break;
      }
    MORSE_CALL(MatRestoreRow(A.get(), i, &nc, &cols, &vals));
  }
  collective_check(comm, err);
  return A;
}

UMat read_op4(MPI_Comm comm, const std::string& spec, const std::string& what, PetscInt n_local) {
  auto [path, name] = split_spec(spec);
  const std::string where = cat(what, " ", spec);
  std::unique_ptr<Op4Reader> reader;
  std::int64_t dims[2] = {0, 0};
  std::string err;
  if (comm_rank(comm) == 0) try {
      reader = std::make_unique<Op4Reader>(path, name);
      dims[0] = reader->header().nrows;
      dims[1] = reader->header().ncols;
      if (dims[0] != dims[1])
        err = cat(where, ": matrix ", reader->header().name, " is ", dims[0], " x ", dims[1], ", not square");
    } catch (const Error& e) {
      err = cat(what, ": ", e.what());
    }
  collective_check(comm, err);
  MPI_Bcast(dims, 2, MPI_INT64_T, 0, comm);
  const auto ranges = row_ranges(comm, static_cast<PetscInt>(dims[0]), n_local);
  Router router(comm, ranges);
  std::int64_t col = 0;
  std::vector<std::int64_t> rows;
  std::vector<double> vals;
  router.run([&](std::vector<Entry>* buf) {
    if (!reader || !err.empty()) return false;
    try {
      while (buf->size() < kRouteBlock) {
        if (!reader->next(&col, &rows, &vals)) return false;
        for (std::size_t k = 0; k < rows.size(); ++k) {
          if (!std::isfinite(vals[k])) {
            err = cat(where, ": entry (", rows[k] + 1, ", ", col + 1, ") is not finite");
            return false;
          }
          buf->push_back({static_cast<PetscInt>(rows[k]), static_cast<PetscInt>(col), vals[k]});
        }
      }
      return true;
    } catch (const Error& e) {
      err = cat(what, ": ", e.what());
      return false;
    }
  });
  collective_check(comm, err);
  return build_matrix(comm, ranges, static_cast<PetscInt>(dims[0]), router.received(), where);
}

// HDF5 DOF map.
std::string read_dof_map_h5(const std::string& path, std::int64_t n_rows, DofMapFile* map) {
  std::vector<std::int64_t> node, comp;
  std::vector<hsize_t> dims;
  std::string err;
  if (!read_ints(path, "/dofmap/node", &node, &dims, &err)) return err;
  if (!read_ints(path, "/dofmap/component", &comp, &dims, &err)) return err;
  if (node.size() != comp.size())
    return cat(path, ": /dofmap/node has ", node.size(), " rows but /dofmap/component has ", comp.size());
  map->node = node;
  map->component.assign(comp.begin(), comp.end());
  // Sets: every dataset of /dofmap/sets.
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return cat(path, ": cannot open the HDF5 file");
  std::vector<std::string> names;
  if (H5Lexists(f, "/dofmap/sets", H5P_DEFAULT) > 0) {
    hid_t g = H5Gopen2(f, "/dofmap/sets", H5P_DEFAULT);
    H5Literate(
        g, H5_INDEX_NAME, H5_ITER_INC, nullptr,
        [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
          static_cast<std::vector<std::string>*>(data)->emplace_back(name);
          return 0;
        },
        &names);
    H5Gclose(g);
  }
  H5Fclose(f);
  for (const auto& s : names) {
    std::vector<std::int64_t> rows;
    if (!read_ints(path, "/dofmap/sets/" + s, &rows, &dims, &err)) return err;
    for (auto r : rows)
      if (r < 0 || r >= n_rows)
        return cat(path, ": /dofmap/sets/", s, " names row ", r, " (0-based) but the matrices have ", n_rows, " rows");
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    map->sets[s] = rows;
  }
  return {};
}

}  // namespace

std::string matrix_file(const std::string& spec) { return split_spec(spec).first; }

MatrixFormat matrix_format(const std::string& spec) {
  auto file = split_spec(spec).first;
  auto ext = lower(fs::path(file).extension().string());
  if (ext == ".mtx" || ext == ".mm") return MatrixFormat::MatrixMarket;
  if (ext == ".petsc" || ext == ".bin") return MatrixFormat::PetscBinary;
  if (ext == ".op4") return MatrixFormat::Op4;
  throw Error(cat("matrix file ", spec,
                  ": unknown format (expected .mtx/.mm MatrixMarket, .petsc/.bin PETSc binary or .op4 Nastran "
                  "OUTPUT4)"));
}

UMat read_matrix(MPI_Comm comm, const std::string& spec, const std::string& what, PetscInt n_local) {
  MatrixFormat fmt = MatrixFormat::MatrixMarket;
  std::string err;
  try {
    fmt = matrix_format(spec);
  } catch (const Error& e) {
    err = cat(what, " ", e.what());
  }
  collective_check(comm, err);
  StageTimer t(comm, "ReadMatrix");
  switch (fmt) {
    case MatrixFormat::MatrixMarket:
      return read_matrix_market(comm, spec, what, n_local);
    case MatrixFormat::PetscBinary:
      return read_petsc_binary(comm, spec, what, n_local);
    case MatrixFormat::Op4:
      return read_op4(comm, spec, what, n_local);
  }
  return {};
}

void write_matrix(Mat A, const std::string& path, bool symmetric) {
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(A));
  const int rank = comm_rank(comm), size = comm_size(comm);
  const MatrixFormat fmt = matrix_format(path);
  MORSE_CHECK(fmt != MatrixFormat::Op4, path, ": morse writes MatrixMarket and PETSc binary, not OP4");
  const std::string tmp = files::temp_path(comm, path);
  std::string err;
  if (fmt == MatrixFormat::PetscBinary) {
    PetscViewer v = nullptr;
    MORSE_CALL(PetscViewerCreate(comm, &v));
    MORSE_CALL(PetscViewerSetType(v, PETSCVIEWERBINARY));
    MORSE_CALL(PetscViewerBinarySkipInfo(v));
    MORSE_CALL(PetscViewerFileSetMode(v, FILE_MODE_WRITE));
    MORSE_CALL(PetscViewerFileSetName(v, tmp.c_str()));
    PetscErrorCode ierr = MatView(A, v);
    PetscViewerDestroy(&v);
    if (ierr) err = cat(path, ": could not write the PETSc binary file");
    if (ierr && rank == 0) std::remove(tmp.c_str());
    collective_check(comm, err);
    if (rank == 0) try {
        files::commit(tmp, path);
      } catch (const Error& e) {
        err = e.what();
      }
    collective_check(comm, err);
    return;
  }
  PetscInt n = 0, rs = 0, re = 0;
  MORSE_CALL(MatGetSize(A, &n, nullptr));
  MORSE_CALL(MatGetOwnershipRange(A, &rs, &re));
  std::vector<std::int64_t> ij;
  std::vector<double> val;
  for (PetscInt i = rs; i < re; ++i) {
    PetscInt nc;
    const PetscInt* cols;
    const PetscScalar* vals;
    MORSE_CALL(MatGetRow(A, i, &nc, &cols, &vals));
    for (PetscInt k = 0; k < nc; ++k) {
      if (symmetric && cols[k] > i) continue;
      ij.push_back(i + 1);
      ij.push_back(cols[k] + 1);
      val.push_back(vals[k]);
    }
    MORSE_CALL(MatRestoreRow(A, i, &nc, &cols, &vals));
  }
  std::int64_t nnz = static_cast<std::int64_t>(val.size()), total = 0;
  MPI_Allreduce(&nnz, &total, 1, MPI_INT64_T, MPI_SUM, comm);
  FILE* f = nullptr;
  if (rank == 0) {
    f = std::fopen(tmp.c_str(), "w");
    if (!f)
      err = cat(path, ": cannot write it (check its directory)");
    else
      std::fprintf(f, "%%%%MatrixMarket matrix coordinate real %s\n%% written by morse\n%lld %lld %lld\n",
                   symmetric ? "symmetric" : "general", (long long)n, (long long)n, (long long)total);
  }
  for (int r = 0; r < size; ++r) {  // one rank's rows at a time
    std::vector<std::int64_t> rij;
    std::vector<double> rval;
    if (r == 0) {
      if (rank == 0) rij.swap(ij), rval.swap(val);
    } else if (rank == r) {
      std::int64_t k = static_cast<std::int64_t>(val.size());
      MPI_Send(&k, 1, MPI_INT64_T, 0, 21, comm);
      MPI_Send(ij.data(), static_cast<int>(ij.size()), MPI_INT64_T, 0, 22, comm);
      MPI_Send(val.data(), static_cast<int>(val.size()), MPI_DOUBLE, 0, 23, comm);
    } else if (rank == 0) {
      std::int64_t k = 0;
      MPI_Recv(&k, 1, MPI_INT64_T, r, 21, comm, MPI_STATUS_IGNORE);
      rij.resize(2 * k), rval.resize(k);
      MPI_Recv(rij.data(), static_cast<int>(2 * k), MPI_INT64_T, r, 22, comm, MPI_STATUS_IGNORE);
      MPI_Recv(rval.data(), static_cast<int>(k), MPI_DOUBLE, r, 23, comm, MPI_STATUS_IGNORE);
    }
    if (rank == 0 && f)
      for (std::size_t k = 0; k < rval.size(); ++k)
        std::fprintf(f, "%lld %lld %.17g\n", (long long)rij[2 * k], (long long)rij[2 * k + 1], rval[k]);
  }
  if (rank == 0 && f) {
    if (std::fclose(f) != 0) err = cat(path, ": write error on ", tmp);
    if (err.empty()) try {
        files::commit(tmp, path);
      } catch (const Error& e) {
        err = e.what();
      }
    if (!err.empty()) std::remove(tmp.c_str());
  }
  collective_check(comm, err);
}

DofMapFile read_dof_map(const std::string& path, std::int64_t n_rows) {
  DofMapFile map;
  auto ext = lower(fs::path(path).extension().string());
  if (ext == ".h5" || ext == ".hdf5") {
    auto err = read_dof_map_h5(path, n_rows, &map);
    MORSE_CHECK(err.empty(), "-matrices_dofmap ", err);
    MORSE_CHECK(static_cast<std::int64_t>(map.node.size()) == n_rows, "-matrices_dofmap ", path, ": /dofmap/node has ",
                map.node.size(), " rows but the matrices have ", n_rows);
    for (std::size_t r = 0; r < map.node.size(); ++r)
      MORSE_CHECK(map.component[r] >= 1 && map.component[r] <= 6, "-matrices_dofmap ", path, ": row ", r,
                  " (0-based) has component ", map.component[r], " (expected 1 to 6)");
  } else {
    std::ifstream in(path);
    MORSE_CHECK(in, "-matrices_dofmap ", path, ": cannot open the file");
    std::string line;
    long ln = 0;
    while (std::getline(in, line)) {
      ++ln;
      if (auto h = line.find('#'); h != std::string::npos) line.erase(h);
      std::istringstream is(line);
      std::vector<std::string> f;
      for (std::string w; is >> w;) f.push_back(w);
      if (f.empty()) continue;
      const std::string where = cat("-matrices_dofmap ", path, ":", ln, ": ");
      MORSE_CHECK(static_cast<std::int64_t>(map.node.size()) < n_rows, where, "this line names row ",
                  map.node.size() + 1, " but the matrices have only ", n_rows, " rows");
      MORSE_CHECK(f.size() >= 2, where, "expected 'node component [set ...]', found '", line, "'");
      char* end = nullptr;
      long long node = std::strtoll(f[0].c_str(), &end, 10);
      MORSE_CHECK(*end == '\0' && node > 0, where, "node id '", f[0], "' is not a positive integer");
      MORSE_CHECK(f[1].size() == 1 && f[1][0] >= '1' && f[1][0] <= '6', where, "component '", f[1], "' is not 1 to 6");
      const auto row = static_cast<std::int64_t>(map.node.size());
      map.node.push_back(node);
      map.component.push_back(f[1][0] - '0');
      for (std::size_t k = 2; k < f.size(); ++k) map.sets[f[k]].push_back(row);
    }
    MORSE_CHECK(static_cast<std::int64_t>(map.node.size()) == n_rows, "-matrices_dofmap ", path, ": ", map.node.size(),
                " rows listed but the matrices have ", n_rows, " (rows ", map.node.size() + 1, " to ", n_rows,
                " have no line)");
  }
  // Each (node, component) once.
  std::vector<std::int64_t> order(map.node.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](auto a, auto b) {
    return map.node[a] != map.node[b] ? map.node[a] < map.node[b] : map.component[a] < map.component[b];
  });
  for (std::size_t k = 1; k < order.size(); ++k) {
    auto a = order[k - 1], b = order[k];
    MORSE_CHECK(map.node[a] != map.node[b] || map.component[a] != map.component[b], "-matrices_dofmap ", path,
                ": node ", map.node[b], " component ", map.component[b], " names rows ", std::min(a, b) + 1, " and ",
                std::max(a, b) + 1);
  }
  return map;
}

void write_dof_map(const std::string& path, const DofMapFile& map) {
  std::vector<std::vector<std::string>> names(map.node.size());
  for (const auto& [name, rows] : map.sets)
    for (auto r : rows) names.at(r).push_back(name);
  const std::string tmp = files::temp_path(path);
  {
    std::ofstream out(tmp);
    MORSE_CHECK(out, path, ": cannot write it (check its directory)");
    out << "# morse DOF map: one line per matrix row: node component [set ...]\n";
    for (std::size_t r = 0; r < map.node.size(); ++r) {
      out << map.node[r] << ' ' << map.component[r];
      for (const auto& s : names[r]) out << ' ' << s;
      out << '\n';
    }
    if (!out.good()) {
      std::remove(tmp.c_str());
      throw Error(cat(path, ": write error"));
    }
  }
  files::commit(tmp, path);
}

DofMapFile mesh_dof_map(const mesh::LocalMesh& lm, const fe::DofLayout& dofs) {
  const int rank = comm_rank(lm.comm), size = comm_size(lm.comm);
  // The rows' labels (node translations, and the six-DOF points of rigid and interpolation
  // elements) and the row sets, on rank 0.
  DofMapFile map;
  std::vector<std::int64_t> component;
  fe::gather_labels(dofs, &map.node, &component);
  map.component.assign(component.begin(), component.end());
  auto gather = [&](std::vector<std::int64_t>& v) {
    int n = static_cast<int>(v.size());
    std::vector<int> counts(size), displs(size, 0);
    MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, lm.comm);
    for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    std::vector<std::int64_t> all(rank == 0 ? displs[size - 1] + counts[size - 1] : 0);
    MPI_Gatherv(v.data(), n, MPI_INT64_T, all.data(), counts.data(), displs.data(), MPI_INT64_T, 0, lm.comm);
    return all;
  };
  for (const auto& [name, owned] : dofs.sets) {
    std::vector<std::int64_t> rows(owned.begin(), owned.end());
    auto set = gather(rows);
    if (rank == 0 && !set.empty()) {
      std::sort(set.begin(), set.end());
      map.sets[name] = std::move(set);
    }
  }
  return map;
}

}  // namespace morse::io
