// core/options.cpp: the option registry and the unknown-option check (morse/core/options.hpp).
#include "morse/core/options.hpp"

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"

namespace morse::options {

namespace {

struct Registry {
  std::map<std::string, std::string> help;               // name without '-' -> help text
  std::vector<std::pair<std::string, Solver>> prefixes;  // solver prefix, kind
  std::vector<std::string> conflicts;
};

Registry& registry() {
  static Registry r;
  return r;
}

std::string bare(const std::string& name) { return name.empty() || name[0] != '-' ? name : name.substr(1); }

// PETSc matches option names regardless of case: so do the suggestions and the early check.
std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string first_word(const std::string& bare_name) { return bare_name.substr(0, bare_name.find('_')); }

bool starts_with(const std::string& s, const char* p) { return s.rfind(p, 0) == 0; }

// The objects of a solver kind: option prefixes (ending in '_') or whole names.
const std::vector<const char*>& objects(Solver kind) {
  static const std::vector<const char*> eigen = {
      "eps_", "st_", "bv_", "ds_", "rg_", "inertia_", "block_", "eigen_solver", "count_slicing", "check_inertia"};
  static const std::vector<const char*> nonlinear = {"snes_", "ksp_", "pc_", "mat_mumps_"};
  static const std::vector<const char*> linear = {"ksp_", "pc_", "mat_mumps_"};
  switch (kind) {
    case Solver::Eigen:
      return eigen;
    case Solver::Nonlinear:
      return nonlinear;
    case Solver::Linear:
      return linear;
  }
  return linear;
}

// The largest edit distance at which a registered name is suggested for a name of this length.
std::size_t max_distance(std::size_t length) { return length <= 4 ? 1 : length <= 10 ? 2 : 3; }

}  // namespace

void add(const std::string& name, const std::string& text) {
  auto& r = registry();
  const std::string b = bare(name);
  auto [it, inserted] = r.help.emplace(b, text);
  if (!inserted && it->second != text) {
    r.conflicts.push_back(cat("-", b, " registered with two help texts: \"", it->second, "\" and \"", text, "\""));
    assert(!"an option registered twice with different help texts (morse/core/options.hpp)");
  }
}

void add(const char* prefix, const char* name, const char* text) {
  const std::string n = bare(name ? name : "");
  add("-" + std::string(prefix ? prefix : "") + n, text ? text : "");
}

void add_prefix(const std::string& prefix, Solver kind) {
  auto& p = registry().prefixes;
  if (std::find(p.begin(), p.end(), std::make_pair(prefix, kind)) == p.end()) p.emplace_back(prefix, kind);
}

bool registered(const std::string& name) { return registry().help.count(bare(name)) > 0; }

std::string help(const std::string& name) {
  auto it = registry().help.find(bare(name));
  return it == registry().help.end() ? std::string() : it->second;
}

bool inner(const std::string& name) {
  const std::string b = lower(bare(name));
  for (const auto& [prefix, kind] : registry().prefixes) {
    if (b.compare(0, prefix.size(), lower(prefix)) != 0) continue;
    const std::string rest = b.substr(prefix.size());
    for (const char* o : objects(kind))
      if (starts_with(rest, o)) return true;
  }
  return false;
}

std::vector<std::string> names() {
  std::vector<std::string> out;
  for (const auto& [n, h] : registry().help) out.push_back("-" + n);
  return out;
}

std::vector<std::string> conflicts() { return registry().conflicts; }

void clear() { registry() = Registry{}; }

std::size_t edit_distance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> d(n + 1, std::vector<std::size_t>(m + 1));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i)
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[n][m];
}

std::string closest(const std::string& name) {
  const std::string b = lower(bare(name));
  std::string best;
  std::size_t best_d = max_distance(b.size()) + 1;
  for (const auto& [n, h] : registry().help) {
    const std::size_t d = edit_distance(b, lower(n));
    if (d < best_d) best_d = d, best = n;  // the map's order breaks ties: the first name wins
  }
  return best.empty() ? best : "-" + best;
}

