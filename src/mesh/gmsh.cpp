#include "morse/mesh/gmsh.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <set>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"

namespace morse::mesh {

namespace {

using Key = std::pair<int, std::int64_t>;  // (dimension, tag) of an entity or physical group

// ------------------------------------------------------------------------------------------------
// Gmsh element types

constexpr int kNone = -1;

struct GmshType {
  int dim;  // -1: unknown type
  int n_nodes;
  const char* name;
  int morse;  // static_cast<int>(ElementType) or kNone
};

// Indexed by the gmsh type number (GmshDefines.h).
constexpr GmshType kGmshTypes[] = {
    {-1, 0, nullptr, kNone},                                               // 0
    {1, 2, "2-node line", kNone},                                          // 1
    {2, 3, "3-node triangle", kNone},                                      // 2
    {2, 4, "4-node quadrangle", kNone},                                    // 3
    {3, 4, "4-node tetrahedron", static_cast<int>(ElementType::Tet4)},     // 4
    {3, 8, "8-node hexahedron", static_cast<int>(ElementType::Hex8)},      // 5
    {3, 6, "6-node prism", static_cast<int>(ElementType::Wedge6)},         // 6
    {3, 5, "5-node pyramid", kNone},                                       // 7
    {1, 3, "3-node line", kNone},                                          // 8
    {2, 6, "6-node triangle", kNone},                                      // 9
    {2, 9, "9-node quadrangle", kNone},                                    // 10
    {3, 10, "10-node tetrahedron", static_cast<int>(ElementType::Tet10)},  // 11
    {3, 27, "27-node hexahedron", kNone},                                  // 12
    {3, 18, "18-node prism", kNone},                                       // 13
    {3, 14, "14-node pyramid", kNone},                                     // 14
    {0, 1, "point", kNone},                                                // 15
    {2, 8, "8-node quadrangle", kNone},                                    // 16
    {3, 20, "20-node hexahedron", static_cast<int>(ElementType::Hex20)},   // 17
    {3, 15, "15-node prism", static_cast<int>(ElementType::Wedge15)},      // 18
    {3, 13, "13-node pyramid", kNone},                                     // 19
    {2, 9, "9-node triangle", kNone},                                      // 20
    {2, 10, "10-node triangle", kNone},                                    // 21
    {2, 12, "12-node triangle", kNone},                                    // 22
    {2, 15, "15-node triangle", kNone},                                    // 23
    {2, 15, "15-node incomplete triangle", kNone},                         // 24
    {2, 21, "21-node triangle", kNone},                                    // 25
    {1, 4, "4-node line", kNone},                                          // 26
    {1, 5, "5-node line", kNone},                                          // 27
    {1, 6, "6-node line", kNone},                                          // 28
    {3, 20, "20-node tetrahedron", kNone},                                 // 29
    {3, 35, "35-node tetrahedron", kNone},                                 // 30
    {3, 56, "56-node tetrahedron", kNone},                                 // 31
    {3, 0, "high-order tetrahedron", kNone},                               // 32
    {3, 0, "high-order tetrahedron", kNone},                               // 33
    {-1, 0, nullptr, kNone},                                               // 34 polygon
    {-1, 0, nullptr, kNone},                                               // 35 polyhedron
    {2, 16, "16-node quadrangle", kNone},                                  // 36
    {2, 25, "25-node quadrangle", kNone},                                  // 37
    {2, 36, "36-node quadrangle", kNone},                                  // 38
    {2, 12, "12-node quadrangle", kNone},                                  // 39
    {2, 16, "16-node incomplete quadrangle", kNone},                       // 40
    {2, 20, "20-node incomplete quadrangle", kNone},                       // 41
};
constexpr int kNumGmshTypes = static_cast<int>(sizeof(kGmshTypes) / sizeof(kGmshTypes[0]));

constexpr int kGmshPoint = 15;

/// Gmsh type number of a morse element type.
int gmsh_type(ElementType t) {
  switch (t) {
    case ElementType::Tet4:
      return 4;
    case ElementType::Tet10:
      return 11;
    case ElementType::Wedge6:
      return 6;
    case ElementType::Wedge15:
      return 18;
    case ElementType::Hex8:
      return 5;
    case ElementType::Hex20:
      return 17;
  }
  return 0;
}

// ------------------------------------------------------------------------------------------------
// Tag -> index map: a dense vector for the usual compact tag ranges, a hash map for the rest.

class TagMap {
 public:
  /// expected: number of tags announced by the file (sizes the dense range).
  void init(std::int64_t expected) {
    dense_limit_ = 4 * std::max<std::int64_t>(expected, 0) + (1 << 20);
    dense_.clear();
    sparse_.clear();
  }
  /// Maps tag to index; returns false (and changes nothing) if tag is already mapped.
  bool insert(std::int64_t tag, std::int64_t index) {
    if (tag >= 0 && tag < dense_limit_) {
      const auto t = static_cast<std::size_t>(tag);
      if (t >= dense_.size()) dense_.resize(std::max(t + 1, 2 * dense_.size()), -1);
      if (dense_[t] >= 0) return false;
      dense_[t] = index;
      return true;
    }
    return sparse_.emplace(tag, index).second;
  }
  /// Index of tag, or -1.
  std::int64_t find(std::int64_t tag) const {
    if (tag >= 0 && tag < dense_limit_) {
      const auto t = static_cast<std::size_t>(tag);
      return t < dense_.size() ? dense_[t] : -1;
    }
    auto it = sparse_.find(tag);
    return it == sparse_.end() ? -1 : it->second;
  }

