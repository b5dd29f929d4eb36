// core/files.cpp: output paths and temporaries (morse/core/files.hpp).
#include "morse/core/files.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"

namespace morse::files {

namespace fs = std::filesystem;

namespace {

constexpr const char* kTempMark = ".tmp.";
constexpr const char* kLockSuffix = ".lock";

// The path with "." and ".." removed and the symlinks of its existing part resolved; the path
// itself if that fails.
fs::path canonical_of(const std::string& p) {
  std::error_code ec;
  fs::path abs = fs::absolute(p, ec);
  if (ec) return fs::path(p).lexically_normal();
  fs::path c = fs::weakly_canonical(abs, ec);
  return ec ? abs.lexically_normal() : c;
}

// Whether process pid runs on this machine (kill(pid, 0): no such process is ESRCH).
bool alive(long pid) {
  if (pid <= 0 || pid != static_cast<long>(static_cast<pid_t>(pid))) return false;
  return kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

// "" if output o may be written, else why not.
std::string check_one(const Named& o) {
  if (o.path.empty()) return cat(o.option, " is empty: give the name of the output file");
  const fs::path p(o.path);
  std::error_code ec;
  const auto st = fs::status(p, ec);
  if (!p.has_filename() || fs::is_directory(st))
    return cat(o.option, " ", o.path, " is a directory: give the name of the output file");
  if (fs::exists(st) && !fs::is_regular_file(st))
    return cat(o.option, " ", o.path, " exists and is not a regular file: give the name of the output file");
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  const auto ds = fs::status(dir, ec);
  if (!fs::exists(ds))
    return cat("cannot write ", o.option, " ", o.path, ": the directory ", dir.string(), " does not exist");
  if (!fs::is_directory(ds))
    return cat("cannot write ", o.option, " ", o.path, ": ", dir.string(), " is not a directory");
  if (access(dir.c_str(), W_OK | X_OK) != 0)
    return cat("cannot write ", o.option, " ", o.path, ": the directory ", dir.string(), " is not writable");
  return {};
}

std::string host_name() {
  char h[256] = {};
  if (gethostname(h, sizeof h - 1) != 0) return {};
  return h;
}

// The holder of lock file fd as it wrote it: "pid N" (and " on HOST" if not this machine), or
// "pid unknown" (it has not written it yet).
std::string holder_of(int fd) {
  char buf[300] = {};
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  std::string text(buf, n > 0 ? static_cast<std::size_t>(n) : 0);
  const std::size_t sp = text.find(' ');
  std::string pid = text.substr(0, sp);
  if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos) return "pid unknown";
  std::string host = sp == std::string::npos ? "" : text.substr(sp + 1);
  while (!host.empty() && (host.back() == '\n' || host.back() == ' ')) host.pop_back();
  return host.empty() || host == host_name() ? cat("pid ", pid) : cat("pid ", pid, " on ", host);
}

}  // namespace

std::string lock_path(const std::string& path) { return path + kLockSuffix; }

OutputLock& OutputLock::operator=(OutputLock&& o) noexcept {
  if (this != &o) {
    release();
    held_ = std::move(o.held_);
    o.held_.clear();
  }
  return *this;
}

std::string OutputLock::add(const Named& o) {
  const std::string lp = lock_path(o.path);
  // A run that releases its lock removes the file first: the lock taken here may be on a file
  // no longer at lp (opened before the removal). Then lp is a new file (or none): try again.
  for (int attempt = 0; attempt < 20; ++attempt) {
    const int fd = open(lp.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0)
      return cat("cannot write ", o.option, " ", o.path, ": cannot create its lock file ", lp, ": ",
                 std::strerror(errno));
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int e = errno;
      std::string msg = e == EWOULDBLOCK
                            ? cat(o.path, " is being written by another morse run (", holder_of(fd),
                                  "); wait for it or choose another ", o.option)
                            : cat("cannot write ", o.option, " ", o.path, ": cannot lock ", lp, ": ", std::strerror(e));
      close(fd);
      return msg;
    }
    struct stat held;
    struct stat now;
    if (fstat(fd, &held) == 0 && stat(lp.c_str(), &now) == 0 && held.st_dev == now.st_dev &&
        held.st_ino == now.st_ino) {
      const std::string me = cat(static_cast<long>(getpid()), " ", host_name(), "\n");
      if (ftruncate(fd, 0) != 0 || pwrite(fd, me.data(), me.size(), 0) != static_cast<ssize_t>(me.size())) {
        // The lock holds without the pid: a refused run says "pid unknown".
      }
      held_.push_back({lp, fd});
      return {};
    }
    close(fd);
  }
  return cat("cannot write ", o.option, " ", o.path, ": its lock file ", lp, " keeps being replaced");
}