bool petsc_global(const std::string& name) {
  // PETSc's options database, logging, memory, error and debugger options (PetscInitialize).
  static const char* globals[] = {"help",
                                  "version",
                                  "info",
                                  "options_",
                                  "log",
                                  "malloc",
                                  "memory_view",
                                  "fp_trap",
                                  "on_error_",
                                  "no_signal_handler",
                                  "check_pointer_intensity",
                                  "objects_dump",
                                  "debugger",
                                  "start_in_debugger",
                                  "stop_for_debugger",
                                  "skip_petscrc",
                                  "nox",
                                  "use_gpu_aware_mpi",
                                  "viewer_",
                                  "saws_",
                                  "checkfunctionlist",
                                  "display"};
  const std::string b = lower(bare(name));
  for (const char* g : globals)
    if (starts_with(b, g)) return true;
  return false;
}

bool suspicious(const std::string& name) {
  const std::string b = bare(name);
  if (petsc_global(b) || inner(b) || registered(b)) return false;
  const std::string w = lower(first_word(b));
  for (const auto& [n, h] : registry().help)
    if (lower(first_word(n)) == w) return true;
  return !closest(b).empty();
}

namespace {
// The options nobody has read that `keep` selects, sorted, as " -a (did you mean -b?) -c": the
// list of an unknown-option message ("" if none).
std::string unused_options(const std::function<bool(const char*)>& keep) {
  PetscInt n = 0;
  char** left = nullptr;
  char** values = nullptr;
  MORSE_CALL(PetscOptionsLeftGet(nullptr, &n, &left, &values));
  std::vector<std::string> names;
  for (PetscInt i = 0; i < n; ++i)
    if (keep(left[i])) names.emplace_back(left[i]);
  MORSE_CALL(PetscOptionsLeftRestore(nullptr, &n, &left, &values));
  std::sort(names.begin(), names.end());
  std::string bad;
  for (const auto& name : names) {
    bad += " -" + name;
    if (auto c = closest(name); !c.empty()) bad += " (did you mean " + c + "?)";
  }
  return bad;
}
}  // namespace

void check_unknown(MPI_Comm comm, bool early) {
  const std::string bad =
      unused_options([&](const char* name) { return !petsc_global(name) && (!early || suspicious(name)); });
  std::string err = bad.empty() ? "" : cat("unknown option(s):", bad, " (see -help)");
  if (err.empty() && !registry().conflicts.empty()) err = cat("internal error: ", registry().conflicts.front());
  collective_check(comm, err);
}

void check_prefix_used(MPI_Comm comm, const std::string& prefix, const std::string& what) {
  const std::string bad = unused_options([&](const char* name) { return std::string(name).rfind(prefix, 0) == 0; });
  collective_check(
      comm, bad.empty() ? std::string()
                        : cat("unknown option(s):", bad, ": not read by ", what, " once they are set up (see -help)"));
}

void notice_prefix_unused(MPI_Comm comm, const std::string& prefix, const std::string& what,
                          const std::vector<std::string>& later) {
  const std::string bad = unused_options([&](const char* name) {
    const std::string n(name);
    if (n.rfind(prefix, 0) != 0) return false;
    for (const auto& l : later)
      if (n.find(l) != std::string::npos) return false;
    return true;
  });
  if (!bad.empty())
    print0(comm, "  notice: not (yet) read by %s:%s; unknown options are refused at the end of the run\n", what.c_str(),
           bad.c_str());
}

namespace {

// Whether `t` is an integer in PetscInt's range; `why` says what is wrong otherwise.
bool parse_int(const std::string& t, std::string* why) {
  std::size_t i = t.empty() || (t[0] != '+' && t[0] != '-') ? 0 : 1;
  if (i == t.size() || t.find_first_not_of("0123456789", i) != std::string::npos) {
    *why = "expected an integer";
    return false;
  }
  errno = 0;
  const long long v = std::strtoll(t.c_str(), nullptr, 10);
  if (errno == ERANGE || v > std::numeric_limits<PetscInt>::max() || v < std::numeric_limits<PetscInt>::min()) {
    *why = cat("out of the integer range [", std::numeric_limits<PetscInt>::min(), ", ",
               std::numeric_limits<PetscInt>::max(), "]");
    return false;
  }
  return true;
}

bool parse_real(const std::string& t, bool finite, std::string* why) {
  char* end = nullptr;
  const double v = t.empty() || std::isspace(static_cast<unsigned char>(t[0])) ? 0 : std::strtod(t.c_str(), &end);
  if (!end || *end != '\0') {
    *why = "expected a real number";
    return false;
  }
  if (finite && !std::isfinite(v)) {
    *why = "expected a finite number";
    return false;
  }
  return true;
}

}  // namespace

