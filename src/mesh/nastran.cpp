// Nastran bulk data reader and writer. See morse/mesh/nastran.hpp for the supported subset.
//
// Reading has two stages. The first turns physical lines into cards: each line is split into
// field 1, its data fields and field 10 according to its format (small, large, free), and the data
// fields of a card and its continuations are appended into one list, in which a small line is one
// row of 8 fields and a large line half a row. Each complete card is then parsed at once into a
// compact record (so that a deck of millions of GRIDs does not keep its text). Bulk data is
// unordered, so the second stage, finish(), resolves the records: coordinate systems, grid
// positions, elements (node order, orientation), properties and materials, constraints, sets and
// masses. Every record keeps the file and line of its card for the error messages.
//
// Writing formats each card's fields as strings and lays them out in the chosen format; reals are
// written with the fewest digits that read back exactly, or as many as fit a fixed-width field.
#include "morse/mesh/nastran.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/options.hpp"
#include "morse/mesh/cells.hpp"

namespace morse::mesh {

namespace {

using std::int64_t;
using std::string_view;

// ------------------------------------------------------------------------------------------------
// Solid element cards and node orderings

struct SolidCard {
  const char* name;
  ElementType linear;
  ElementType quadratic;
};
constexpr SolidCard kSolidCards[] = {{"CTETRA", ElementType::Tet4, ElementType::Tet10},
                                     {"CPENTA", ElementType::Wedge6, ElementType::Wedge15},
                                     {"CHEXA", ElementType::Hex8, ElementType::Hex20}};

const SolidCard& solid_card(ElementType t) {
  for (const SolidCard& c : kSolidCards)
    if (c.linear == t || c.quadratic == t) return c;
  return kSolidCards[0];  // not reached: every type has a card
}

using EdgeList = std::vector<std::pair<int, int>>;

/// The vertex permutation that mirrors an element (an involution): the tetrahedron swaps G2 and
/// G3, the pentahedron and the hexahedron swap their bottom and top faces.
std::vector<int> mirror_vertices(ElementType t) {
  switch (vertices_per_element(t)) {
    case 4:
      return {0, 2, 1, 3};
    case 6:
      return {3, 4, 5, 0, 1, 2};
    default:
      return {4, 5, 6, 7, 0, 1, 2, 3};
  }
}

/// For each Nastran node position i, its position in the morse element: as given, and for an
/// element whose corners are mirrored first (vertex i goes to sigma(i); a midside grid follows its
/// edge, whose ends are renamed by sigma).
struct Ordering {
  std::array<int, kMaxNodes> direct{};
  std::array<int, kMaxNodes> mirrored{};
};

Ordering build_ordering(ElementType t) {
  Ordering o;
  const int nv = vertices_per_element(t), n = nodes_per_element(t);
  const std::vector<int> sigma = mirror_vertices(t);
  for (int i = 0; i < nv; ++i) {
    o.direct[i] = i;
    o.mirrored[i] = sigma[i];
  }
  if (n > nv) {
    const EdgeList& edges = mid_edges(t, NodeOrder::Nastran);
    EdgeList renamed;
    for (const auto& [a, b] : edges) renamed.emplace_back(sigma[a], sigma[b]);
    const std::vector<int> d = foreign_to_morse(t, edges);
    const std::vector<int> m = foreign_to_morse(t, renamed);
    for (int i = nv; i < n; ++i) {
      o.direct[i] = d[i];
      o.mirrored[i] = m[i];
    }
  }
  return o;
}

const Ordering& ordering(ElementType t) {
  static const std::array<Ordering, kNumElementTypes> all = [] {
    std::array<Ordering, kNumElementTypes> a{};
    for (int i = 0; i < kNumElementTypes; ++i) a[i] = build_ordering(static_cast<ElementType>(i));
    return a;
  }();
  return all[static_cast<int>(t)];
}

// ------------------------------------------------------------------------------------------------
// Text and numbers

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }
inline char to_upper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 32) : c; }

string_view trim(string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && is_space(s[b])) ++b;
  while (e > b && is_space(s[e - 1])) --e;
  return s.substr(b, e - b);
}

std::string upper(string_view s) {
  std::string u(s);
  for (char& c : u) c = to_upper(c);
  return u;
}

bool iequals(string_view a, string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (to_upper(a[i]) != to_upper(b[i])) return false;
  return true;
}

bool istarts_with(string_view s, string_view prefix) {
  return s.size() >= prefix.size() && iequals(s.substr(0, prefix.size()), prefix);
}

/// Upper-case copy without blanks.
std::string compact_upper(string_view s) {
  std::string u;
  for (char c : s)
    if (!is_space(c)) u += to_upper(c);
  return u;
}

/// A Nastran integer: [sign]digits.
bool parse_int(string_view s, int64_t* v) {
  if (s.empty()) return false;
  std::size_t i = 0;
  bool neg = false;
  if (s[0] == '+' || s[0] == '-') {
    neg = s[0] == '-';
    i = 1;
  }
  if (i == s.size()) return false;
  std::uint64_t acc = 0;
  for (; i < s.size(); ++i) {
    if (!is_digit(s[i])) return false;
    const unsigned d = static_cast<unsigned>(s[i] - '0');
    if (acc > (static_cast<std::uint64_t>(INT64_MAX) - d) / 10) return false;
    acc = acc * 10 + d;
  }
  *v = neg ? -static_cast<int64_t>(acc) : static_cast<int64_t>(acc);
  return true;
}

/// A Nastran real: [sign] mantissa (digits with at most one '.') [exponent], the exponent being
/// E or D with an optional sign, or a bare sign (1.-3 = 1.0E-3), followed by digits. An integer is
/// accepted. Anything else (blanks inside, "inf", hex) is rejected.
bool parse_real(string_view s, double* v) {
  if (s.empty() || s.size() > 48) return false;
  char buf[64];
  std::size_t k = 0, i = 0;
  if (s[0] == '+' || s[0] == '-') buf[k++] = s[i++];
  int digits = 0;
  bool dot = false;
  for (; i < s.size(); ++i) {
    if (is_digit(s[i])) {
      buf[k++] = s[i];
      ++digits;
    } else if (s[i] == '.' && !dot) {
      buf[k++] = '.';
      dot = true;
    } else {
      break;
    }
  }
  if (digits == 0) return false;
  if (i < s.size()) {
    const char c = to_upper(s[i]);
    buf[k++] = 'E';
    if (c == 'E' || c == 'D') {
      ++i;
      if (i < s.size() && (s[i] == '+' || s[i] == '-')) buf[k++] = s[i++];
    } else if (c == '+' || c == '-') {
      buf[k++] = c;
      ++i;
    } else {
      return false;
    }
    int exp_digits = 0;
    for (; i < s.size() && is_digit(s[i]); ++i, ++exp_digits) buf[k++] = s[i];
    if (exp_digits == 0 || i != s.size()) return false;
  }
  buf[k] = '\0';
  char* end = nullptr;
  const double x = std::strtod(buf, &end);
  if (end != buf + k || !std::isfinite(x)) return false;
  *v = x;
  return true;
}

/// A component set: digits 1-6 without repetition (bit d-1 for digit d), or "0" (scalar point,
/// *zero set and mask 0).
bool parse_components(string_view s, std::uint8_t* mask, bool* zero) {
  *mask = 0;
  *zero = false;
  if (s == "0") {
    *zero = true;
    return true;
  }
  if (s.empty()) return false;
  for (char c : s) {
    if (c < '1' || c > '6') return false;
    const std::uint8_t bit = static_cast<std::uint8_t>(1u << (c - '1'));
    if (*mask & bit) return false;
    *mask |= bit;
  }
  return true;
}

std::string component_string(std::uint8_t mask) {
  std::string s;
  for (int d = 0; d < 6; ++d)
    if (mask & (1u << d)) s += static_cast<char>('1' + d);
  return s;
}

// ------------------------------------------------------------------------------------------------
// Cards that the reader knows without reading them

/// Rigid elements and MPCs: their dependent DOFs would have to be eliminated.
const std::unordered_set<std::string>& rigid_cards() {
  static const std::unordered_set<std::string> s = {"RBE1",    "RBAR",    "RBAR1",  "RROD",  "RTRPLT",
                                                    "RTRPLT1", "RSPLINE", "RSSCON", "RJOINT"};
  return s;
}

/// Elements and matrix inputs that carry stiffness or mass: skipping them changes the model.
const std::unordered_set<std::string>& structural_cards() {
  static const std::unordered_set<std::string> s = {
      "CELAS1", "CELAS2",  "CELAS3", "CELAS4",  "CBUSH",   "CBUSH1D", "CBUSH2D", "CBAR",    "CBEAM",   "CBEAM3",
      "CBEND",  "CROD",    "CONROD", "CTUBE",   "CQUAD4",  "CQUAD8",  "CQUAD",   "CQUADR",  "CTRIA3",  "CTRIA6",
      "CTRIAR", "CSHEAR",  "CPYRAM", "CQUADX",  "CQUADX4", "CQUADX8", "CTRIAX",  "CTRIAX3", "CTRIAX6", "CGAP",
      "CFAST",  "CWELD",   "CSEAM",  "CONM1",   "CMASS1",  "CMASS2",  "CMASS3",  "CMASS4",  "GENEL",   "DMIG",
      "CHEXCZ", "CPENTCZ", "CIFHEX", "CIFPENT", "CIFQUAD", "CIFQDX",  "CRAC2D",  "CRAC3D"};
  return s;
}

// ------------------------------------------------------------------------------------------------
// Reader

struct Loc {
  int file = 0;
  int line = 0;
};

struct Range {
  int64_t lo = 0;
  int64_t hi = 0;
  bool thru = false;  // from "lo THRU hi": ids missing in the range are allowed
};

struct GridRec {
  int64_t id = 0;
  int64_t cp = 0;
  int64_t cd = 0;
  double x[3] = {0, 0, 0};
  std::uint8_t ps = 0;
  std::uint8_t blanks = 0;  // bit 0: CP blank, bit 1: CD blank, bit 2: PS blank
  Loc loc;
};