 private:
  std::int64_t dense_limit_ = 1 << 20;
  std::vector<std::int64_t> dense_;
  std::unordered_map<std::int64_t, std::int64_t> sparse_;
};

// ------------------------------------------------------------------------------------------------
// Reader

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }

class Reader {
 public:
  Reader(const std::string& path, const std::string& text)
      : path_(path), begin_(text.data()), p_(begin_), end_(begin_ + text.size()) {}

  Mesh read();

 private:
  // --- tokenizer
  [[noreturn]] void fail(const std::string& msg) const { fail_at(line_, msg); }
  [[noreturn]] void fail_at(std::int64_t line, const std::string& msg) const {
    throw Error(cat(path_, ":", line, ": ", msg));
  }
  /// Line of the last non-blank character (for errors met at the end of the file).
  std::int64_t last_line() const {
    std::int64_t line = line_;
    for (const char* q = end_; q > begin_ && is_space(q[-1]); --q)
      if (q[-1] == '\n') --line;
    return std::max<std::int64_t>(line, 1);
  }
  [[noreturn]] void fail_eof(const std::string& msg) const { fail_at(last_line(), msg); }
  void skip_ws() {
    while (p_ < end_) {
      const char c = *p_;
      if (c == '\n') {
        ++line_;
      } else if (!is_space(c)) {
        break;
      }
      ++p_;
    }
  }
  /// The whitespace-delimited token at p_ (not consumed), shortened for messages.
  std::string peek_token() const {
    const char* q = p_;
    while (q < end_ && !is_space(*q) && q - p_ < 40) ++q;
    return std::string(p_, q);
  }
  /// Throws for end of file or a '$' line met while data of `what` was expected.
  [[noreturn]] void premature(const char* what) const {
    if (p_ >= end_)
      fail_eof(cat("unexpected end of file in section $", section_, " (started at line ", section_line_,
                   ") while reading ", what, ": truncated file?"));
    fail(cat("unexpected '", peek_token(), "' in section $", section_, " (started at line ", section_line_,
             ") while reading ", what, ": the section is shorter than its counts say (truncated file?)"));
  }
  std::int64_t read_int(const char* what) {
    skip_ws();
    if (p_ >= end_ || *p_ == '$') premature(what);
    const char* q = p_;
    bool neg = false;
    if (*q == '-' || *q == '+') neg = *q++ == '-';
    const char* d0 = q;
    std::int64_t v = 0;
    while (q < end_ && is_digit(*q) && q - d0 < 18) v = 10 * v + (*q++ - '0');
    if (q == d0) fail(cat("expected ", what, " (an integer), found '", peek_token(), "'"));
    if (q < end_ && is_digit(*q)) {  // long number: let strtoll check the range
      char* e = nullptr;
      errno = 0;
      const long long w = std::strtoll(p_, &e, 10);
      if (errno == ERANGE) fail(cat(what, " '", peek_token(), "' is out of range"));
      v = w;
      q = e;
      neg = false;
    }
    if (q < end_ && !is_space(*q)) fail(cat("expected ", what, " (an integer), found '", peek_token(), "'"));
    p_ = q;
    return neg ? -v : v;
  }
  /// Reads a non-negative count.
  std::int64_t read_count(const char* what) {
    const std::int64_t n = read_int(what);
    if (n < 0) fail(cat("expected ", what, " (a count >= 0), found ", n));
    return n;
  }
  /// Reads a count of entries (nodes, elements, ...) of at least `numbers` numbers each, which the
  /// rest of the file must have room for (an ASCII number and its separator take 2 bytes at
  /// least): a header cannot promise more than the file holds, nor make the reader allocate it.
  /// Small counts are left to the parsing, which names the line where a truncated file ends.
  std::int64_t read_entries(const char* what, int numbers, const char* entries) {
    const std::int64_t n = read_count(what);
    const std::int64_t left = end_ - p_, most = left / (2 * numbers);
    if (n > most && n > (1 << 16))
      fail(cat(what, " is ", n, ", but the ", left, " bytes left in the file hold at most ", most, " ", entries, " (",
               2 * numbers, " bytes each at least): corrupt header or truncated file?"));
    return n;
  }
  double read_double(const char* what) {
    skip_ws();
    if (p_ >= end_ || *p_ == '$') premature(what);
    // from_chars: locale-independent and exact; it takes no leading '+'.
    const char* q = *p_ == '+' && p_ + 1 < end_ && *(p_ + 1) != '-' ? p_ + 1 : p_;
    double v = 0;
    const auto [e, ec] = std::from_chars(q, end_, v);
    if (ec == std::errc::invalid_argument || (e < end_ && !is_space(*e)))
      fail(cat("expected ", what, " (a number), found '", peek_token(), "'"));
    if (ec != std::errc() || !std::isfinite(v)) fail(cat(what, " '", peek_token(), "' is out of range or not finite"));
    p_ = e;
    return v;
  }
  std::string read_token(const char* what) {
    skip_ws();
    if (p_ >= end_) premature(what);
    const char* q = p_;
    while (q < end_ && !is_space(*q)) ++q;
    std::string t(p_, q);
    p_ = q;
    return t;
  }
  /// A physical name: "quoted, may contain blanks" or a bare token.
  std::string read_name() {
    skip_ws();
    if (p_ >= end_ || *p_ == '$') premature("a physical name");
    if (*p_ != '"') return read_token("a physical name");
    const char* q = p_ + 1;
    while (q < end_ && *q != '"' && *q != '\n') ++q;
    if (q >= end_ || *q != '"') fail("unterminated quoted physical name");
    std::string name(p_ + 1, q);
    p_ = q + 1;
    return name;
  }
  void expect_end(const std::string& name) {
    skip_ws();
    if (p_ >= end_)
      fail_eof(cat("unexpected end of file: missing $End", name, " for section $", name, " started at line ",
                   section_line_, " (truncated file?)"));
    const std::string tok = peek_token();
    if (tok != "$End" + name)
      fail(cat("expected $End", name, " (section $", name, " started at line ", section_line_, "), found '", tok,
               "': the section holds more data than its counts say"));
    p_ += tok.size();
  }
  /// Skips an unknown section up to its $End line.
  void skip_section(const std::string& name) {
    const std::string end_tag = "$End" + name;
    while (p_ < end_) {
      skip_ws();
      const char* ls = p_;
      while (p_ < end_ && *p_ != '\n') ++p_;
      const std::size_t len = static_cast<std::size_t>(p_ - ls);
      if (len >= end_tag.size() && std::memcmp(ls, end_tag.data(), end_tag.size()) == 0 &&
          (len == end_tag.size() || is_space(ls[end_tag.size()])))
        return;
    }
    fail_eof(cat("unexpected end of file: missing ", end_tag, " for section $", name, " started at line ",
                 section_line_, " (truncated file?)"));
  }