std::string value_error(const std::string& name, const char* text, Value kind) {
  if (!text || !*text)
    return cat(name, ": give a value (", kind == Value::Int ? "an integer" : "a number",
               kind == Value::IntArray || kind == Value::RealArray ? " list" : "", ")");
  const std::string value = text;
  std::string why;
  bool ok = true;
  switch (kind) {
    case Value::Int:
      ok = parse_int(value, &why);
      break;
    case Value::Real:
    case Value::RealNonFinite:
      ok = parse_real(value, kind == Value::Real, &why);
      break;
    case Value::IntArray:
    case Value::RealArray:
      for (std::size_t p = 0; ok && p <= value.size();) {
        std::size_t q = value.find(',', p);
        if (q == std::string::npos) q = value.size();
        const std::string item = value.substr(p, q - p);
        if (kind == Value::RealArray) {
          ok = parse_real(item, true, &why);
        } else {
          // PETSc's ranges: a-b (the dash after the first character).
          const std::size_t dash = item.find('-', 1);
          ok = parse_int(item.substr(0, dash), &why) &&
               (dash == std::string::npos || parse_int(item.substr(dash + 1), &why));
        }
        if (!ok) why = cat("item '", item, "': ", why);
        p = q + 1;
      }
      break;
  }
  return ok ? std::string() : cat(name, " ", value, ": ", why);
}

std::string magnitude_error(const std::string& name, double value) {
  if (value >= kMinMagnitude && value <= kMaxMagnitude) return {};
  return cat(name, " ", value, " must be a positive number in [", kMinMagnitude, ", ", kMaxMagnitude, "]");
}

PetscErrorCode check_value(PetscOptions options, const char* prefix, const char* name, Value kind) {
  const std::string full = "-" + std::string(prefix ? prefix : "") + bare(name ? name : "");
  const char* value = nullptr;
  PetscBool set = PETSC_FALSE;
  PetscCall(PetscOptionsFindPair(options, prefix, ("-" + bare(name ? name : "")).c_str(), &value, &set));
  if (!set) return PETSC_SUCCESS;
  const std::string err = value_error(full, value, kind);
  if (!err.empty()) throw Error(err);
  return PETSC_SUCCESS;
}

PetscErrorCode get_string_list(MPI_Comm comm, const char* name, const char* help, std::vector<std::string>* list,
                               const char* prefix) {
  char* v[64];
  PetscInt n = 64;
  PetscBool set = PETSC_FALSE;
  PetscOptionsBegin(comm, prefix, "morse set list", "");
  PetscCall(MorseOptionsStringArray(name, help, "", v, &n, &set));
  PetscOptionsEnd();
  if (set)
    for (PetscInt i = 0; i < n; ++i) {
      list->emplace_back(v[i]);
      PetscCall(PetscFree(v[i]));
    }
  return PETSC_SUCCESS;
}

PetscErrorCode get_rayleigh(PetscOptionItems* PetscOptionsObject, const char* name, const char* help, double* alpha,
                            double* beta, PetscBool* set, std::string* error) {
  PetscReal ab[3] = {0, 0, 0};  // room for a third value, so that one too many is counted, not cut off
  PetscInt n = 3;
  PetscCall(MorseOptionsRealArray(name, help, "", ab, &n, set));
  if (!*set) return PETSC_SUCCESS;
  std::string why;
  if (n != 2)
    why = cat(name, " takes two values alpha,beta (got ", n, ")");
  else if (!(std::isfinite(ab[0]) && std::isfinite(ab[1]) && ab[0] >= 0 && ab[1] >= 0))
    why = cat(name, " ", ab[0], ",", ab[1], ": alpha and beta must be finite and >= 0");
  else
    *alpha = ab[0], *beta = ab[1];
  if (error->empty()) *error = why;
  return PETSC_SUCCESS;
}

}  // namespace morse::options
