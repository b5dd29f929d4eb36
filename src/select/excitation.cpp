// EBR load table (-select_ebr_load): per-DOF amplitudes and phases of each harmonic.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "morse/core/error.hpp"
#include "morse/select/select.hpp"

namespace morse::select {

namespace {

// Parses the table on one rank; returns an error message (empty on success).
std::string parse_load_table(const std::string& path, const cb::CBResult& cb, Excitation* ex) {
  std::ifstream in(path);
  if (!in) return cat("-select_ebr_load ", path, ": cannot open the file");
  std::map<std::pair<std::int64_t, int>, PetscInt> dof_pos;  // (boundary node id, component) -> position
  for (std::size_t j = 0; j < cb.boundary_dof_node.size(); ++j)
    dof_pos[{cb.boundary_dof_node[j], cb.boundary_dof_component[j]}] = static_cast<PetscInt>(j);
  std::map<std::pair<std::size_t, PetscInt>, long> seen;  // (harmonic, dof) -> line
  std::string line;
  long ln = 0;
  while (std::getline(in, line)) {
    ++ln;
    const std::string where = cat(path, ":", ln, ": ");
    if (auto h = line.find('#'); h != std::string::npos) line.erase(h);
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream is(line);
    std::vector<std::string> f;
    for (std::string w; is >> w;) f.push_back(w);
    if (f.empty()) continue;
    if (f.size() < 4 || f.size() > 5)
      return cat(where, "expected 'freq_hz node component amplitude [phase_deg]', found ", f.size(), " fields");
    auto number = [&](const std::string& w, const char* what, double* v) -> std::string {
      char* end = nullptr;
      *v = std::strtod(w.c_str(), &end);
      if (end == w.c_str() || *end != '\0' || !std::isfinite(*v)) return cat(where, what, " '", w, "' is not a number");
      return {};
    };
    double freq = 0, amp = 0, phase = 0, node_d = 0;
    if (auto e = number(f[0], "frequency", &freq); !e.empty()) return e;
    if (auto e = number(f[1], "node", &node_d); !e.empty()) return e;
    if (auto e = number(f[3], "amplitude", &amp); !e.empty()) return e;
    if (f.size() == 5)
      if (auto e = number(f[4], "phase", &phase); !e.empty()) return e;
    if (freq <= 0) return cat(where, "frequency ", f[0], " Hz must be > 0");
    const auto node = static_cast<std::int64_t>(node_d);
    if (static_cast<double>(node) != node_d) return cat(where, "node '", f[1], "' is not an integer node id");
    std::string c = f[2];
    std::transform(c.begin(), c.end(), c.begin(), [](unsigned char ch) { return std::tolower(ch); });
    int d = c == "x" ? 1 : c == "y" ? 2 : c == "z" ? 3 : c.size() == 1 && c[0] >= '1' && c[0] <= '6' ? c[0] - '0' : 0;
    if (d == 0) return cat(where, "component '", f[2], "': expected x, y, z or 1 to 6");
    auto it = dof_pos.lower_bound({node, 0});
    if (it == dof_pos.end() || it->first.first != node) return cat(where, "node ", node, " is not in the boundary set");
    it = dof_pos.find({node, d});
    if (it == dof_pos.end()) return cat(where, "node ", node, " has no boundary DOF of component ", f[2]);
    std::size_t k = 0;
    while (k < ex->freq_hz.size() && ex->freq_hz[k] != freq) ++k;
    if (k == ex->freq_hz.size()) {
      ex->freq_hz.push_back(freq);
      ex->load.emplace_back(cb.n_b, std::complex<double>(0.0, 0.0));
    }
    const PetscInt dof = it->second;
    auto [pos, fresh] = seen.emplace(std::pair{k, dof}, ln);
    if (!fresh)
      return cat(where, "node ", node, " component ", f[2], " at ", f[0], " Hz is already loaded on line ",
                 pos->second);
    ex->load[k][dof] = std::polar(amp, phase * M_PI / 180.0);
  }
  if (in.bad()) return cat("-select_ebr_load ", path, ": read error");
  if (ex->freq_hz.empty())
    return cat("-select_ebr_load ", path,
               ": no load line (freq_hz node component amplitude "
               "[phase_deg])");
  return {};
}

}  // namespace

Excitation read_ebr_load(MPI_Comm comm, const std::string& path, const cb::CBResult& cb) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  Excitation ex;
  ex.all_components = false;
  std::string err;
  if (rank == 0) err = parse_load_table(path, cb, &ex);
  collective_check(comm, err);
  unsigned long nh = ex.freq_hz.size();
  MPI_Bcast(&nh, 1, MPI_UNSIGNED_LONG, 0, comm);
  ex.freq_hz.resize(nh);
  ex.load.resize(nh, std::vector<std::complex<double>>(cb.n_b));
  MPI_Bcast(ex.freq_hz.data(), static_cast<int>(nh), MPI_DOUBLE, 0, comm);
  for (auto& f : ex.load) MPI_Bcast(f.data(), static_cast<int>(2 * f.size()), MPI_DOUBLE, 0, comm);
  return ex;
}

}  // namespace morse::select
