#include "morse/io/h5.hpp"

#include <petscsys.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <limits>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/log.hpp"
#include "morse/mesh/cells.hpp"

namespace morse::io {

H5Output::H5Output(MPI_Comm comm, const std::string& path) : comm_(comm), path_(path) {
  MPI_Comm_rank(comm, &rank_);
  tmp_ = files::temp_path(comm, path);
  std::string err;
  if (rank_ == 0) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    file_ = H5Fcreate(tmp_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (file_ < 0) err = cat("cannot create output file ", path, " (check -out and its directory)");
  }
  collective_check(comm, err);
}

H5Output::~H5Output() {
  if (rank_ == 0 && file_ >= 0) H5Fclose(file_);
  if (rank_ == 0 && !committed_) std::remove(tmp_.c_str());
}

void H5Output::note_error(const std::string& what) {
  if (error_.empty()) error_ = cat("HDF5 error writing ", what, " to ", path_);
}

hid_t H5Output::ensure_group(const std::string& name) {
  // Creates every group on the path; returns the innermost one (caller closes).
  hid_t g = H5Gopen2(file_, "/", H5P_DEFAULT);
  std::size_t start = 1;
  while (start < name.size()) {
    auto end = name.find('/', start);
    if (end == std::string::npos) end = name.size();
    std::string part = name.substr(start, end - start);
    hid_t next = H5Lexists(g, part.c_str(), H5P_DEFAULT) > 0
                     ? H5Gopen2(g, part.c_str(), H5P_DEFAULT)
                     : H5Gcreate2(g, part.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Gclose(g);
    g = next;
    if (g < 0) return g;
    start = end + 1;
  }
  return g;
}

namespace {
std::pair<std::string, std::string> split(const std::string& name) {
  auto p = name.rfind('/');
  return {p == 0 ? "/" : name.substr(0, p), name.substr(p + 1)};
}

template <class T>
void write_any(hid_t file_group, const std::string& leaf, hid_t type, const std::vector<T>& data,
               std::vector<hsize_t> dims, bool* ok) {
  if (dims.empty()) dims.push_back(data.size());
  hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  hid_t ds = H5Dcreate2(file_group, leaf.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  *ok = ds >= 0 && H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()) >= 0;
  if (ds >= 0) H5Dclose(ds);
  H5Sclose(space);
}
}  // namespace

void H5Output::write(const std::string& name, const std::vector<double>& data, std::vector<hsize_t> dims) {
  if (rank_ != 0 || !error_.empty()) return;
  auto [grp, leaf] = split(name);
  hid_t g = ensure_group(grp);
  bool ok = g >= 0;
  if (ok) write_any(g, leaf, H5T_NATIVE_DOUBLE, data, dims, &ok);
  if (g >= 0) H5Gclose(g);
  if (!ok) note_error(name);
}

void H5Output::create_rows(const std::string& name, const std::vector<hsize_t>& dims) {
  if (rank_ != 0 || !error_.empty()) return;
  auto [grp, leaf] = split(name);
  hid_t g = ensure_group(grp);
  bool ok = g >= 0 && !dims.empty();
  if (ok) {
    hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
    hid_t ds = H5Dcreate2(g, leaf.c_str(), H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ok = space >= 0 && ds >= 0;
    if (ds >= 0) H5Dclose(ds);
    if (space >= 0) H5Sclose(space);
  }
  if (g >= 0) H5Gclose(g);
  if (!ok) note_error(name);
}

void H5Output::write_row(const std::string& name, hsize_t row, const std::vector<double>& data) {
  if (rank_ != 0 || !error_.empty()) return;
  hid_t ds = H5Dopen2(file_, name.c_str(), H5P_DEFAULT);
  bool ok = ds >= 0;
  if (ok) {
    hid_t fs = H5Dget_space(ds);
    const int nd = H5Sget_simple_extent_ndims(fs);
    std::vector<hsize_t> dims(std::max(nd, 1)), start(dims.size(), 0), count;
    H5Sget_simple_extent_dims(fs, dims.data(), nullptr);
    count = dims;
    count[0] = 1;
    start[0] = row;
    hsize_t per_row = 1;
    for (std::size_t k = 1; k < dims.size(); ++k) per_row *= dims[k];
    ok = nd >= 1 && row < dims[0] && data.size() == per_row;
    if (ok) {
      H5Sselect_hyperslab(fs, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
      hid_t ms = H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr);
      ok = H5Dwrite(ds, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, data.data()) >= 0;
      H5Sclose(ms);
    }
    H5Sclose(fs);
    H5Dclose(ds);
  }
  if (!ok) note_error(name);
}

void H5Output::write(const std::string& name, const std::vector<std::int64_t>& data, std::vector<hsize_t> dims) {
  if (rank_ != 0 || !error_.empty()) return;
  auto [grp, leaf] = split(name);
  hid_t g = ensure_group(grp);
  bool ok = g >= 0;
  if (ok) write_any(g, leaf, H5T_NATIVE_INT64, data, dims, &ok);
  if (g >= 0) H5Gclose(g);
  if (!ok) note_error(name);
}

void H5Output::write_string(const std::string& name, const std::string& value) {
  if (rank_ != 0 || !error_.empty()) return;
  auto [grp, leaf] = split(name);
  hid_t g = ensure_group(grp);
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.empty() ? 1 : value.size());
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t ds = H5Dcreate2(g, leaf.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  bool ok = ds >= 0 && H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, value.c_str()) >= 0;
  if (ds >= 0) H5Dclose(ds);
  H5Sclose(space);
  H5Tclose(type);
  H5Gclose(g);
  if (!ok) note_error(name);
}

void H5Output::attribute(const std::string& object, const std::string& name, const std::string& value) {
  if (rank_ != 0 || !error_.empty()) return;
  hid_t obj = open_object(object);
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.empty() ? 1 : value.size());
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t a = H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
  bool ok = a >= 0 && H5Awrite(a, type, value.c_str()) >= 0;
  if (a >= 0) H5Aclose(a);
  H5Sclose(space);
  H5Tclose(type);
  H5Oclose(obj);
  if (!ok) note_error(object + "@" + name);
}

namespace {
template <class T>
bool write_scalar_attribute(hid_t obj, const std::string& name, hid_t type, const T& value) {
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t a = H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
  bool ok = a >= 0 && H5Awrite(a, type, &value) >= 0;
  if (a >= 0) H5Aclose(a);
  H5Sclose(space);
  return ok;
}
}  // namespace

hid_t H5Output::open_object(const std::string& object) {
  return H5Lexists(file_, object.c_str(), H5P_DEFAULT) > 0 || object == "/"
             ? H5Oopen(file_, object.c_str(), H5P_DEFAULT)
             : ensure_group(object);
}

void H5Output::attribute(const std::string& object, const std::string& name, double value) {
  if (rank_ != 0 || !error_.empty()) return;
  hid_t obj = open_object(object);
  bool ok = obj >= 0 && write_scalar_attribute(obj, name, H5T_NATIVE_DOUBLE, value);
  if (obj >= 0) H5Oclose(obj);
  if (!ok) note_error(object + "@" + name);
}

void H5Output::attribute_int(const std::string& object, const std::string& name, std::int64_t value) {
  if (rank_ != 0 || !error_.empty()) return;
  hid_t obj = open_object(object);
  bool ok = obj >= 0 && write_scalar_attribute(obj, name, H5T_NATIVE_INT64, value);
  if (obj >= 0) H5Oclose(obj);
  if (!ok) note_error(object + "@" + name);
}

void H5Output::commit() {
  if (rank_ == 0) {
    if (file_ >= 0 && H5Fclose(file_) < 0) note_error("(close)");
    file_ = -1;
    if (error_.empty()) try {
        files::commit(tmp_, path_);
      } catch (const Error& e) {
        error_ = e.what();
      }
  }
  collective_check(comm_, error_);
  committed_ = true;
}

void H5Output::suspend() {
  if (rank_ == 0 && file_ >= 0) {
    if (H5Fclose(file_) < 0) note_error("(suspend)");
    file_ = -1;
  }
  collective_check(comm_, error_);
}

void H5Output::resume() {
  if (rank_ == 0) {
    file_ = H5Fopen(tmp_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    if (file_ < 0) note_error("(reopen)");
  }
  collective_check(comm_, error_);
}

H5SliceWriter::H5SliceWriter(MPI_Comm comm, const std::string& file, std::int64_t n_global, std::int64_t first,
                             std::int64_t n_local)
    : comm_(comm), file_name_(file), n_global_(n_global), first_(first), n_local_(n_local) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_fapl_mpio(fapl, comm, MPI_INFO_NULL);
  file_ = H5Fopen(file.c_str(), H5F_ACC_RDWR, fapl);
  H5Pclose(fapl);
  dxpl_ = H5Pcreate(H5P_DATASET_XFER);
  H5Pset_dxpl_mpio(dxpl_, H5FD_MPIO_COLLECTIVE);
  check(file_ >= 0, "(parallel open)");
}

H5SliceWriter::~H5SliceWriter() {
  for (hid_t d : sets_)
    if (d >= 0) H5Dclose(d);
  if (dxpl_ >= 0) H5Pclose(dxpl_);
  if (file_ >= 0) H5Fclose(file_);  // not collective-safe after an error; only on unwinding
}

void H5SliceWriter::check(bool ok, const std::string& what) {
  collective_check(comm_, ok ? "" : cat("HDF5 error writing ", what, " to ", file_name_, " (parallel HDF5)"));
}

namespace {
// Creates the intermediate groups of name (collective in parallel HDF5).
hid_t create_with_groups(hid_t file, const std::string& name, hid_t type, hid_t space) {
  hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  hid_t d = H5Dcreate2(file, name.c_str(), type, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
  H5Pclose(lcpl);
  return d;
}
}  // namespace

int H5SliceWriter::create(const std::string& name, std::int64_t n_rows) {
  hsize_t dims[2] = {static_cast<hsize_t>(n_rows), static_cast<hsize_t>(n_global_)};
  const bool two = n_rows > 0;
  hid_t space = two ? H5Screate_simple(2, dims, nullptr) : H5Screate_simple(1, dims + 1, nullptr);
  hid_t d = create_with_groups(file_, name, H5T_NATIVE_DOUBLE, space);
  H5Sclose(space);
  check(d >= 0, name);
  sets_.push_back(d);
  two_d_.push_back(two);
  return static_cast<int>(sets_.size()) - 1;
}

void H5SliceWriter::write_int(const std::string& name, const std::vector<std::int64_t>& local) {
  hsize_t n = static_cast<hsize_t>(n_global_), off = static_cast<hsize_t>(first_), cnt = static_cast<hsize_t>(n_local_);
  hid_t space = H5Screate_simple(1, &n, nullptr);
  hid_t d = create_with_groups(file_, name, H5T_NATIVE_INT64, space);
  bool ok = d >= 0 && static_cast<std::int64_t>(local.size()) == n_local_;
  if (ok) {
    H5Sselect_hyperslab(space, H5S_SELECT_SET, &off, nullptr, &cnt, nullptr);
    hid_t mem = H5Screate_simple(1, &cnt, nullptr);
    ok = H5Dwrite(d, H5T_NATIVE_INT64, mem, space, dxpl_, local.data()) >= 0;
    H5Sclose(mem);
  }
  if (d >= 0) H5Dclose(d);
  H5Sclose(space);
  check(ok, name);
}

void H5SliceWriter::write_row(int dataset, std::int64_t row, Vec x) {
  hid_t d = sets_.at(dataset);
  hid_t space = H5Dget_space(d);
  const bool two = two_d_[dataset];
  hsize_t off[2] = {static_cast<hsize_t>(row), static_cast<hsize_t>(first_)};
  hsize_t cnt[2] = {1, static_cast<hsize_t>(n_local_)};
  H5Sselect_hyperslab(space, H5S_SELECT_SET, two ? off : off + 1, nullptr, two ? cnt : cnt + 1, nullptr);
  hid_t mem = H5Screate_simple(1, cnt + 1, nullptr);
  const PetscScalar* a;
  MORSE_CALL(VecGetArrayRead(x, &a));
  bool ok = H5Dwrite(d, H5T_NATIVE_DOUBLE, mem, space, dxpl_, a) >= 0;
  MORSE_CALL(VecRestoreArrayRead(x, &a));
  H5Sclose(mem);
  H5Sclose(space);
  check(ok, "a row of a distributed dataset");
}

void H5SliceWriter::attribute(const std::string& object, const std::string& name, const std::string& value) {
  hid_t obj = H5Oopen(file_, object.c_str(), H5P_DEFAULT);
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.empty() ? 1 : value.size());
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t a = obj >= 0 ? H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT) : -1;
  bool ok = a >= 0 && H5Awrite(a, type, value.c_str()) >= 0;
  if (a >= 0) H5Aclose(a);
  H5Sclose(space);
  H5Tclose(type);
  if (obj >= 0) H5Oclose(obj);
  check(ok, object + "@" + name);
}

