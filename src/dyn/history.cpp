// Tabulated nodal load histories (see morse/dyn/dyn.hpp: LoadTable, read_load_table, LoadHistory).
#include <mpi.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "morse/core/error.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/io/h5.hpp"

namespace morse::dyn {

std::string parse_outside(const std::string& text, Outside* out) {
  if (text == "error")
    *out = Outside::Error;
  else if (text == "zero")
    *out = Outside::Zero;
  else if (text == "hold")
    *out = Outside::Hold;
  else
    return cat("'", text, "' is not error, zero or hold");
  return {};
}

std::string LoadTable::validate() const {
  const std::size_t nt = time.size(), nn = node_ids.size();
  if (nt == 0) return cat(source, ": the load table has no time");
  if (nn == 0) return cat(source, ": the load table has no node");
  if (forces.size() != nt * nn * 3)
    return cat(source, ": the forces hold ", forces.size(), " values, not n_times x n_nodes x 3 = ", nt, " x ", nn,
               " x 3");
  for (std::size_t i = 0; i < nt; ++i) {
    if (!std::isfinite(time[i])) return cat(source, ": time ", i, " is not finite (", time[i], ")");
    if (i > 0 && !(time[i] > time[i - 1]))
      return cat(source, ": the times are not strictly increasing: time ", i, " = ", time[i], " s follows ",
                 time[i - 1], " s");
  }
  std::vector<std::int64_t> sorted(node_ids);
  std::sort(sorted.begin(), sorted.end());
  if (auto it = std::adjacent_find(sorted.begin(), sorted.end()); it != sorted.end())
    return cat(source, ": node ", *it, " appears twice");
  for (std::size_t i = 0; i < nt; ++i)
    for (std::size_t k = 0; k < nn; ++k)
      for (int d = 0; d < 3; ++d)
        if (!std::isfinite(forces[(i * nn + k) * 3 + d]))
          return cat(source, ": force ", "xyz"[d], " of node ", node_ids[k], " at time ", i, " (t = ", time[i],
                     " s) is not finite (", forces[(i * nn + k) * 3 + d], ")");
  return {};
}

void LoadTable::locate(double t, std::size_t* i, double* w, bool* inside) const {
  const std::size_t nt = time.size();
  const double tol = 1e-9 * std::max(time.back() - time.front(), std::abs(time.back()));
  *inside = t >= time.front() - tol && t <= time.back() + tol;
  if (nt == 1 || t <= time.front()) {
    *i = 0, *w = 0.0;
    return;
  }
  if (t >= time.back()) {
    *i = nt - 2, *w = 1.0;
    return;
  }
  // time[j - 1] <= t < time[j]
  const std::size_t j = static_cast<std::size_t>(std::upper_bound(time.begin(), time.end(), t) - time.begin());
  *i = j - 1;
  *w = (t - time[j - 1]) / (time[j] - time[j - 1]);
}

namespace {

bool ends_with_csv(const std::string& path) {
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".csv";
}

// Splits FILE:GROUP at the last ':' followed by '/', so that a path with ':' still works.
void split_spec(const std::string& spec, std::string* file, std::string* group) {
  const auto p = spec.rfind(":/");
  if (p == std::string::npos) {
    *file = spec, group->clear();
  } else {
    *file = spec.substr(0, p), *group = spec.substr(p + 1);
  }
  while (group->size() > 1 && group->back() == '/') group->pop_back();
}

std::string read_csv(const std::string& file, LoadTable* t) {
  std::ifstream in(file);
  if (!in) return cat(file, ": cannot open");
  t->source = file;
  // Blocks of one time; the node order of the first block defines the columns.
  std::map<std::int64_t, std::size_t> column;
  std::vector<double> row;  // the block being read, n_nodes x 3
  std::vector<char> seen;   // per column, in the block being read
  std::size_t n_seen = 0;
  bool first_block = true, header_ok = true;
  std::string line;
  long line_no = 0, first_line_of_block = 0;
  auto close_block = [&]() -> std::string {
    if (first_block) {
      first_block = false;
      t->forces.insert(t->forces.end(), row.begin(), row.end());
      seen.assign(t->node_ids.size(), 0);
      n_seen = 0;
      return {};
    }
    if (n_seen != t->node_ids.size()) {
      for (std::size_t k = 0; k < seen.size(); ++k)
        if (!seen[k])
          return cat(file, ":", first_line_of_block, ": the block of time ", t->time.back(), " s lacks node ",
                     t->node_ids[k], " (every time must list every node of the table)");
    }
    t->forces.insert(t->forces.end(), row.begin(), row.end());
    std::fill(seen.begin(), seen.end(), 0);
    n_seen = 0;
    return {};
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (auto h = line.find('#'); h != std::string::npos) line.erase(h);
    for (auto& c : line)
      if (c == ',' || c == ';' || c == '\t' || c == '\r') c = ' ';
    std::istringstream ss(line);
    std::vector<std::string> f;
    for (std::string w; ss >> w;) f.push_back(w);
    if (f.empty()) continue;
    double v[5];
    bool numeric = f.size() == 5;
    for (std::size_t j = 0; numeric && j < 5; ++j) {
      char* end = nullptr;
      v[j] = std::strtod(f[j].c_str(), &end);
      numeric = end != f[j].c_str() && *end == '\0';
    }
    if (!numeric) {
      // One header line of words before the data.
      if (header_ok && t->time.empty() && std::isalpha(static_cast<unsigned char>(f[0][0]))) {
        header_ok = false;
        continue;
      }
      return cat(file, ":", line_no, ": expected 5 numbers 'time, node_id, fx, fy, fz', got '", line, "'");
    }
    header_ok = false;
    for (int j = 0; j < 5; ++j)
      if (!std::isfinite(v[j])) return cat(file, ":", line_no, ": value ", j + 1, " is not finite (", f[j], ")");
    if (v[1] != std::floor(v[1]) || !(std::abs(v[1]) < 9.0e15))
      return cat(file, ":", line_no, ": node id ", f[1], " is not an integer node id");
    const auto id = static_cast<std::int64_t>(v[1]);
    if (t->time.empty() || v[0] != t->time.back()) {
      if (!t->time.empty()) {
        if (!(v[0] > t->time.back()))
          return cat(file, ":", line_no, ": the times are not increasing: ", f[0], " s follows ", t->time.back(),
                     " s (rows come in blocks of one time, in increasing time)");
        if (auto e = close_block(); !e.empty()) return e;
      }
      t->time.push_back(v[0]);
      first_line_of_block = line_no;
      if (!first_block) std::fill(row.begin(), row.end(), 0.0);
    }
    std::size_t k;
    if (first_block) {
      if (column.count(id)) return cat(file, ":", line_no, ": node ", id, " appears twice at time ", f[0], " s");
      k = column.size();
      column[id] = k;
      t->node_ids.push_back(id);
      row.insert(row.end(), {v[2], v[3], v[4]});
      continue;
    }
    auto it = column.find(id);
    if (it == column.end())
      return cat(file, ":", line_no, ": node ", id,
                 " is not in the first time block (every time must list the same nodes)");
    k = it->second;
    if (seen[k]) return cat(file, ":", line_no, ": node ", id, " appears twice at time ", f[0], " s");
    seen[k] = 1;
    ++n_seen;
    for (int d = 0; d < 3; ++d) row[3 * k + d] = v[2 + d];
  }
  if (t->time.empty()) return cat(file, ": no data row ('time, node_id, fx, fy, fz')");
  if (auto e = close_block(); !e.empty()) return e;
  return {};
}

std::string read_h5_table(const std::string& file, const std::string& group, LoadTable* t) {
  std::string err;
  std::vector<hsize_t> dims;
  t->source = cat(file, ":", group);
  if (io::has_object(file, group + "/forces")) {  // the generic table
    if (!io::read_doubles(file, group + "/time", &t->time, &dims, &err)) return err;
    if (dims.size() != 1) return cat(file, ": ", group, "/time must be 1-D");
    if (!io::read_ints(file, group + "/node_ids", &t->node_ids, &dims, &err)) return err;
    if (dims.size() != 1) return cat(file, ": ", group, "/node_ids must be 1-D");
    if (!io::read_doubles(file, group + "/forces", &t->forces, &dims, &err)) return err;
    if (dims.size() != 3 || dims[0] != t->time.size() || dims[1] != t->node_ids.size() || dims[2] != 3)
      return cat(file, ": ", group, "/forces must have the shape (n_times, n_nodes, 3) = (", t->time.size(), ", ",
                 t->node_ids.size(), ", 3)");
    return {};
  }
  if (io::has_object(file, group + "/normal")) {  // a morse simulate contact group
    if (!io::has_object(file, group + "/mean_force"))
      return cat(file, ": ", group, " has no mean_force (the mean contact force of each output interval): the file ",
                 "was written by an older morse simulate; run it again");
    if (!io::read_doubles(file, group + "/mean_force_time", &t->time, &dims, &err)) return err;
    if (!io::read_ints(file, group + "/node_ids", &t->node_ids, &dims, &err)) return err;
    if (!io::read_doubles(file, group + "/mean_force", &t->forces, &dims, &err)) return err;
    if (dims.size() != 3 || dims[0] != t->time.size() || dims[1] != t->node_ids.size() || dims[2] != 3)
      return cat(file, ": ", group, "/mean_force must have the shape (n_times, n_nodes, 3) = (", t->time.size(), ", ",
                 t->node_ids.size(), ", 3)");
    return {};
  }
  if (!io::has_object(file, group)) return cat(file, ": no group ", group);
  return cat(file, ": ", group,
             " is neither a load table (time, node_ids, forces) nor a morse simulate contact group "
             "(node_ids, mean_force, mean_force_time): no dataset ",
             group, "/forces");
}

}  // namespace

std::string read_load_table(const std::string& spec, LoadTable* table) {
  *table = LoadTable{};
  std::string file, group;
  split_spec(spec, &file, &group);
  std::string err;
  if (ends_with_csv(file)) {
    if (!group.empty()) return cat(spec, ": a CSV load table has no group");
    err = read_csv(file, table);
  } else {
    {
      std::ifstream probe(file);
      if (!probe) return cat(file, ": cannot open");
    }
    if (group.empty()) {
      if (io::has_object(file, "/load_history"))
        group = "/load_history";
      else if (io::has_object(file, "/sim/contact"))
        group = "/sim/contact";
      else {
        std::vector<double> v;
        std::vector<hsize_t> d;
        // A file that is not HDF5 says so rather than "no group".
        if (!io::read_doubles(file, "/load_history/time", &v, &d, &err) && err.find("cannot open") != std::string::npos)
          return err;
        return cat(file,
                   ": no load table (/load_history) nor morse simulate contact forces (/sim/contact); name the "
                   "group as FILE:/GROUP");
      }
    }
    err = read_h5_table(file, group, table);
  }
  if (!err.empty()) return err;
  return table->validate();
}

LoadTable read_load_table(MPI_Comm comm, const std::string& spec) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  LoadTable t;
  std::string err;
  if (rank == 0) err = read_load_table(spec, &t);
  collective_check(comm, err);
  unsigned long long n[3] = {t.time.size(), t.node_ids.size(), t.source.size()};
  MPI_Bcast(n, 3, MPI_UNSIGNED_LONG_LONG, 0, comm);
  t.time.resize(n[0]);
  t.node_ids.resize(n[1]);
  t.forces.resize(n[0] * n[1] * 3);
  t.source.resize(n[2]);
  MPI_Bcast(t.time.data(), static_cast<int>(n[0]), MPI_DOUBLE, 0, comm);
  MPI_Bcast(t.node_ids.data(), static_cast<int>(n[1]), MPI_INT64_T, 0, comm);
  // The forces may exceed INT_MAX values: in pieces.
  const std::size_t piece = std::size_t(1) << 28;
  for (std::size_t o = 0; o < t.forces.size(); o += piece)
    MPI_Bcast(t.forces.data() + o, static_cast<int>(std::min(piece, t.forces.size() - o)), MPI_DOUBLE, 0, comm);
  MPI_Bcast(t.source.data(), static_cast<int>(n[2]), MPI_CHAR, 0, comm);
  return t;
}

