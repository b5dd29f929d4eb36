// morse/core/files.hpp: the output files of a run: the start-of-run check of the output paths
// against the input files, and the temporaries every writer goes through.
//
// Every output is written to a temporary "<out>.tmp.<pid>" (pid: the process id of the writing
// rank, or of rank 0 for a file every rank writes) and renamed onto <out> when complete, so that a
// failed or killed run never leaves a partial <out> and two runs cannot write the same temporary.
// A run killed while writing leaves its temporary behind: prepare_outputs removes it at the start
// of the next run of the same output.
#pragma once

#include <mpi.h>

#include <string>
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

/// The start-of-run check of a command's outputs, before any work. Refuses, naming the option and
/// the paths: an empty output path; a directory, or anything but a regular file, where an output
/// is to be written; an output whose directory does not exist or is not writable; an output that
/// is one of the inputs (same_file), or two outputs that are the same file. Then removes the stale
/// temporaries of every output (remove_stale_temps). Rank 0 checks; every rank throws the same
/// morse::Error. Collective.
void prepare_outputs(MPI_Comm comm, const std::vector<Named>& outputs, const std::vector<Named>& inputs);

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