void H5SliceWriter::close() {
  bool ok = true;
  for (hid_t& d : sets_) {
    ok = H5Dclose(d) >= 0 && ok;
    d = -1;
  }
  if (dxpl_ >= 0) H5Pclose(dxpl_);
  dxpl_ = -1;
  if (file_ >= 0) ok = H5Fclose(file_) >= 0 && ok;
  file_ = -1;
  check(ok, "(parallel close)");
}

void read_nodal_field(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::string& file,
                      const std::string& dataset, Vec x) {
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  std::string err;
  std::vector<std::int64_t> ids;
  std::vector<double> val;
  if (rank == 0) {
    std::vector<hsize_t> di, dv;
    if (read_ints(file, "/mesh/node_ids", &ids, &di, &err) && read_doubles(file, dataset, &val, &dv, &err)) {
      if (dv.size() < 2 || dv.back() != 3 || dv[dv.size() - 2] != ids.size())
        err = cat(file, ": dataset ", dataset, " is not a nodal field [..][", ids.size(), "][3]");
      else
        val.erase(val.begin(), val.end() - 3 * ids.size());  // the last field
    }
  }
  collective_check(lm.comm, err);
  std::int64_t n = static_cast<std::int64_t>(ids.size());
  MPI_Bcast(&n, 1, MPI_INT64_T, 0, lm.comm);
  ids.resize(n);
  val.resize(3 * n);
  MPI_Bcast(ids.data(), static_cast<int>(n), MPI_INT64_T, 0, lm.comm);
  MPI_Bcast(val.data(), static_cast<int>(3 * n), MPI_DOUBLE, 0, lm.comm);
  std::vector<std::pair<std::int64_t, std::int64_t>> order;  // (id, row)
  for (std::int64_t i = 0; i < n; ++i) order.emplace_back(ids[i], i);
  std::sort(order.begin(), order.end());
  PetscScalar* a;
  MORSE_CALL(VecGetArray(x, &a));
  for (std::int64_t k = 0; k < lm.mesh.num_nodes() && err.empty(); ++k) {
    if (lm.node_owner[k] != rank) continue;
    auto it = std::lower_bound(order.begin(), order.end(), std::make_pair(lm.mesh.node_ids[k], std::int64_t(-1)));
    if (it == order.end() || it->first != lm.mesh.node_ids[k]) {
      err = cat(file, ": node ", lm.mesh.node_ids[k], " of the mesh is not in /mesh/node_ids (another mesh?)");
      break;
    }
    for (int d = 0; d < 3; ++d)
      if (dofs.node_dof[3 * k + d] >= 0) a[dofs.node_dof[3 * k + d] - dofs.first] = val[3 * it->second + d];
  }
  MORSE_CALL(VecRestoreArray(x, &a));
  collective_check(lm.comm, err);
}

