// Abaqus / CalculiX input-deck reader. See morse/mesh/abaqus.hpp for the supported subset.
//
// Files are read whole into memory and scanned line by line with char pointers; numbers are
// parsed with strtod/strtoll. *INCLUDE is textual: the keyword block in force continues into and
// out of the included file. Everything that may refer forward (element nodes, set members,
// *BOUNDARY, *SOLID SECTION) is recorded with its file and line and resolved after the whole deck
// has been read.
#include "morse/mesh/abaqus.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <initializer_list>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/mesh/cells.hpp"

namespace morse::mesh {

namespace {

// ------------------------------------------------------------------------------------------------
// Element types and node orderings

struct AbaqusType {
  const char* name;
  ElementType type;
};
constexpr AbaqusType kAbaqusTypes[] = {
    {"C3D4", ElementType::Tet4},     {"C3D10", ElementType::Tet10}, {"C3D6", ElementType::Wedge6},
    {"C3D15", ElementType::Wedge15}, {"C3D8", ElementType::Hex8},   {"C3D20", ElementType::Hex20},
    {"C3D20R", ElementType::Hex20},
};
constexpr const char* kSupportedTypes = "C3D4, C3D10, C3D6, C3D15, C3D8, C3D20, C3D20R";

using Perm = std::array<int, kMaxNodes>;

Perm build_perm(ElementType t) {
  Perm p{};
  const auto f2m = foreign_to_morse(t, NodeOrder::Abaqus);
  for (std::size_t i = 0; i < f2m.size(); ++i) p[f2m[i]] = static_cast<int>(i);
  return p;
}

/// perm[k] = position in the Abaqus connectivity of morse node k.
const Perm& abaqus_to_morse(ElementType t) {
  static const std::array<Perm, kNumElementTypes> perms = [] {
    std::array<Perm, kNumElementTypes> a{};
    for (int i = 0; i < kNumElementTypes; ++i) a[i] = build_perm(static_cast<ElementType>(i));
    return a;
  }();
  return perms[static_cast<int>(t)];
}

// ------------------------------------------------------------------------------------------------
// Text helpers

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

std::string to_upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

/// Upper-cased copy of [b,e) without blanks.
std::string compact_upper(const char* b, const char* e) {
  std::string s;
  for (; b < e; ++b)
    if (!is_blank(*b)) s += static_cast<char>(std::toupper(static_cast<unsigned char>(*b)));
  return s;
}

struct Field {
  const char* b;
  const char* e;
  bool empty() const { return b == e; }
  std::string str() const { return std::string(b, e); }
};

/// Splits [b,e) at commas into blank-trimmed fields. A comma that ends the line does not open an
/// empty last field.
void split_fields(const char* b, const char* e, std::vector<Field>* out) {
  out->clear();
  const char* p = b;
  while (true) {
    const char* q = p;
    while (q < e && *q != ',') ++q;
    const char* fb = p;
    const char* fe = q;
    while (fb < fe && is_blank(*fb)) ++fb;
    while (fe > fb && is_blank(fe[-1])) --fe;
    if (q == e) {
      // The last field; an empty one after a final comma is dropped.
      if (fb != fe || p == b) out->push_back({fb, fe});
      break;
    }
    out->push_back({fb, fe});
    p = q + 1;
  }
}

bool parse_int(const Field& f, std::int64_t* v) {
  if (f.empty()) return false;
  char* end = nullptr;
  errno = 0;
  long long x = std::strtoll(f.b, &end, 10);
  if (end != f.e || errno == ERANGE) return false;
  *v = static_cast<std::int64_t>(x);
  return true;
}

bool parse_double(const Field& f, double* v) {
  if (f.empty()) return false;
  char* end = nullptr;
  double x = std::strtod(f.b, &end);
  if (end != f.e && end < f.e && (*end == 'd' || *end == 'D') && f.e - f.b < 64) {
    // Fortran double-precision exponent: 1.5D+03.
    char buf[64];
    const std::size_t len = static_cast<std::size_t>(f.e - f.b);
    std::memcpy(buf, f.b, len);
    buf[len] = '\0';
    buf[end - f.b] = 'E';
    char* end2 = nullptr;
    x = std::strtod(buf, &end2);
    if (end2 != buf + len) return false;
  } else if (end != f.e) {
    return false;
  }
  if (!std::isfinite(x)) return false;
  *v = x;
  return true;
}

// ------------------------------------------------------------------------------------------------
// Reader

struct Loc {
  int file = 0;
  int line = 0;
};

/// A node or element set while reading: member labels plus where each run of them came from.
struct SetData {
  std::string name;
  std::vector<std::int64_t> labels;
  std::vector<std::pair<std::size_t, Loc>> marks;  // labels[first..] were read at Loc
};

struct BoundaryEntry {
  std::int64_t label = 0;
  std::string set;  // non-empty: a node set name instead of a label
  std::uint8_t mask = 0;
  Loc loc;
};

struct SectionEntry {
  std::string elset;
  std::string material;
  Loc loc;
};

struct MaterialData {
  Material m;
  int elastic_lines = 0;
  int density_lines = 0;
  bool has_elastic = false;
  bool has_density = false;
};

/// One term of an *EQUATION: a node label or a node set name, a DOF and its coefficient.
struct EquationTerm {
  std::int64_t label = 0;
  std::string set;  // non-empty: a node set name instead of a label
  int dof = 0;
  double coefficient = 0;
  Loc loc;
};

struct EquationEntry {
  Loc loc;  // the line giving the number of terms
  std::size_t n_terms = 0;
  std::vector<EquationTerm> terms;
};

/// *RIGID BODY: the reference node (a label or a one-node set) and the sets that follow it.
struct RigidBodyEntry {
  Loc loc;
  std::string ref;
  std::string nset, tie_nset, pin_nset, elset;
};

/// *COUPLING with its *KINEMATIC or *DISTRIBUTING.
struct CouplingEntry {
  Loc loc;
  std::string name;  // CONSTRAINT NAME, may be empty
  std::string ref;
  std::string surface;
  bool distributing = false;
  std::uint8_t dofs = 0;  // from the data lines of *KINEMATIC / *DISTRIBUTING; 0: all six
};

/// A line of a node-based *SURFACE: a node label or a node set, and its weight (0: not given).
struct SurfaceEntry {
  std::int64_t label = 0;
  std::string set;
  double weight = 0;
  Loc loc;
};

struct SurfaceData {
  std::string name;
  std::string type;  // upper case: NODE, ELEMENT, ...
  Loc loc;           // first definition
  std::vector<SurfaceEntry> entries;
};

enum class Block {
  kNone,
  kSkip,
  kNoData,
  kNode,
  kElement,
  kNset,
  kElset,
  kBoundary,
  kElastic,
  kDensity,
  kEquation,
  kSurface,
  kCouplingDofs
};

class Reader {
 public:
  explicit Reader(bool verbose) : verbose_(verbose) {}

  Mesh read(const std::string& path) {
    parse_file(path, nullptr, 0);
    check_open_blocks(nullptr, nullptr);
    return finish(path);
  }