struct CordRec {
  int64_t cid = 0;
  int64_t rid = 0;
  char type = 'R';
  double a[3] = {0, 0, 0}, b[3] = {0, 0, 0}, c[3] = {0, 0, 0};
  Loc loc;
  // resolved
  int state = 0;  // 0 not yet, 1 in progress, 2 done
  double origin[3] = {0, 0, 0};
  double axes[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // e1, e2, e3 in basic
};

struct ElemRec {
  int64_t id = 0;
  int64_t pid = 0;
  ElementType type = ElementType::Tet4;
  std::size_t offset = 0;  // first grid id in elem_grids_
  Loc loc;
};

struct PsolidRec {
  int64_t mid = 0;
  Loc loc;
};

struct Mat1Rec {
  double E = 0, G = 0, nu = 0, rho = 0;
  bool has_E = false, has_G = false, has_nu = false, has_rho = false;
  Loc loc;
};

/// A list of ids with one component set: SPC, SPC1, SET1, ASET, ASET1, QSET, QSET1.
struct ListRec {
  const char* card = "";
  int64_t sid = 0;
  std::uint8_t mask = 0;
  bool zero = false;  // component "0" or blank (scalar points)
  Loc loc;
  std::vector<Range> ids;
};

struct Conm2Rec {
  int64_t eid = 0;
  int64_t grid = 0;
  int64_t cid = 0;
  double m = 0;
  double x[3] = {0, 0, 0};
  double inertia[6] = {0, 0, 0, 0, 0, 0};
  Loc loc;
};

/// RBE2 EID GN CM GM1 ... [ALPHA [TREF]].
struct Rbe2Rec {
  int64_t eid = 0;
  int64_t gn = 0;
  std::uint8_t cm = 0;
  std::vector<Range> gm;
  Loc loc;
};

/// RBE3 EID - REFGRID REFC (WT C G ...)+ [UM ...] [ALPHA a] [TREF t].
struct Rbe3Rec {
  int64_t eid = 0;
  int64_t ref = 0;
  std::uint8_t refc = 0;
  struct Group {
    double wt = 0;
    std::uint8_t c = 0;
    std::vector<int64_t> g;
  };
  std::vector<Group> groups;
  Loc loc;
};

/// MPC SID (G C A)+: one equation per card.
struct MpcRec {
  int64_t sid = 0;
  std::vector<int64_t> g;
  std::vector<int> c;
  std::vector<double> a;
  Loc loc;
};

enum class Kind {
  kGrid,
  kGrdset,
  kCord2,
  kCordUnsupported,
  kSolid,
  kPsolid,
  kMat1,
  kParam,
  kSpc,
  kSpc1,
  kSpcadd,
  kSet1,
  kAset,
  kAset1,
  kQset,
  kQset1,
  kSpoint,
  kConm2,
  kRbe2,
  kRbe3,
  kMpc,
  kRigid,
  kOther
};

Kind kind_of(const std::string& name) {
  static const std::unordered_map<std::string, Kind> kinds = {{"GRID", Kind::kGrid},
                                                              {"GRDSET", Kind::kGrdset},
                                                              {"CORD2R", Kind::kCord2},
                                                              {"CORD2C", Kind::kCord2},
                                                              {"CORD2S", Kind::kCord2},
                                                              {"CORD1R", Kind::kCordUnsupported},
                                                              {"CORD1C", Kind::kCordUnsupported},
                                                              {"CORD1S", Kind::kCordUnsupported},
                                                              {"CORD3G", Kind::kCordUnsupported},
                                                              {"CORD3R", Kind::kCordUnsupported},
                                                              {"CTETRA", Kind::kSolid},
                                                              {"CPENTA", Kind::kSolid},
                                                              {"CHEXA", Kind::kSolid},
                                                              {"PSOLID", Kind::kPsolid},
                                                              {"MAT1", Kind::kMat1},
                                                              {"PARAM", Kind::kParam},
                                                              {"SPC", Kind::kSpc},
                                                              {"SPC1", Kind::kSpc1},
                                                              {"SPCADD", Kind::kSpcadd},
                                                              {"SET1", Kind::kSet1},
                                                              {"ASET", Kind::kAset},
                                                              {"ASET1", Kind::kAset1},
                                                              {"QSET", Kind::kQset},
                                                              {"QSET1", Kind::kQset1},
                                                              {"SPOINT", Kind::kSpoint},
                                                              {"CONM2", Kind::kConm2},
                                                              {"RBE2", Kind::kRbe2},
                                                              {"RBE3", Kind::kRbe3},
                                                              {"MPC", Kind::kMpc}};
  auto it = kinds.find(name);
  if (it != kinds.end()) return it->second;
  if (rigid_cards().count(name)) return Kind::kRigid;
  return Kind::kOther;
}

constexpr double kDegree = 3.14159265358979323846 / 180.0;

class Reader {
 public:
  Reader(bool verbose, bool skip_unsupported) : verbose_(verbose), skip_unsupported_(skip_unsupported) {}

  Mesh read(const std::string& path) {
    parse_file(path, nullptr, 0);
    return finish(path);
  }

 private:
  // ---------------------------------------------------------------------------------------------
  // Messages

  std::string where(const Loc& l) const { return cat(files_[l.file], ":", l.line, ": "); }
  std::string at(const Loc& l) const { return cat(files_[l.file], ":", l.line); }

  template <class... T>
  [[noreturn]] void fail(const Loc& l, const std::string& card, const T&... pieces) const {
    throw Error(cat(where(l), "card ", card, ": ", pieces...));
  }

  template <class... T>
  void notice(const std::string& key, const Loc& l, const T&... pieces) {
    if (!verbose_ || !noticed_.insert(key).second) return;
    std::cerr << "morse: notice: " << where(l) << cat(pieces...) << '\n';
  }

  /// A notice about the whole deck (named by its main file).
  template <class... T>
  void summary(const T&... pieces) const {
    if (verbose_) std::cerr << "morse: notice: " << files_[0] << ": " << cat(pieces...) << '\n';
  }

  // ---------------------------------------------------------------------------------------------
  // Files and lines

  static bool read_whole_file(const std::string& path, std::string* text, std::string* why) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) {
      *why = std::strerror(errno);
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
    if (!ok) *why = std::strerror(errno);
    std::fclose(f);
    return ok;
  }

  /// Line i (0-based) of text without its line end.
  using Lines = std::vector<std::pair<std::size_t, std::size_t>>;