namespace {
// "" if a dataset of shape dims (elements of `elem` bytes in memory) may be read; else why not,
// before anything is allocated: a product of the extents that overflows, or (a corrupt or
// hostile file) more bytes than the file holds for a dataset stored without filters (no
// compression, so its data are in the file), or more than the memory available (elem 0: no
// memory check, for a read of one row).
std::string declared_size_error(hid_t f, hid_t d, const std::vector<hsize_t>& dims, std::size_t elem) {
  double n = 1;
  hsize_t exact = 1;
  for (auto v : dims) {
    n *= static_cast<double>(v);
    if (v != 0 && exact > std::numeric_limits<hsize_t>::max() / v) return cat(" declares ", n, " values: too many");
    exact *= v;
  }
  hid_t dcpl = H5Dget_create_plist(d);
  const int filters = dcpl >= 0 ? H5Pget_nfilters(dcpl) : -1;
  if (dcpl >= 0) H5Pclose(dcpl);
  hid_t ft = H5Dget_type(d);
  const double stored = ft >= 0 ? n * static_cast<double>(H5Tget_size(ft)) : 0;
  if (ft >= 0) H5Tclose(ft);
  hsize_t fsize = 0;
  // Unfiltered, or filters unknown (a corrupt creation property list): the data are in the file.
  if (filters <= 0 && H5Fget_filesize(f, &fsize) >= 0 && stored > static_cast<double>(fsize))
    return cat(" declares ", exact, " values (", stored, " bytes), more than the file's ", fsize, " bytes");
  // Storage recorded beyond the end of the file (a corrupt layout message: libhdf5 allocates its
  // size to read the data, 4.8 GB for a 20 kB file in a case found by fuzzing).
  if (H5Fget_filesize(f, &fsize) >= 0 && H5Dget_storage_size(d) > fsize)
    return cat(" records ", H5Dget_storage_size(d), " bytes of storage, more than the file's ", fsize,
               " bytes (a corrupt file)");
  // Compressed (morse writes none): deflate, the strongest standard filter, packs at most 1032 to 1.
  if (filters > 0) {
    const double kept = static_cast<double>(H5Dget_storage_size(d));
    if (stored > 1100.0 * std::max(kept, 1.0))
      return cat(" declares ", exact, " values (", stored, " bytes) in ", kept,
                 " bytes of compressed storage: more than any filter packs (a corrupt file)");
  }
  std::string m = memory_error(cat("dataset of ", exact, " values"), n * static_cast<double>(elem), "reading it");
  return m.empty() ? m : cat(": ", m);
}

// Reads a whole dataset, or only row `row` (>= 0) of a 2-D one (dims then holds {1, columns}).
template <class T>
bool read_any(const std::string& file, const std::string& name, hid_t type, std::vector<T>* out,
              std::vector<hsize_t>* dims, std::string* error, std::int64_t row = -1) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) {
    *error = cat(file, ": cannot open as HDF5");
    return false;
  }
  // Every link on the path must exist (H5Lexists fails on a missing intermediate group).
  bool exists = true;
  for (std::size_t p = name.find('/', 1); exists; p = name.find('/', p + 1)) {
    exists = H5Lexists(f, name.substr(0, p).c_str(), H5P_DEFAULT) > 0;
    if (p == std::string::npos) break;
  }
  hid_t d = exists ? H5Dopen2(f, name.c_str(), H5P_DEFAULT) : -1;
  bool ok = d >= 0;
  if (!ok) *error = cat(file, ": no dataset ", name);
  if (ok) {
    hid_t sp = H5Dget_space(d);
    const int ndims = H5Sget_simple_extent_ndims(sp);
    dims->assign(ndims > 0 ? ndims : 0, 0);
    if (ndims < 0 || H5Sget_simple_extent_dims(sp, dims->data(), nullptr) < 0) {
      *error = cat(file, ": ", name, " has an unreadable shape");
      ok = false;
    } else if (std::string e = declared_size_error(f, d, *dims, row >= 0 ? 0 : sizeof(T)); !e.empty()) {
      *error = cat(file, ": ", name, e);
      ok = false;
    }
    hid_t msp = H5S_ALL;
    if (!ok) {
    } else if (row >= 0) {
      if (dims->size() != 2 || static_cast<hsize_t>(row) >= (*dims)[0]) {
        *error = cat(file, ": ", name, " has no row ", row);
        ok = false;
      } else {
        hsize_t start[2] = {static_cast<hsize_t>(row), 0}, count[2] = {1, (*dims)[1]};
        H5Sselect_hyperslab(sp, H5S_SELECT_SET, start, nullptr, count, nullptr);
        msp = H5Screate_simple(2, count, nullptr);
        *dims = {1, count[1]};
      }
    }
    if (ok) {
      hsize_t n = 1;
      for (auto v : *dims) n *= v;
      out->resize(static_cast<std::size_t>(n));
      if (H5Dread(d, type, msp, row >= 0 ? sp : H5S_ALL, H5P_DEFAULT, out->data()) < 0) {
        *error = cat(file, ": cannot read ", name);
        ok = false;
      }
    }
    if (msp != H5S_ALL) H5Sclose(msp);
    H5Sclose(sp);
    H5Dclose(d);
  }
  H5Fclose(f);
  return ok;
}
}  // namespace