 private:
  using Params = std::vector<std::pair<std::string, std::string>>;

  // --- messages
  std::string where(const Loc& l) const { return cat(files_[l.file], ":", l.line, ": "); }

  template <class... T>
  [[noreturn]] void fail(const Loc& l, const T&... pieces) const {
    throw Error(cat(where(l), pieces...));
  }

  template <class... T>
  void notice(const std::string& key, const Loc& l, const T&... pieces) {
    if (!verbose_ || !noticed_.insert(key).second) return;
    std::cerr << "morse: notice: " << where(l) << cat(pieces...) << '\n';
  }

  // --- files
  /// Reads a whole file; on failure returns false and a reason in *error.
  static bool read_whole_file(const std::string& path, std::string* text, std::string* error) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) {
      *error = std::strerror(errno);
      return false;
    }
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    text->clear();
    if (!ec) text->reserve(static_cast<std::size_t>(size));
    char chunk[1 << 16];
    std::size_t n;
    while ((n = std::fread(chunk, 1, sizeof chunk, f)) > 0) text->append(chunk, n);
    const bool ok = !std::ferror(f);
    if (!ok) *error = std::strerror(errno);
    std::fclose(f);
    return ok;
  }

  void parse_file(const std::string& path, const Loc* from, int depth) {
    if (from && depth > 32) fail(*from, "*INCLUDE nested more than 32 deep (does '", path, "' include itself?)");
    std::string text, why;
    if (!read_whole_file(path, &text, &why)) {
      if (from) fail(*from, "cannot read included file '", path, "' (", why, ")");
      throw Error(cat("cannot read Abaqus input file '", path, "' (", why, ")"));
    }
    const int fid = static_cast<int>(files_.size());
    files_.push_back(path);
    depth_ = depth;

    const char* p = text.data();
    const char* const end = p + text.size();
    int line = 0;
    while (p < end) {
      const char* nl = static_cast<const char*>(std::memchr(p, '\n', end - p));
      const char* e = nl ? nl : end;
      const char* b = p;
      p = nl ? nl + 1 : end;
      ++line;
      while (e > b && is_blank(e[-1])) --e;
      while (b < e && is_blank(*b)) ++b;
      if (b == e) continue;
      const Loc loc{fid, line};
      if (*b == '*') {
        if (e - b >= 2 && b[1] == '*') continue;  // comment
        keyword_line(b + 1, e, loc);
      } else {
        data_line(b, e, loc);
      }
    }
    if (pending_)
      fail(pending_loc_, "element ", pending_label_, " is truncated: ", pending_nodes_.size(), " of ",
           nodes_per_element(etype_), " nodes before the end of the file");
  }

  std::string resolve(const Loc& from, const std::string& name) const {
    namespace fs = std::filesystem;
    fs::path p(name);
    if (p.is_absolute()) return p.string();
    const fs::path dir = fs::path(files_[from.file]).parent_path();
    return (dir / p).lexically_normal().string();
  }

  // --- keyword lines
  static void split_keyword(const char* b, const char* e, std::string* name, std::string* display, Params* params) {
    // Split at commas outside double quotes.
    std::vector<std::pair<const char*, const char*>> parts;
    const char* s = b;
    bool quoted = false;
    for (const char* q = b; q <= e; ++q) {
      if (q < e && *q == '"') quoted = !quoted;
      if (q == e || (*q == ',' && !quoted)) {
        parts.emplace_back(s, q);
        s = q + 1;
      }
    }
    *name = compact_upper(parts[0].first, parts[0].second);
    display->clear();
    for (const char* q = parts[0].first; q < parts[0].second; ++q) {
      if (is_blank(*q)) {
        if (!display->empty() && display->back() != ' ') *display += ' ';
      } else {
        *display += static_cast<char>(std::toupper(static_cast<unsigned char>(*q)));
      }
    }
    while (!display->empty() && display->back() == ' ') display->pop_back();
    *display = "*" + *display;
    params->clear();
    for (std::size_t i = 1; i < parts.size(); ++i) {
      const char* pb = parts[i].first;
      const char* pe = parts[i].second;
      const char* eq = pb;
      while (eq < pe && *eq != '=') ++eq;
      std::string key = compact_upper(pb, eq);
      if (key.empty()) continue;
      std::string value;
      if (eq < pe) {
        const char* vb = eq + 1;
        const char* ve = pe;
        while (vb < ve && is_blank(*vb)) ++vb;
        while (ve > vb && is_blank(ve[-1])) --ve;
        if (ve - vb >= 2 && *vb == '"' && ve[-1] == '"') ++vb, --ve;
        value.assign(vb, ve);
      }
      params->emplace_back(std::move(key), std::move(value));
    }
  }

  static const std::string* param(const Params& ps, const char* key) {
    for (const auto& [k, v] : ps)
      if (k == key) return &v;
    return nullptr;
  }

  const std::string& required(const Params& ps, const char* key, const std::string& kw, const Loc& loc) const {
    const std::string* v = param(ps, key);
    if (!v || v->empty()) fail(loc, kw, " needs the parameter ", key, "=");
    return *v;
  }

  /// Keywords that morse knowingly ignores (analysis steps, output requests, loads, ...), in
  /// compact upper-case form, each surrounded by blanks.
  static constexpr const char* kIgnored =
      " HEADING PREPRINT RESTART AMPLITUDE INITIALCONDITIONS STEP ENDSTEP FREQUENCY STATIC"
      " DYNAMIC MODALDYNAMIC STEADYSTATEDYNAMICS BUCKLE SELECTCYCLICSYMMETRYMODES MODALDAMPING"
      " CLOAD DLOAD CONTROLS TIMEPOINTS MONITOR OUTPUT NODEOUTPUT ELEMENTOUTPUT NODEPRINT ELPRINT"
      " NODEFILE ELFILE CONTACTPRINT CONTACTFILE ENERGYPRINT SECTIONPRINT ";

  static bool ignored(const std::string& kw) { return std::strstr(kIgnored, (" " + kw + " ").c_str()) != nullptr; }