  static Lines split_lines(const std::string& text) {
    Lines lines;
    std::size_t p = 0;
    if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) p = 3;  // UTF-8 byte order mark
    while (p < text.size()) {
      std::size_t nl = text.find('\n', p);
      const std::size_t e = nl == std::string::npos ? text.size() : nl;
      std::size_t ee = e;
      if (ee > p && text[ee - 1] == '\r') --ee;
      lines.emplace_back(p, ee);
      p = nl == std::string::npos ? text.size() : nl + 1;
    }
    return lines;
  }

  std::string resolve(const Loc& from, const std::string& name) const {
    namespace fs = std::filesystem;
    fs::path p(name);
    if (p.is_absolute()) return p.string();
    return (fs::path(files_[from.file]).parent_path() / p).lexically_normal().string();
  }

  /// Text of a line without its '$' comment.
  static string_view strip_comment(string_view s) {
    const std::size_t d = s.find('$');
    return d == string_view::npos ? s : s.substr(0, d);
  }

  /// If the main file has a BEGIN BULK line, returns the index of the line after it and notes
  /// what is skipped above it (and a case-control PARAM,WTMASS); otherwise returns 0.
  std::size_t skip_to_bulk(const std::string& text, const Lines& lines, int fid) {
    std::size_t begin = lines.size();
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const string_view t =
          trim(strip_comment(string_view(text).substr(lines[i].first, lines[i].second - lines[i].first)));
      if (t.size() >= 5 && istarts_with(t, "BEGIN") && (t.size() == 5 || is_space(t[5]))) {
        if (compact_upper(t.substr(5)) == "BULK") begin = i;
        break;
      }
    }
    if (begin == lines.size()) return 0;
    int skipped = 0;
    for (std::size_t i = 0; i < begin; ++i) {
      const string_view t =
          trim(strip_comment(string_view(text).substr(lines[i].first, lines[i].second - lines[i].first)));
      if (t.empty()) continue;
      ++skipped;
      // Case control: PARAM,WTMASS,value (or PARAM WTMASS value).
      std::vector<std::string> tokens;
      std::string tok;
      for (char c : t) {
        if (c == ',' || c == '=' || is_space(c)) {
          if (!tok.empty()) tokens.push_back(upper(tok));
          tok.clear();
        } else {
          tok += c;
        }
      }
      if (!tok.empty()) tokens.push_back(upper(tok));
      if (tokens.size() >= 2 && tokens[0] == "PARAM" && tokens[1] == "WTMASS") {
        const Loc loc{fid, static_cast<int>(i) + 1};
        double w = 0;
        if (tokens.size() < 3 || !parse_real(tokens[2], &w) || !(w > 0))
          fail(loc, "PARAM", "case-control PARAM,WTMASS needs a positive real value");
        case_wtmass_ = w;
        case_wtmass_loc_ = loc;
      }
    }
    if (skipped > 0)
      notice("EXEC", Loc{fid, static_cast<int>(begin) + 1}, "skipped ", skipped,
             " line(s) of executive and case control above BEGIN BULK (morse reads the bulk data;"
             " every SPC set is applied)");
    return begin + 1;
  }

  void parse_file(const std::string& path, const Loc* from, int depth) {
    if (from && depth > 32)
      fail(*from, "INCLUDE", "INCLUDE nested more than 32 deep (does '", path, "' include itself?)");
    std::string text, why;
    if (!read_whole_file(path, &text, &why)) {
      if (from) fail(*from, "INCLUDE", "cannot read included file '", path, "' (", why, ")");
      throw Error(cat("cannot read Nastran file '", path, "' (", why, ")"));
    }
    const int fid = static_cast<int>(files_.size());
    files_.push_back(path);
    const Lines lines = split_lines(text);
    const string_view all(text);
    std::size_t i = depth == 0 ? skip_to_bulk(text, lines, fid) : 0;
    for (; i < lines.size() && !stop_; ++i) {
      const string_view raw = all.substr(lines[i].first, lines[i].second - lines[i].first);
      const Loc loc{fid, static_cast<int>(i) + 1};
      if (istarts_with(raw, "INCLUDE") && (raw.size() == 7 || is_space(raw[7]) || raw[7] == '\'' || raw[7] == '"')) {
        flush();
        const std::string name = include_name(all, lines, &i, loc);
        parse_file(resolve(loc, name), &loc, depth + 1);
        continue;
      }
      bulk_line(strip_comment(raw), loc);
    }
    flush();
  }

  /// The file name of the INCLUDE statement on line *i; advances *i over the lines of a quoted
  /// name that runs over several lines.
  std::string include_name(string_view all, const Lines& lines, std::size_t* i, const Loc& loc) const {
    string_view rest = all.substr(lines[*i].first + 7, lines[*i].second - lines[*i].first - 7);
    rest = trim(rest);
    std::string name;
    if (!rest.empty() && (rest[0] == '\'' || rest[0] == '"')) {
      const char quote = rest[0];
      rest.remove_prefix(1);
      while (true) {
        const std::size_t q = rest.find(quote);
        if (q != string_view::npos) {
          name += std::string(trim(rest.substr(0, q)));
          break;
        }
        name += std::string(trim(rest));
        if (++*i >= lines.size()) fail(loc, "INCLUDE", "the quoted file name is not closed before the end of the file");
        rest = all.substr(lines[*i].first, lines[*i].second - lines[*i].first);
      }
    } else {
      name = std::string(trim(strip_comment(rest)));
    }
    if (name.empty()) fail(loc, "INCLUDE", "no file name");
    return name;
  }

  // ---------------------------------------------------------------------------------------------
  // Lines to cards

  /// Splits a bulk data line (comment removed) and adds it to the card being assembled.
  void bulk_line(string_view s, const Loc& loc) {
    if (trim(s).empty()) return;
    {
      const string_view t = trim(s);
      if (t.size() >= 5 && istarts_with(t, "BEGIN") && (t.size() == 5 || is_space(t[5]))) {
        flush();
        if (compact_upper(t.substr(5)) == "BULK") {
          notice("BEGIN2", loc, "BEGIN BULK inside the bulk data is ignored");
          return;
        }
        fail(loc, "BEGIN", "'", t,
             "' is not supported: morse reads a single bulk data section"
             " (no part superelements, auxiliary models or modules)");
      }
    }

    string_view f1, f10;
    string_view data[8];
    int n_data = 0;
    bool large = false;
    const bool free = s.substr(0, 10).find(',') != string_view::npos;
    if (free) {
      std::size_t p = 0;
      int n_parts = 0;
      std::array<string_view, 11> parts;
      while (true) {
        const std::size_t c = s.find(',', p);
        const string_view part = trim(s.substr(p, c == string_view::npos ? string_view::npos : c - p));
        if (n_parts < 11) parts[n_parts] = part;
        ++n_parts;
        if (c == string_view::npos) break;
        p = c + 1;
      }
      f1 = parts[0];
      large = (!f1.empty() && f1[0] == '*') || (!f1.empty() && f1.back() == '*' && f1[0] != '+');
      const int max_parts = large ? 6 : 10;
      if (n_parts > max_parts)
        fail(loc, card_name_for(f1), "free-field line has ", n_parts, " fields; at most ", max_parts, " are allowed (",
             large ? "name, 4 data fields and a continuation marker in large free field)"
                   : "name, 8 data fields and a continuation marker)");
      const int nd = large ? 4 : 8;
      for (int j = 1; j < n_parts && j <= nd; ++j) data[n_data++] = parts[j];
      if (n_parts == max_parts) f10 = parts[max_parts - 1];
    } else {
      // Fixed format: expand tabs to 8-column stops, keep 80 columns.
      string_view l = s;
      if (s.find('\t') != string_view::npos) {
        line_.clear();
        for (char c : s) {
          if (c == '\t')
            line_.append(8 - line_.size() % 8, ' ');
          else
            line_ += c;
        }
        l = line_;
      }
      if (l.size() > 80) {
        if (!trim(l.substr(80)).empty()) notice("COL80", loc, "text beyond column 80 is ignored (fixed-field format)");
        l = l.substr(0, 80);
        if (trim(l).empty()) return;  // only a sequence number beyond column 80
      }
      auto col = [&](std::size_t b, std::size_t w) { return b >= l.size() ? string_view() : trim(l.substr(b, w)); };
      f1 = col(0, 8);
      large = !f1.empty() && (f1[0] == '*' || (f1.back() == '*' && f1[0] != '+'));
      if (large) {
        for (int j = 0; j < 4; ++j) data[n_data++] = col(8 + 16 * j, 16);
      } else {
        for (int j = 0; j < 8; ++j) data[n_data++] = col(8 + 8 * j, 8);
      }
      f10 = col(72, 8);
    }

    const bool continuation = f1.empty() || f1[0] == '+' || f1[0] == '*';
    if (continuation) {
      if (!card_.active) throw Error(cat(where(loc), "continuation line ('", f1, "') without a parent card"));
      const std::string want = marker(card_.marker), got = marker(f1);
      if (!want.empty() && !got.empty() && want != got)
        fail(loc, card_.name, "continuation marker '", f1, "' does not match the marker '", card_.marker,
             "' in field 10 of line ", card_.last_line);
    } else {
      flush();
      string_view name = f1;
      if (name.back() == '*') name.remove_suffix(1);
      std::string u = upper(trim(name));
      if (u == "=" || u == "==" || u.empty())
        fail(loc, u.empty() ? std::string("?") : u,
             "replication of cards ('=', '==') is not supported: write the card in full");
      bool valid = u.size() <= 8 && u[0] >= 'A' && u[0] <= 'Z';
      for (char c : u) valid = valid && ((c >= 'A' && c <= 'Z') || is_digit(c));
      if (!valid)
        throw Error(cat(where(loc), "'", f1, "' is not a card name (field 1 of a fixed-format",
                        " line is columns 1-8; free-field lines need commas)"));
      if (u == "ENDDATA") {
        stop_ = true;
        return;
      }
      card_.active = true;
      card_.name = std::move(u);
      card_.loc = loc;
      card_.n = 0;
    }
    // A small line starts a new row of 8 fields; a large line fills half a row.
    if (!large)
      while (card_.n % 8 != 0) push_field(string_view(), loc.line);
    for (int j = 0; j < (large ? 4 : 8); ++j) {
      const string_view d = j < n_data ? data[j] : string_view();
      if (d == "=" || d == "==" || d.substr(0, 2) == "*(" || d.substr(0, 2) == "=(")
        fail(loc, card_.name, "field ", card_.n % 8 + 2, " ('", d,
             "'): replication is not supported: write the value in full");
      push_field(d, loc.line);
    }
    card_.marker = std::string(f10);
    card_.last_line = loc.line;
  }

  /// Name to use in a message about a line whose field 1 is f1.
  std::string card_name_for(string_view f1) const {
    if (f1.empty() || f1[0] == '+' || f1[0] == '*') return card_.active ? card_.name : "?";
    std::string u = upper(f1);
    if (!u.empty() && u.back() == '*') u.pop_back();
    return u;
  }

  /// A continuation marker without its leading '+' or '*', upper-cased.
  static std::string marker(string_view f) {
    f = trim(f);
    if (!f.empty() && (f[0] == '+' || f[0] == '*')) f.remove_prefix(1);
    return upper(trim(f));
  }

  void push_field(string_view d, int line) {
    if (static_cast<std::size_t>(card_.n) == card_.f.size()) {
      card_.f.emplace_back();
      card_.line.emplace_back();
    }
    card_.f[card_.n].assign(d.data(), d.size());
    card_.line[card_.n] = line;
    ++card_.n;
  }

  void flush() {
    if (!card_.active) return;
    card_.active = false;
    dispatch();
  }

  // ---------------------------------------------------------------------------------------------
  // Fields of the current card (index 0 = field 2 of the first line; 8 fields per row)

  string_view fld(int i) const { return i < card_.n ? string_view(card_.f[i]) : string_view(); }
  bool blank(int i) const { return fld(i).empty(); }
  Loc field_loc(int i) const { return Loc{card_.loc.file, i < card_.n ? card_.line[i] : card_.last_line}; }
  static int field_number(int i) { return i % 8 + 2; }

  template <class... T>
  [[noreturn]] void field_fail(int i, const T&... pieces) const {
    fail(field_loc(i), card_.name, "field ", field_number(i), " ", pieces...);
  }

  template <class... T>
  [[noreturn]] void card_fail(const T&... pieces) const {
    fail(card_.loc, card_.name, pieces...);
  }

  int64_t int_field(int i, const char* what) const {
    if (blank(i)) field_fail(i, "(", what, ") is blank; an integer is required");
    int64_t v;
    if (!parse_int(fld(i), &v)) field_fail(i, "('", fld(i), "') is not an integer (", what, ")");
    return v;
  }
  int64_t int_field(int i, const char* what, int64_t dflt) const { return blank(i) ? dflt : int_field(i, what); }
  int64_t id_field(int i, const char* what) const {
    const int64_t v = int_field(i, what);
    if (v <= 0) field_fail(i, "('", fld(i), "'): ", what, " must be a positive integer");
    return v;
  }
  double real_field(int i, const char* what) const {
    if (blank(i)) field_fail(i, "(", what, ") is blank; a real number is required");
    double v;
    if (!parse_real(fld(i), &v)) field_fail(i, "('", fld(i), "') is not a real number (", what, ")");
    return v;
  }
  double real_field(int i, const char* what, double dflt) const { return blank(i) ? dflt : real_field(i, what); }
  std::uint8_t comp_field(int i, const char* what, bool* zero) const {
    std::uint8_t mask;
    if (!parse_components(fld(i), &mask, zero))
      field_fail(i, "('", fld(i), "') is not a component set (", what,
                 ": distinct digits 1 to 6, or 0 for scalar points)");
    return mask;
  }
  /// Every field from index k on must be blank.
  void no_more(int k) const {
    for (int i = k; i < card_.n; ++i)
      if (!blank(i)) field_fail(i, "('", fld(i), "'): unexpected data; ", card_.name, " has ", k, " data fields");
  }
  /// Ids from field index first on: integers and "a THRU b" ranges; blank fields are skipped.
  std::vector<Range> id_list(int first, const char* what) const {
    std::vector<Range> out;
    for (int i = first; i < card_.n; ++i) {
      if (blank(i)) continue;
      if (iequals(fld(i), "THRU")) field_fail(i, "('THRU') is not preceded by an id");
      const int64_t a = id_field(i, what);
      if (i + 1 < card_.n && iequals(fld(i + 1), "THRU")) {
        if (blank(i + 2)) field_fail(i + 2, "is blank: THRU needs the last id of the range");
        const int64_t b = id_field(i + 2, what);
        if (b < a) field_fail(i + 2, "('", b, "'): the range ", a, " THRU ", b, " is empty");
        out.push_back({a, b, true});
        i += 2;
      } else {
        out.push_back({a, a, false});
      }
    }
    if (out.empty()) card_fail("no ", what, " given");
    return out;
  }

  // ---------------------------------------------------------------------------------------------
  // Cards to records

  void dispatch() {
    switch (kind_of(card_.name)) {
      case Kind::kGrid:
        return read_grid();
      case Kind::kGrdset:
        return read_grdset();
      case Kind::kCord2:
        return read_cord2();
      case Kind::kCordUnsupported:
        card_fail(card_.name, " is not supported: define the system with CORD2R, CORD2C or CORD2S");
      case Kind::kSolid:
        return read_solid();
      case Kind::kPsolid:
        return read_psolid();
      case Kind::kMat1:
        return read_mat1();
      case Kind::kParam:
        return read_param();
      case Kind::kSpc:
        return read_spc();
      case Kind::kSpc1:
        return read_list(1, "SPC1", /*with_sid=*/true, "grid ids");
      case Kind::kSpcadd:
        return;  // every SPC set is applied anyway
      case Kind::kSet1:
        return read_set1();
      case Kind::kAset:
        return read_pairs("ASET");
      case Kind::kAset1:
        return read_list(0, "ASET1", /*with_sid=*/false, "grid ids");
      case Kind::kQset:
        return read_pairs("QSET");
      case Kind::kQset1:
        return read_list(0, "QSET1", /*with_sid=*/false, "ids");
      case Kind::kSpoint:
        spoints_.push_back({card_.loc, id_list(0, "scalar point ids")});
        return;
      case Kind::kConm2:
        return read_conm2();
      case Kind::kRbe2:
        return read_rbe2();
      case Kind::kRbe3:
        return read_rbe3();
      case Kind::kMpc:
        return read_mpc();
      case Kind::kRigid:
        card_fail("this rigid element is not supported (morse reads RBE2, RBE3 and MPC); write it as RBE2 or MPC,",
                  " or export the assembled matrices (-matrices_K/-matrices_M)");
      case Kind::kOther:
        return skip_card();
    }
  }

  void skip_card() {
    if (!skip_unsupported_ && structural_cards().count(card_.name))
      card_fail("element type not supported: its stiffness and mass would be missing from the model. morse reads",
                " CTETRA, CPENTA, CHEXA and CONM2; remove the card, give -mesh_skip_unsupported to drop such",
                " cards knowingly, or export the assembled matrices (-matrices_K/-matrices_M)");
    ++skipped_[card_.name];
    // Remember other property and material ids for clearer messages about PSOLID and MAT1.
    int64_t id;
    if (!parse_int(fld(0), &id)) return;
    if (card_.name.compare(0, 3, "MAT") == 0)
      other_mats_.emplace(id, card_.name);
    else if (card_.name[0] == 'P' && card_.name != "PLOTEL" && card_.name.compare(0, 5, "PLOAD"))
      other_props_.emplace(id, card_.name);
  }

  void read_grid() {
    GridRec g;
    g.id = id_field(0, "ID");
    g.loc = card_.loc;
    if (blank(1))
      g.blanks |= 1;
    else
      g.cp = int_field(1, "CP");
    if (g.cp < 0) field_fail(1, "('", fld(1), "'): CP must be 0 or positive");
    for (int j = 0; j < 3; ++j) g.x[j] = real_field(2 + j, j == 0 ? "X1" : j == 1 ? "X2" : "X3", 0.0);
    if (blank(5))
      g.blanks |= 2;
    else
      g.cd = int_field(5, "CD");
    if (g.cd < 0) field_fail(5, "('", fld(5), "'): CD = ", g.cd, " (fluid grid points) is not supported");
    bool zero = false;
    if (blank(6))
      g.blanks |= 4;
    else
      g.ps = comp_field(6, "PS", &zero);
    if (zero) field_fail(6, "('0'): PS of a grid needs components 1 to 6");
    if (!blank(7)) int_field(7, "SEQ");
    no_more(8);
    auto [it, fresh] = grid_index_.emplace(g.id, grids_.size());
    if (!fresh) card_fail("grid ", g.id, " is defined twice (first at ", at(grids_[it->second].loc), ")");
    grids_.push_back(g);
  }

  void read_grdset() {
    if (grdset_.loc.line) card_fail("GRDSET is given twice (first at ", at(grdset_.loc), ")");
    grdset_.loc = card_.loc;
    grdset_.cp = int_field(1, "CP", 0);
    grdset_.cd = int_field(5, "CD", 0);
    if (grdset_.cp < 0 || grdset_.cd < 0) card_fail("CP and CD must be 0 or positive");
    bool zero = false;
    if (!blank(6)) grdset_.ps = comp_field(6, "PS", &zero);
    if (zero) field_fail(6, "('0'): PS of a grid needs components 1 to 6");
    no_more(8);
  }

  void read_cord2() {
    CordRec c;
    c.type = card_.name.back();
    c.loc = card_.loc;
    c.cid = id_field(0, "CID");
    c.rid = int_field(1, "RID", 0);
    if (c.rid < 0) field_fail(1, "('", fld(1), "'): RID must be 0 or positive");
    if (card_.n <= 8 || (blank(8) && blank(9) && blank(10)))
      card_fail("coordinate system ", c.cid, " is truncated: C1 C2 C3 (the continuation line)", " are missing");
    static const char* const kNames[9] = {"A1", "A2", "A3", "B1", "B2", "B3", "C1", "C2", "C3"};
    for (int j = 0; j < 3; ++j) {
      c.a[j] = real_field(2 + j, kNames[j], 0.0);
      c.b[j] = real_field(5 + j, kNames[3 + j], 0.0);
      c.c[j] = real_field(8 + j, kNames[6 + j], 0.0);
    }
    no_more(11);
    auto [it, fresh] = cords_.emplace(c.cid, c);
    if (!fresh) card_fail("coordinate system ", c.cid, " is defined twice (first at ", at(it->second.loc), ")");
  }

  void read_solid() {
    const SolidCard* sc = nullptr;
    for (const SolidCard& c : kSolidCards)
      if (card_.name == c.name) sc = &c;
    const int nv = vertices_per_element(sc->linear), nq = nodes_per_element(sc->quadratic);
    ElemRec r;
    r.loc = card_.loc;
    r.id = id_field(0, "EID");
    r.pid = id_field(1, "PID");
    static const char* const kG[kMaxNodes] = {"G1",  "G2",  "G3",  "G4",  "G5",  "G6",  "G7",  "G8",  "G9",  "G10",
                                              "G11", "G12", "G13", "G14", "G15", "G16", "G17", "G18", "G19", "G20"};
    std::array<int64_t, kMaxNodes> g{};
    int n_mid = 0;
    for (int k = 0; k < nq; ++k) {
      const char* what = kG[k];
      g[k] = int_field(2 + k, what, 0);
      if (g[k] < 0) field_fail(2 + k, "('", fld(2 + k), "'): ", what, " must be a positive grid id");
      if (k < nv && g[k] == 0)
        field_fail(2 + k, "(", what, ") is blank: element ", r.id, " needs its ", nv, " corner grids G1..G", nv);
      if (k >= nv && g[k] != 0) ++n_mid;
    }
    no_more(2 + nq);
    if (n_mid != 0 && n_mid != nq - nv)
      card_fail("element ", r.id, " has ", n_mid, " of its ", nq - nv, " midside grids (G", nv + 1, "..G", nq,
                "): partial midside grids are not supported");
    r.type = n_mid ? sc->quadratic : sc->linear;
    const int n = nodes_per_element(r.type);
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b)
        if (g[a] == g[b]) card_fail("grid ", g[a], " appears twice in element ", r.id);
    add_element_id(r.id, sc->name);
    r.offset = elem_grids_.size();
    elem_grids_.insert(elem_grids_.end(), g.begin(), g.begin() + n);
    elems_.push_back(r);
  }

  /// Solid elements and CONM2 share one id space.
  void add_element_id(int64_t id, const char* card) {
    auto [it, fresh] = element_ids_.emplace(id, std::make_pair(card_.loc, card));
    if (!fresh)
      card_fail("element id ", id, " is used twice (first by the ", it->second.second, " at ", at(it->second.first),
                ")");
  }

  void read_psolid() {
    const int64_t pid = id_field(0, "PID");
    PsolidRec p;
    p.loc = card_.loc;
    p.mid = id_field(1, "MID");
    if (!blank(6) && !iequals(fld(6), "SMECH"))
      field_fail(6, "('", fld(6), "'): FCTN = ", fld(6), " is not supported (only structural solids, FCTN = SMECH)");
    auto [it, fresh] = psolids_.emplace(pid, p);
    if (!fresh) card_fail("PSOLID ", pid, " is defined twice (first at ", at(it->second.loc), ")");
  }

  void read_mat1() {
    const int64_t mid = id_field(0, "MID");
    Mat1Rec m;
    m.loc = card_.loc;
    if ((m.has_E = !blank(1))) m.E = real_field(1, "E");
    if ((m.has_G = !blank(2))) m.G = real_field(2, "G");
    if ((m.has_nu = !blank(3))) m.nu = real_field(3, "NU");
    if ((m.has_rho = !blank(4))) m.rho = real_field(4, "RHO");
    static const char* const kOthers[6] = {"A", "TREF", "GE", "ST", "SC", "SS"};
    for (int i = 5; i <= 10; ++i) real_field(i, kOthers[i - 5], 0.0);
    int_field(11, "MCSID", 0);
    no_more(12);
    auto [it, fresh] = mat1s_.emplace(mid, m);
    if (!fresh) card_fail("MAT1 ", mid, " is defined twice (first at ", at(it->second.loc), ")");
  }

  void read_param() {
    if (blank(0)) field_fail(0, "(N) is blank: PARAM needs a parameter name");
    const std::string name = upper(fld(0));
    if (name != "WTMASS") {
      ++skipped_["PARAM"];
      skipped_params_.insert(name);
      return;
    }
    const double w = real_field(1, "V1");
    if (!(w > 0)) field_fail(1, "('", fld(1), "'): WTMASS must be positive");
    if (bulk_wtmass_loc_.line && w != bulk_wtmass_)
      card_fail("PARAM,WTMASS is given twice with different values (first at ", at(bulk_wtmass_loc_), ")");
    bulk_wtmass_ = w;
    bulk_wtmass_loc_ = card_.loc;
  }

  void read_spc() {
    const int64_t sid = id_field(0, "SID");
    for (int j = 0; j < 2; ++j) {
      const int b = 1 + 3 * j;
      if (j == 1 && blank(b) && blank(b + 1) && blank(b + 2)) break;
      ListRec r;
      r.card = "SPC";
      r.sid = sid;
      r.loc = field_loc(b);
      const int64_t g = id_field(b, j == 0 ? "G1" : "G2");
      if (blank(b + 1))
        r.zero = true;
      else
        r.mask = comp_field(b + 1, j == 0 ? "C1" : "C2", &r.zero);
      const double d = real_field(b + 2, j == 0 ? "D1" : "D2", 0.0);
      if (d != 0.0)
        field_fail(b + 2, "('", fld(b + 2), "'): enforced displacements are not supported (only", " D = 0)");
      r.ids.push_back({g, g, false});
      spc_.push_back(std::move(r));
    }
    no_more(7);
  }

  /// SPC1 SID C ids, ASET1 C ids, QSET1 C ids.
  void read_list(int c_index, const char* card, bool with_sid, const char* what) {
    ListRec r;
    r.card = card;
    r.loc = card_.loc;
    if (with_sid) r.sid = id_field(0, "SID");
    if (blank(c_index)) {
      if (with_sid) field_fail(c_index, "(C) is blank: a component set is required");
      r.zero = true;
    } else {
      r.mask = comp_field(c_index, "C", &r.zero);
    }
    r.ids = id_list(c_index + 1, what);
    if (std::strcmp(card, "SPC1") == 0)
      spc_.push_back(std::move(r));
    else if (std::strcmp(card, "ASET1") == 0)
      add_aset(std::move(r), c_index);
    else
      qset_.push_back(std::move(r));
  }

  /// ASET and QSET: pairs ID C in fields 2-9.
  void read_pairs(const char* card) {
    for (int j = 0; j < 4; ++j) {
      const int b = 2 * j;
      if (blank(b) && blank(b + 1)) continue;
      ListRec r;
      r.card = card;
      r.loc = field_loc(b);
      const int64_t id = id_field(b, "ID");
      if (blank(b + 1))
        r.zero = true;
      else
        r.mask = comp_field(b + 1, "C", &r.zero);
      r.ids.push_back({id, id, false});
      if (card[0] == 'A')
        add_aset(std::move(r), b + 1);
      else
        qset_.push_back(std::move(r));
    }
    no_more(8);
  }

  void add_aset(ListRec r, int c_index) {
    if (!r.zero && (r.mask & 7) != 7)
      field_fail(c_index, "('", fld(c_index), "'): the components do not include all of 1, 2, 3:",
                 " morse's boundary is made of whole nodes (all three translations)");
    aset_.push_back(std::move(r));
  }

  void read_set1() {
    ListRec r;
    r.card = "SET1";
    r.loc = card_.loc;
    r.sid = id_field(0, "SID");
    r.ids = id_list(1, "grid ids");
    auto [it, fresh] = set1_sids_.emplace(r.sid, card_.loc);
    if (!fresh) card_fail("SET1 ", r.sid, " is defined twice (first at ", at(it->second), ")");
    set1_.push_back(std::move(r));
  }

  void read_conm2() {
    Conm2Rec c;
    c.loc = card_.loc;
    c.eid = id_field(0, "EID");
    c.grid = id_field(1, "G");
    c.cid = int_field(2, "CID", 0);
    if (c.cid < -1) field_fail(2, "('", fld(2), "'): CID must be -1, 0 or positive");
    c.m = real_field(3, "M", 0.0);
    static const char* const kX[3] = {"X1", "X2", "X3"};
    for (int j = 0; j < 3; ++j) c.x[j] = real_field(4 + j, kX[j], 0.0);
    if (!blank(7)) field_fail(7, "('", fld(7), "'): field 9 of CONM2 must be blank");
    static const char* const kI[6] = {"I11", "I21", "I22", "I31", "I32", "I33"};
    for (int j = 0; j < 6; ++j) c.inertia[j] = real_field(8 + j, kI[j], 0.0);
    no_more(14);
    add_element_id(c.eid, "CONM2");
    conm2_.push_back(c);
  }

  /// True if field i holds an integer (an id), false if a real (with a decimal point or exponent).
  bool is_integer_field(int i) const {
    int64_t v;
    return parse_int(fld(i), &v);
  }

  void read_rbe2() {
    Rbe2Rec r;
    r.loc = card_.loc;
    r.eid = id_field(0, "EID");
    r.gn = id_field(1, "GN");
    bool zero = false;
    if (blank(2)) field_fail(2, "(CM) is blank: the dependent components are required");
    r.cm = comp_field(2, "CM", &zero);
    if (zero) field_fail(2, "('0'): CM needs components 1 to 6");
    // GMi (ids, THRU ranges) up to the first real: ALPHA, then TREF.
    int i = 3;
    for (; i < card_.n; ++i) {
      if (blank(i)) continue;
      if (iequals(fld(i), "THRU")) {
        if (r.gm.empty() || i + 1 >= card_.n) field_fail(i, "('THRU') needs an id before and after it");
        const int64_t b = id_field(i + 1, "GMi");
        if (b < r.gm.back().lo) field_fail(i + 1, "('", b, "'): the range ", r.gm.back().lo, " THRU ", b, " is empty");
        r.gm.back().hi = b;
        r.gm.back().thru = true;
        ++i;
        continue;
      }
      if (!is_integer_field(i)) break;
      const int64_t g = id_field(i, "GMi");
      r.gm.push_back({g, g, false});
    }
    if (i < card_.n) real_field(i++, "ALPHA");
    while (i < card_.n && blank(i)) ++i;
    if (i < card_.n) real_field(i++, "TREF");
    no_more(i);
    if (r.gm.empty()) card_fail("rigid element ", r.eid, " has no dependent grid (GM1)");
    add_element_id(r.eid, "RBE2");
    rbe2_.push_back(std::move(r));
  }

  void read_rbe3() {
    Rbe3Rec r;
    r.loc = card_.loc;
    r.eid = id_field(0, "EID");
    if (!blank(1)) field_fail(1, "('", fld(1), "'): field 3 of RBE3 must be blank");
    r.ref = id_field(2, "REFGRID");
    bool zero = false;
    if (blank(3)) field_fail(3, "(REFC) is blank: the reference components are required");
    r.refc = comp_field(3, "REFC", &zero);
    if (zero) field_fail(3, "('0'): REFC needs components 1 to 6");
    int i = 4;
    auto next = [&]() {
      while (i < card_.n && blank(i)) ++i;
      return i < card_.n;
    };
    while (next()) {
      if (iequals(fld(i), "UM")) {
        // UM names the DOFs to make dependent instead of the reference's; morse chooses them
        // itself (the constrained motions are the same), so the pairs are read and checked only.
        ++i;
        while (next() && !iequals(fld(i), "ALPHA") && !iequals(fld(i), "TREF")) {
          id_field(i++, "GMi");
          if (!next()) card_fail("UM: grid without its components");
          bool z = false;
          comp_field(i++, "CMi", &z);
        }
        ++rbe3_um_;
        if (!rbe3_um_loc_.line) rbe3_um_loc_ = r.loc;
        continue;
      }
      if (iequals(fld(i), "ALPHA") || iequals(fld(i), "TREF")) {
        const char* what = iequals(fld(i), "ALPHA") ? "ALPHA" : "TREF";
        ++i;
        if (!next()) card_fail(what, " without its value");
        real_field(i++, what);
        continue;
      }
      if (is_integer_field(i)) {
        if (r.groups.empty()) field_fail(i, "('", fld(i), "'): a weight WT1 (a real, e.g. 1.0) must come first");
        r.groups.back().g.push_back(id_field(i++, "Gi,j"));
        continue;
      }
      Rbe3Rec::Group grp;
      grp.wt = real_field(i, "WTi");
      if (!(grp.wt > 0)) field_fail(i, "('", fld(i), "'): the weight WTi must be positive");
      ++i;
      if (!next()) card_fail("weight ", grp.wt, " without its components Ci");
      bool z = false;
      grp.c = comp_field(i, "Ci", &z);
      if (z) field_fail(i, "('0'): Ci needs components 1 to 6");
      ++i;
      if (!r.groups.empty() && r.groups.back().g.empty()) card_fail("weight ", r.groups.back().wt, " has no grids");
      r.groups.push_back(grp);
    }
    if (r.groups.empty()) card_fail("interpolation element ", r.eid, " has no weighted grids (WT1 C1 G1,1 ...)");
    if (r.groups.back().g.empty()) card_fail("weight ", r.groups.back().wt, " has no grids");
    add_element_id(r.eid, "RBE3");
    rbe3_.push_back(std::move(r));
  }

  void read_mpc() {
    MpcRec r;
    r.loc = card_.loc;
    r.sid = id_field(0, "SID");
    for (int row = 0; 8 * row < card_.n; ++row) {
      if (row > 0 && !blank(8 * row))
        field_fail(8 * row, "('", fld(8 * row), "'): field 2 of an MPC continuation must be blank");
      for (int j = 0; j < 2; ++j) {
        const int b = 8 * row + 1 + 3 * j;
        if (blank(b) && blank(b + 1) && blank(b + 2)) continue;
        r.g.push_back(id_field(b, "Gi"));
        const int64_t c = int_field(b + 1, "Ci", 0);
        if (c < 1 || c > 6) field_fail(b + 1, "('", fld(b + 1), "'): Ci must be one component 1 to 6 of a grid");
        r.c.push_back(static_cast<int>(c));
        r.a.push_back(real_field(b + 2, "Ai"));
      }
      if (!blank(8 * row + 7)) field_fail(8 * row + 7, "('", fld(8 * row + 7), "'): field 9 of MPC must be blank");
    }
    if (r.g.empty()) card_fail("MPC ", r.sid, " has no terms");
    if (r.a[0] == 0.0) field_fail(3, "('", fld(3), "'): the first coefficient A1 (of the dependent DOF) is 0");
    mpc_.push_back(std::move(r));
  }

  // ---------------------------------------------------------------------------------------------
  // Resolution

  /// Resolves coordinate system cid (its origin and axes in basic), following its RID chain.
  void resolve_cord(int64_t cid, std::vector<int64_t>* chain) {
    CordRec& c = cords_.at(cid);
    if (c.state == 2) return;
    const std::string name = cat("CORD2", c.type);
    if (c.state == 1) {
      std::string path;
      for (int64_t id : *chain) path += cat(id, " -> ");
      fail(c.loc, name, "coordinate system ", cid, ": the RID chain is a cycle (", path, cid, ")");
    }
    c.state = 1;
    chain->push_back(cid);
    if (c.rid != 0) {
      auto it = cords_.find(c.rid);
      if (it == cords_.end())
        fail(c.loc, name, "coordinate system ", cid, " references undefined coordinate system ", c.rid, " (RID)");
      resolve_cord(c.rid, chain);
    }
    double a[3], b[3], p[3];
    to_basic(c.rid, c.a, a);
    to_basic(c.rid, c.b, b);
    to_basic(c.rid, c.c, p);
    double e3[3], v[3];
    for (int j = 0; j < 3; ++j) {
      e3[j] = b[j] - a[j];
      v[j] = p[j] - a[j];
    }
    const double l3 = std::sqrt(e3[0] * e3[0] + e3[1] * e3[1] + e3[2] * e3[2]);
    if (!(l3 > 0)) fail(c.loc, name, "coordinate system ", cid, ": points A and B coincide");
    for (double& x : e3) x /= l3;
    double e2[3] = {e3[1] * v[2] - e3[2] * v[1], e3[2] * v[0] - e3[0] * v[2], e3[0] * v[1] - e3[1] * v[0]};
    const double lv = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const double l2 = std::sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
    if (!(l2 > 1e-12 * lv)) fail(c.loc, name, "coordinate system ", cid, ": points A, B and C are on one line");
    for (double& x : e2) x /= l2;
    const double e1[3] = {e2[1] * e3[2] - e2[2] * e3[1], e2[2] * e3[0] - e2[0] * e3[2], e2[0] * e3[1] - e2[1] * e3[0]};
    for (int j = 0; j < 3; ++j) {
      c.origin[j] = a[j];
      c.axes[0][j] = e1[j];
      c.axes[1][j] = e2[j];
      c.axes[2][j] = e3[j];
    }
    c.state = 2;
    chain->pop_back();
  }

  /// Point x given in the (resolved) coordinate system cid, in basic coordinates.
  void to_basic(int64_t cid, const double x[3], double out[3]) const {
    if (cid == 0) {
      std::copy_n(x, 3, out);
      return;
    }
    const CordRec& c = cords_.at(cid);
    double l[3];
    if (c.type == 'R') {
      std::copy_n(x, 3, l);
    } else if (c.type == 'C') {
      const double t = x[1] * kDegree;
      l[0] = x[0] * std::cos(t);
      l[1] = x[0] * std::sin(t);
      l[2] = x[2];
    } else {
      const double t = x[1] * kDegree, f = x[2] * kDegree;
      l[0] = x[0] * std::sin(t) * std::cos(f);
      l[1] = x[0] * std::sin(t) * std::sin(f);
      l[2] = x[0] * std::cos(t);
    }
    for (int j = 0; j < 3; ++j) out[j] = c.origin[j] + l[0] * c.axes[0][j] + l[1] * c.axes[1][j] + l[2] * c.axes[2][j];
  }

  std::int64_t node_of(int64_t id) const {
    auto it = grid_index_.find(id);
    return it == grid_index_.end() ? -1 : static_cast<int64_t>(it->second);
  }

  bool is_spoint(int64_t id) const { return spoint_ids_.count(id) != 0; }

  /// What to do with a scalar point met in an id list.
  enum class OnScalar { kError, kIgnore, kCount };

  /// Calls f(node index, grid id) for every grid of range r of list card `card` at loc. Explicit
  /// ids must exist; THRU ranges may have gaps but not be empty. Returns the number of scalar
  /// points met (which are errors if on_scalar is kError).
  template <class F>
  int64_t for_each_grid(const Range& r, const Loc& loc, const char* card, OnScalar on_scalar, F f) const {
    int64_t n_scalar = 0;
    if (!r.thru) {
      const int64_t k = node_of(r.lo);
      if (k >= 0) {
        f(k, r.lo);
      } else if (is_spoint(r.lo)) {
        if (on_scalar == OnScalar::kError)
          fail(loc, card, r.lo, " is a scalar point (SPOINT); ", card, " needs grids here");
        ++n_scalar;
      } else {
        fail(loc, card, "undefined grid ", r.lo);
      }
      return n_scalar;
    }
    auto b = std::lower_bound(sorted_grids_.begin(), sorted_grids_.end(), std::make_pair(r.lo, int64_t{-1}));
    int64_t n_grids = 0;
    for (auto it = b; it != sorted_grids_.end() && it->first <= r.hi; ++it, ++n_grids) f(it->second, it->first);
    n_scalar = std::upper_bound(sorted_spoints_.begin(), sorted_spoints_.end(), r.hi) -
               std::lower_bound(sorted_spoints_.begin(), sorted_spoints_.end(), r.lo);
    if (n_scalar > 0 && on_scalar == OnScalar::kError)
      fail(loc, card, "the range ", r.lo, " THRU ", r.hi, " contains scalar points (SPOINT); ", card,
           " needs grids here");
    if (n_grids == 0 && n_scalar == 0) fail(loc, card, "the range ", r.lo, " THRU ", r.hi, " contains no grid");
    return n_scalar;
  }

  /// Elastic constants of MAT1 mid by Nastran's rules.
  void elastic(int64_t mid, const Mat1Rec& m, double* E, double* nu) {
    const Loc& l = m.loc;
    if (m.has_E && m.has_G && m.has_nu) {
      *E = m.E;
      *nu = m.nu;
      const double ratio = m.E / (2 * (1 + m.nu) * m.G);
      if (!(std::fabs(ratio - 1) <= 0.01))
        notice(cat("EGNU", mid), l, "MAT1 ", mid, ": E, G and NU are all given and", " E / (2 (1 + NU) G) = ", ratio,
               " differs from 1 by more than 1 %; E and NU are", " used");
    } else if (m.has_E && m.has_nu) {
      *E = m.E;
      *nu = m.nu;
    } else if (m.has_E && m.has_G) {
      *E = m.E;
      *nu = m.E / (2 * m.G) - 1;
    } else if (m.has_G && m.has_nu) {
      *E = 2 * (1 + m.nu) * m.G;
      *nu = m.nu;
    } else {
      fail(l, "MAT1", "material ", mid, ": give two of E, G, NU (",
           m.has_E    ? "only E"
           : m.has_G  ? "only G"
           : m.has_nu ? "only NU"
                      : "E and G are blank",
           "): a solid needs both elastic constants");
    }
    if (!(*E > 0) || !(*nu > -1 && *nu < 0.5))
      fail(l, "MAT1", "material ", mid, ": invalid elastic constants E = ", *E, ", NU = ", *nu,
           " (need E > 0 and -1 < NU < 0.5)");
  }

  std::string other_note(const std::unordered_map<int64_t, std::string>& others, int64_t id, const char* kind,
                         const char* supported) const {
    auto it = others.find(id);
    if (it == others.end()) return "";
    return cat(" (", kind, " ", id, " is a ", it->second, "; only ", supported, " is supported)");
  }

  Mesh finish(const std::string& path) {
    Mesh mesh;
    mesh.units = "unknown";
    mesh.source = path;
    const double wtmass = case_wtmass_ > 0 ? case_wtmass_ : bulk_wtmass_;

    // Scalar points.
    for (const auto& [loc, ranges] : spoints_)
      for (const Range& r : ranges) {
        if (r.hi - r.lo >= 10000000) fail(loc, "SPOINT", "the range ", r.lo, " THRU ", r.hi, " is too large");
        for (int64_t id = r.lo; id <= r.hi; ++id) {
          auto g = grid_index_.find(id);
          if (g != grid_index_.end())
            fail(loc, "SPOINT", "scalar point ", id, " has the id of the grid at ", at(grids_[g->second].loc));
          spoint_ids_.insert(id);
        }
      }
    sorted_spoints_.assign(spoint_ids_.begin(), spoint_ids_.end());
    std::sort(sorted_spoints_.begin(), sorted_spoints_.end());

    // Coordinate systems, then grids in basic.
    for (auto& [cid, c] : cords_) {
      std::vector<int64_t> chain;
      resolve_cord(cid, &chain);
    }
    const std::size_t nn = grids_.size();
    mesh.node_ids.resize(nn);
    mesh.coords.resize(3 * nn);
    std::vector<int64_t> cd(nn);
    std::vector<std::uint8_t> ps(nn);
    for (std::size_t k = 0; k < nn; ++k) {
      const GridRec& g = grids_[k];
      const int64_t cp = g.blanks & 1 ? grdset_.cp : g.cp;
      cd[k] = g.blanks & 2 ? grdset_.cd : g.cd;
      ps[k] = g.blanks & 4 ? grdset_.ps : g.ps;
      if (cp != 0 && !cords_.count(cp))
        fail(g.loc, "GRID", "grid ", g.id, " references undefined coordinate system ", cp, " (CP",
             g.blanks & 1 ? " from GRDSET)" : ")");
      if (cd[k] != 0 && !cords_.count(cd[k]))
        fail(g.loc, "GRID", "grid ", g.id, " references undefined coordinate system ", cd[k], " (CD",
             g.blanks & 2 ? " from GRDSET)" : ")");
      mesh.node_ids[k] = g.id;
      to_basic(cp, g.x, &mesh.coords[3 * k]);
    }
    sorted_grids_.reserve(nn);
    for (std::size_t k = 0; k < nn; ++k) sorted_grids_.emplace_back(grids_[k].id, static_cast<int64_t>(k));
    std::sort(sorted_grids_.begin(), sorted_grids_.end());

    // Elements: grid ids to indices, orientation, Nastran to morse order.
    std::vector<char> used(nn, 0);
    std::map<int64_t, int> pid_material;  // in increasing PID
    int64_t n_mirrored = 0;
    std::string first_mirrored;
    {
      std::array<int64_t, kMaxNodes> idx{}, ordered{};
      std::array<double, 3 * 8> xyz{};
      for (const ElemRec& r : elems_) {
        const int n = nodes_per_element(r.type);
        const SolidCard& sc = solid_card(r.type);
        for (int i = 0; i < n; ++i) {
          const int64_t id = elem_grids_[r.offset + i];
          idx[i] = node_of(id);
          if (idx[i] < 0)
            fail(r.loc, sc.name, "element ", r.id, " references ", is_spoint(id) ? "scalar point " : "undefined grid ",
                 id);
          used[idx[i]] = 1;
        }
        const int nv = vertices_per_element(r.type);
        for (int i = 0; i < nv; ++i)
          for (int j = 0; j < 3; ++j) xyz[3 * i + j] = mesh.coords[3 * idx[i] + j];
        const double det = corner_jacobian(sc.linear, xyz.data());
        const Ordering& o = ordering(r.type);
        const auto& perm = det < 0 ? o.mirrored : o.direct;
        if (det < 0 && n_mirrored++ == 0) first_mirrored = cat(sc.name, " ", r.id, " at ", at(r.loc));
        for (int i = 0; i < n; ++i) ordered[perm[i]] = idx[i];
        mesh.add_element(r.id, r.type, ordered.data());
        if (!psolids_.count(r.pid))
          fail(r.loc, sc.name, "element ", r.id, " references PSOLID ", r.pid, ", which is not defined",
               other_note(other_props_, r.pid, "property", "PSOLID"));
        pid_material.emplace(r.pid, -1);
      }
    }

    // Properties and materials: one per PSOLID used.
    for (auto& [pid, index] : pid_material) {
      const PsolidRec& p = psolids_.at(pid);
      auto m = mat1s_.find(p.mid);
      if (m == mat1s_.end())
        fail(p.loc, "PSOLID", "property ", pid, " references MAT1 ", p.mid, ", which is not defined",
             other_note(other_mats_, p.mid, "material", "MAT1"));
      Material mat;
      mat.name = cat("PSOLID_", pid);
      elastic(p.mid, m->second, &mat.E, &mat.nu);
      if (!m->second.has_rho)
        notice(cat("RHO", p.mid), m->second.loc, "MAT1 ", p.mid, " has no density (RHO blank):", " 0 is used");
      if (m->second.rho < 0)
        fail(m->second.loc, "MAT1", "material ", p.mid, ": negative density RHO = ", m->second.rho);
      mat.rho = m->second.rho * wtmass;
      index = static_cast<int>(mesh.materials.size());
      mesh.materials.push_back(mat);
    }
    for (std::size_t e = 0; e < elems_.size(); ++e) {
      const int index = pid_material.at(elems_[e].pid);
      mesh.elem_material[e] = index;
      mesh.elem_sets[mesh.materials[index].name].push_back(static_cast<int64_t>(e));
    }

    // Constraints: GRID PS, SPC, SPC1.
    std::vector<std::uint8_t> fixed(nn, 0);
    int64_t n_rotational = 0, n_scalar_spc = 0;
    auto constrain = [&](int64_t k, std::uint8_t mask, const Loc& loc, const char* card) {
      const std::uint8_t translations = mask & 7;
      if ((mask >> 3) && used[k]) ++n_rotational;
      if (translations && translations != 7 && cd[k] != 0)
        fail(loc, card, "grid ", mesh.node_ids[k], " has its displacement coordinate system CD = ", cd[k],
             ", and components '", component_string(mask), "' fix only part of its",
             " translations, which would act along skewed directions in the basic system that",
             " morse works in: fix all of 1, 2, 3 or none");
      fixed[k] |= used[k] ? translations : static_cast<std::uint8_t>(mask & 63);  // six-DOF points keep 4-6
    };
    for (std::size_t k = 0; k < nn; ++k)
      if (ps[k]) constrain(static_cast<int64_t>(k), ps[k], grids_[k].loc, "GRID");
    std::set<int64_t> sids;
    for (const ListRec& r : spc_) {
      sids.insert(r.sid);
      for (const Range& range : r.ids)
        n_scalar_spc += for_each_grid(range, r.loc, r.card, OnScalar::kIgnore, [&](int64_t k, int64_t id) {
          if (r.zero) fail(r.loc, r.card, "component 0 is for scalar points,", " but ", id, " is a grid");
          constrain(k, r.mask, r.loc, r.card);
        });
    }
    if (std::any_of(fixed.begin(), fixed.end(), [](std::uint8_t f) { return f != 0; }))
      mesh.fixed_dofs = std::move(fixed);

    // Sets.
    for (const ListRec& r : set1_) {
      std::vector<int64_t>& set = mesh.node_sets[cat("SET1_", r.sid)];
      for (const Range& range : r.ids)
        for_each_grid(range, r.loc, r.card, OnScalar::kError, [&](int64_t k, int64_t) { set.push_back(k); });
    }
    if (!aset_.empty()) {
      std::vector<int64_t>& set = mesh.node_sets["ASET"];
      for (const ListRec& r : aset_)
        for (const Range& range : r.ids)
          for_each_grid(range, r.loc, r.card, OnScalar::kError, [&](int64_t k, int64_t id) {
            if (r.zero)
              fail(r.loc, r.card, "the components are blank or 0 (scalar points), but ", id,
                   " is a grid: give 123 or 123456");
            set.push_back(k);
          });
    }
    std::set<int64_t> modal;  // scalar points of QSET / QSET1
    Loc qset_loc;
    for (const ListRec& r : qset_) {
      qset_loc = r.loc;
      for (const Range& range : r.ids) {
        for_each_grid(range, r.loc, r.card, OnScalar::kCount, [&](int64_t, int64_t id) {
          fail(r.loc, r.card, r.card, " on grids (", id, ") is not supported: morse computes the",
               " fixed-interface modes itself (QSET on scalar points only)");
        });
        auto b = std::lower_bound(sorted_spoints_.begin(), sorted_spoints_.end(), range.lo);
        for (; b != sorted_spoints_.end() && *b <= range.hi; ++b) modal.insert(*b);
      }
    }
    const auto n_modal = static_cast<int64_t>(modal.size());

    // Rigid elements, interpolation elements, MPCs: by grid id (mesh/constraints.hpp).
    std::set<int64_t> constrained;  // grids they name
    {
      auto grid = [&](int64_t id, const Loc& loc, const char* card) {
        if (node_of(id) < 0)
          fail(loc, card, is_spoint(id) ? "scalar point " : "undefined grid ", id,
               is_spoint(id) ? " is not supported here (grids only)" : "");
        constrained.insert(id);
        return id;
      };
      auto& cs = mesh.constraints;
      for (const Rbe2Rec& r : rbe2_) {
        mesh::RigidElement e;
        e.id = r.eid;
        e.where = cat(at(r.loc), ": RBE2 ", r.eid);
        e.reference = grid(r.gn, r.loc, "RBE2");
        e.components = r.cm;
        for (const Range& range : r.gm)
          for_each_grid(range, r.loc, "RBE2", OnScalar::kError,
                        [&](int64_t, int64_t id) { e.dependent.push_back(grid(id, r.loc, "RBE2")); });
        cs.rigid.push_back(std::move(e));
      }
      for (const Rbe3Rec& r : rbe3_) {
        mesh::InterpolationElement e;
        e.id = r.eid;
        e.where = cat(at(r.loc), ": RBE3 ", r.eid);
        e.reference = grid(r.ref, r.loc, "RBE3");
        e.ref_components = r.refc;
        for (const auto& g : r.groups)
          for (int64_t id : g.g) {
            e.nodes.push_back(grid(id, r.loc, "RBE3"));
            e.weights.push_back(g.wt);
            e.node_components.push_back(g.c);
          }
        cs.interpolation.push_back(std::move(e));
      }
      std::set<int64_t> mpc_sids;
      for (const MpcRec& r : mpc_) {
        mpc_sids.insert(r.sid);
        mesh::LinearConstraint e;
        e.id = r.sid;
        e.where = cat(at(r.loc), ": MPC ", r.sid);
        for (std::size_t k = 0; k < r.g.size(); ++k) e.terms.push_back({grid(r.g[k], r.loc, "MPC"), r.c[k], r.a[k]});
        cs.linear.push_back(std::move(e));
      }
      if (mpc_sids.size() > 1) {
        std::string list;
        for (int64_t sid : mpc_sids) list += cat(list.empty() ? "" : ", ", sid);
        summary("MPC cards use the SIDs ", list, ": all of them are applied (the case control, which selects one,",
                " is not read)");
      }
      if (rbe3_um_)
        notice("RBE3UM", rbe3_um_loc_, rbe3_um_, " RBE3 card(s) give UM: morse chooses the dependent DOFs that make",
               " the reference independent itself (the constrained motions are the same)");
    }

    // Point masses.
    int64_t n_offset = 0;
    Loc offset_loc;
    if (!conm2_.empty()) {
      mesh.point_mass.assign(nn, 0.0);
      for (const Conm2Rec& c : conm2_) {
        const int64_t k = node_of(c.grid);
        if (k < 0)
          fail(c.loc, "CONM2", "mass element ", c.eid, " references ",
               is_spoint(c.grid) ? "scalar point " : "undefined grid ", c.grid);
        if (!used[k] && !constrained.count(c.grid))
          fail(c.loc, "CONM2", "mass element ", c.eid, " is on grid ", c.grid, ", which no solid",
               " element, rigid element or MPC uses (the mass would be connected to nothing)");
        if (c.cid > 0 && !cords_.count(c.cid))
          fail(c.loc, "CONM2", "mass element ", c.eid, " references undefined coordinate system ", c.cid, " (CID)");
        bool offset = false;
        for (int j = 0; j < 3; ++j) offset = offset || (c.cid == -1 ? c.x[j] != mesh.coords[3 * k + j] : c.x[j] != 0.0);
        for (double i : c.inertia) offset = offset || i != 0.0;
        if (offset && !used[k]) {
          // A six-DOF point: the rigid mass with its offset and inertia, in the basic system.
          // CID = -1: X is the centre of gravity in basic; 0: the offset in basic; > 0: the
          // offset and the inertia in that (rectangular) system.
          double d[3], J[9];
          const double Jl[9] = {c.inertia[0],  -c.inertia[1], -c.inertia[3], -c.inertia[1], c.inertia[2],
                                -c.inertia[4], -c.inertia[3], -c.inertia[4], c.inertia[5]};
          double R[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // columns: the system's axes in basic
          if (c.cid > 0) {
            const CordRec& cs = cords_.at(c.cid);
            if (cs.type != 'R')
              fail(c.loc, "CONM2", "mass element ", c.eid, " on six-DOF point ", c.grid, " gives its offset and ",
                   "inertia in the ", cs.type == 'C' ? "cylindrical" : "spherical", " system ", c.cid,
                   "; use a rectangular system (CORD2R) or CID 0");
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j) R[i][j] = cs.axes[j][i];
          }
          for (int i = 0; i < 3; ++i) {
            d[i] = 0;
            for (int j = 0; j < 3; ++j) d[i] += R[i][j] * c.x[j];
            if (c.cid == -1) d[i] = c.x[i] - mesh.coords[3 * k + i];
          }
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
              J[3 * i + j] = 0;
              for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b) J[3 * i + j] += R[i][a] * Jl[3 * a + b] * R[j][b];
              J[3 * i + j] *= wtmass;
            }
          const auto M6 = mesh::rigid_mass_matrix(c.m * wtmass, d, J);
          mesh.constraints.mass_ids.push_back(c.grid);
          mesh.constraints.mass_matrices.insert(mesh.constraints.mass_matrices.end(), M6.begin(), M6.end());
          continue;
        }
        if (offset && n_offset++ == 0) offset_loc = c.loc;
        mesh.point_mass[k] += c.m * wtmass;
      }
    }

    mesh.normalize_sets();

    // Notices.
    if (wtmass != 1.0) {
      const Loc& l = case_wtmass_ > 0 ? case_wtmass_loc_ : bulk_wtmass_loc_;
      notice("WTMASS", l, "PARAM,WTMASS = ", wtmass, case_wtmass_ > 0 ? " (case control)" : "",
             ": densities and CONM2 masses are multiplied by it");
    }
    if (case_wtmass_ > 0 && bulk_wtmass_loc_.line && bulk_wtmass_ != case_wtmass_)
      notice("WTMASS2", bulk_wtmass_loc_, "PARAM,WTMASS = ", bulk_wtmass_,
             " of the bulk data is overridden by the case control");
    if (n_mirrored)
      summary(n_mirrored, " element(s) were given with their corners in",
              " the other orientation (first: ", first_mirrored, "); they were mirrored");
    if (sids.size() > 1) {
      std::string list;
      for (int64_t s : sids) list += cat(list.empty() ? "" : ", ", s);
      summary("SPC/SPC1 cards use the SIDs ", list, ": all of them are applied",
              " (the case control, which selects one, is not read)");
    }
    if (n_rotational)
      summary(n_rotational, " constraint(s) on components 4-6 ignored (solid", " grids have no rotations)");
    if (n_scalar_spc) summary(n_scalar_spc, " constraint(s) on scalar points ignored");
    if (n_modal)
      notice("QSET", qset_loc, "QSET/QSET1 define ", n_modal, " modal coordinates: use", " -cb_num_fixed_modes ",
             n_modal);
    if (n_offset)
      notice("CONM2", offset_loc, n_offset, " CONM2 card(s) on grids of solid elements have offsets or inertias;",
             " they act on rotations, which solid grids lack, and are ignored (only M is used). On a grid of its",
             " own tied by an RBE2 or RBE3 (a six-DOF point) they are kept");
    if (verbose_ && !skipped_.empty()) {
      std::string structural, other;
      for (const auto& [name, count] : skipped_) {
        std::string& s = structural_cards().count(name) ? structural : other;
        s += cat(s.empty() ? "" : ", ", count, " ", name);
        if (name == "PARAM") {
          std::string names;
          for (const std::string& p : skipped_params_) names += cat(names.empty() ? "" : ", ", p);
          s += cat(" (", names, ")");
        }
      }
      if (!structural.empty())
        std::cerr << "morse: WARNING: " << path << ": elements not supported (their stiffness and"
                  << " mass are MISSING from the model): " << structural << '\n';
      if (!other.empty()) std::cerr << "morse: notice: " << path << ": skipped cards: " << other << '\n';
    }
    return mesh;
  }

  // ---------------------------------------------------------------------------------------------
  // State

  struct Card {
    bool active = false;
    std::string name;
    Loc loc;
    int n = 0;                   // data fields in use
    std::vector<std::string> f;  // data fields (capacity kept between cards)
    std::vector<int> line;       // line of each data field
    std::string marker;          // field 10 of the last line
    int last_line = 0;
  };

  struct Grdset {
    int64_t cp = 0, cd = 0;
    std::uint8_t ps = 0;
    Loc loc;
  };

  bool verbose_;
  bool skip_unsupported_;
  bool stop_ = false;
  std::vector<std::string> files_;
  std::set<std::string> noticed_;
  std::string line_;
  Card card_;

  std::vector<GridRec> grids_;
  std::unordered_map<int64_t, std::size_t> grid_index_;
  std::vector<std::pair<int64_t, int64_t>> sorted_grids_;  // (id, index)
  Grdset grdset_;
  std::map<int64_t, CordRec> cords_;
  std::vector<ElemRec> elems_;
  std::vector<int64_t> elem_grids_;
  std::unordered_map<int64_t, std::pair<Loc, const char*>> element_ids_;  // card name
  std::unordered_map<int64_t, PsolidRec> psolids_;
  std::unordered_map<int64_t, Mat1Rec> mat1s_;
  std::unordered_map<int64_t, std::string> other_props_, other_mats_;
  std::vector<ListRec> spc_, set1_, aset_, qset_;
  std::unordered_map<int64_t, Loc> set1_sids_;
  std::vector<std::pair<Loc, std::vector<Range>>> spoints_;
  std::unordered_set<int64_t> spoint_ids_;
  std::vector<int64_t> sorted_spoints_;
  std::vector<Conm2Rec> conm2_;
  std::vector<Rbe2Rec> rbe2_;
  std::vector<Rbe3Rec> rbe3_;
  std::vector<MpcRec> mpc_;
  int64_t rbe3_um_ = 0;
  Loc rbe3_um_loc_;
  double bulk_wtmass_ = 1.0, case_wtmass_ = 0.0;
  Loc bulk_wtmass_loc_, case_wtmass_loc_;
  std::map<std::string, int64_t> skipped_;
  std::set<std::string> skipped_params_;
};