LoadHistory::LoadHistory(const mesh::LocalMesh& lm, const fe::DofLayout& dofs, const LoadTable& table, Outside outside,
                         double scale)
    : outside_(outside), n_nodes_(table.n_nodes()) {
  std::string err = table.validate();
  if (err.empty() && !std::isfinite(scale)) err = cat(table.source, ": the scale factor is not finite");
  collective_check(lm.comm, err);
  grid_.time = table.time;
  grid_.source = table.source;
  int rank = 0;
  MPI_Comm_rank(lm.comm, &rank);
  const std::size_t nt = table.n_times(), nn = table.n_nodes();
  std::map<std::int64_t, std::size_t> column;
  for (std::size_t k = 0; k < nn; ++k) column[table.node_ids[k]] = k;
  std::vector<int> found(nn, 0);
  std::vector<std::size_t> src;  // table index (node * 3 + d) of each owned free entry
  for (std::int64_t k = 0; k < lm.mesh.num_nodes(); ++k) {
    auto it = column.find(lm.mesh.node_ids[k]);
    if (it == column.end()) continue;
    found[it->second] = 1;
    if (lm.node_owner[k] != rank) continue;
    for (int d = 0; d < 3; ++d) {
      const PetscInt g = dofs.node_dof[3 * k + d];
      if (g < 0) continue;  // clamped: a reaction
      local_.push_back(g - dofs.first);
      src.push_back(3 * it->second + d);
    }
  }
  MPI_Allreduce(MPI_IN_PLACE, found.data(), static_cast<int>(nn), MPI_INT, MPI_MAX, lm.comm);
  std::string missing;
  int n_missing = 0;
  for (std::size_t k = 0; k < nn; ++k)
    if (!found[k] && ++n_missing <= 10) missing += cat(n_missing > 1 ? ", " : "", table.node_ids[k]);
  if (n_missing)
    err = cat(table.source, ": ", n_missing, " node id(s) of the load table are not nodes of ", lm.mesh.source, " (",
              missing, n_missing > 10 ? ", ..." : "", ")");
  collective_check(lm.comm, err);
  values_.resize(nt * local_.size());
  sum_.assign(nt * 3, 0.0);
  for (std::size_t i = 0; i < nt; ++i) {
    for (std::size_t e = 0; e < src.size(); ++e)
      values_[i * local_.size() + e] = scale * table.forces[i * nn * 3 + src[e]];
    for (std::size_t k = 0; k < nn; ++k)
      for (int d = 0; d < 3; ++d) sum_[3 * i + d] += scale * table.forces[(i * nn + k) * 3 + d];
  }
}