  void keyword_line(const char* b, const char* e, const Loc& loc) {
    if (pending_)
      fail(pending_loc_, "element ", pending_label_, " is truncated: ", pending_nodes_.size(), " of ",
           nodes_per_element(etype_), " nodes before the next keyword");
    std::string kw, display;
    Params ps;
    split_keyword(b, e, &kw, &display, &ps);
    if (kw.empty()) fail(loc, "empty keyword");
    // *INCLUDE is textual: an equation's terms or a *COUPLING's *KINEMATIC may follow in the file.
    if (kw != "INCLUDE") check_open_blocks(&kw, &loc);

    // A material definition ends at the next model or step keyword; unknown keywords (*EXPANSION,
    // *DAMPING, ...) may be material options and keep it open.
    static const std::set<std::string> kEndsMaterial = {"NODE",     "ELEMENT",  "NSET",         "ELSET",
                                                        "BOUNDARY", "MATERIAL", "SOLIDSECTION", "STEP",
                                                        "EQUATION", "SURFACE",  "RIGIDBODY",    "COUPLING"};
    if (kEndsMaterial.count(kw) || ignored(kw)) material_ = -1;
    const std::string* input = nullptr;
    if (kw == "NODE") {
      block_ = Block::kNode;
      if (const std::string* sys = param(ps, "SYSTEM"); sys && to_upper(*sys) != "R")
        fail(loc, "*NODE, SYSTEM=", *sys, " is not supported (only rectangular coordinates)");
      const std::string* ns = param(ps, "NSET");
      node_set_ = ns && !ns->empty() ? get_set(&nsets_, &nset_lookup_, *ns) : -1;
      input = param(ps, "INPUT");
    } else if (kw == "ELEMENT") {
      const std::string& type_param = required(ps, "TYPE", display, loc);
      const std::string type = compact_upper(type_param.data(), type_param.data() + type_param.size());
      bool known = false;
      for (const auto& t : kAbaqusTypes)
        if (type == t.name) etype_ = t.type, known = true;
      if (!known) fail(loc, "unsupported element type '", type, "' (supported: ", kSupportedTypes, ")");
      const std::string* es = param(ps, "ELSET");
      elem_set_ = es && !es->empty() ? get_set(&esets_, &eset_lookup_, *es) : -1;
      block_ = Block::kElement;
      input = param(ps, "INPUT");
    } else if (kw == "NSET" || kw == "ELSET") {
      const bool nodes = kw == "NSET";
      if (nodes && param(ps, "ELSET")) fail(loc, "*NSET, ELSET= is not supported; list the nodes or node sets instead");
      const std::string& name = required(ps, nodes ? "NSET" : "ELSET", display, loc);
      set_ = nodes ? get_set(&nsets_, &nset_lookup_, name) : get_set(&esets_, &eset_lookup_, name);
      generate_ = param(ps, "GENERATE") != nullptr;
      block_ = nodes ? Block::kNset : Block::kElset;
      input = param(ps, "INPUT");
    } else if (kw == "INCLUDE") {
      const std::string path = resolve(loc, required(ps, "INPUT", display, loc));
      const int depth = depth_;
      parse_file(path, &loc, depth + 1);
      depth_ = depth;
      return;
    } else if (kw == "BOUNDARY") {
      if (const std::string* t = param(ps, "TYPE"); t && to_upper(*t) != "DISPLACEMENT")
        fail(loc, "*BOUNDARY, TYPE=", *t, " is not supported (only zero displacements)");
      if (param(ps, "USER")) fail(loc, "*BOUNDARY, USER is not supported");
      if (in_step_)
        notice("BOUNDARY-IN-STEP", loc, "*BOUNDARY inside a *STEP is applied as a model constraint for all analyses");
      block_ = Block::kBoundary;
    } else if (kw == "MATERIAL") {
      const std::string& name = required(ps, "NAME", display, loc);
      const std::string key = to_upper(name);
      if (material_lookup_.count(key)) fail(loc, "material '", name, "' is defined twice");
      material_lookup_[key] = static_cast<int>(materials_.size());
      material_ = static_cast<int>(materials_.size());
      materials_.emplace_back();
      materials_.back().m.name = name;
      block_ = Block::kSkip;
    } else if (kw == "ELASTIC" || kw == "DENSITY") {
      if (material_ < 0) fail(loc, display, " outside a *MATERIAL definition");
      if (kw == "ELASTIC") {
        if (const std::string* t = param(ps, "TYPE")) {
          const std::string tu = to_upper(*t);
          if (tu != "ISO" && tu != "ISOTROPIC")
            fail(loc, "*ELASTIC, TYPE=", *t, " is not supported (only isotropic elasticity)");
        }
        materials_[material_].elastic_lines = 0;
        block_ = Block::kElastic;
      } else {
        materials_[material_].density_lines = 0;
        block_ = Block::kDensity;
      }
    } else if (kw == "SOLIDSECTION") {
      sections_.push_back({required(ps, "ELSET", display, loc), required(ps, "MATERIAL", display, loc), loc});
      block_ = Block::kSkip;
    } else if (kw == "EQUATION") {
      check_params(ps, {"INPUT"}, display, loc);
      block_ = Block::kEquation;
      input = param(ps, "INPUT");
    } else if (kw == "RIGIDBODY") {
      if (const std::string* r = param(ps, "ROTNODE"))
        fail(loc, "*RIGID BODY, ROT NODE=", *r, " is not supported: the reference node (REF NODE) carries the",
             " rotations itself (a six-DOF point); remove ROT NODE");
      check_params(ps, {"REF NODE", "NSET", "TIE NSET", "PIN NSET", "ELSET", "ISOTHERMAL"}, display, loc);
      RigidBodyEntry rb;
      rb.loc = loc;
      rb.ref = nonempty_param(ps, "REFNODE", "REF NODE", display, loc);
      rb.nset = nonempty_param(ps, "NSET", "NSET", display, loc);
      rb.tie_nset = nonempty_param(ps, "TIENSET", "TIE NSET", display, loc);
      rb.pin_nset = nonempty_param(ps, "PINNSET", "PIN NSET", display, loc);
      rb.elset = nonempty_param(ps, "ELSET", "ELSET", display, loc);
      if (rb.ref.empty()) fail(loc, "*RIGID BODY needs REF NODE= (the reference node)");
      if (rb.nset.empty() && rb.tie_nset.empty() && rb.pin_nset.empty() && rb.elset.empty())
        fail(loc, "*RIGID BODY needs NSET=, TIE NSET=, PIN NSET= or ELSET= (the nodes that follow REF NODE)");
      rigid_bodies_.push_back(std::move(rb));
      block_ = Block::kNoData;
    } else if (kw == "COUPLING") {
      if (const std::string* o = param(ps, "ORIENTATION"))
        fail(loc, "*COUPLING, ORIENTATION=", *o, " is not supported (the coupled DOFs are the global ones)");
      if (param(ps, "INFLUENCERADIUS"))
        fail(loc, "*COUPLING, INFLUENCE RADIUS= is not supported: list the coupled nodes in the surface");
      check_params(ps, {"CONSTRAINT NAME", "REF NODE", "SURFACE"}, display, loc);
      CouplingEntry c;
      c.loc = loc;
      c.name = nonempty_param(ps, "CONSTRAINTNAME", "CONSTRAINT NAME", display, loc);
      c.ref = nonempty_param(ps, "REFNODE", "REF NODE", display, loc);
      c.surface = nonempty_param(ps, "SURFACE", "SURFACE", display, loc);
      if (c.ref.empty()) fail(loc, "*COUPLING needs REF NODE= (the reference node)");
      if (c.surface.empty()) fail(loc, "*COUPLING needs SURFACE= (a node-based surface: *SURFACE, TYPE=NODE)");
      couplings_.push_back(std::move(c));
      coupling_open_ = true;
      block_ = Block::kNoData;
    } else if (kw == "KINEMATIC" || kw == "DISTRIBUTING") {
      if (!coupling_open_) fail(loc, display, " must directly follow a *COUPLING keyword line");
      coupling_open_ = false;
      if (kw == "DISTRIBUTING") {
        if (const std::string* w = param(ps, "WEIGHTINGMETHOD");
            w && compact_upper(w->data(), w->data() + w->size()) != "UNIFORM")
          fail(loc, "*DISTRIBUTING, WEIGHTING METHOD=", *w, " is not supported (only UNIFORM: the weights are",
               " those of the surface's nodes, 1 where none is given)");
        if (const std::string* c = param(ps, "COUPLING"); c && to_upper(*c) != "CONTINUUM")
          fail(loc, "*DISTRIBUTING, COUPLING=", *c, " is not supported (only CONTINUUM)");
        check_params(ps, {"WEIGHTING METHOD", "COUPLING"}, display, loc);
        couplings_.back().distributing = true;
      } else {
        check_params(ps, {}, display, loc);
      }
      block_ = Block::kCouplingDofs;
    } else if (kw == "SURFACE") {
      const std::string& name = required(ps, "NAME", display, loc);
      const std::string* t = param(ps, "TYPE");
      const std::string type = t ? compact_upper(t->data(), t->data() + t->size()) : "ELEMENT";
      auto [it, inserted] = surface_lookup_.emplace(to_upper(name), static_cast<int>(surfaces_.size()));
      if (inserted) surfaces_.push_back({name, type, loc, {}});
      SurfaceData& sd = surfaces_[it->second];
      if (sd.type != type)
        fail(loc, "surface '", name, "' is defined again with TYPE=", type, " (TYPE=", sd.type, " at ",
             files_[sd.loc.file], ":", sd.loc.line, ")");
      if (type == "NODE") {
        if (param(ps, "COMBINE") || param(ps, "CROP"))
          fail(loc, "*SURFACE, TYPE=NODE with COMBINE= or CROP= is not supported: list the nodes or node sets");
        surface_ = it->second;
        block_ = Block::kSurface;
      } else {
        notice("SURFACE-" + type, loc, "*SURFACE, TYPE=", type, " (element-based) is not read: morse reads",
               " node-based surfaces (TYPE=NODE) for *COUPLING");
        block_ = Block::kSkip;
      }
    } else {
      if (kw == "STEP") in_step_ = true;
      if (kw == "ENDSTEP") in_step_ = false;
      if (ignored(kw))
        notice(kw, loc, "ignoring ", display, " and its data lines (not used by morse)");
      else
        notice(kw, loc, "ignoring unsupported keyword ", display, " and its data lines");
      block_ = Block::kSkip;
    }
    block_keyword_ = display;
    if (input && !input->empty()) {
      const std::string path = resolve(loc, *input);
      const int depth = depth_;
      parse_file(path, &loc, depth + 1);
      depth_ = depth;
    }
  }