// ------------------------------------------------------------------------------------------------
// Writer

/// |x| in decimal: digits d[0..nd) (trailing zeros removed) and the decimal exponent e of d[0].
struct Decimal {
  char d[32];
  int nd = 0;
  int e = 0;
};

/// p = 0 gives the shortest digits that read back as x; p > 0 rounds to p significant digits.
Decimal decimal(double x, int p) {
  char buf[64];
  const std::to_chars_result r =
      p == 0 ? std::to_chars(buf, buf + sizeof buf, std::fabs(x), std::chars_format::scientific)
             : std::to_chars(buf, buf + sizeof buf, std::fabs(x), std::chars_format::scientific, p - 1);
  Decimal dec;
  const char* s = buf;
  for (; s < r.ptr && *s != 'e'; ++s)
    if (is_digit(*s) && dec.nd < 31) dec.d[dec.nd++] = *s;
  while (dec.nd > 1 && dec.d[dec.nd - 1] == '0') --dec.nd;
  int e = 0;
  const bool negative_exponent = s + 1 < r.ptr && s[1] == '-';
  for (s += 2; s < r.ptr; ++s) e = 10 * e + (*s - '0');
  dec.e = negative_exponent ? -e : e;
  return dec;
}

int decimal_length(int v) {
  int n = 1;
  while (v >= 10) v /= 10, ++n;
  return n;
}

