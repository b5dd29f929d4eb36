// morse/core/log.hpp: stage timing, memory, progress and PETSc log events.
//
// Every stage of a command runs inside a StageTimer, which opens a PetscLogEvent of the same name
// (so -log_view shows where the time went) and records wall time and the peak resident memory
// for the summary table printed at the end of a run.
#pragma once

#include <petscsys.h>

#include <chrono>
#include <string>
#include <vector>

namespace morse {

/// One line of the timing summary.
struct StageRecord {
  std::string name;
  double seconds = 0.0;
  double peak_mb = 0.0;  ///< peak resident set size at stage end (this rank)
};

/// Accumulates the records of a run (one per process).
std::vector<StageRecord>& stage_records();

/// Returns (registering on first use) the PetscLogEvent named "morse:<name>".
PetscLogEvent log_event(const std::string& name);

/// Scoped stage: PetscLogEventBegin/End plus wall time and peak memory of this rank. Not
/// collective (the destructor may run during stack unwinding on one rank only).
class StageTimer {
 public:
  StageTimer(MPI_Comm comm, const std::string& name);
  ~StageTimer();
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  MPI_Comm comm_;
  std::string name_;
  PetscLogEvent event_;
  std::chrono::steady_clock::time_point start_;
};

/// The stage records of this run with time and memory reduced to their maximum over the ranks.
/// Collective: every rank must have recorded the same stages.
std::vector<StageRecord> reduced_stage_records(MPI_Comm comm);

/// Peak resident set size of this process, in MB.
double peak_memory_mb();

/// Bytes of memory available on this machine now: Linux MemAvailable, capped by the limit of the
/// process's cgroup (memory.max - memory.current) when it has one; -1 if unknown. Not collective.
double available_bytes();
/// "" if `bytes`, needed for `purpose`, fit in the memory available now (or it is unknown); else
/// "<what> needs 14.8 GB for <purpose>; 2.3 GB available". For work of one rank. Not collective.
std::string memory_error(const std::string& what, double bytes, const std::string& purpose);
/// The same for `bytes` held by every rank of comm: the ranks that share a node add up. Throws
/// (morse::Error, every rank alike) if a node lacks the memory, before anything is allocated.
/// Collective.
void check_memory(MPI_Comm comm, const std::string& what, double bytes, const std::string& purpose);

/// Progress of a long loop, printed on rank 0 of comm: "  <stage>: 42% (ETA 12 s)". Prints at
/// most every 2 s and only once the loop has run for 2 s. Not collective.
class Progress {
 public:
  Progress(MPI_Comm comm, std::string stage, double total);
  /// Reports that `done` out of `total` units are finished.
  void update(double done);
  ~Progress();

 private:
  std::string stage_;
  double total_;
  bool print_;
  bool printed_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

/// A duration for people: "42 s", "12.5 min", "5.2 h" or "3.1 days".
std::string duration_text(double seconds);

/// printf on rank 0 of comm (PetscPrintf), throwing on error.
void print0(MPI_Comm comm, const char* fmt, ...);

}  // namespace morse