  /// Fails unless every parameter is one of `allowed` (written with blanks: "REF NODE").
  void check_params(const Params& ps, std::initializer_list<const char*> allowed, const std::string& kw,
                    const Loc& loc) const {
    for (const auto& [k, v] : ps) {
      std::string list;
      bool ok = false;
      for (const char* a : allowed) {
        ok = ok || compact_upper(a, a + std::strlen(a)) == k;
        list += cat(list.empty() ? "" : ", ", a, "=");
      }
      if (!ok)
        fail(loc, kw, ": the parameter ", k, " is not supported (", list.empty() ? "it takes none" : "it takes " + list,
             ")");
    }
  }

  /// The value of parameter key ("" if absent); present with an empty value is an error.
  const std::string& nonempty_param(const Params& ps, const char* key, const char* name, const std::string& kw,
                                    const Loc& loc) const {
    static const std::string kNone;
    const std::string* v = param(ps, key);
    if (!v) return kNone;
    if (v->empty()) fail(loc, kw, ": ", name, "= has no value");
    return *v;
  }

  /// Errors for an *EQUATION with missing terms or a *COUPLING without its *KINEMATIC or
  /// *DISTRIBUTING, when keyword kw (at *at) or, if kw is null, the end of the deck comes.
  void check_open_blocks(const std::string* kw, const Loc* at) const {
    const std::string next =
        at ? cat("the next keyword (", files_[at->file], ":", at->line, ")") : "the end of the deck";
    if (!equations_.empty() && equations_.back().terms.size() < equations_.back().n_terms) {
      const EquationEntry& eq = equations_.back();
      fail(eq.loc, "*EQUATION has ", eq.terms.size(), " of its ", eq.n_terms, " terms before ", next);
    }
    if (coupling_open_ && (!kw || (*kw != "KINEMATIC" && *kw != "DISTRIBUTING")))
      fail(couplings_.back().loc, "*COUPLING must be followed by *KINEMATIC or *DISTRIBUTING, not by ", next);
  }

  int get_set(std::vector<SetData>* sets, std::unordered_map<std::string, int>* names, const std::string& name) {
    auto [it, inserted] = names->emplace(to_upper(name), static_cast<int>(sets->size()));
    if (inserted) {
      sets->emplace_back();
      sets->back().name = name;
    }
    return it->second;
  }

  static void add_labels(SetData* s, const std::int64_t* labels, std::size_t n, const Loc& loc) {
    if (s->marks.empty() || s->marks.back().second.file != loc.file || s->marks.back().second.line != loc.line)
      s->marks.emplace_back(s->labels.size(), loc);
    s->labels.insert(s->labels.end(), labels, labels + n);
  }

  // --- data lines
  std::int64_t int_field(const Field& f, const Loc& loc, const char* what) const {
    std::int64_t v = 0;
    if (f.empty()) fail(loc, "missing ", what, " in ", block_keyword_, " data line");
    if (!parse_int(f, &v)) fail(loc, "invalid ", what, " '", f.str(), "' in ", block_keyword_, " data line");
    return v;
  }

  double real_field(const Field& f, const Loc& loc, const char* what) const {
    double v = 0;
    if (f.empty()) fail(loc, "missing ", what, " in ", block_keyword_, " data line");
    if (!parse_double(f, &v)) fail(loc, "invalid ", what, " '", f.str(), "' in ", block_keyword_, " data line");
    return v;
  }

  void data_line(const char* b, const char* e, const Loc& loc) {
    switch (block_) {
      case Block::kNone:
        fail(loc, "data line before the first keyword");
      case Block::kSkip:
        return;
      case Block::kNoData:
        fail(loc, block_keyword_, " takes no data lines");
      case Block::kNode:
        return node_line(b, e, loc);
      case Block::kElement:
        return element_line(b, e, loc);
      case Block::kNset:
      case Block::kElset:
        return set_line(b, e, loc);
      case Block::kBoundary:
        return boundary_line(b, e, loc);
      case Block::kElastic:
      case Block::kDensity:
        return material_line(b, e, loc);
      case Block::kEquation:
        return equation_line(b, e, loc);
      case Block::kSurface:
        return surface_line(b, e, loc);
      case Block::kCouplingDofs:
        return coupling_dofs_line(b, e, loc);
    }
  }