/// Writes the text of (-1)^neg dec for a field of `width` columns (0: unlimited) to out and
/// returns its length, or 0 if it does not fit. The readable forms, plain (0.25) and with E
/// (2.5E-7), are preferred, the shorter first; the compact forms (.25, and Nastran's 2.5-7) only
/// if neither fits. Every form contains a decimal point, as Nastran requires for reals.
int render_real(const Decimal& dec, bool neg, int width, char* out) {
  const int s = neg ? 1 : 0, nd = dec.nd, e = dec.e, ed = decimal_length(std::abs(e));
  enum Form { kPlain, kShort, kE, kNoE };
  const int len_plain = e >= 0 ? s + std::max(nd, e + 1) + 1 : s + 2 + (-e - 1) + nd;
  const int len[4] = {len_plain, e < 0 ? len_plain - 1 : 1 << 30, s + nd + 3 + ed, s + nd + 2 + ed};
  const Form readable = len[kPlain] <= len[kE] ? kPlain : kE;
  const Form order[4] = {readable, readable == kPlain ? kE : kPlain, kShort, kNoE};
  for (Form f : order) {
    if (width != 0 && len[f] > width) continue;
    char* p = out;
    if (neg) *p++ = '-';
    if (f == kPlain || f == kShort) {
      if (e >= 0) {
        for (int i = 0; i <= e; ++i) *p++ = i < nd ? dec.d[i] : '0';
        *p++ = '.';
        for (int i = e + 1; i < nd; ++i) *p++ = dec.d[i];
      } else {
        if (f == kPlain) *p++ = '0';
        *p++ = '.';
        for (int i = 0; i < -e - 1; ++i) *p++ = '0';
        for (int i = 0; i < nd; ++i) *p++ = dec.d[i];
      }
    } else {
      *p++ = dec.d[0];
      *p++ = '.';
      for (int i = 1; i < nd; ++i) *p++ = dec.d[i];
      if (f == kE) *p++ = 'E';
      *p++ = e < 0 ? '-' : '+';
      char exp[8];
      int n = 0;
      for (int v = std::abs(e); n == 0 || v > 0; v /= 10) exp[n++] = static_cast<char>('0' + v % 10);
      while (n > 0) *p++ = exp[--n];
    }
    return static_cast<int>(p - out);
  }
  return 0;
}