  // --- sections
  void read_format();
  void read_physical_names();
  void read_entities();
  void read_nodes4();
  void read_elements4();
  void read_nodes2();
  void read_elements2();
  void read_morse_materials();
  void read_morse_sets();

  // --- helpers
  void begin_nodes(std::int64_t count);
  void add_node(std::int64_t tag, double x, double y, double z);
  const GmshType& element_type(std::int64_t type, int block_dim);
  /// Reads n node tags into nodes_ as indices.
  void read_element_nodes(int n);
  /// Stores one element (nodes in nodes_) with its physical groups.
  void add_element(std::int64_t tag, const GmshType& t, const std::int64_t* phys, std::size_t nphys,
                   std::int64_t elem_line);
  void build_sets();
  /// True if element e has type t and the nodes in nodes_.
  bool same_element(std::int64_t e, ElementType t) const {
    return mesh_.elem_types[e] == t &&
           std::equal(nodes_.begin(), nodes_.end(), mesh_.elem_nodes.data() + mesh_.elem_offsets[e]);
  }

  const std::string& path_;
  const char* begin_;
  const char* p_;
  const char* end_;
  std::int64_t line_ = 1;
  std::string section_;
  std::int64_t section_line_ = 0;

  Mesh mesh_;
  int major_ = 0;  // 2 or 4
  bool have_nodes_ = false;
  bool have_elements_ = false;
  bool have_entities_ = false;
  bool morse_sets_ = false;  // file written by write_gmsh(): 3D groups are element sets only
  TagMap node_map_;
  TagMap elem_map_;                                                 // solid elements only
  std::unordered_multimap<std::uint64_t, std::int64_t> elem_hash_;  // connectivity -> element
  std::vector<std::int64_t> nodes_;                                 // scratch: node indices of the current element

  std::map<Key, std::string> names_;                               // physical names
  std::set<Key> declared_;                                         // every physical group met
  std::map<Key, std::vector<std::int64_t>> entity_phys_;           // 4.1: entity -> physical tags
  std::map<Key, std::vector<std::int64_t>> group_nodes_;           // dim < 3 groups: node indices
  std::map<std::int64_t, std::vector<std::int64_t>> group_elems_;  // 3D groups: element indices
};

void Reader::read_format() {
  const std::string version = read_token("the format version");
  if (version.rfind("4.1", 0) == 0 && (version.size() == 3 || version.find_first_not_of('0', 3) == std::string::npos)) {
    major_ = 4;
  } else if (version.size() >= 2 && version[0] == '2' && version[1] == '.') {
    major_ = 2;
  } else {
    fail(cat("unsupported MSH format version ", version, " (supported: 4.1 and 2.2; re-save the mesh in one of them)"));
  }
  const std::int64_t file_type = read_int("the file type");
  if (file_type == 1) fail("binary .msh not supported, re-save as ASCII");
  if (file_type != 0) fail(cat("invalid file type ", file_type, " (0 = ASCII expected)"));
  read_int("the data size");
  expect_end("MeshFormat");
}

void Reader::read_physical_names() {
  const std::int64_t n = read_entries("the number of physical names", 3, "names");
  for (std::int64_t i = 0; i < n; ++i) {
    const std::int64_t dim = read_int("a physical group dimension");
    if (dim < 0 || dim > 3) fail(cat("invalid physical group dimension ", dim));
    const std::int64_t tag = read_int("a physical tag");
    const Key key{static_cast<int>(dim), tag};
    names_[key] = read_name();
    declared_.insert(key);
  }
  expect_end("PhysicalNames");
}

void Reader::read_entities() {
  if (major_ != 4) fail("$Entities section in a MSH 2 file");
  if (have_elements_) fail("$Entities after $Elements is not supported");
  have_entities_ = true;
  std::int64_t counts[4];
  for (auto& c : counts) c = read_entries("an entity count", 5, "entities");
  for (int dim = 0; dim < 4; ++dim) {
    for (std::int64_t i = 0; i < counts[dim]; ++i) {
      const std::int64_t tag = read_int("an entity tag");
      for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) read_double("an entity bounding box");
      const std::int64_t nphys = read_entries("the number of physical tags", 1, "tags");
      std::vector<std::int64_t>& phys = entity_phys_[Key{dim, tag}];
      for (std::int64_t k = 0; k < nphys; ++k) {
        phys.push_back(read_int("a physical tag"));
        declared_.insert(Key{dim, phys.back()});
      }
      if (dim > 0) {
        const std::int64_t nb = read_entries("the number of bounding entities", 1, "tags");
        for (std::int64_t k = 0; k < nb; ++k) read_int("a bounding entity tag");
      }
    }
  }
  expect_end("Entities");
}