  void node_line(const char* b, const char* e, const Loc& loc) {
    split_fields(b, e, &fields_);
    if (fields_.size() < 4) fail(loc, "*NODE data line needs 'label, x, y, z' (", fields_.size(), " fields found)");
    if (fields_.size() > 4) fail(loc, "*NODE data line has more than 'label, x, y, z'");
    const std::int64_t label = int_field(fields_[0], loc, "node label");
    if (label <= 0) fail(loc, "node label ", label, " is not positive");
    double x[3];
    for (int d = 0; d < 3; ++d) x[d] = fields_[1 + d].empty() ? 0.0 : real_field(fields_[1 + d], loc, "coordinate");
    if (!node_index_.emplace(label, static_cast<std::int64_t>(node_ids_.size())).second)
      fail(loc, "node ", label, " is defined twice");
    node_ids_.push_back(label);
    coords_.insert(coords_.end(), {x[0], x[1], x[2]});
    if (node_set_ >= 0) add_labels(&nsets_[node_set_], &label, 1, loc);
  }

  void element_line(const char* b, const char* e, const Loc& loc) {
    split_fields(b, e, &fields_);
    std::size_t i = 0;
    if (!pending_) {
      pending_label_ = int_field(fields_[0], loc, "element label");
      if (pending_label_ <= 0) fail(loc, "element label ", pending_label_, " is not positive");
      pending_loc_ = loc;
      pending_nodes_.clear();
      pending_ = true;
      i = 1;
    }
    for (; i < fields_.size(); ++i) pending_nodes_.push_back(int_field(fields_[i], loc, "node"));
    const std::size_t n = static_cast<std::size_t>(nodes_per_element(etype_));
    if (pending_nodes_.size() > n) fail(loc, "element ", pending_label_, " has more than ", n, " nodes");
    if (pending_nodes_.size() < n) return;  // continues on the next line
    pending_ = false;
    const std::int64_t label = pending_label_;
    if (!elem_index_.emplace(label, static_cast<std::int64_t>(elem_ids_.size())).second)
      fail(pending_loc_, "element ", label, " is defined twice");
    elem_ids_.push_back(label);
    elem_types_.push_back(etype_);
    elem_locs_.push_back(pending_loc_);
    elem_labels_.insert(elem_labels_.end(), pending_nodes_.begin(), pending_nodes_.end());
    if (elem_set_ >= 0) add_labels(&esets_[elem_set_], &label, 1, pending_loc_);
  }

  void set_line(const char* b, const char* e, const Loc& loc) {
    const bool nodes = block_ == Block::kNset;
    SetData* set = nodes ? &nsets_[set_] : &esets_[set_];
    split_fields(b, e, &fields_);
    if (generate_) {
      if (fields_.size() < 2 || fields_.size() > 3)
        fail(loc, block_keyword_, ", GENERATE data line needs 'first, last[, increment]'");
      const std::int64_t first = int_field(fields_[0], loc, "first label");
      const std::int64_t last = int_field(fields_[1], loc, "last label");
      const std::int64_t step =
          fields_.size() == 3 && !fields_[2].empty() ? int_field(fields_[2], loc, "increment") : 1;
      if (step <= 0 || last < first)
        fail(loc, block_keyword_, ", GENERATE needs first <= last and a positive increment");
      if ((last - first) / step > 100000000) fail(loc, block_keyword_, ", GENERATE range is too large");
      std::vector<std::int64_t>& tmp = scratch_;
      tmp.clear();
      for (std::int64_t l = first; l <= last; l += step) tmp.push_back(l);
      add_labels(set, tmp.data(), tmp.size(), loc);
      return;
    }
    for (const Field& f : fields_) {
      if (f.empty()) continue;
      std::int64_t label;
      if (parse_int(f, &label)) {
        add_labels(set, &label, 1, loc);
        continue;
      }
      auto& names = nodes ? nset_lookup_ : eset_lookup_;
      auto it = names.find(to_upper(f.str()));
      if (it == names.end())
        fail(loc, "undefined ", nodes ? "node" : "element", " set '", f.str(), "' in ", block_keyword_);
      std::vector<SetData>& sets = nodes ? nsets_ : esets_;
      scratch_ = sets[it->second].labels;  // copy: the set may be the one being extended
      add_labels(set, scratch_.data(), scratch_.size(), loc);
    }
  }

  void boundary_line(const char* b, const char* e, const Loc& loc) {
    split_fields(b, e, &fields_);
    if (fields_.size() < 2 || fields_[1].empty())
      fail(loc, "*BOUNDARY data line needs 'node or node set, first DOF[, last DOF[, value]]'");
    BoundaryEntry be;
    be.loc = loc;
    if (fields_[0].empty()) fail(loc, "missing node or node set in *BOUNDARY data line");
    if (!parse_int(fields_[0], &be.label)) be.set = fields_[0].str();
    std::int64_t first = 0, last = 0;
    if (parse_int(fields_[1], &first)) {
      last = fields_.size() > 2 && !fields_[2].empty() ? int_field(fields_[2], loc, "last DOF") : first;
      if (first < 1 || last < first) fail(loc, "invalid DOF range ", first, "..", last, " in *BOUNDARY");
      if (fields_.size() > 3 && !fields_[3].empty()) {
        const double value = real_field(fields_[3], loc, "prescribed value");
        if (value != 0.0)
          fail(loc, "nonzero prescribed displacement (", fields_[3].str(), ") in *BOUNDARY is not supported");
      }
      if (fields_.size() > 4) fail(loc, "too many fields in *BOUNDARY data line");
      for (std::int64_t d = first; d <= std::min<std::int64_t>(last, 6); ++d)
        be.mask |= static_cast<std::uint8_t>(1u << (d - 1));
      if (last > 3)
        notice("BOUNDARY-DOF", loc,
               "*BOUNDARY: DOFs 4-6 (rotations) act on six-DOF points only (reference nodes of rigid bodies and "
               "couplings) and are ignored on solid nodes; DOFs above 6 are ignored");
    } else {
      const std::string type = compact_upper(fields_[1].b, fields_[1].e);
      // Abaqus boundary types: the DOFs they fix (bits 0-2 translations, 3-5 rotations, which
      // only six-DOF points have).
      static const std::pair<const char*, std::uint8_t> kTypes[] = {{"ENCASTRE", 63}, {"PINNED", 7}, {"XSYMM", 49},
                                                                    {"YSYMM", 42},    {"ZSYMM", 28}, {"XASYMM", 14},
                                                                    {"YASYMM", 21},   {"ZASYMM", 35}};
      bool known = false;
      for (const auto& [name, mask] : kTypes)
        if (type == name) be.mask = mask, known = true;
      if (!known)
        fail(loc, "invalid DOF '", fields_[1].str(), "' in *BOUNDARY (expected a number or ",
             "ENCASTRE, PINNED, XSYMM, YSYMM, ZSYMM, XASYMM, YASYMM, ZASYMM)");
      if (fields_.size() > 2) fail(loc, "too many fields in *BOUNDARY data line");
    }
    if (be.mask) boundaries_.push_back(std::move(be));
  }