/// A real for a field of `width` columns (0: unlimited): the shortest decimal that reads back
/// as x if it fits, else rounded to the most digits that fit.
std::string format_real(double x, int width) {
  if (!std::isfinite(x)) throw Error(cat("write_nastran: cannot write the real ", x));
  if (x == 0) return "0.";
  char out[64];
  Decimal dec = decimal(x, 0);
  int n = render_real(dec, x < 0, width, out);
  if (n > 0) return std::string(out, static_cast<std::size_t>(n));
  // The most digits any form could hold with this exponent (rounding may still change it).
  const int s = x < 0 ? 1 : 0, e = dec.e;
  int p_max = width - s - 2 - decimal_length(std::abs(e));                   // 2.5-7
  if (e >= 0 && s + e + 2 <= width) p_max = std::max(p_max, width - s - 1);  // 123.45
  if (e < 0) p_max = std::max(p_max, width - s + e);                         // .00123
  for (int p = std::min(p_max, 17); p >= 1; --p) {
    dec = decimal(x, p);
    n = render_real(dec, x < 0, width, out);
    if (n == 0) continue;
    std::string text(out, static_cast<std::size_t>(n));
    double back;  // rounding next to the largest double may overflow
    if (std::fabs(x) < 1e300 || parse_real(text, &back)) return text;
  }
  throw Error(cat("write_nastran: the real ", x, " does not fit a ", width, "-column field"));
}