void Reader::begin_nodes(std::int64_t count) {
  if (have_nodes_) fail("second $Nodes section");
  have_nodes_ = true;
  node_map_.init(count);
  mesh_.node_ids.reserve(static_cast<std::size_t>(std::min<std::int64_t>(count, 1 << 26)));
  mesh_.coords.reserve(3 * mesh_.node_ids.capacity());
}

void Reader::add_node(std::int64_t tag, double x, double y, double z) {
  if (tag <= 0) fail(cat("invalid node tag ", tag, " (must be >= 1)"));
  if (!node_map_.insert(tag, mesh_.num_nodes())) fail(cat("node tag ", tag, " defined twice"));
  mesh_.add_node(tag, x, y, z);
}

void Reader::read_nodes4() {
  const std::int64_t nblocks = read_entries("the number of node blocks", 4, "blocks");
  const std::int64_t nnodes = read_entries("the number of nodes", 4, "nodes");
  read_int("the minimum node tag");
  read_int("the maximum node tag");
  begin_nodes(nnodes);
  for (std::int64_t b = 0; b < nblocks; ++b) {
    const std::int64_t dim = read_int("a node block entity dimension");
    if (dim < 0 || dim > 3) fail(cat("invalid entity dimension ", dim));
    read_int("a node block entity tag");
    const std::int64_t parametric = read_int("the parametric flag");
    if (parametric != 0 && parametric != 1) fail(cat("invalid parametric flag ", parametric));
    const std::int64_t n = read_entries("the number of nodes in the block", 4, "nodes");
    const std::int64_t first = mesh_.num_nodes();
    // Tags first, then coordinates: record the tags, insert once coordinates are known.
    std::vector<std::int64_t> tags(static_cast<std::size_t>(n));
    for (std::int64_t k = 0; k < n; ++k) {
      const std::int64_t tag = read_int("a node tag");
      if (tag <= 0) fail(cat("invalid node tag ", tag, " (must be >= 1)"));
      if (!node_map_.insert(tag, first + k)) fail(cat("node tag ", tag, " defined twice"));
      tags[static_cast<std::size_t>(k)] = tag;
    }
    const int extra = parametric ? static_cast<int>(dim) : 0;
    for (std::int64_t k = 0; k < n; ++k) {
      const double x = read_double("a node coordinate");
      const double y = read_double("a node coordinate");
      const double z = read_double("a node coordinate");
      for (int j = 0; j < extra; ++j) read_double("a parametric node coordinate");
      mesh_.add_node(tags[static_cast<std::size_t>(k)], x, y, z);
    }
  }
  if (mesh_.num_nodes() != nnodes)
    fail(cat("$Nodes announces ", nnodes, " nodes but its blocks hold ", mesh_.num_nodes()));
  expect_end("Nodes");
}

void Reader::read_nodes2() {
  const std::int64_t n = read_entries("the number of nodes", 4, "nodes");
  begin_nodes(n);
  for (std::int64_t k = 0; k < n; ++k) {
    const std::int64_t tag = read_int("a node tag");
    const double x = read_double("a node coordinate");
    const double y = read_double("a node coordinate");
    const double z = read_double("a node coordinate");
    add_node(tag, x, y, z);
  }
  expect_end("Nodes");
}

const GmshType& Reader::element_type(std::int64_t type, int block_dim) {
  if (type <= 0 || type >= kNumGmshTypes || kGmshTypes[type].dim < 0)
    fail(cat("unknown or unsupported gmsh element type ", type));
  const GmshType& t = kGmshTypes[type];
  if (t.dim == 3 && t.morse == kNone)
    fail(cat("unsupported gmsh element type ", type, " (", t.name,
             "); supported 3D types: 4 (tet4), 11 (tet10), 6 (wedge6), 18 (wedge15), "
             "5 (hex8), 17 (hex20)"));
  if (block_dim >= 0 && block_dim != t.dim)
    fail(cat("gmsh element type ", type, " (", t.name, ", dimension ", t.dim, ") in a block of entity dimension ",
             block_dim));
  return t;
}

void Reader::read_element_nodes(int n) {
  nodes_.resize(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const std::int64_t tag = read_int("an element node tag");
    const std::int64_t idx = node_map_.find(tag);
    if (idx < 0) fail(cat("element references node ", tag, ", which is not defined in $Nodes"));
    nodes_[static_cast<std::size_t>(k)] = idx;
  }
}