void LoadHistory::check_covers(double t_begin, double t_end) const {
  if (outside_ != Outside::Error) return;
  std::size_t i;
  double w;
  bool in0, in1;
  grid_.locate(t_begin, &i, &w, &in0);
  grid_.locate(t_end, &i, &w, &in1);
  MORSE_CHECK(in0 && in1, grid_.source, ": the load history covers [", t_first(), ", ", t_last(),
              "] s, not the run's [", t_begin, ", ", t_end,
              "] s (shorten the run, or give -load_history_outside zero|hold to extrapolate)");
}

void LoadHistory::add_to(double t, Vec F) const {
  std::size_t i;
  double w;
  bool inside;
  grid_.locate(t, &i, &w, &inside);
  if (!inside) {
    MORSE_CHECK(outside_ != Outside::Error, grid_.source, ": t = ", t, " s is outside the load history [", t_first(),
                ", ", t_last(), "] s");
    if (outside_ == Outside::Zero) return;
  }
  const std::size_t n = local_.size();
  if (n == 0) return;
  PetscScalar* a;
  MORSE_CALL(VecGetArray(F, &a));
  const double* v0 = values_.data() + i * n;
  const double* v1 = grid_.time.size() > 1 ? v0 + n : v0;
  for (std::size_t e = 0; e < n; ++e) a[local_[e]] += (1.0 - w) * v0[e] + w * v1[e];
  MORSE_CALL(VecRestoreArray(F, &a));
}

std::vector<double> LoadHistory::total(double t) const {
  std::size_t i;
  double w;
  bool inside;
  grid_.locate(t, &i, &w, &inside);
  std::vector<double> f(3, 0.0);
  if (!inside && outside_ == Outside::Zero) return f;
  const std::size_t j = grid_.time.size() > 1 ? i + 1 : i;
  for (int d = 0; d < 3; ++d) f[d] = (1.0 - w) * sum_[3 * i + d] + w * sum_[3 * j + d];
  return f;
}

std::string LoadHistoryOptions::file() const {
  std::string file, group;
  split_spec(spec, &file, &group);
  return file;
}

}  // namespace morse::dyn