  void material_line(const char* b, const char* e, const Loc& loc) {
    MaterialData& md = materials_[material_];
    split_fields(b, e, &fields_);
    if (block_ == Block::kElastic) {
      if (md.elastic_lines++ > 0) {
        notice("ELASTIC-T:" + md.m.name, loc, "material '", md.m.name,
               "': *ELASTIC has several data lines (temperature dependence); using the first");
        return;
      }
      if (fields_.size() < 2) fail(loc, "*ELASTIC data line needs 'E, nu[, temperature]'");
      md.m.E = real_field(fields_[0], loc, "Young's modulus");
      md.m.nu = real_field(fields_[1], loc, "Poisson's ratio");
      if (fields_.size() > 2 && !fields_[2].empty()) real_field(fields_[2], loc, "temperature");
      if (!(md.m.E > 0) || !(md.m.nu > -1 && md.m.nu < 0.5))
        fail(loc, "material '", md.m.name, "': invalid elastic constants E=", md.m.E, ", nu=", md.m.nu);
      md.has_elastic = true;
    } else {
      if (md.density_lines++ > 0) {
        notice("DENSITY-T:" + md.m.name, loc, "material '", md.m.name,
               "': *DENSITY has several data lines (temperature dependence); using the first");
        return;
      }
      if (fields_.empty()) fail(loc, "*DENSITY data line needs 'rho[, temperature]'");
      md.m.rho = real_field(fields_[0], loc, "density");
      if (fields_.size() > 1 && !fields_[1].empty()) real_field(fields_[1], loc, "temperature");
      if (!(md.m.rho > 0)) fail(loc, "material '", md.m.name, "': density must be positive");
      md.has_density = true;
    }
  }

  void equation_line(const char* b, const char* e, const Loc& loc) {
    split_fields(b, e, &fields_);
    if (equations_.empty() || equations_.back().terms.size() == equations_.back().n_terms) {
      if (fields_.size() != 1)
        fail(loc, "*EQUATION: the first data line of an equation gives its number of terms N alone (", fields_.size(),
             " fields found)");
      const std::int64_t n = int_field(fields_[0], loc, "number of terms");
      if (n < 1 || n > 1000000) fail(loc, "*EQUATION: invalid number of terms ", n);
      equations_.push_back({loc, static_cast<std::size_t>(n), {}});
      return;
    }
    EquationEntry& eq = equations_.back();
    if (fields_.empty() || fields_.size() % 3 != 0 || fields_.size() > 12)
      fail(loc, "*EQUATION data line needs one to four terms 'node or node set, DOF, coefficient' (", fields_.size(),
           " fields found)");
    if (eq.terms.size() + fields_.size() / 3 > eq.n_terms)
      fail(loc, "*EQUATION has more terms than the ", eq.n_terms, " given at line ", eq.loc.line);
    for (std::size_t j = 0; j < fields_.size(); j += 3) {
      EquationTerm t;
      t.loc = loc;
      if (fields_[j].empty()) fail(loc, "missing node or node set in *EQUATION data line");
      if (!parse_int(fields_[j], &t.label)) t.set = fields_[j].str();
      const std::int64_t dof = int_field(fields_[j + 1], loc, "DOF");
      if (dof < 1 || dof > 6) fail(loc, "*EQUATION: DOF ", dof, " is not one of 1 to 6 (displacements, rotations)");
      t.dof = static_cast<int>(dof);
      t.coefficient = real_field(fields_[j + 2], loc, "coefficient");
      if (eq.terms.empty() && t.coefficient == 0.0)
        fail(loc, "*EQUATION: the first coefficient (of ", t.set.empty() ? cat("node ", t.label) : "node set " + t.set,
             " DOF ", t.dof, ", the dependent DOF) is 0");
      eq.terms.push_back(std::move(t));
    }
  }

  void surface_line(const char* b, const char* e, const Loc& loc) {
    split_fields(b, e, &fields_);
    if (fields_.empty() || fields_.size() > 2 || fields_[0].empty())
      fail(loc, "*SURFACE, TYPE=NODE data line needs 'node or node set[, weight]'");
    SurfaceEntry se;
    se.loc = loc;
    if (!parse_int(fields_[0], &se.label)) se.set = fields_[0].str();
    if (fields_.size() == 2 && !fields_[1].empty()) {
      se.weight = real_field(fields_[1], loc, "weight");
      if (se.weight < 0) fail(loc, "*SURFACE: negative weight ", fields_[1].str());
    }
    surfaces_[surface_].entries.push_back(std::move(se));
  }

  void coupling_dofs_line(const char* b, const char* e, const Loc& loc) {
    split_fields(b, e, &fields_);
    if (fields_.empty() || fields_.size() > 2) fail(loc, block_keyword_, " data line needs 'first DOF[, last DOF]'");
    const std::int64_t first = int_field(fields_[0], loc, "first DOF");
    const std::int64_t last =
        fields_.size() == 2 && !fields_[1].empty() ? int_field(fields_[1], loc, "last DOF") : first;
    if (first < 1 || last < first || last > 6)
      fail(loc, "invalid DOF range ", first, "..", last, " in ", block_keyword_, " (DOFs 1 to 6)");
    for (std::int64_t d = first; d <= last; ++d) couplings_.back().dofs |= static_cast<std::uint8_t>(1u << (d - 1));
  }

  // --- resolution
  std::int64_t lookup(const std::unordered_map<std::int64_t, std::int64_t>& index, std::int64_t label) const {
    auto it = index.find(label);
    return it == index.end() ? -1 : it->second;
  }

  std::vector<std::int64_t> resolve_set(const SetData& s, bool nodes) const {
    const auto& index = nodes ? node_index_ : elem_index_;
    std::vector<std::int64_t> out(s.labels.size());
    for (std::size_t i = 0; i < s.labels.size(); ++i) {
      out[i] = lookup(index, s.labels[i]);
      if (out[i] < 0) {
        auto it = std::upper_bound(s.marks.begin(), s.marks.end(), i,
                                   [](std::size_t v, const std::pair<std::size_t, Loc>& m) { return v < m.first; });
        const Loc loc = it == s.marks.begin() ? Loc{} : std::prev(it)->second;
        fail(loc, nodes ? "node" : "element", " set '", s.name, "' contains undefined ", nodes ? "node " : "element ",
             s.labels[i]);
      }
    }
    return out;
  }