std::vector<std::string> OutputLock::paths() const {
  std::vector<std::string> p;
  for (const Held& h : held_) p.push_back(h.path.substr(0, h.path.size() - std::strlen(kLockSuffix)));
  return p;
}

void OutputLock::release() noexcept {
  // Removed while locked, so no other run can hold a lock on this file (see add).
  for (const Held& h : held_) {
    unlink(h.path.c_str());
    close(h.fd);
  }
  held_.clear();
}

bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool eq = fs::equivalent(a, b, ec);
    if (!ec) return eq;
  }
  return canonical_of(a) == canonical_of(b);
}

std::string absolute_path(const std::string& p) { return p.empty() ? p : canonical_of(p).string(); }

std::string resolve_stored_path(const std::string& stored, const std::string& file) {
  std::error_code ec;
  if (stored.empty() || fs::path(stored).is_absolute() || fs::exists(stored, ec)) return stored;
  const fs::path beside = fs::path(file).parent_path() / stored;
  return fs::exists(beside, ec) ? beside.lexically_normal().string() : stored;
}

OutputLock prepare_outputs(MPI_Comm comm, const std::vector<Named>& outputs, const std::vector<Named>& inputs) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  OutputLock lock;
  std::string err;
  std::vector<std::string> removed;
  if (rank == 0) {
    for (std::size_t k = 0; k < outputs.size() && err.empty(); ++k) {
      const Named& o = outputs[k];
      err = check_one(o);
      for (const Named& i : inputs)
        if (err.empty() && !i.path.empty() && same_file(o.path, i.path))
          err = cat(o.option, " ", o.path, " is the input file ", i.option, " ", i.path,
                    " (the same file): the run would overwrite it; give another ", o.option);
      for (std::size_t j = 0; j < k && err.empty(); ++j)
        if (same_file(o.path, outputs[j].path))
          err = cat(outputs[j].option, " ", outputs[j].path, " and ", o.option, " ", o.path,
                    " are the same output file; give different names");
    }
    for (std::size_t k = 0; k < outputs.size() && err.empty(); ++k) err = lock.add(outputs[k]);
    if (err.empty())
      for (const Named& o : outputs)
        for (auto& f : remove_stale_temps(o.path)) removed.push_back(std::move(f));
  }
  collective_check(comm, err);  // a refused run releases the locks it took (lock's destructor)
  for (const auto& f : removed)
    print0(PETSC_COMM_SELF, "morse: removed %s, the temporary of a killed run\n", f.c_str());
  return lock;
}

std::string temp_path(const std::string& path) { return cat(path, kTempMark, static_cast<long>(getpid())); }

std::string temp_path(MPI_Comm comm, const std::string& path) {
  long pid = static_cast<long>(getpid());
  MPI_Bcast(&pid, 1, MPI_LONG, 0, comm);
  return cat(path, kTempMark, pid);
}

void commit(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw Error(cat(path, ": cannot rename its temporary ", tmp, " onto it: ", ec.message()));
  }
}

std::vector<std::string> remove_stale_temps(const std::string& path) {
  std::vector<std::string> removed;
  const fs::path p(path);
  if (!p.has_filename()) return removed;
  const std::string prefix = p.filename().string() + kTempMark;
  const fs::path dir = p.parent_path();
  std::error_code ec;
  fs::directory_iterator it(dir.empty() ? fs::path(".") : dir, ec), end;
  const long self = static_cast<long>(getpid());
  for (; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.size() > 18 || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    const long pid = std::stol(digits);
    if (pid != self && alive(pid)) continue;
    std::error_code rc;
    if (!fs::is_directory(it->symlink_status(rc)) && fs::remove(it->path(), rc))
      removed.push_back((dir / name).string());
  }
  return removed;
}

}  // namespace morse::files
