// morse/core/files.hpp: the output files of a run: the start-of-run check of the output paths
// against the input files, and the temporaries every writer goes through.
//
// Every output is written to a temporary "<out>.tmp.<pid>" (pid: the process id of the writing
// rank, or of rank 0 for a file every rank writes) and renamed onto <out> when complete, so that a
// failed or killed run never leaves a partial <out> and two runs cannot write the same temporary.
// A run killed while writing leaves its temporary behind: prepare_outputs removes it at the start
// of the next run of the same output.
//
// Two runs on the same output would overwrite each other's work (a sweep resumed while the killed
// run's ranks still write checkpoints): rank 0 holds an exclusive lock on every output for the
// whole run (OutputLock, taken by prepare_outputs), and a second run is refused at its start.
#pragma once

#include <mpi.h>

#include <string>
#include <utility>
#include <vector>

namespace morse::files {

/// A file named on the command line: the option (or argument) that names it and its path as given.
struct Named {
  std::string option;  ///< e.g. "-mesh", "-out", "ROM.h5"
  std::string path;    ///< empty: not given (ignored)
};

/// Whether a and b name the same file: the same inode if both exist (a symlink or a hard link is
/// its target), else the same canonical path (symlinks of the existing part resolved, "." and ".."
/// removed, relative paths taken from the working directory), so "m.msh", "./m.msh" and its
/// absolute path all match. Not collective.
bool same_file(const std::string& a, const std::string& b);

/// The absolute, canonical form of a path (as same_file compares them): what an output stores to
/// name an input, so that the record holds from any working directory. Empty stays empty. Not
/// collective.
std::string absolute_path(const std::string& p);

/// A path stored in `file` (an input it names), as found from here: the path itself if it is
/// absolute or exists from the working directory, else taken relative to `file`'s directory
/// (files written before paths were stored absolute). Not collective.
std::string resolve_stored_path(const std::string& stored, const std::string& file);

/// The locks on the outputs of a run, held by rank 0 (empty on the other ranks) from
/// prepare_outputs until it is destroyed: keep it alive for the whole command.
///
/// The lock of output <out> is flock(LOCK_EX) on the lock file "<out>.lock" beside it, which holds
/// the holder's "pid host". Not on <out> itself: <out> may not exist yet (an empty <out> would be a
/// partial output) and every commit renames a new file onto it, so a lock on the old inode would
/// not cover the next run. flock rather than fcntl(F_SETLK): its lock belongs to the open file
/// description, so closing some other descriptor of the file (HDF5, a test) does not drop it, and a
/// second open() in the same process conflicts (testable). The kernel drops it when the process
/// dies (kill -9 included), so a lock file left by a killed run does not block: only the lock does.
/// A normal release removes the lock file while still holding the lock; a run that took the lock
/// on a file that was removed meanwhile (its inode is no longer the path's) retries on the new one.
/// On a network file system flock is as reliable as the server's locks (NFS: Linux maps flock to
/// byte-range locks). Not collective.
class OutputLock {
 public:
  OutputLock() = default;
  ~OutputLock() { release(); }
  OutputLock(OutputLock&& o) noexcept : held_(std::move(o.held_)) { o.held_.clear(); }
  OutputLock& operator=(OutputLock&& o) noexcept;
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

  /// Locks output o.path. Returns "" if granted, else why not: "<out> is being written by another
  /// morse run (pid N); wait for it or choose another -out" (the holder's pid as it wrote it, and
  /// its host if not this one), or a lock file that cannot be created.
  std::string add(const Named& o);
  /// The outputs locked.
  std::vector<std::string> paths() const;
  /// Unlocks every output and removes their lock files.
  void release() noexcept;

 private:
  struct Held {
    std::string path;  ///< the lock file
    int fd;
  };
  std::vector<Held> held_;
};

/// The lock file of output path: "<path>.lock".
std::string lock_path(const std::string& path);

/// The start-of-run check of a command's outputs, before any work. Refuses, naming the option and
/// the paths: an empty output path; a directory, or anything but a regular file, where an output
/// is to be written; an output whose directory does not exist or is not writable; an output that
/// is one of the inputs (same_file), or two outputs that are the same file. Then locks every output
/// (OutputLock: an output that another run is writing is refused, naming its pid) and removes the
/// stale temporaries of every output (remove_stale_temps). Rank 0 checks and holds the locks; every
/// rank throws the same morse::Error. Keep the result until the command ends:
///   const auto lock = files::prepare_outputs(comm, {{"-out", out}}, inputs);
/// Collective.
[[nodiscard]] OutputLock prepare_outputs(MPI_Comm comm, const std::vector<Named>& outputs,
                                         const std::vector<Named>& inputs);

/// The temporary that `path` is written to: "<path>.tmp.<pid>" with this process's id (a writer
/// that runs on one rank). Not collective.
std::string temp_path(const std::string& path);
/// The same with rank 0's process id on every rank of comm (a file that every rank opens).
/// Collective.
std::string temp_path(MPI_Comm comm, const std::string& path);

/// Renames the complete temporary tmp onto path. On failure removes tmp and throws morse::Error
/// naming path and the reason. Not collective.
void commit(const std::string& tmp, const std::string& path);

/// Removes the temporaries of path left by killed runs: the files "<path>.tmp.<pid>" (exactly
/// that name, pid all digits) whose process no longer runs on this machine, or that carry this
/// process's own id (it has not started writing). A temporary of a live process (a run writing the
/// same output now) is kept. Returns the removed files. Not collective.
std::vector<std::string> remove_stale_temps(const std::string& path);

}  // namespace morse::files