void Reader::add_element(std::int64_t tag, const GmshType& t, const std::int64_t* phys, std::size_t nphys,
                         std::int64_t elem_line) {
  if (t.dim < 3) {
    for (std::size_t k = 0; k < nphys; ++k) {
      auto& v = group_nodes_[Key{t.dim, phys[k]}];
      v.insert(v.end(), nodes_.begin(), nodes_.end());
    }
    return;
  }
  if (tag <= 0) {
    line_ = elem_line;
    fail(cat("invalid element tag ", tag, " (must be >= 1)"));
  }
  const auto type = static_cast<ElementType>(t.morse);
  std::int64_t e = elem_map_.find(tag);
  if (e >= 0) {
    // A tag may repeat only for the very same element.
    if (!same_element(e, type)) {
      line_ = elem_line;
      fail(cat("element tag ", tag, " defined twice with different nodes"));
    }
  } else {
    // MSH 2 writes an element once per physical group it belongs to, under a new tag: merge
    // repeated connectivity into the first element.
    std::uint64_t h = 1469598103934665603ull ^ static_cast<std::uint64_t>(t.morse);
    for (std::int64_t v : nodes_) h = (h ^ static_cast<std::uint64_t>(v)) * 1099511628211ull;
    auto range = elem_hash_.equal_range(h);
    for (auto it = range.first; it != range.second && e < 0; ++it)
      if (same_element(it->second, type)) e = it->second;
    if (e < 0) {
      e = mesh_.add_element(tag, type, nodes_.data());
      elem_hash_.emplace(h, e);
    }
    elem_map_.insert(tag, e);
  }
  for (std::size_t k = 0; k < nphys; ++k) group_elems_[phys[k]].push_back(e);
}

void Reader::read_elements4() {
  if (!have_nodes_) fail("$Elements before $Nodes");
  if (have_elements_) fail("second $Elements section");
  have_elements_ = true;
  const std::int64_t nblocks = read_entries("the number of element blocks", 4, "blocks");
  const std::int64_t nelems = read_entries("the number of elements", 2, "elements");
  read_int("the minimum element tag");
  read_int("the maximum element tag");
  elem_map_.init(nelems);
  elem_hash_.reserve(static_cast<std::size_t>(std::min<std::int64_t>(nelems, 1 << 26)));
  std::int64_t total = 0;
  static const std::vector<std::int64_t> kNoPhys;
  for (std::int64_t b = 0; b < nblocks; ++b) {
    const std::int64_t dim = read_int("an element block entity dimension");
    if (dim < 0 || dim > 3) fail(cat("invalid entity dimension ", dim));
    const std::int64_t entity = read_int("an element block entity tag");
    const std::int64_t type_num = read_int("an element type");
    const GmshType& t = element_type(type_num, static_cast<int>(dim));
    const std::int64_t n = read_entries("the number of elements in the block", 1 + t.n_nodes, "elements");
    auto it = entity_phys_.find(Key{static_cast<int>(dim), entity});
    const std::vector<std::int64_t>& phys = it == entity_phys_.end() ? kNoPhys : it->second;
    if (t.dim < 3 && phys.empty()) {
      // Not part of any physical group: check and drop.
      for (std::int64_t k = 0; k < n; ++k) {
        read_int("an element tag");
        read_element_nodes(t.n_nodes);
      }
    } else {
      for (std::int64_t k = 0; k < n; ++k) {
        const std::int64_t tag = read_int("an element tag");
        const std::int64_t elem_line = line_;
        read_element_nodes(t.n_nodes);
        add_element(tag, t, phys.data(), phys.size(), elem_line);
      }
    }
    total += n;
  }
  if (total != nelems) fail(cat("$Elements announces ", nelems, " elements but its blocks hold ", total));
  expect_end("Elements");
}

void Reader::read_elements2() {
  if (!have_nodes_) fail("$Elements before $Nodes");
  if (have_elements_) fail("second $Elements section");
  have_elements_ = true;
  const std::int64_t n = read_entries("the number of elements", 4, "elements");
  elem_map_.init(n);
  elem_hash_.reserve(static_cast<std::size_t>(std::min<std::int64_t>(n, 1 << 26)));
  for (std::int64_t k = 0; k < n; ++k) {
    const std::int64_t tag = read_int("an element tag");
    const std::int64_t elem_line = line_;
    const GmshType& t = element_type(read_int("an element type"), -1);
    const std::int64_t ntags = read_entries("the number of element tags", 1, "tags");
    std::int64_t phys = 0;
    for (std::int64_t j = 0; j < ntags; ++j) {
      const std::int64_t v = read_int("an element tag value");
      if (j == 0) phys = v;
    }
    read_element_nodes(t.n_nodes);
    if (phys != 0) declared_.insert(Key{t.dim, phys});
    add_element(tag, t, &phys, phys != 0 ? 1 : 0, elem_line);
  }
  expect_end("Elements");
}

void Reader::read_morse_sets() {
  const std::int64_t version = read_int("the $MorseSets version");
  if (version != 1) fail(cat("unsupported $MorseSets version ", version));
  morse_sets_ = true;
  expect_end("MorseSets");
}