bool has_object(const std::string& file, const std::string& name) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return false;
  bool exists = true;
  for (std::size_t p = name.find('/', 1); exists; p = name.find('/', p + 1)) {
    exists = H5Lexists(f, name.substr(0, p).c_str(), H5P_DEFAULT) > 0;
    if (p == std::string::npos) break;
  }
  H5Fclose(f);
  return exists;
}

bool read_doubles(const std::string& file, const std::string& name, std::vector<double>* out,
                  std::vector<hsize_t>* dims, std::string* error) {
  return read_any(file, name, H5T_NATIVE_DOUBLE, out, dims, error);
}

bool read_ints(const std::string& file, const std::string& name, std::vector<std::int64_t>* out,
               std::vector<hsize_t>* dims, std::string* error) {
  if (!read_any(file, name, H5T_NATIVE_INT64, out, dims, error)) return false;
  // HDF5 converts a floating-point dataset by truncation (node 1401.5 would become 1401): such a
  // dataset must hold integers.
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  hid_t d = f >= 0 ? H5Dopen2(f, name.c_str(), H5P_DEFAULT) : -1;
  hid_t t = d >= 0 ? H5Dget_type(d) : -1;
  const bool real = t >= 0 && H5Tget_class(t) == H5T_FLOAT;
  if (t >= 0) H5Tclose(t);
  if (d >= 0) H5Dclose(d);
  if (f >= 0) H5Fclose(f);
  if (!real) return true;
  std::vector<double> v;
  if (!read_any(file, name, H5T_NATIVE_DOUBLE, &v, dims, error)) return false;
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!(std::abs(v[i]) < 9.0e15) || v[i] != static_cast<double>((*out)[i])) {
      *error = cat(file, ": ", name, " holds ", v[i], " (entry ", i, "), not an integer");
      return false;
    }
  return true;
}