  Mesh finish(const std::string& path) {
    Mesh mesh;
    mesh.units = "unknown";
    mesh.source = path;
    mesh.node_ids = std::move(node_ids_);
    mesh.coords = std::move(coords_);

    // Elements: labels -> indices, Abaqus -> morse ordering.
    const std::size_t ne = elem_ids_.size();
    mesh.elem_types.reserve(ne);
    mesh.elem_offsets.reserve(ne + 1);
    mesh.elem_nodes.reserve(elem_labels_.size());
    mesh.elem_ids.reserve(ne);
    mesh.elem_material.reserve(ne);
    std::size_t off = 0;
    std::array<std::int64_t, kMaxNodes> idx{}, ordered{};
    for (std::size_t el = 0; el < ne; ++el) {
      const ElementType t = elem_types_[el];
      const int n = nodes_per_element(t);
      const Perm& perm = abaqus_to_morse(t);
      for (int k = 0; k < n; ++k) {
        idx[k] = lookup(node_index_, elem_labels_[off + k]);
        if (idx[k] < 0)
          fail(elem_locs_[el], "element ", elem_ids_[el], " references undefined node ", elem_labels_[off + k]);
      }
      for (int k = 0; k < n; ++k) ordered[k] = idx[perm[k]];
      mesh.add_element(elem_ids_[el], t, ordered.data());
      off += static_cast<std::size_t>(n);
    }

    for (const SetData& s : nsets_) mesh.node_sets[s.name] = resolve_set(s, true);
    for (const SetData& s : esets_) mesh.elem_sets[s.name] = resolve_set(s, false);

    // *BOUNDARY
    if (!boundaries_.empty()) {
      mesh.fixed_dofs.assign(static_cast<std::size_t>(mesh.num_nodes()), 0);
      for (const BoundaryEntry& be : boundaries_) {
        if (be.set.empty()) {
          const std::int64_t k = lookup(node_index_, be.label);
          if (k < 0) fail(be.loc, "*BOUNDARY references undefined node ", be.label);
          mesh.fixed_dofs[k] |= be.mask;
        } else {
          auto it = nset_lookup_.find(to_upper(be.set));
          if (it == nset_lookup_.end()) fail(be.loc, "*BOUNDARY references undefined node set '", be.set, "'");
          for (std::int64_t k : mesh.node_sets[nsets_[it->second].name]) mesh.fixed_dofs[k] |= be.mask;
        }
      }
    }

    // Materials and *SOLID SECTION
    for (const MaterialData& md : materials_) mesh.materials.push_back(md.m);
    for (const SectionEntry& se : sections_) {
      auto es = eset_lookup_.find(to_upper(se.elset));
      if (es == eset_lookup_.end()) fail(se.loc, "*SOLID SECTION references undefined element set '", se.elset, "'");
      auto mat = material_lookup_.find(to_upper(se.material));
      if (mat == material_lookup_.end())
        fail(se.loc, "*SOLID SECTION references undefined material '", se.material, "'");
      const MaterialData& md = materials_[mat->second];
      if (!md.has_elastic) notice("NO-ELASTIC:" + md.m.name, se.loc, "material '", md.m.name, "' has no *ELASTIC");
      if (!md.has_density) notice("NO-DENSITY:" + md.m.name, se.loc, "material '", md.m.name, "' has no *DENSITY");
      for (std::int64_t el : mesh.elem_sets[esets_[es->second].name]) mesh.elem_material[el] = mat->second;
    }
    if (!sections_.empty()) {
      const auto bare = std::count(mesh.elem_material.begin(), mesh.elem_material.end(), -1);
      if (bare > 0 && verbose_)
        std::cerr << "morse: notice: " << path << ": " << bare
                  << " element(s) have no *SOLID SECTION; their material comes from the options\n";
    }

    resolve_constraints(&mesh);
    mesh.normalize_sets();
    return mesh;
  }

  // --- constraints (by node label: mesh/constraints.hpp)
  std::int64_t node_label(std::int64_t label, const Loc& loc, const std::string& who) const {
    if (lookup(node_index_, label) < 0) fail(loc, who, " references undefined node ", label);
    return label;
  }

  /// The labels of node set `name`, ascending and unique (its members are defined: resolve_set
  /// checked them).
  std::vector<std::int64_t> set_labels(const std::string& name, const Loc& loc, const std::string& who) const {
    auto it = nset_lookup_.find(to_upper(name));
    if (it == nset_lookup_.end()) fail(loc, who, " references undefined node set '", name, "'");
    std::vector<std::int64_t> v = nsets_[it->second].labels;
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    return v;
  }

  /// REF NODE=: a node label, or a node set holding exactly one node.
  std::int64_t ref_node(const std::string& ref, const Loc& loc, const std::string& who) const {
    std::int64_t label = 0;
    if (parse_int(Field{ref.data(), ref.data() + ref.size()}, &label)) return node_label(label, loc, who);
    const auto v = set_labels(ref, loc, who);
    if (v.size() != 1)
      fail(loc, who, ": REF NODE=", ref, " is a node set of ", v.size(), " nodes; it must hold exactly one node");
    return v[0];
  }

  /// The nodes of node-based surface s, ascending, with their weights (1 where none or 0 is given).
  std::vector<std::pair<std::int64_t, double>> surface_nodes(const SurfaceData& s) const {
    const std::string who = "*SURFACE " + s.name;
    std::map<std::int64_t, std::pair<double, Loc>> nodes;
    for (const SurfaceEntry& se : s.entries) {
      const double w = se.weight > 0 ? se.weight : 1.0;
      const std::vector<std::int64_t> ids = se.set.empty()
                                                ? std::vector<std::int64_t>{node_label(se.label, se.loc, who)}
                                                : set_labels(se.set, se.loc, who);
      for (std::int64_t id : ids) {
        auto [it, inserted] = nodes.emplace(id, std::make_pair(w, se.loc));
        if (!inserted && it->second.first != w)
          fail(se.loc, who, ": node ", id, " has the weight ", w, " here and ", it->second.first, " at ",
               files_[it->second.second.file], ":", it->second.second.line);
      }
    }
    std::vector<std::pair<std::int64_t, double>> out;
    for (const auto& [id, wl] : nodes) out.emplace_back(id, wl.first);
    return out;
  }