// Materials of a file written by write_gmsh(): the material table and one index per element
// (-1 = none), in element order. Gmsh ignores the section.
void Reader::read_morse_materials() {
  const std::int64_t version = read_int("the $MorseMaterials version");
  if (version != 1) fail(cat("unsupported $MorseMaterials version ", version));
  if (!have_elements_) fail("$MorseMaterials before $Elements");
  const std::int64_t nm = read_entries("the number of materials", 4, "materials");
  for (std::int64_t i = 0; i < nm; ++i) {
    Material mat;
    mat.name = read_name();
    mat.E = read_double("Young's modulus");
    mat.nu = read_double("Poisson's ratio");
    mat.rho = read_double("density");
    mesh_.materials.push_back(mat);
  }
  const std::int64_t ne = read_count("the number of elements");
  if (ne != mesh_.num_elements())
    fail(cat("$MorseMaterials lists ", ne, " elements but the mesh has ", mesh_.num_elements()));
  for (std::int64_t e = 0; e < ne; ++e) {
    const std::int64_t m = read_int("a material index");
    if (m < -1 || m >= nm) fail(cat("material index ", m, " out of range [-1, ", nm, ")"));
    mesh_.elem_material[e] = static_cast<int>(m);
  }
  expect_end("MorseMaterials");
}

void Reader::build_sets() {
  for (const auto& [dim, tag] : declared_) {
    auto nit = names_.find(Key{dim, tag});
    const std::string name = nit != names_.end() ? nit->second : cat("physical_", dim, "_", tag);
    if (dim < 3) {
      auto& set = mesh_.node_sets[name];
      auto git = group_nodes_.find(Key{dim, tag});
      if (git != group_nodes_.end()) set.insert(set.end(), git->second.begin(), git->second.end());
      continue;
    }
    auto& eset = mesh_.elem_sets[name];
    auto git = group_elems_.find(tag);
    if (git != group_elems_.end()) eset.insert(eset.end(), git->second.begin(), git->second.end());
    if (morse_sets_) continue;
    auto& nset = mesh_.node_sets[name];
    if (git == group_elems_.end()) continue;
    // Nodes of the group's elements, each once.
    std::vector<char> mark(static_cast<std::size_t>(mesh_.num_nodes()), 0);
    for (std::int64_t e : git->second)
      for (std::int64_t j = mesh_.elem_offsets[e]; j < mesh_.elem_offsets[e + 1]; ++j) {
        const std::int64_t v = mesh_.elem_nodes[j];
        if (!mark[v]) {
          mark[v] = 1;
          nset.push_back(v);
        }
      }
  }
  mesh_.normalize_sets();
}

Mesh Reader::read() {
  mesh_.source = path_;
  bool have_format = false;
  for (;;) {
    skip_ws();
    if (p_ >= end_) break;
    if (*p_ != '$') fail(cat("expected a section header ($Name), found '", peek_token(), "'"));
    section_line_ = line_;
    section_ = read_token("a section header").substr(1);
    if (!have_format && section_ != "MeshFormat")
      fail(cat("expected $MeshFormat first, found $", section_, " (not a .msh file?)"));
    if (section_ == "MeshFormat") {
      if (have_format) fail("second $MeshFormat section");
      have_format = true;
      read_format();
    } else if (section_ == "PhysicalNames") {
      read_physical_names();
    } else if (section_ == "Entities") {
      read_entities();
    } else if (section_ == "PartitionedEntities") {
      fail("partitioned .msh files are not supported; re-save the mesh without partitions");
    } else if (section_ == "Nodes") {
      major_ == 4 ? read_nodes4() : read_nodes2();
    } else if (section_ == "Elements") {
      major_ == 4 ? read_elements4() : read_elements2();
    } else if (section_ == "MorseSets") {
      read_morse_sets();
    } else if (section_ == "MorseMaterials") {
      read_morse_materials();
    } else if (section_.rfind("End", 0) == 0) {
      fail(cat("unexpected $", section_, " outside of its section"));
    } else {
      skip_section(section_);
    }
  }
  section_ = "(none)";
  if (!have_format) fail_eof("empty file, not a .msh file");
  if (!have_nodes_) fail_eof("no $Nodes section (truncated file?)");
  if (!have_elements_) fail_eof("no $Elements section (truncated file?)");
  if (mesh_.num_elements() == 0)
    fail_eof(
        "the mesh contains no supported 3D element (tet4, tet10, wedge6, wedge15, hex8, hex20); "
        "was it meshed in 3D?");
  build_sets();
  return std::move(mesh_);
}

// ------------------------------------------------------------------------------------------------
// Writer

class Out {
 public:
  void str(const char* s) { buf_ += s; }
  void str(const std::string& s) { buf_ += s; }
  void chr(char c) { buf_ += c; }
  void num(std::int64_t v) {
    char tmp[24];
    auto r = std::to_chars(tmp, tmp + sizeof(tmp), v);
    buf_.append(tmp, r.ptr);
  }
  void dbl(double v) {  // as %.17g, but locale-independent
    char tmp[40];
    auto r = std::to_chars(tmp, tmp + sizeof(tmp), v, std::chars_format::general, 17);
    buf_.append(tmp, r.ptr);
  }
  const std::string& data() const { return buf_; }
  void reserve(std::size_t n) { buf_.reserve(n); }

 private:
  std::string buf_;
};

void check_set_name(const std::string& name) {
  MORSE_CHECK(!name.empty(), "write_gmsh: empty set name");
  MORSE_CHECK(name.find_first_of("\"\n\r") == std::string::npos, "write_gmsh: set name '", name,
              "' contains a double quote or a line break");
}

}  // namespace