using Format = NastranWriteOptions::Format;

class CardWriter {
 public:
  CardWriter(Format f, std::ostream* os)
      : format_(f),
        width_(f == Format::Small   ? 8
               : f == Format::Large ? 16
                                    : 0),
        os_(*os) {}

  std::string real(double x) const { return format_real(x, width_); }

  std::string integer(int64_t v) const {
    std::string s = std::to_string(v);
    if (width_ && static_cast<int>(s.size()) > width_)
      throw Error(cat("write_nastran: ", v, " does not fit a ", width_, "-column field; use the Large or Free format"));
    return s;
  }

  void comment(const std::string& text) { os_ << "$ " << text << '\n'; }

  /// Writes card `name` with data fields (field 2 on), continuing as needed.
  void card(const char* name, const std::vector<std::string>& fields) {
    std::size_t nf = fields.size();
    while (nf > 0 && fields[nf - 1].empty()) --nf;
    const std::size_t per_line = format_ == Format::Large ? 4 : 8;
    const std::size_t n_lines = std::max<std::size_t>(1, (nf + per_line - 1) / per_line);
    for (std::size_t l = 0; l < n_lines; ++l) {
      line_.clear();
      const std::size_t b = l * per_line, e = std::min(nf, b + per_line);
      if (format_ == Format::Free) {
        if (l == 0) line_ = name;
        // Rows other than the last are complete, so a line starting with ',' is the next row.
        for (std::size_t i = b; i < e; ++i) (line_ += ',') += fields[i];
      } else {
        if (l == 0)
          line_ = format_ == Format::Large ? cat(name, "*") : name;
        else
          line_ = format_ == Format::Large ? "*" : "+";
        line_.resize(8, ' ');
        const std::size_t w = static_cast<std::size_t>(width_);
        for (std::size_t i = b; i < e; ++i) {
          line_ += fields[i];
          if (i + 1 < e) line_.resize(8 + (i - b + 1) * w, ' ');
        }
        while (!line_.empty() && line_.back() == ' ') line_.pop_back();
      }
      os_ << line_ << '\n';
    }
  }