bool read_attribute(const std::string& file, const std::string& object, const std::string& name, double* out,
                    std::string* error) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) {
    *error = cat(file, ": cannot open as HDF5");
    return false;
  }
  bool ok = false;
  if (H5Lexists(f, object.c_str(), H5P_DEFAULT) > 0 &&
      H5Aexists_by_name(f, object.c_str(), name.c_str(), H5P_DEFAULT) > 0) {
    hid_t a = H5Aopen_by_name(f, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
    hid_t sp = H5Aget_space(a);
    hid_t t = H5Aget_type(a);
    ok = H5Sget_simple_extent_npoints(sp) == 1 && (H5Tget_class(t) == H5T_INTEGER || H5Tget_class(t) == H5T_FLOAT) &&
         H5Aread(a, H5T_NATIVE_DOUBLE, out) >= 0;
    H5Tclose(t);
    H5Sclose(sp);
    H5Aclose(a);
  }
  H5Fclose(f);
  if (!ok) *error = cat(file, ": no numeric attribute ", name, " on ", object);
  return ok;
}

bool read_string(const std::string& file, const std::string& name, std::string* out, std::string* error) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) {
    *error = cat(file, ": cannot open as HDF5");
    return false;
  }
  bool ok = false;
  hid_t d = H5Lexists(f, name.c_str(), H5P_DEFAULT) > 0 ? H5Dopen2(f, name.c_str(), H5P_DEFAULT) : -1;
  if (d >= 0) {
    hid_t t = H5Dget_type(d);
    if (H5Tget_class(t) == H5T_STRING && !H5Tis_variable_str(t)) {
      std::vector<char> buf(H5Tget_size(t) + 1, '\0');
      hid_t mt = H5Tcopy(H5T_C_S1);
      H5Tset_size(mt, buf.size());
      ok = H5Dread(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) >= 0;
      H5Tclose(mt);
      if (ok) *out = buf.data();
    }
    H5Tclose(t);
    H5Dclose(d);
  }
  H5Fclose(f);
  if (!ok) *error = cat(file, ": no string dataset ", name);
  return ok;
}