Mesh read_gmsh(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw Error(cat(path, ": cannot open gmsh file: ", std::strerror(errno)));
  std::string text;
  char chunk[1 << 16];
  std::size_t got = 0;
  if (std::fseek(f, 0, SEEK_END) == 0) {
    const long size = std::ftell(f);
    if (size > 0) text.reserve(static_cast<std::size_t>(size));
    std::rewind(f);
  }
  while ((got = std::fread(chunk, 1, sizeof(chunk), f)) > 0) text.append(chunk, got);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) throw Error(cat(path, ": error reading gmsh file: ", std::strerror(errno)));
  Reader reader(path, text);
  return reader.read();
}

void write_gmsh(const Mesh& m, const std::string& path) {
  const std::int64_t nn = m.num_nodes();
  const std::int64_t ne = m.num_elements();
  MORSE_CHECK(static_cast<std::int64_t>(m.coords.size()) == 3 * nn &&
                  static_cast<std::int64_t>(m.elem_offsets.size()) == ne + 1 &&
                  static_cast<std::int64_t>(m.elem_ids.size()) == ne,
              "write_gmsh(", path, "): inconsistent mesh arrays");
  std::int64_t min_node = nn ? m.node_ids[0] : 0, max_node = min_node;
  for (std::int64_t id : m.node_ids) {
    MORSE_CHECK(id >= 1, "write_gmsh(", path, "): node id ", id, " is not positive");
    min_node = std::min(min_node, id);
    max_node = std::max(max_node, id);
  }
  std::int64_t max_elem = 0;
  for (std::int64_t id : m.elem_ids) {
    MORSE_CHECK(id >= 1, "write_gmsh(", path, "): element id ", id, " is not positive");
    max_elem = std::max(max_elem, id);
  }
  for (std::int64_t v : m.elem_nodes)
    MORSE_CHECK(v >= 0 && v < nn, "write_gmsh(", path, "): element node index ", v, " out of range");
  for (const auto& [name, set] : m.node_sets) {
    check_set_name(name);
    for (std::int64_t v : set)
      MORSE_CHECK(v >= 0 && v < nn, "write_gmsh(", path, "): node set '", name, "' index ", v, " out of range");
  }
  for (const auto& [name, set] : m.elem_sets) {
    check_set_name(name);
    for (std::int64_t e : set)
      MORSE_CHECK(e >= 0 && e < ne, "write_gmsh(", path, "): element set '", name, "' index ", e, " out of range");
  }

  // Volume entities: one per distinct combination of element sets an element belongs to.
  std::vector<std::vector<int>> member(static_cast<std::size_t>(ne));
  {
    int s = 0;
    for (const auto& [name, set] : m.elem_sets) {
      (void)name;
      for (std::int64_t e : set) {
        auto& v = member[static_cast<std::size_t>(e)];
        if (v.empty() || v.back() != s) v.push_back(s);  // sets may hold duplicates
      }
      ++s;
    }
  }
  std::map<std::vector<int>, int> entity_of;
  std::vector<const std::vector<int>*> entity_sets;  // volume entity tag - 1 -> physical tags - 1
  std::vector<int> elem_entity(static_cast<std::size_t>(ne));
  for (std::int64_t e = 0; e < ne; ++e) {
    auto [it, added] = entity_of.emplace(member[e], static_cast<int>(entity_sets.size()) + 1);
    if (added) entity_sets.push_back(&it->first);
    elem_entity[e] = it->second;
  }
  if (entity_sets.empty()) {
    auto it = entity_of.emplace(std::vector<int>{}, 1).first;
    entity_sets.push_back(&it->first);
  }

  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (std::int64_t k = 0; k < nn; ++k)
    for (int d = 0; d < 3; ++d) {
      const double x = m.coords[3 * k + d];
      if (k == 0 || x < lo[d]) lo[d] = x;
      if (k == 0 || x > hi[d]) hi[d] = x;
    }

  Out out;
  out.reserve(static_cast<std::size_t>(80 * nn + 12 * m.elem_nodes.size() + 4096));
  out.str("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
  out.str("$MorseSets\n1\n$EndMorseSets\n");

  // Physical groups: node set i -> (0, i), element set j -> (3, j), tags from 1.
  out.str("$PhysicalNames\n");
  out.num(static_cast<std::int64_t>(m.node_sets.size() + m.elem_sets.size()));
  out.chr('\n');
  int tag = 0;
  for (const auto& [name, set] : m.node_sets) {
    (void)set;
    out.str("0 ");
    out.num(++tag);
    out.str(" \"");
    out.str(name);
    out.str("\"\n");
  }
  tag = 0;
  for (const auto& [name, set] : m.elem_sets) {
    (void)set;
    out.str("3 ");
    out.num(++tag);
    out.str(" \"");
    out.str(name);
    out.str("\"\n");
  }
  out.str("$EndPhysicalNames\n");

  // Entities: point entity i carries node set i; volume entities carry element set combinations.
  out.str("$Entities\n");
  out.num(static_cast<std::int64_t>(m.node_sets.size()));
  out.str(" 0 0 ");
  out.num(static_cast<std::int64_t>(entity_sets.size()));
  out.chr('\n');
  tag = 0;
  for (const auto& [name, set] : m.node_sets) {
    (void)name;
    out.num(++tag);
    for (int d = 0; d < 3; ++d) {
      out.chr(' ');
      out.dbl(set.empty() ? 0.0 : m.coords[3 * set[0] + d]);
    }
    out.str(" 1 ");
    out.num(tag);
    out.chr('\n');
  }
  for (std::size_t v = 0; v < entity_sets.size(); ++v) {
    out.num(static_cast<std::int64_t>(v + 1));
    for (const double* b : {lo, hi})
      for (int d = 0; d < 3; ++d) {
        out.chr(' ');
        out.dbl(b[d]);
      }
    out.chr(' ');
    out.num(static_cast<std::int64_t>(entity_sets[v]->size()));
    for (int s : *entity_sets[v]) {
      out.chr(' ');
      out.num(s + 1);
    }
    out.str(" 0\n");
  }
  out.str("$EndEntities\n");

  // Nodes: one block on volume entity 1.
  out.str("$Nodes\n");
  out.num(nn ? 1 : 0);
  out.chr(' ');
  out.num(nn);
  out.chr(' ');
  out.num(min_node);
  out.chr(' ');
  out.num(max_node);
  out.chr('\n');
  if (nn) {
    out.str("3 1 0 ");
    out.num(nn);
    out.chr('\n');
    for (std::int64_t id : m.node_ids) {
      out.num(id);
      out.chr('\n');
    }
    for (std::int64_t k = 0; k < nn; ++k) {
      out.dbl(m.coords[3 * k]);
      out.chr(' ');
      out.dbl(m.coords[3 * k + 1]);
      out.chr(' ');
      out.dbl(m.coords[3 * k + 2]);
      out.chr('\n');
    }
  }
  out.str("$EndNodes\n");

  // Elements: runs of consecutive solid elements with the same entity and type keep the Mesh
  // order; then one block of point elements per non-empty node set.
  std::vector<std::pair<std::int64_t, std::int64_t>> runs;  // [begin, end) element ranges
  for (std::int64_t e = 0; e < ne; ++e)
    if (e == 0 || elem_entity[e] != elem_entity[e - 1] || m.elem_types[e] != m.elem_types[e - 1])
      runs.emplace_back(e, e + 1);
    else
      runs.back().second = e + 1;
  std::int64_t n_points = 0, n_point_blocks = 0;
  for (const auto& [name, set] : m.node_sets) {
    (void)name;
    n_points += static_cast<std::int64_t>(set.size());
    n_point_blocks += set.empty() ? 0 : 1;
  }
  std::int64_t min_elem = ne ? m.elem_ids[0] : 0;
  for (std::int64_t id : m.elem_ids) min_elem = std::min(min_elem, id);
  const std::int64_t first_point_tag = max_elem + 1;
  if (ne == 0 && n_points > 0) min_elem = first_point_tag;
  const std::int64_t last_tag = n_points > 0 ? first_point_tag + n_points - 1 : max_elem;

  out.str("$Elements\n");
  out.num(static_cast<std::int64_t>(runs.size()) + n_point_blocks);
  out.chr(' ');
  out.num(ne + n_points);
  out.chr(' ');
  out.num(min_elem);
  out.chr(' ');
  out.num(last_tag);
  out.chr('\n');
  for (const auto& [b, e_end] : runs) {
    out.str("3 ");
    out.num(elem_entity[b]);
    out.chr(' ');
    out.num(gmsh_type(m.elem_types[b]));
    out.chr(' ');
    out.num(e_end - b);
    out.chr('\n');
    for (std::int64_t e = b; e < e_end; ++e) {
      out.num(m.elem_ids[e]);
      for (std::int64_t j = m.elem_offsets[e]; j < m.elem_offsets[e + 1]; ++j) {
        out.chr(' ');
        out.num(m.node_ids[m.elem_nodes[j]]);
      }
      out.chr('\n');
    }
  }
  std::int64_t point_tag = first_point_tag;
  tag = 0;
  for (const auto& [name, set] : m.node_sets) {
    (void)name;
    ++tag;
    if (set.empty()) continue;
    out.str("0 ");
    out.num(tag);
    out.chr(' ');
    out.num(kGmshPoint);
    out.chr(' ');
    out.num(static_cast<std::int64_t>(set.size()));
    out.chr('\n');
    for (std::int64_t v : set) {
      out.num(point_tag++);
      out.chr(' ');
      out.num(m.node_ids[v]);
      out.chr('\n');
    }
  }
  out.str("$EndElements\n");
  if (!m.materials.empty()) {
    for (const auto& mat : m.materials) check_set_name(mat.name);
    out.str("$MorseMaterials\n1\n");
    out.num(static_cast<std::int64_t>(m.materials.size()));
    out.chr('\n');
    for (const auto& mat : m.materials) {
      out.chr('"');
      out.str(mat.name);
      out.str("\" ");
      out.dbl(mat.E);
      out.chr(' ');
      out.dbl(mat.nu);
      out.chr(' ');
      out.dbl(mat.rho);
      out.chr('\n');
    }
    out.num(ne);
    out.chr('\n');
    for (std::int64_t e = 0; e < ne; ++e) {
      out.num(m.elem_material[e]);
      out.chr('\n');
    }
    out.str("$EndMorseMaterials\n");
  }

  // Atomic write: temporary file, then rename.
  const std::string tmp = files::temp_path(path);
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw Error(cat(path, ": cannot create file: ", std::strerror(errno)));
  const std::string& data = out.data();
  const bool wrote = std::fwrite(data.data(), 1, data.size(), f) == data.size();
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!wrote || !closed) {
    const int err = !wrote ? write_errno : errno;
    std::remove(tmp.c_str());
    throw Error(cat(path, ": error writing gmsh file (its temporary ", tmp, "): ", std::strerror(err)));
  }
  files::commit(tmp, path);
}

}  // namespace morse::mesh
