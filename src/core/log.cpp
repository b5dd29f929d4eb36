#include "morse/core/log.hpp"

#include <sys/resource.h>

#include <cstdarg>
#include <cstdio>
#include <map>

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

}  // namespace morse