bool read_double_row(const std::string& file, const std::string& name, std::int64_t row, std::vector<double>* out,
                     std::string* error) {
  std::vector<hsize_t> dims;
  return read_any(file, name, H5T_NATIVE_DOUBLE, out, &dims, error, row);
}

UMat read_dof_rows(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const std::string& file,
                   const std::string& dataset) {
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  std::string err;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) err = cat(file, ": cannot open as HDF5 (a morse fom file with snapshots is expected)");
  const std::string group = dataset.substr(0, dataset.rfind('/'));
  auto open = [&](const std::string& name) -> hid_t {
    if (!err.empty()) return -1;
    hid_t d = H5Lexists(f, group.c_str(), H5P_DEFAULT) > 0 && H5Lexists(f, name.c_str(), H5P_DEFAULT) > 0
                  ? H5Dopen2(f, name.c_str(), H5P_DEFAULT)
                  : -1;
    if (d < 0) err = cat(file, ": no dataset ", name, " (run morse fom with -fom_snapshot_every K)");
    return d;
  };
  std::vector<std::int64_t> ids, comps;
  auto read_int = [&](const std::string& name, std::vector<std::int64_t>* out) {
    hid_t d = open(name);
    if (d < 0) return;
    hid_t sp = H5Dget_space(d);
    const hssize_t n = H5Sget_simple_extent_npoints(sp);
    if (n < 0)
      err = cat(file, ": ", name, " has an unreadable shape");
    else if (std::string e = declared_size_error(f, d, {static_cast<hsize_t>(n)}, sizeof(std::int64_t)); !e.empty())
      err = cat(file, ": ", name, e);
    if (err.empty()) out->resize(static_cast<std::size_t>(n));
    if (err.empty() && H5Dread(d, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, out->data()) < 0)
      err = cat(file, ": cannot read ", name);
    H5Sclose(sp);
    H5Dclose(d);
  };
  read_int(group + "/dof_node_ids", &ids);
  read_int(group + "/dof_components", &comps);
  hid_t d = open(dataset);
  hsize_t dims[2] = {0, 0};
  if (d >= 0) {
    hid_t sp = H5Dget_space(d);
    if (H5Sget_simple_extent_ndims(sp) != 2)
      err = cat(file, ": ", dataset, " is not 2-D (rows x DOFs)");
    else
      H5Sget_simple_extent_dims(sp, dims, nullptr);
    H5Sclose(sp);
    if (err.empty() && (dims[1] != ids.size() || comps.size() != ids.size()))
      err = cat(file, ": ", dataset, " has ", dims[1], " columns but the DOF map has ", ids.size());
  }
  // Column of each owned free DOF.
  std::vector<std::int64_t> col(dofs.n_owned, -1);
  if (err.empty()) {
    std::vector<std::pair<std::int64_t, std::int64_t>> order;  // (3 id + comp, column)
    for (std::size_t j = 0; j < ids.size(); ++j)
      order.emplace_back(3 * ids[j] + comps[j], static_cast<std::int64_t>(j));
    std::sort(order.begin(), order.end());
    for (std::int64_t k = 0; k < lm.mesh.num_nodes() && err.empty(); ++k) {
      if (lm.node_owner[k] != rank) continue;
      for (int c = 0; c < 3; ++c) {
        const PetscInt g = dofs.node_dof[3 * k + c];
        if (g < 0) continue;
        const std::int64_t key = 3 * lm.mesh.node_ids[k] + c;
        auto it = std::lower_bound(order.begin(), order.end(), std::make_pair(key, std::int64_t(-1)));
        if (it == order.end() || it->first != key) {
          err = cat(file, ": ", dataset, " has no column for node ", lm.mesh.node_ids[k], " component ", c,
                    " (another mesh or other clamped sets?)");
          break;
        }
        col[g - dofs.first] = it->second;
      }
    }
  }
  collective_check(lm.comm, err);
  std::int64_t rows = static_cast<std::int64_t>(dims[0]);
  MPI_Allreduce(MPI_IN_PLACE, &rows, 1, MPI_INT64_T, MPI_MAX, lm.comm);
  UMat X;
  MORSE_CALL(MatCreateDense(lm.comm, dofs.n_owned, PETSC_DECIDE, dofs.n_global, static_cast<PetscInt>(rows), nullptr,
                            X.ptr()));
  PetscScalar* x;
  PetscInt ld = 0;
  MORSE_CALL(MatDenseGetLDA(X.get(), &ld));
  MORSE_CALL(MatDenseGetArrayWrite(X.get(), &x));
  std::vector<double> row(dims[1]);
  hid_t fsp = H5Dget_space(d);
  hsize_t cnt[2] = {1, dims[1]};
  hid_t msp = H5Screate_simple(2, cnt, nullptr);
  for (std::int64_t k = 0; k < rows && err.empty(); ++k) {
    hsize_t start[2] = {static_cast<hsize_t>(k), 0};
    H5Sselect_hyperslab(fsp, H5S_SELECT_SET, start, nullptr, cnt, nullptr);
    if (H5Dread(d, H5T_NATIVE_DOUBLE, msp, fsp, H5P_DEFAULT, row.data()) < 0) {
      err = cat(file, ": cannot read row ", k, " of ", dataset);
      break;
    }
    for (PetscInt i = 0; i < dofs.n_owned; ++i) x[i + static_cast<std::size_t>(ld) * k] = row[col[i]];
  }
  H5Sclose(msp);
  H5Sclose(fsp);
  H5Dclose(d);
  H5Fclose(f);
  MORSE_CALL(MatDenseRestoreArrayWrite(X.get(), &x));
  collective_check(lm.comm, err);
  MORSE_CALL(MatAssemblyBegin(X.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(X.get(), MAT_FINAL_ASSEMBLY));
  return X;
}