 private:
  Format format_;
  int width_;
  std::ostream& os_;
  std::string line_;
};

}  // namespace

Mesh read_nastran(const std::string& path, bool verbose, bool skip_unsupported) {
  return Reader(verbose, skip_unsupported).read(path);
}

void write_nastran(const Mesh& m, const std::string& path, const NastranWriteOptions& o) {
  const int64_t nn = m.num_nodes(), ne = m.num_elements();
  for (int64_t e = 0; e < ne; ++e) {
    if (m.elem_material[e] < 0)
      throw Error(cat("write_nastran: element ", m.elem_ids[e], " has no material",
                      " (elem_material = -1): Nastran needs a PSOLID and a MAT1 for every",
                      " element; assign the materials first"));
    if (m.elem_material[e] >= static_cast<int>(m.materials.size()))
      throw Error(cat("write_nastran: element ", m.elem_ids[e], " has material index ", m.elem_material[e],
                      " but the mesh has ", m.materials.size(), " materials"));
    if (m.elem_ids[e] <= 0) throw Error(cat("write_nastran: element id ", m.elem_ids[e], " is not positive"));
  }
  for (int64_t k = 0; k < nn; ++k)
    if (m.node_ids[k] <= 0) throw Error(cat("write_nastran: node id ", m.node_ids[k], " is not positive"));
  if (!m.fixed_dofs.empty() && static_cast<int64_t>(m.fixed_dofs.size()) != nn)
    throw Error("write_nastran: fixed_dofs does not have one entry per node");
  if (!m.point_mass.empty() && static_cast<int64_t>(m.point_mass.size()) != nn)
    throw Error("write_nastran: point_mass does not have one entry per node");
  const std::vector<int64_t>* aset = nullptr;
  if (!o.aset.empty()) {
    auto it = m.node_sets.find(o.aset);
    if (it == m.node_sets.end()) {
      std::string known;
      for (const auto& [name, v] : m.node_sets) known += cat(known.empty() ? "" : ", ", name);
      throw Error(cat("write_nastran: the ASET node set '", o.aset, "' is not in the mesh",
                      " (node sets: ", known.empty() ? "none" : known, ")"));
    }
    aset = &it->second;
  }

  const std::string tmp = files::temp_path(path);
  {
    std::ofstream os(tmp, std::ios::binary);
    if (!os) throw Error(cat("write_nastran: cannot open '", path, "' for writing (check its directory)"));
    CardWriter w(o.format, &os);
    w.comment("Nastran bulk data written by morse");
    w.comment(cat("source: ", m.source));
    w.comment(cat("units: ", m.units));
    w.comment(cat(nn, " grids, ", ne, " solid elements, ", m.materials.size(), " materials"));
    if (!m.fixed_dofs.empty()) w.comment("fixed DOFs: SPC1 with SID 1 (case control: SPC = 1)");
    os << "BEGIN BULK\n";

    std::vector<std::string> f;
    for (int64_t k = 0; k < nn; ++k) {
      f = {w.integer(m.node_ids[k]), "", w.real(m.coords[3 * k]), w.real(m.coords[3 * k + 1]),
           w.real(m.coords[3 * k + 2])};
      w.card("GRID", f);
    }
    for (int64_t e = 0; e < ne; ++e) {
      const ElementType t = m.elem_types[e];
      const int n = nodes_per_element(t);
      const Ordering& ord = ordering(t);
      const std::int64_t* nodes = &m.elem_nodes[m.elem_offsets[e]];
      f = {w.integer(m.elem_ids[e]), w.integer(m.elem_material[e] + 1)};
      for (int i = 0; i < n; ++i) f.push_back(w.integer(m.node_ids[nodes[ord.direct[i]]]));
      w.card(solid_card(t).name, f);
    }
    for (std::size_t i = 0; i < m.materials.size(); ++i) {
      const Material& mat = m.materials[i];
      const std::string id = w.integer(static_cast<int64_t>(i) + 1);
      w.comment(cat("material ", i + 1, ": ", mat.name));
      w.card("PSOLID", {id, id});
      w.card("MAT1", {id, w.real(mat.E), "", w.real(mat.nu), w.real(mat.rho)});
    }
    if (!m.fixed_dofs.empty()) {
      for (std::uint8_t mask = 1; mask < 8; ++mask) {
        f = {"1", component_string(mask)};
        for (int64_t k = 0; k < nn; ++k)
          if ((m.fixed_dofs[k] & 7) == mask) f.push_back(w.integer(m.node_ids[k]));
        if (f.size() > 2) w.card("SPC1", f);
      }
    }
    int64_t sid = 0;
    for (const auto& [name, members] : m.node_sets) {
      if (members.empty()) continue;
      ++sid;
      w.comment(cat("SET1 ", sid, " = ", name));
      f = {w.integer(sid)};
      for (int64_t k : members) f.push_back(w.integer(m.node_ids[k]));
      w.card("SET1", f);
    }
    if (aset && !aset->empty()) {
      f = {"123"};
      for (int64_t k : *aset) f.push_back(w.integer(m.node_ids[k]));
      w.card("ASET1", f);
    }
    if (!m.point_mass.empty()) {
      int64_t eid = 0;
      for (int64_t id : m.elem_ids) eid = std::max(eid, id);
      for (int64_t k = 0; k < nn; ++k)
        if (m.point_mass[k] != 0.0)
          w.card("CONM2", {w.integer(++eid), w.integer(m.node_ids[k]), "0", w.real(m.point_mass[k])});
    }
    os << "ENDDATA\n";
    os.flush();
    if (!os) {
      os.close();
      std::remove(tmp.c_str());
      throw Error(cat("write_nastran: error while writing '", path, "' (its temporary '", tmp, "')"));
    }
  }
  files::commit(tmp, path);
}

}  // namespace morse::mesh

namespace morse::mesh {

PetscErrorCode NastranWriteOptions::set_from_options(MPI_Comm comm) {
  char fmt[32] = "", aset_buf[256] = "", spc_buf[256] = "";
  PetscCall(PetscStrncpy(fmt,
                         format == Format::Large   ? "large"
                         : format == Format::Small ? "small"
                                                   : "free",
                         sizeof fmt));
  PetscCall(PetscStrncpy(aset_buf, aset.c_str(), sizeof aset_buf));
  PetscCall(PetscStrncpy(spc_buf, spc.c_str(), sizeof spc_buf));
  auto& mat = material;
  PetscBool e_set = PETSC_FALSE, rho_set = PETSC_FALSE;
  PetscOptionsBegin(comm, nullptr, "morse mesh: Nastran output (-out FILE.bdf)", "");
  PetscCall(MorseOptionsReal("-material_E", "Young's modulus written to MAT1", "", mat.E, &mat.E, &e_set));
  PetscCall(MorseOptionsReal("-material_nu", "Poisson's ratio written to MAT1", "", mat.nu, &mat.nu, nullptr));
  PetscCall(MorseOptionsReal("-material_rho", "Density written to MAT1", "", mat.rho, &mat.rho, &rho_set));
  PetscCall(MorseOptionsString("-nastran_format", "Field format: large (16 characters), small (8) or free", "", fmt,
                               fmt, sizeof fmt, nullptr));
  PetscCall(MorseOptionsString("-nastran_aset", "Node set written as ASET1 (the Craig-Bampton boundary)", "", aset_buf,
                               aset_buf, sizeof aset_buf, nullptr));
  PetscCall(MorseOptionsString("-nastran_spc",
                               "Node set whose translations are fixed by SPC1 123 (read back by -clamp '*BOUNDARY')",
                               "", spc_buf, spc_buf, sizeof spc_buf, nullptr));
  PetscOptionsEnd();
  const std::string f = fmt;
  if (f == "large" || f == "small" || f == "free")
    format = f == "large" ? Format::Large : f == "small" ? Format::Small : Format::Free;
  else if (error.empty())
    error = cat("-nastran_format ", f, ": expected large, small or free");
  if (error.empty() && e_set) error = options::magnitude_error("-material_E", mat.E);
  if (error.empty() && rho_set) error = options::magnitude_error("-material_rho", mat.rho);
  aset = aset_buf;
  spc = spc_buf;
  return PETSC_SUCCESS;
}

}  // namespace morse::mesh
