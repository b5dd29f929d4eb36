#include "morse/core/log.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>

#include "morse/core/error.hpp"

namespace morse {

std::vector<StageRecord>& stage_records() {
  static std::vector<StageRecord> records;
  return records;
}

PetscLogEvent log_event(const std::string& name) {
  static std::map<std::string, PetscLogEvent> events;
  static PetscClassId class_id = 0;
  if (!class_id) MORSE_CALL(PetscClassIdRegister("morse", &class_id));
  auto it = events.find(name);
  if (it != events.end()) return it->second;
  PetscLogEvent ev;
  MORSE_CALL(PetscLogEventRegister(("morse:" + name).c_str(), class_id, &ev));
  events[name] = ev;
  return ev;
}

double peak_memory_mb() {
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_maxrss) / 1024.0;
}

namespace {

// A number of bytes with 3 significant digits in GB ("14.8 GB", "0.0012 GB"), TB or PB.
std::string size_text(double bytes) {
  const char* unit = bytes < 1e12 ? "GB" : bytes < 1e15 ? "TB" : "PB";
  const double scale = bytes < 1e12 ? 1e9 : bytes < 1e15 ? 1e12 : 1e15;
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.3g %s", bytes / scale, unit);
  return buf;
}

// A number from the first line of a file, or -1 (missing file, "max").
double number_in(const char* path) {
  std::ifstream f(path);
  std::string word;
  if (!(f >> word) || word.find_first_not_of("0123456789") != std::string::npos) return -1.0;
  return std::strtod(word.c_str(), nullptr);
}

}  // namespace

double available_bytes() {
  double avail = -1.0;
  {
    std::ifstream f("/proc/meminfo");
    std::string key, unit;
    double kb = 0;
    while (f >> key >> kb >> unit)
      if (key == "MemAvailable:") {
        avail = kb * 1024.0;
        break;
      }
  }
  // A container's limit (cgroup v2) is below what the machine has.
  const double max = number_in("/sys/fs/cgroup/memory.max"), current = number_in("/sys/fs/cgroup/memory.current");
  if (max > 0 && current >= 0) {
    const double left = std::max(0.0, max - current);
    avail = avail < 0 ? left : std::min(avail, left);
  }
  return avail;
}

std::string memory_error(const std::string& what, double bytes, const std::string& purpose) {
  const double avail = available_bytes();
  if (avail < 0 || bytes <= avail) return {};
  return cat(what, " needs ", size_text(bytes), " for ", purpose, "; ", size_text(avail), " available");
}

void check_memory(MPI_Comm comm, const std::string& what, double bytes, const std::string& purpose) {
  MPI_Comm node;
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  double on_node = bytes;
  int ranks = 1;
  MPI_Allreduce(MPI_IN_PLACE, &on_node, 1, MPI_DOUBLE, MPI_SUM, node);
  MPI_Comm_size(node, &ranks);
  MPI_Comm_free(&node);
  std::string err = memory_error(what, on_node, purpose);
  if (!err.empty() && ranks > 1) {
    const double avail = available_bytes();
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    err = cat(what, " needs ", size_text(on_node), " for ", purpose, " on a node of ", ranks, " ranks (",
              size_text(bytes), " on rank ", rank, "); ", size_text(avail), " available");
  }
  collective_check(comm, err);
}

StageTimer::StageTimer(MPI_Comm comm, const std::string& name)
    : comm_(comm), name_(name), event_(log_event(name)), start_(std::chrono::steady_clock::now()) {
  PetscLogEventBegin(event_, 0, 0, 0, 0);
}

StageTimer::~StageTimer() {
  PetscLogEventEnd(event_, 0, 0, 0, 0);
  StageRecord r;
  r.name = name_;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  r.peak_mb = peak_memory_mb();
  stage_records().push_back(r);
}

Progress::Progress(MPI_Comm comm, std::string stage, double total)
    : stage_(std::move(stage)), total_(total > 0 ? total : 1.0) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  print_ = rank == 0;
  start_ = last_ = std::chrono::steady_clock::now();
}

void Progress::update(double done) {
  if (!print_) return;
  auto now = std::chrono::steady_clock::now();
  double since_start = std::chrono::duration<double>(now - start_).count();
  double since_last = std::chrono::duration<double>(now - last_).count();
  if (since_start < 2.0 || since_last < 2.0 || done <= 0) return;
  last_ = now;
  double frac = done / total_;
  double eta = since_start * (1.0 - frac) / frac;
  std::fprintf(stdout, "  %s: %3.0f%% (ETA %.0f s)\n", stage_.c_str(), 100.0 * frac, eta);
  std::fflush(stdout);
  printed_ = true;
}

Progress::~Progress() {
  if (print_ && printed_) {
    double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::fprintf(stdout, "  %s: 100%% (%.1f s)\n", stage_.c_str(), t);
    std::fflush(stdout);
  }
}

std::vector<StageRecord> reduced_stage_records(MPI_Comm comm) {
  std::vector<StageRecord> out = stage_records();
  for (auto& r : out) {
    MPI_Allreduce(MPI_IN_PLACE, &r.seconds, 1, MPI_DOUBLE, MPI_MAX, comm);
    MPI_Allreduce(MPI_IN_PLACE, &r.peak_mb, 1, MPI_DOUBLE, MPI_MAX, comm);
  }
  return out;
}

void print0(MPI_Comm comm, const char* fmt, ...) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank != 0) return;
  va_list ap;
  va_start(ap, fmt);
  std::vprintf(fmt, ap);
  va_end(ap);
  std::fflush(stdout);
}

std::string duration_text(double seconds) {
  char b[64];
  if (!std::isfinite(seconds))
    std::snprintf(b, sizeof b, "an unknown time");
  else if (seconds < 120.0)
    std::snprintf(b, sizeof b, "%.0f s", seconds);
  else if (seconds < 7200.0)
    std::snprintf(b, sizeof b, "%.1f min", seconds / 60.0);
  else if (seconds < 3.0 * 86400.0)
    std::snprintf(b, sizeof b, "%.1f h", seconds / 3600.0);
  else
    std::snprintf(b, sizeof b, "%.1f days", seconds / 86400.0);
  return b;
}

}  // namespace morse