std::vector<double> gather_nodal(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, Vec x) {
  int rank = 0, size = 1;
  MPI_Comm_rank(lm.comm, &rank);
  MPI_Comm_size(lm.comm, &size);
  const PetscScalar* a;
  MORSE_CALL(VecGetArrayRead(x, &a));
  std::vector<double> mine;  // (global node, ux, uy, uz)
  for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k) {
    if (lm.node_owner[k] != rank) continue;
    mine.push_back(static_cast<double>(lm.global_node[k]));
    for (int d = 0; d < 3; ++d) {
      PetscInt g = dofs.node_dof[3 * k + d];
      mine.push_back(g >= 0 ? PetscRealPart(a[g - dofs.first]) : 0.0);
    }
  }
  MORSE_CALL(VecRestoreArrayRead(x, &a));
  int n = static_cast<int>(mine.size());
  std::vector<int> counts(size), displs(size, 0);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, lm.comm);
  std::vector<double> all;
  if (rank == 0) {
    for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    all.resize(displs[size - 1] + counts[size - 1]);
  }
  MPI_Gatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, 0, lm.comm);
  std::vector<double> out;
  if (rank != 0) return out;
  out.assign(3 * lm.n_global_nodes, 0.0);
  for (std::size_t i = 0; i + 4 <= all.size(); i += 4) {
    auto g = static_cast<std::int64_t>(all[i]);
    for (int d = 0; d < 3; ++d) out[3 * g + d] = all[i + 1 + d];
  }
  return out;
}

void write_provenance(H5Output& out, const std::string& command, const std::string& units) {
  char* opts = nullptr;
  PetscOptionsGetAll(nullptr, &opts);
  std::time_t now = std::time(nullptr);
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  out.write_string("/meta/version", MORSE_VERSION);
  out.write_string("/meta/command", command);
  out.write_string("/meta/options", opts ? opts : "");
  out.write_string("/meta/units", units);
  out.write_string("/meta/date", date);
  out.attribute("/", "units", units);
  out.attribute("/", "morse_version", MORSE_VERSION);
  PetscFree(opts);
}

namespace {

// XDMF type codes and names; the node orderings (VTK's) are in mesh/cells.hpp.
struct XdmfType {
  int code;
  const char* name;
};

const XdmfType& xdmf_type(mesh::ElementType t) {
  using ET = mesh::ElementType;
  static const XdmfType tet4{6, "Tetrahedron"}, wedge6{8, "Wedge"}, hex8{9, "Hexahedron"};
  static const XdmfType tet10{38, "Tetrahedron_10"}, wedge15{40, "Wedge_15"}, hex20{48, "Hexahedron_20"};
  switch (t) {
    case ET::Tet4:
      return tet4;
    case ET::Tet10:
      return tet10;
    case ET::Wedge6:
      return wedge6;
    case ET::Wedge15:
      return wedge15;
    case ET::Hex8:
      return hex8;
    default:
      return hex20;
  }
}

// perm[i] = morse node index of the i-th XDMF node.
std::vector<int> xdmf_permutation(mesh::ElementType t) { return mesh::foreign_to_morse(t, mesh::NodeOrder::Vtk); }

}  // namespace