  void resolve_constraints(Mesh* mesh) const {
    Constraints& cs = mesh->constraints;

    // *EQUATION: a node-set term gives one equation per node of the set; the sets of an equation
    // are matched in ascending order of their labels, a single node is in every equation.
    for (const EquationEntry& eq : equations_) {
      std::vector<std::vector<std::int64_t>> ids(eq.terms.size());
      const EquationTerm* first_set = nullptr;
      std::size_t n_eq = 1;
      for (std::size_t k = 0; k < eq.terms.size(); ++k) {
        const EquationTerm& t = eq.terms[k];
        if (t.set.empty()) {
          ids[k] = {node_label(t.label, t.loc, "*EQUATION")};
          continue;
        }
        ids[k] = set_labels(t.set, t.loc, "*EQUATION");
        if (ids[k].empty()) fail(t.loc, "*EQUATION: node set '", t.set, "' is empty");
        if (!first_set) {
          first_set = &t;
          n_eq = ids[k].size();
        } else if (ids[k].size() != n_eq) {
          fail(t.loc, "*EQUATION: node set '", t.set, "' has ", ids[k].size(), " nodes and '", first_set->set, "' has ",
               n_eq, "; the node sets of an equation must have as many nodes (matched in ascending order); give a",
               " node that every equation shares by its number");
        }
      }
      for (std::size_t i = 0; i < n_eq; ++i) {
        LinearConstraint lc;
        lc.id = static_cast<std::int64_t>(cs.linear.size()) + 1;
        lc.where = where(eq.loc) + "*EQUATION";
        for (std::size_t k = 0; k < eq.terms.size(); ++k)
          lc.terms.push_back(
              {eq.terms[k].set.empty() ? ids[k][0] : ids[k][i], eq.terms[k].dof, eq.terms[k].coefficient});
        cs.linear.push_back(std::move(lc));
      }
    }

    auto add_rigid = [&](const std::string& where_, std::int64_t ref, ComponentMask mask,
                         std::vector<std::int64_t> dependent) {
      RigidElement r;
      r.id = static_cast<std::int64_t>(cs.rigid.size()) + 1;
      r.where = where_;
      r.reference = ref;
      r.components = mask;
      r.dependent = std::move(dependent);
      cs.rigid.push_back(std::move(r));
    };

    // *RIGID BODY: NSET, TIE NSET and the nodes of ELSET follow in all six components, PIN NSET
    // in the translations.
    for (const RigidBodyEntry& rb : rigid_bodies_) {
      const std::string who = "*RIGID BODY";
      const std::int64_t ref = ref_node(rb.ref, rb.loc, who);
      std::vector<std::int64_t> tied;
      for (const std::string* s : {&rb.nset, &rb.tie_nset}) {
        if (s->empty()) continue;
        const auto v = set_labels(*s, rb.loc, who);
        tied.insert(tied.end(), v.begin(), v.end());
      }
      if (!rb.elset.empty()) {
        auto it = eset_lookup_.find(to_upper(rb.elset));
        if (it == eset_lookup_.end()) fail(rb.loc, who, " references undefined element set '", rb.elset, "'");
        for (std::int64_t el : mesh->elem_sets.at(esets_[it->second].name))
          for (auto k = mesh->elem_offsets[el]; k < mesh->elem_offsets[el + 1]; ++k)
            tied.push_back(mesh->node_ids[mesh->elem_nodes[k]]);
      }
      std::sort(tied.begin(), tied.end());
      tied.erase(std::unique(tied.begin(), tied.end()), tied.end());
      const std::vector<std::int64_t> pinned =
          rb.pin_nset.empty() ? std::vector<std::int64_t>{} : set_labels(rb.pin_nset, rb.loc, who);
      for (std::int64_t id : pinned)
        if (std::binary_search(tied.begin(), tied.end(), id))
          fail(rb.loc, who, ": node ", id, " is both tied (all components) and pinned (translations)");
      if (tied.empty() && pinned.empty()) fail(rb.loc, who, ": its node sets are empty");
      if (!tied.empty()) add_rigid(where(rb.loc) + who, ref, 63, std::move(tied));
      if (!pinned.empty()) add_rigid(where(rb.loc) + who + " (PIN NSET)", ref, 7, pinned);
    }

    // *COUPLING: the nodes of a node-based surface; *KINEMATIC -> rigid, *DISTRIBUTING ->
    // interpolation with the surface's weights.
    for (const CouplingEntry& c : couplings_) {
      const std::string who = c.name.empty() ? "*COUPLING" : "*COUPLING " + c.name;
      const std::int64_t ref = ref_node(c.ref, c.loc, who);
      auto it = surface_lookup_.find(to_upper(c.surface));
      if (it == surface_lookup_.end()) fail(c.loc, who, " references undefined surface '", c.surface, "'");
      const SurfaceData& s = surfaces_[it->second];
      if (s.type != "NODE")
        fail(c.loc, who, ": surface '", s.name, "' (", files_[s.loc.file], ":", s.loc.line,
             ") is not node-based (TYPE=", s.type,
             "); morse couples the nodes of a node-based surface: define it with *SURFACE, NAME=", s.name,
             ", TYPE=NODE and its nodes or node sets");
      const auto nodes = surface_nodes(s);
      if (nodes.empty()) fail(c.loc, who, ": surface '", s.name, "' has no nodes");
      const ComponentMask dofs = c.dofs ? c.dofs : 63;
      if (!c.distributing) {
        std::vector<std::int64_t> dependent;
        for (const auto& [id, w] : nodes) dependent.push_back(id);
        add_rigid(where(c.loc) + who, ref, dofs, std::move(dependent));
        continue;
      }
      InterpolationElement r;
      r.id = static_cast<std::int64_t>(cs.interpolation.size()) + 1;
      r.where = where(c.loc) + who;
      r.reference = ref;
      r.ref_components = dofs;
      for (const auto& [id, w] : nodes) {
        r.nodes.push_back(id);
        r.weights.push_back(w);
        r.node_components.push_back(7);
      }
      cs.interpolation.push_back(std::move(r));
    }
  }

  // --- state
  bool verbose_;
  std::vector<std::string> files_;
  std::set<std::string> noticed_;
  int depth_ = 0;

  Block block_ = Block::kNone;
  std::string block_keyword_;
  ElementType etype_ = ElementType::Tet4;
  int node_set_ = -1;  // *NODE, NSET=
  int elem_set_ = -1;  // *ELEMENT, ELSET=
  int set_ = -1;       // *NSET / *ELSET being filled
  bool generate_ = false;
  int material_ = -1;  // material receiving *ELASTIC / *DENSITY
  bool in_step_ = false;

  bool pending_ = false;  // element connectivity continues on the next line
  std::int64_t pending_label_ = 0;
  Loc pending_loc_;
  std::vector<std::int64_t> pending_nodes_;

  std::vector<Field> fields_;
  std::vector<std::int64_t> scratch_;

  std::vector<std::int64_t> node_ids_;
  std::vector<double> coords_;
  std::unordered_map<std::int64_t, std::int64_t> node_index_;

  std::vector<std::int64_t> elem_ids_;
  std::vector<ElementType> elem_types_;
  std::vector<Loc> elem_locs_;
  std::vector<std::int64_t> elem_labels_;  // Abaqus ordering, node labels
  std::unordered_map<std::int64_t, std::int64_t> elem_index_;

  std::vector<SetData> nsets_, esets_;
  std::unordered_map<std::string, int> nset_lookup_, eset_lookup_;

  std::vector<MaterialData> materials_;
  std::unordered_map<std::string, int> material_lookup_;
  std::vector<BoundaryEntry> boundaries_;
  std::vector<SectionEntry> sections_;

  std::vector<EquationEntry> equations_;
  std::vector<RigidBodyEntry> rigid_bodies_;
  std::vector<CouplingEntry> couplings_;
  bool coupling_open_ = false;  // a *COUPLING waits for its *KINEMATIC or *DISTRIBUTING
  std::vector<SurfaceData> surfaces_;
  std::unordered_map<std::string, int> surface_lookup_;
  int surface_ = -1;  // node-based *SURFACE being filled
};

}  // namespace

Mesh read_abaqus(const std::string& path, bool verbose) { return Reader(verbose).read(path); }

}  // namespace morse::mesh
