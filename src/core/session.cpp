#include "morse/core/session.hpp"

#include <signal.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/factor.hpp"

namespace morse {

namespace {

int g_world_rank = 0;  // rank in MPI_COMM_WORLD, for world_rank() outside PETSc's lifetime

bool same_word(const std::string& a, const char* b) { return strcasecmp(a.c_str(), b) == 0; }

// Whitespace-separated tokens, as PETSc splits an options line (tabs and ^M are blanks).
std::vector<std::string> tokens(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream is(line);
  for (std::string t; is >> t;) out.push_back(t);
  return out;
}

// Follows the -options_file chain depth first; `open` holds the files being read (their
// canonical path and their name as given), so a file met again on it closes a cycle.
class OptionsFiles {
 public:
  // `where` is "" (command line), "PETSC_OPTIONS: " or "file:line: ".
  std::string visit(const std::string& file, const std::string& where, bool required) {
    // ${VAR} substitutions and YAML files are PETSc's own business.
    if (file.find("${") != std::string::npos) return {};
    for (const char* ext : {".yaml", ".yml", ".json", ":yaml"})
      if (file.size() >= std::strlen(ext) && file.compare(file.size() - std::strlen(ext), std::string::npos, ext) == 0)
        return {};
    const std::string what = cat(where, "-options_file ", file, ": ");
    char* real = realpath(file.c_str(), nullptr);
    if (!real) return required ? cat(what, "cannot open (", std::strerror(errno), ")") : std::string();
    const std::string key = real;
    std::free(real);
    for (std::size_t i = 0; i < open_.size(); ++i)
      if (open_[i].first == key) {
        if (i + 1 == open_.size())
          return cat("options file ", file, " includes itself (", where, "-options_file ", file, ")");
        std::string chain;
        for (std::size_t j = i; j < open_.size(); ++j) chain += open_[j].second + " -> ";
        return cat("options files include each other: ", chain, file);
      }
    struct stat st {};
    if (stat(key.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) return cat(what, "is a directory, not an options file");
    std::ifstream in(key);
    if (!in) return required ? cat(what, "cannot open (", std::strerror(errno), ")") : std::string();
    open_.emplace_back(key, file);
    std::string line, err;
    for (int n = 1; err.empty() && std::getline(in, line); ++n) {
      line = line.substr(0, line.find('#'));
      const auto t = tokens(line);
      count(t, file);
      if (t.empty() || !same_word(t[0], "-options_file")) continue;
      if (t.size() < 2 || t[1][0] == '-')
        err = cat(file, ":", n, ": -options_file needs a file name");
      else
        err = visit(unquote(t[1]), cat(file, ":", n, ": "), true);
    }
    open_.pop_back();
    return err;
  }

  // Every -options_file NAME of a list of arguments (the command line, PETSC_OPTIONS).
  std::string visit_args(const std::vector<std::string>& args, const std::string& where) {
    count(args, where.empty() ? "the command line" : where.substr(0, where.size() - 2));
    for (std::size_t i = 0; i < args.size(); ++i) {
      if (!same_word(args[i], "-options_file")) continue;
      if (i + 1 >= args.size() || args[i + 1][0] == '-') return cat(where, "-options_file needs a file name");
      if (auto err = visit(unquote(args[i + 1]), where, true); !err.empty()) return err;
      ++i;
    }
    return {};
  }

 public:
  /// Options given in all (tokens "-name"; a negative number is a value), and the source that
  /// gives the most.
  long options() const { return total_; }
  const std::string& largest() const { return largest_; }
  long largest_count() const { return largest_n_; }

 private:
  void count(const std::vector<std::string>& t, const std::string& source) {
    long n = 0;
    for (const auto& w : t)
      if (w.size() > 1 && w[0] == '-' && std::isalpha(static_cast<unsigned char>(w[1]))) ++n;
    total_ += n;
    per_source_[source] += n;
    if (per_source_[source] > largest_n_) largest_n_ = per_source_[source], largest_ = source;
  }
  long total_ = 0, largest_n_ = 0;
  std::string largest_;
  std::map<std::string, long> per_source_;

  static std::string unquote(const std::string& s) {
    if (s.size() >= 2 && (s.front() == '"' || s.front() == '\'') && s.back() == s.front())
      return s.substr(1, s.size() - 2);
    return s;
  }
  std::vector<std::pair<std::string, std::string>> open_;
};

// Whether this process was started by an MPI launcher (mpirun/orted of Open MPI, PRRTE, hydra):
// they all set one of these. A singleton (morse run without mpirun) has none until MPI_Init.
bool launched_by_mpirun() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
    if (std::getenv(v)) return true;
  return false;
}

// The ranks exit when their launcher dies. Open MPI puts each rank in its own process group, so
// `kill -9` of mpirun's group (a killed job, a timeout) leaves the ranks running: a sweep wrote
// checkpoints for another second, and a resume started at once wrote the same file. The parent of
// a rank is the launcher (mpirun, or the orted/prted daemon on another node); when it dies the
// rank is re-parented (to init or a subreaper) and getppid() changes. A detached thread polls it
// every 200 ms and ends the process at once with _exit: no destructor, no atexit handler, no
// commit, so no partial output (outputs are temporaries until renamed) and no further checkpoint.
// Not PR_SET_PDEATHSIG: it fires when the parent *thread* that forked the rank ends, and Open
// MPI's launcher forks from a progress thread; nor for a singleton, whose parent is a shell that
// may go (nohup) while the run should go on.
void start_launcher_watchdog() {
  const pid_t parent = getppid();
  std::thread([parent] {
    for (;;) {
      usleep(200 * 1000);
      if (getppid() != parent) _exit(128 + SIGHUP);
    }
  }).detach();
}

}  // namespace

std::string options_file_error(int argc, char** argv) {
  OptionsFiles files;
  std::vector<std::string> args(argv + std::min(argc, 1), argv + std::max(argc, 0));
  bool skip_rc = false;
  for (const auto& a : args) skip_rc = skip_rc || same_word(a, "-skip_petscrc");
  // PETSc reads PETSC_OPTIONS, then the rc files (if present), then the command line.
  if (const char* env = std::getenv("PETSC_OPTIONS"))
    if (auto err = files.visit_args(tokens(env), "PETSC_OPTIONS: "); !err.empty()) return err;
  if (!skip_rc) {
    std::vector<std::string> rc = {".petscrc", "petscrc"};
    if (const char* home = std::getenv("HOME")) rc.insert(rc.begin(), std::string(home) + "/.petscrc");
    for (const auto& f : rc)
      if (auto err = files.visit(f, "", false); !err.empty()) return err;
  }
  if (auto err = files.visit_args(args, ""); !err.empty()) return err;
  // PETSc's options database holds at most 512 options (MAXOPTIONS) and fails with "Out of
  // memory" beyond; the solvers add their defaults to it, so the options given keep a margin.
  if (files.options() > kMaxGivenOptions)
    return cat(files.options(), " options given (", files.largest_count(), " in ", files.largest(),
               "): PETSc's options database holds at most 512, and morse's solvers add their defaults; give at most ",
               kMaxGivenOptions);
  return {};
}

Session::Session(int* argc, char*** argv, const char* help) {
  // Before MPI_Init: an Open MPI singleton sets the launcher's variables for itself there.
  const bool launched = launched_by_mpirun();
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (!initialized) {
    MPI_Init(argc, argv);
    began_mpi_ = true;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &g_world_rank);
  if (launched) start_launcher_watchdog();
  try {
    // PETSc follows an options file that includes itself until the stack overflows, and dumps
    // a page for a missing one: check them first, one message on every rank.
    collective_check(MPI_COMM_WORLD, options_file_error(*argc, *argv));
    MORSE_CALL(SlepcInitialize(argc, argv, nullptr, help));
  } catch (...) {
    if (began_mpi_) MPI_Finalize();
    throw;
  }
  // PETSc errors become morse::Error exceptions carrying PETSc's message (MORSE_CALL); the
  // default handler would also print a traceback on every rank.
  MORSE_CALL(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
  init_factorization();
}

Session::~Session() {
  (void)SlepcFinalize();
  if (began_mpi_) MPI_Finalize();
}

bool huge_pages_requested() {
  const char* t = std::getenv("GLIBC_TUNABLES");
  return t && std::strstr(t, "glibc.malloc.hugetlb=1");
}

void use_huge_pages(char** argv) {
  const char* off = std::getenv("MORSE_HUGEPAGES");
  if (off && std::strcmp(off, "0") == 0) return;
  const char* t = std::getenv("GLIBC_TUNABLES");
  // Already set (by us after the re-exec, or by the user, whatever the value): never loop.
  if (t && std::strstr(t, "glibc.malloc.hugetlb")) return;
  // Under valgrind /proc/self/exe is the valgrind tool, not morse: never re-execute there.
  const char* pre = std::getenv("LD_PRELOAD");
  if (pre && std::strstr(pre, "vgpreload")) return;
  std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (mode.find("[madvise]") == std::string::npos && mode.find("[always]") == std::string::npos) return;
  const std::string v = t && *t ? std::string(t) + ":glibc.malloc.hugetlb=1" : std::string("glibc.malloc.hugetlb=1");
  if (setenv("GLIBC_TUNABLES", v.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // The re-exec failed (no /proc, say): go on as we are, with the variable restored.
  if (t)
    setenv("GLIBC_TUNABLES", t, 1);
  else
    unsetenv("GLIBC_TUNABLES");
}

int world_rank() {
  PetscBool up = PETSC_FALSE, down = PETSC_FALSE;
  PetscInitialized(&up);
  PetscFinalized(&down);
  if (!up || down) return g_world_rank;
  int r = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &r);
  return r;
}

int world_size() {
  int s = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &s);
  return s;
}

}  // namespace morse