void write_mesh(H5Output& out, const mesh::Mesh& m) {
  out.write("/mesh/coordinates", m.coords, {static_cast<hsize_t>(m.num_nodes()), 3});
  out.write("/mesh/node_ids", m.node_ids);
  out.write("/mesh/element_ids", m.elem_ids);
  std::vector<std::int64_t> topo;
  topo.reserve(m.elem_nodes.size() + m.elem_types.size());
  std::vector<std::vector<int>> perms(mesh::kNumElementTypes);
  for (int k = 0; k < mesh::kNumElementTypes; ++k) perms[k] = xdmf_permutation(static_cast<mesh::ElementType>(k));
  for (std::int64_t e = 0; e < m.num_elements(); ++e) {
    auto t = m.elem_types[e];
    topo.push_back(xdmf_type(t).code);
    for (int p : perms[static_cast<int>(t)]) topo.push_back(m.elem_nodes[m.elem_offsets[e] + p]);
  }
  out.write("/mesh/topology", topo);
  out.attribute("/mesh/topology", "description",
                "XDMF mixed topology: per element its XDMF type code then its nodes (VTK order)");
  const auto& cs = m.constraints;
  if (!cs.point_ids.empty()) {
    out.write("/mesh/point_ids", cs.point_ids);
    out.write("/mesh/point_coordinates", cs.point_coords, {static_cast<hsize_t>(cs.point_ids.size()), 3});
    out.attribute("/mesh/point_ids", "description",
                  "six-DOF points (reference nodes of rigid and interpolation elements); no solid element uses them");
  }
}

void write_xdmf(const std::string& xdmf_path, const std::string& h5_name, const mesh::Mesh& m,
                const std::vector<XdmfField>& fields) {
  std::size_t topo_len = 0;
  for (std::int64_t e = 0; e < m.num_elements(); ++e) topo_len += 1 + mesh::nodes_per_element(m.elem_types[e]);
  const std::string tmp = files::temp_path(xdmf_path);
  {
    std::ofstream f(tmp);
    MORSE_CHECK(f, "cannot write ", xdmf_path, " (check its directory)");
    f << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n<Domain>\n";
    f << "<Grid Name=\"morse\" GridType=\"Uniform\">\n";
    f << "<Topology TopologyType=\"Mixed\" NumberOfElements=\"" << m.num_elements() << "\">\n"
      << "<DataItem Dimensions=\"" << topo_len << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" << h5_name
      << ":/mesh/topology</DataItem>\n</Topology>\n";
    f << "<Geometry GeometryType=\"XYZ\">\n<DataItem Dimensions=\"" << m.num_nodes()
      << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name
      << ":/mesh/coordinates</DataItem>\n</Geometry>\n";
    for (const auto& fld : fields) {
      const std::int64_t n = fld.cell ? m.num_elements() : m.num_nodes();
      const int c = fld.components;
      const char* type = c == 1 ? "Scalar" : c == 3 ? "Vector" : "Tensor6";
      MORSE_CHECK(c == 1 || c == 3 || c == 6, "XDMF field ", fld.dataset, ": ", c, " components (1, 3 or 6)");
      // Scalars are stored [count][n], the others [count][n][c]: the hyperslab has that rank.
      const std::string cs = c == 1 ? "" : " " + std::to_string(c);
      for (int k = 0; k < fld.count; ++k) {
        f << "<Attribute Name=\"" << fld.label << "_" << k + 1 << "\" AttributeType=\"" << type << "\" Center=\""
          << (fld.cell ? "Cell" : "Node") << "\">\n"
          << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" << n << cs << "\">\n"
          << "<DataItem Dimensions=\"3 " << (c == 1 ? 2 : 3) << "\" Format=\"XML\">" << k
          << (c == 1 ? " 0 1 1 1 " : " 0 0 1 1 1 1 ") << n << cs << "</DataItem>\n"
          << "<DataItem Dimensions=\"" << fld.count << " " << n << cs
          << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name << ":" << fld.dataset
          << "</DataItem>\n</DataItem>\n</Attribute>\n";
      }
    }
    f << "</Grid>\n</Domain>\n</Xdmf>\n";
    if (!f.good()) {
      std::remove(tmp.c_str());
      throw Error(cat("error writing ", xdmf_path, " (its temporary ", tmp, ")"));
    }
  }
  files::commit(tmp, xdmf_path);
}

std::string read_string_attribute(const std::string& file, const std::string& object, const std::string& name) {
  std::string out;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return out;
  if (H5Lexists(f, object.c_str(), H5P_DEFAULT) > 0 &&
      H5Aexists_by_name(f, object.c_str(), name.c_str(), H5P_DEFAULT) > 0) {
    hid_t a = H5Aopen_by_name(f, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
    hid_t t = H5Aget_type(a);
    if (H5Tget_class(t) == H5T_STRING) {
      if (H5Tis_variable_str(t) > 0) {
        char* s = nullptr;
        hid_t mt = H5Tcopy(H5T_C_S1);
        H5Tset_size(mt, H5T_VARIABLE);
        if (H5Aread(a, mt, &s) >= 0 && s) out = s;
        if (s) H5free_memory(s);
        H5Tclose(mt);
      } else {
        std::vector<char> b(H5Tget_size(t) + 1, 0);
        if (H5Aread(a, t, b.data()) >= 0) out = b.data();
      }
    }
    H5Tclose(t);
    H5Aclose(a);
  }
  H5Fclose(f);
  return out;
}

}  // namespace morse::io
