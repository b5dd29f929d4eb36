// Tests of the Nastran OUTPUT4 reader and writer (io/op4.hpp). Every rank runs the same serial
// tests on its own temporary files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/session.hpp"
#include "morse/io/op4.hpp"
#include "scratch.hpp"

namespace {

namespace fs = std::filesystem;
using morse::cat;
using morse::io::Op4Header;
using morse::io::Op4Reader;
using morse::io::Op4WriteOptions;
using morse::io::write_op4;

using Key = std::pair<std::int64_t, std::int64_t>;  // (column, row), 0-based: CSC order
using Entries = std::map<Key, double>;

struct Csc {
  std::int64_t nrows = 0, ncols = 0;
  std::vector<std::int64_t> ptr, idx;
  std::vector<double> val;
};

Csc to_csc(std::int64_t nrows, std::int64_t ncols, const Entries& e) {
  Csc a;
  a.nrows = nrows;
  a.ncols = ncols;
  a.ptr.assign(static_cast<std::size_t>(ncols + 1), 0);
  for (const auto& [k, v] : e) {
    ++a.ptr[static_cast<std::size_t>(k.first + 1)];
    a.idx.push_back(k.second);
    a.val.push_back(v);
  }
  for (std::int64_t j = 0; j < ncols; ++j) a.ptr[j + 1] += a.ptr[j];
  return a;
}

void write_csc(const std::string& path, const std::string& name, const Csc& a, const Op4WriteOptions& o,
               bool append = false) {
  write_op4(path, name, a.nrows, a.ncols, a.ptr, a.idx, a.val, o, append);
}

/// The entries as the file stores them: rounded to float for single precision, zeros dropped.
Entries as_stored(const Entries& e, bool single) {
  Entries out;
  for (const auto& [k, v] : e) {
    const double s = single ? static_cast<double>(static_cast<float>(v)) : v;
    if (s != 0.0) out[k] = s;
  }
  return out;
}

/// Reads the whole matrix `name`, checking the order and range of the runs.
Entries read_all(const std::string& path, const std::string& name, Op4Header* header = nullptr) {
  Op4Reader r(path, name);
  if (header != nullptr) *header = r.header();
  const Op4Header& h = r.header();
  Entries out;
  std::int64_t col = -1, last_col = -1, last_row = -1;
  std::vector<std::int64_t> rows;
  std::vector<double> vals;
  while (r.next(&col, &rows, &vals)) {
    EXPECT_EQ(rows.size(), vals.size());
    EXPECT_FALSE(rows.empty());
    EXPECT_GE(col, 0);
    EXPECT_LT(col, h.ncols);
    EXPECT_GE(col, last_col) << "columns out of order";
    if (col != last_col) last_row = -1;
    for (std::size_t k = 0; k < rows.size() && k < vals.size(); ++k) {
      EXPECT_GT(rows[k], last_row) << "rows out of order in column " << col;
      EXPECT_GE(rows[k], 0);
      EXPECT_LT(rows[k], h.nrows);
      EXPECT_NE(vals[k], 0.0);
      EXPECT_TRUE(out.emplace(Key{col, rows[k]}, vals[k]).second)
          << "entry (" << rows[k] << ", " << col << ") read twice";
      last_row = rows[k];
    }
    last_col = col;
  }
  EXPECT_FALSE(r.next(&col, &rows, &vals)) << "next() after the end";
  return out;
}

std::uint64_t bits(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

std::string full(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

/// Same entries, values bitwise identical.
void expect_same(const Entries& expected, const Entries& got) {
  EXPECT_EQ(expected.size(), got.size());
  for (const auto& [k, v] : expected) {
    const auto it = got.find(k);
    if (it == got.end()) {
      ADD_FAILURE() << "entry (" << k.second << ", " << k.first << ") = " << full(v) << " not read";
      continue;
    }
    EXPECT_EQ(bits(v), bits(it->second)) << "entry (" << k.second << ", " << k.first << "): " << full(v) << " read as "
                                         << full(it->second);
  }
  for (const auto& [k, v] : got)
    if (expected.count(k) == 0) ADD_FAILURE() << "extra entry (" << k.second << ", " << k.first << ") = " << full(v);
}

double random_value(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), ex(-6.0, 6.0);
  double v = 0.0;
  while (v == 0.0) v = u(rng) * std::pow(10.0, ex(rng));
  return v;
}

/// Random sparse symmetric n x n matrix with empty rows and columns (the first and the last
/// among them). extremes adds values that need three-digit exponents, a subnormal and the
/// largest double.
Entries random_symmetric(int n, std::mt19937_64& rng, bool extremes) {
  std::uniform_real_distribution<double> p(0.0, 1.0);
  const std::set<int> empty = {0, 5, 6, 17, n - 1};
  Entries e;
  for (int j = 0; j < n; ++j) {
    if (empty.count(j) != 0) continue;
    for (int i = 0; i <= j; ++i) {
      if (empty.count(i) != 0) continue;
      if (i == j || p(rng) < 0.25) {
        const double v = random_value(rng);
        e[{j, i}] = v;
        e[{i, j}] = v;
      }
    }
  }
  if (extremes) {
    const std::pair<Key, double> special[] = {{{1, 2}, 1e-300},
                                              {{3, 4}, -2.2250738585072014e-308},
                                              {{7, 7}, 4.9406564584124654e-324},
                                              {{8, 9}, 1.7976931348623157e308},
                                              {{10, 10}, -1.5e+250},
                                              {{11, 12}, 0.1}};
    for (const auto& [k, v] : special) {
      e[k] = v;
      e[{k.second, k.first}] = v;
    }
  }
  return e;
}

/// Dense 5 x 7 with two explicit zeros (one leading a column).
Entries dense_rect(std::mt19937_64& rng) {
  Entries e;
  for (int j = 0; j < 7; ++j)
    for (int i = 0; i < 5; ++i) e[{j, i}] = random_value(rng);
  e[{0, 0}] = 0.0;
  e[{3, 2}] = 0.0;
  return e;
}

// The 4 x 4 symmetric matrix of the hand-written files.
Entries small_symmetric(double last) {
  return {{{0, 0}, 4.0}, {{0, 1}, -1.0}, {{0, 2}, 0.5},    {{1, 0}, -1.0}, {{1, 1}, 3.0},    {{1, 3}, 0.25},
          {{2, 0}, 0.5}, {{2, 2}, 2.0},  {{2, 3}, -0.125}, {{3, 1}, 0.25}, {{3, 2}, -0.125}, {{3, 3}, last}};
}

// ------------------------------------------------------------------------------------------------
// Binary transcoding: rewrites a file of write_op4 (native byte order, 4-byte markers and words)
// with the other byte order, other markers or 8-byte words, following the format.

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

template <class T>
T get(const std::string& s, std::size_t off) {
  T v;
  std::memcpy(&v, s.data() + off, sizeof(T));
  return v;
}

std::vector<std::string> records(const std::string& path) {
  const std::string data = slurp(path);
  std::vector<std::string> recs;
  for (std::size_t p = 0; p + 8 <= data.size();) {
    const auto len = static_cast<std::size_t>(get<std::int32_t>(data, p));
    recs.push_back(data.substr(p + 4, len));
    p += 8 + len;
  }
  return recs;
}

struct Emitter {
  bool swap;
  int word;
  std::string bytes;
  template <class T>
  void raw(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (swap) std::reverse(b, b + sizeof(T));
    bytes.append(b, sizeof(T));
  }
  void integer(std::int64_t v) {
    if (word == 4)
      raw(static_cast<std::int32_t>(v));
    else
      raw(v);
  }
  void real(double v, int size) {
    if (size == 4)
      raw(static_cast<float>(v));
    else
      raw(v);
  }
};

std::string frame(const std::string& payload, bool swap, int marker) {
  Emitter m{swap, marker, {}};
  m.integer(static_cast<std::int64_t>(payload.size()));
  return m.bytes + payload + m.bytes;
}

std::string transcode(const std::string& path, bool swap, int marker, int word) {
  const auto recs = records(path);
  std::string out;
  std::size_t k = 0;
  while (k < recs.size()) {
    const std::string& h = recs[k++];
    const auto ncol = get<std::int32_t>(h, 0), nrow = get<std::int32_t>(h, 4);
    const auto type = get<std::int32_t>(h, 12);
    const std::string name = h.substr(16, 8);
    Emitter e{swap, word, {}};
    for (int i = 0; i < 4; ++i) e.integer(get<std::int32_t>(h, 4 * static_cast<std::size_t>(i)));
    if (word == 4) {
      e.bytes += name;
    } else {  // 2A4 in two 8-byte words
      e.bytes += name.substr(0, 4) + "    ";
      e.bytes += name.substr(4, 4) + "    ";
    }
    out += frame(e.bytes, swap, marker);
    const bool bigmat = nrow < 0;
    const int vin = type == 2 ? 8 : 4, vout = word == 8 ? 8 : vin, wpv = vout / word;
    for (;;) {
      const std::string& r = recs.at(k++);
      const auto icol = get<std::int32_t>(r, 0), irow = get<std::int32_t>(r, 4);
      auto value = [&](std::size_t off) {
        return vin == 8 ? get<double>(r, off) : static_cast<double>(get<float>(r, off));
      };
      Emitter c{swap, word, {}};
      c.integer(icol);
      if (icol == ncol + 1) {
        c.integer(1);
        c.integer(wpv);
        c.real(1.0, vout);
        out += frame(c.bytes, swap, marker);
        break;
      }
      c.integer(irow);
      if (irow > 0) {
        const std::size_t n = (r.size() - 12) / static_cast<std::size_t>(vin);
        c.integer(static_cast<std::int64_t>(n) * wpv);
        for (std::size_t i = 0; i < n; ++i) c.real(value(12 + i * vin), vout);
      } else {
        std::vector<std::pair<std::int64_t, std::vector<double>>> strings;
        for (std::size_t p = 12; p < r.size();) {
          std::int64_t len, row;
          if (bigmat) {
            len = get<std::int32_t>(r, p) - 1;
            row = get<std::int32_t>(r, p + 4);
            p += 8;
          } else {
            const std::int64_t is = get<std::int32_t>(r, p);
            len = is / 65536 - 1;
            row = is - 65536 * (len + 1);
            p += 4;
          }
          const auto n = static_cast<std::size_t>(len * 4 / vin);
          std::vector<double> v;
          for (std::size_t i = 0; i < n; ++i) v.push_back(value(p + i * vin));
          p += n * static_cast<std::size_t>(vin);
          strings.emplace_back(row, v);
        }
        std::int64_t nw = 0;
        for (const auto& s : strings) nw += (bigmat ? 2 : 1) + static_cast<std::int64_t>(s.second.size()) * wpv;
        c.integer(nw);
        for (const auto& s : strings) {
          const std::int64_t len = static_cast<std::int64_t>(s.second.size()) * wpv;
          if (bigmat) {
            c.integer(len + 1);
            c.integer(s.first);
          } else {
            c.integer(s.first + 65536 * (len + 1));
          }
          for (double v : s.second) c.real(v, vout);
        }
      }
      out += frame(c.bytes, swap, marker);
    }
  }
  return out;
}

// ------------------------------------------------------------------------------------------------

class Op4Test : public morse::test::ScratchDirTest {
 protected:
  Op4Test() : ScratchDirTest("op4") {}

  /// Writes bytes to dir_/rel and returns the path.
  std::string put(const std::string& rel, const std::string& bytes) const { return write(rel, bytes); }

  /// Expects reading matrix `name` of path to the end to throw a morse::Error whose message
  /// contains every part.
  static void expect_error(const std::string& path, const std::string& name, std::initializer_list<std::string> parts) {
    morse::test::expect_error_parts(
        [&] {
          Op4Reader r(path, name);
          std::int64_t col;
          std::vector<std::int64_t> rows;
          std::vector<double> vals;
          while (r.next(&col, &rows, &vals)) {
          }
        },
        parts, path);
  }
};

// ------------------------------------------------------------------------------------------------
// Round trips through every layout

TEST_F(Op4Test, RoundTripEveryLayout) {
  std::mt19937_64 rng(20240611);
  struct Mode {
    const char* label;
    bool sparse, bigmat;
  };
  const Mode modes[] = {{"dense", false, true}, {"bigmat", true, true}, {"packed", true, false}};
  for (bool binary : {false, true}) {
    for (const Mode& m : modes) {
      for (bool single : {false, true}) {
        const std::string label = cat(binary ? "binary_" : "ascii_", m.label, single ? "_single" : "_double");
        SCOPED_TRACE(label);
        const Entries sym = random_symmetric(37, rng, !single);
        const Entries rect = dense_rect(rng);
        const Entries one = {{{0, 0}, random_value(rng)}};
        Op4WriteOptions o;
        o.binary = binary;
        o.sparse = m.sparse;
        o.bigmat = m.bigmat;
        o.single = single;
        const std::string p = path(label + ".op4");
        write_csc(p, "KAA", to_csc(37, 37, sym), o);
        write_csc(p, "rect", to_csc(5, 7, rect), o, true);
        write_csc(p, "ONE", to_csc(1, 1, one), o, true);
        EXPECT_EQ(Op4Reader::names_in_file(p), (std::vector<std::string>{"KAA", "RECT", "ONE"}));

        struct Case {
          const char* name;
          std::int64_t nrows, ncols;
          int form;
          const Entries* entries;
        };
        const Case cases[] = {{"KAA", 37, 37, 6, &sym}, {"RECT", 5, 7, 2, &rect}, {"ONE", 1, 1, 6, &one}};
        for (const Case& c : cases) {
          SCOPED_TRACE(c.name);
          Op4Header h;
          const Entries got = read_all(p, c.name, &h);
          EXPECT_EQ(h.name, c.name);
          EXPECT_EQ(h.nrows, c.nrows);
          EXPECT_EQ(h.ncols, c.ncols);
          EXPECT_EQ(h.form, c.form);
          EXPECT_EQ(h.type, single ? 1 : 2);
          EXPECT_EQ(h.sparse, m.sparse);
          EXPECT_EQ(h.binary, binary);
          EXPECT_EQ(h.bigmat, m.sparse && m.bigmat);
          expect_same(as_stored(*c.entries, single), got);
        }
      }
    }
  }
}

TEST_F(Op4Test, TwoMatricesByName) {
  const Entries k = small_symmetric(1.5);
  const Entries mass = {{{0, 0}, 2.0}, {{1, 1}, 2.0}, {{2, 2}, 3.0}, {{3, 3}, 0.5}};
  for (bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    Op4WriteOptions o;
    o.binary = binary;
    const std::string p = path(binary ? "km.op4b" : "km.op4");
    write_csc(p, "KAA", to_csc(4, 4, k), o);
    write_csc(p, "MAA", to_csc(4, 4, mass), o, true);
    EXPECT_EQ(Op4Reader::names_in_file(p), (std::vector<std::string>{"KAA", "MAA"}));
    Op4Header h;
    expect_same(mass, read_all(p, "maa", &h));
    EXPECT_EQ(h.name, "MAA");
    expect_same(k, read_all(p, "KAA  ", &h));
    EXPECT_EQ(h.name, "KAA");
    expect_same(k, read_all(p, "", &h));  // the first one
    EXPECT_EQ(h.name, "KAA");
    expect_error(p, "KXX", {p + ": ", "no matrix named 'KXX'", "KAA, MAA"});
  }
}

TEST_F(Op4Test, EmptyMatrix) {
  for (bool binary : {false, true}) {
    for (bool sparse : {false, true}) {
      Op4WriteOptions o;
      o.binary = binary;
      o.sparse = sparse;
      const std::string p = path(cat("zero_", binary, sparse, ".op4"));
      const Csc z = to_csc(3, 2, {{{1, 1}, 0.0}});  // one explicit zero: nothing stored
      write_csc(p, "Z", z, o);
      write_csc(p, "ONE", to_csc(1, 1, {{{0, 0}, 1.0}}), o, true);
      Op4Header h;
      EXPECT_TRUE(read_all(p, "Z", &h).empty());
      EXPECT_EQ(h.form, 2);
      EXPECT_EQ(h.sparse, sparse);  // BIGMAT by default: NROW < 0
      expect_same({{{0, 0}, 1.0}}, read_all(p, "ONE"));
    }
  }
}

// ------------------------------------------------------------------------------------------------
// The ASCII layout of Nastran

// A dense (non-sparse) double matrix as OUTPUT4 prints it with DIGITS=16, except that column 1
// is split in two records. In non-sparse ASCII records NW is the number of values printed.
const char* const kNastranDense =
    "       4       4       6       2KAA     1P,3E23.16\n"
    "       1       1       2\n"
    " 4.0000000000000000E+00-1.0000000000000000E+00\n"
    "       1       3       1\n"
    " 5.0000000000000000E-01\n"
    "       2       1       4\n"
    "-1.0000000000000000E+00 3.0000000000000000E+00 0.0000000000000000E+00\n"
    " 2.5000000000000000E-01\n"
    "       3       1       4\n"
    " 5.0000000000000000E-01 0.0000000000000000E+00 2.0000000000000000E+00\n"
    "-1.2500000000000000E-01\n"
    "       4       2       3\n"
    " 2.5000000000000000E-01-1.2500000000000000E-01 1.0000000000000000-300\n"
    "       5       1       1\n"
    " 1.0000000000000000E+00\n";

TEST_F(Op4Test, ReadsNastranAsciiLayout) {
  const std::string p = put("kaa.op4", kNastranDense);
  Op4Header h;
  expect_same(small_symmetric(1e-300), read_all(p, "KAA", &h));
  EXPECT_EQ(h.nrows, 4);
  EXPECT_EQ(h.ncols, 4);
  EXPECT_EQ(h.form, 6);
  EXPECT_EQ(h.type, 2);
  EXPECT_FALSE(h.sparse);
  EXPECT_FALSE(h.binary);

  // The runs as stored: column 1 in two runs, the zero of column 2 dropped.
  Op4Reader r(p);
  std::int64_t col;
  std::vector<std::int64_t> rows;
  std::vector<double> vals;
  ASSERT_TRUE(r.next(&col, &rows, &vals));
  EXPECT_EQ(col, 0);
  EXPECT_EQ(rows, (std::vector<std::int64_t>{0, 1}));
  ASSERT_TRUE(r.next(&col, &rows, &vals));
  EXPECT_EQ(col, 0);
  EXPECT_EQ(rows, (std::vector<std::int64_t>{2}));
  ASSERT_TRUE(r.next(&col, &rows, &vals));
  EXPECT_EQ(col, 1);
  EXPECT_EQ(rows, (std::vector<std::int64_t>{0, 1, 3}));
  EXPECT_EQ(vals, (std::vector<double>{-1.0, 3.0, 0.25}));
}

TEST_F(Op4Test, ReadsSparseAndWideAsciiLayouts) {
  // The same 3 x 2 matrix in non-BIGMAT sparse (packed IS headers, D exponents), BIGMAT sparse
  // and non-sparse single precision with the 4I16 header of large dimensions.
  const Entries expected = {{{0, 1}, -950.3654033}, {{1, 0}, 1.0}, {{1, 1}, 2.0}, {{1, 2}, 3.0}};
  const std::string packed =
      "       2       3       2       2RMAT    1P,5E16.9\n"
      "       1       0       3\n"
      "  196610\n"
      "-9.503654033D+02\n"
      "       2       0       8\n"
      "  196609\n"
      " 1.000000000E+00\n"
      "  327682\n"
      " 2.000000000E+00 3.000000000D+00\n"
      "       3       1       1\n"
      " 1.000000000E+00\n";
  const std::string bigmat =
      "       2      -3       2       2RMAT    1P,5E16.9\n"
      "       1       0       4\n"
      "       3       2\n"
      "-9.503654033E+02\n"
      "       2       0      10\n"
      "       3       1\n"
      " 1.000000000E+00\n"
      "       5       2\n"
      " 2.000000000E+00 3.000000000E+00\n"
      "       3       1       1\n"
      " 1.000000000E+00\n";
  const std::string wide =
      "               2               3               2               1RMAT    1P,5E16.9|I16\n"
      "       1       2       1\n"
      "-9.503654033E+02\n"
      "       2       1       3\n"
      " 1.000000000E+00 2.000000000E+00 3.000000000E+00\n"
      "       3       1       1\n"
      " 1.000000000E+00\n";
  Op4Header h;
  expect_same(expected, read_all(put("packed.op4", packed), "RMAT", &h));
  EXPECT_TRUE(h.sparse);
  EXPECT_FALSE(h.bigmat);
  expect_same(expected, read_all(put("bigmat.op4", bigmat), "RMAT", &h));
  EXPECT_TRUE(h.sparse);
  EXPECT_TRUE(h.bigmat);
  EXPECT_EQ(h.nrows, 3);
  // NTYPE 1 printed with 9 decimals: single precision values.
  expect_same(as_stored(expected, true), read_all(put("wide.op4", wide), "RMAT", &h));
  EXPECT_FALSE(h.sparse);
  EXPECT_EQ(h.type, 1);
  EXPECT_EQ(h.ncols, 2);
  // Matrices of several layouts in one file.
  const std::string p = put("all.op4", packed + bigmat + wide);
  expect_same(expected, read_all(p, "RMAT"));  // the first of the three
  EXPECT_EQ(Op4Reader::names_in_file(p), (std::vector<std::string>{"RMAT", "RMAT", "RMAT"}));
}

TEST_F(Op4Test, WriterPrintsNastranAsciiLayout) {
  Op4WriteOptions o;
  const std::string dense = path("dense.op4");
  write_csc(dense, "kaa", to_csc(4, 4, small_symmetric(1e-300)), o);
  EXPECT_EQ(slurp(dense),
            "       4       4       6       2KAA     1P,3E23.16\n"
            "       1       1       3\n"
            " 4.0000000000000000E+00-1.0000000000000000E+00 5.0000000000000000E-01\n"
            "       2       1       4\n"
            "-1.0000000000000000E+00 3.0000000000000000E+00 0.0000000000000000E+00\n"
            " 2.5000000000000000E-01\n"
            "       3       1       4\n"
            " 5.0000000000000000E-01 0.0000000000000000E+00 2.0000000000000000E+00\n"
            "-1.2500000000000000E-01\n"
            "       4       2       3\n"
            " 2.5000000000000000E-01-1.2500000000000000E-01 1.0000000000000000-300\n"
            "       5       1       1\n"
            " 1.0000000000000000E+00\n");

  o.sparse = true;
  o.single = true;
  const std::string bigmat = path("bigmat.op4");
  write_csc(bigmat, "KAA", to_csc(4, 4, small_symmetric(1024.0)), o);
  EXPECT_EQ(slurp(bigmat),
            "       4      -4       6       1KAA     1P,5E16.9\n"
            "       1       0       5\n"
            "       4       1\n"
            " 4.000000000E+00-1.000000000E+00 5.000000000E-01\n"
            "       2       0       7\n"
            "       3       1\n"
            "-1.000000000E+00 3.000000000E+00\n"
            "       2       4\n"
            " 2.500000000E-01\n"
            "       3       0       7\n"
            "       2       1\n"
            " 5.000000000E-01\n"
            "       3       3\n"
            " 2.000000000E+00-1.250000000E-01\n"
            "       4       0       5\n"
            "       4       2\n"
            " 2.500000000E-01-1.250000000E-01 1.024000000E+03\n"
            "       5       1       1\n"
            " 1.000000000E+00\n");

  o.single = false;
  o.bigmat = false;
  const std::string packed = path("packed.op4");
  write_csc(packed, "KAA", to_csc(4, 4, small_symmetric(1e-300)), o);
  EXPECT_EQ(slurp(packed),
            "       4       4       6       2KAA     1P,3E23.16\n"
            "       1       0       7\n"
            "  458753\n"
            " 4.0000000000000000E+00-1.0000000000000000E+00 5.0000000000000000E-01\n"
            "       2       0       8\n"
            "  327681\n"
            "-1.0000000000000000E+00 3.0000000000000000E+00\n"
            "  196612\n"
            " 2.5000000000000000E-01\n"
            "       3       0       8\n"
            "  196609\n"
            " 5.0000000000000000E-01\n"
            "  327683\n"
            " 2.0000000000000000E+00-1.2500000000000000E-01\n"
            "       4       0       7\n"
            "  458754\n"
            " 2.5000000000000000E-01-1.2500000000000000E-01 1.0000000000000000-300\n"
            "       5       1       1\n"
            " 1.0000000000000000E+00\n");
}

// ------------------------------------------------------------------------------------------------
// Binary layouts

TEST_F(Op4Test, WriterBinaryRecords) {
  // Header record of 24 bytes, one record per column (3 + NW words), the end record.
  Op4WriteOptions o;
  o.binary = true;
  const std::string p = path("one.op4");
  write_csc(p, "KAA", to_csc(2, 2, {{{1, 0}, 2.5}, {{1, 1}, -1.0}}), o);
  const auto recs = records(p);
  ASSERT_EQ(recs.size(), 3u);
  ASSERT_EQ(recs[0].size(), 24u);
  EXPECT_EQ(get<std::int32_t>(recs[0], 0), 2);   // NCOL
  EXPECT_EQ(get<std::int32_t>(recs[0], 4), 2);   // NROW
  EXPECT_EQ(get<std::int32_t>(recs[0], 8), 1);   // form: square
  EXPECT_EQ(get<std::int32_t>(recs[0], 12), 2);  // type: real double
  EXPECT_EQ(recs[0].substr(16), "KAA     ");
  ASSERT_EQ(recs[1].size(), 12u + 16u);  // column 2, rows 1-2: NW = 4 words
  EXPECT_EQ(get<std::int32_t>(recs[1], 0), 2);
  EXPECT_EQ(get<std::int32_t>(recs[1], 4), 1);
  EXPECT_EQ(get<std::int32_t>(recs[1], 8), 4);
  EXPECT_EQ(get<double>(recs[1], 12), 2.5);
  EXPECT_EQ(get<double>(recs[1], 20), -1.0);
  ASSERT_EQ(recs[2].size(), 12u + 8u);
  EXPECT_EQ(get<std::int32_t>(recs[2], 0), 3);  // NCOL + 1
  EXPECT_EQ(get<std::int32_t>(recs[2], 4), 1);
  EXPECT_EQ(get<std::int32_t>(recs[2], 8), 2);
  EXPECT_EQ(get<double>(recs[2], 12), 1.0);
}

TEST_F(Op4Test, OtherBinaryLayouts) {
  // Big-endian, 8-byte record markers and 64-bit-integer files, made from files of write_op4.
  std::mt19937_64 rng(7);
  struct Mode {
    const char* label;
    bool sparse, bigmat, single;
  };
  const Mode modes[] = {{"dense_d", false, true, false},  {"dense_s", false, true, true},
                        {"bigmat_d", true, true, false},  {"bigmat_s", true, true, true},
                        {"packed_d", true, false, false}, {"packed_s", true, false, true}};
  struct Layout {
    bool swap;
    int marker, word;
  };
  const Layout layouts[] = {{true, 4, 4}, {false, 8, 4}, {true, 8, 4}, {false, 4, 8}, {true, 4, 8}, {true, 8, 8}};
  for (const Mode& m : modes) {
    SCOPED_TRACE(m.label);
    Op4WriteOptions o;
    o.binary = true;
    o.sparse = m.sparse;
    o.bigmat = m.bigmat;
    o.single = m.single;
    const std::string p = path(cat(m.label, ".op4"));
    const Entries sym = as_stored(random_symmetric(37, rng, !m.single), m.single);
    const Entries rect = as_stored(dense_rect(rng), m.single);
    write_csc(p, "KAA", to_csc(37, 37, sym), o);
    write_csc(p, "RECT", to_csc(5, 7, rect), o, true);
    EXPECT_EQ(transcode(p, false, 4, 4), slurp(p));  // the transcoder itself
    for (const Layout& l : layouts) {
      SCOPED_TRACE(cat("swap ", l.swap, " marker ", l.marker, " word ", l.word));
      const std::string q =
          put(cat(m.label, "_", l.swap, l.marker, l.word, ".op4"), transcode(p, l.swap, l.marker, l.word));
      EXPECT_EQ(Op4Reader::names_in_file(q), (std::vector<std::string>{"KAA", "RECT"}));
      Op4Header h;
      expect_same(sym, read_all(q, "KAA", &h));
      EXPECT_TRUE(h.binary);
      EXPECT_EQ(h.form, 6);
      EXPECT_EQ(h.type, m.single ? 1 : 2);
      EXPECT_EQ(h.sparse, m.sparse);
      expect_same(rect, read_all(q, "RECT", &h));
      EXPECT_EQ(h.nrows, 5);
      EXPECT_EQ(h.ncols, 7);
    }
  }
}

// ------------------------------------------------------------------------------------------------
// Errors

TEST_F(Op4Test, AsciiErrors) {
  const std::string head = "       3       2       2       2KAA     1P,3E23.16\n";
  const std::string one = " 1.0000000000000000E+00\n";
  const std::string end = "       4       1       1\n" + one;
  struct Case {
    const char* file;
    std::string text;
    std::vector<std::string> parts;
  };
  const Case cases[] = {
      {"complex.op4",
       "       2       2       1       4CMAT    1P,3E23.16\n       1       1       2\n" +
           std::string(" 1.0000000000000000E+00 0.0000000000000000E+00\n       3       1       1\n") + one,
       {":1: ", "complex matrices are not supported"}},
      {"form.op4",
       "       2       2       3       2KAA     1P,3E23.16\n       3       1       1\n" + one,
       {":1: ", "form 3 (diagonal)", "not supported"}},
      {"type.op4",
       "       2       2       1       7KAA     1P,3E23.16\n       3       1       1\n" + one,
       {":1: ", "unknown type 7"}},
      {"col_high.op4",
       head + "       1       1       1\n" + one + "       5       1       1\n" + one + end,
       {":4: ", "column number 5 out of range 1..3"}},
      {"col_zero.op4", head + "       0       1       1\n" + one + end, {":2: ", "column number 0 out of range"}},
      {"col_down.op4",
       head + "       2       1       1\n" + one + "       1       1       1\n" + one + end,
       {":4: ", "column 1 after column 2"}},
      {"row_high.op4",
       head + "       1       3       1\n" + one + end,
       {":2: ", "row 3 of column 1 out of range 1..2"}},
      {"row_run.op4",
       head + "       1       2       2\n" + one + one + end,
       {":2: ", "run of 2 values from row 2", "passes the last row 2"}},
      {"row_down.op4",
       head + "       1       1       2\n" + one + one + "       1       2       1\n" + one + end,
       {":5: ", "does not follow row 2"}},
      {"truncated.op4",
       head + "       1       1       2\n" + one + one,
       {":4: ", "end of file before the end-of-matrix record"}},
      {"short_values.op4",
       head + "       1       1       2\n" + one,
       {":3: ", "end of file while 1 more values were expected"}},
      {"bad_value.op4",
       head + "       1       1       1\n 1.00000000000000X0E+00\n" + end,
       {":3: ", "is not a real number"}},
      {"too_many.op4",
       head + "       1       1       1\n" + std::string(" 1.0E+00 2.0E+00\n") + end,
       {":3: ", "holds 2 values where 1 were expected"}},
      {"overrun.op4",
       "       3      -2       2       2KAA     1P,3E23.16\n       1       0       3\n"
       "       3       1\n" +
           one + end,
       {":3: ", "overruns column 1"}},
      {"odd_string.op4",
       "       3      -2       2       2KAA     1P,3E23.16\n       1       0       3\n"
       "       2       1\n" +
           one + end,
       {":3: ", "string length L = 1 is not a multiple of 2"}},
      {"no_record.op4",
       head + "       3       2       2       2MAA     1P,3E23.16\n",
       {":2: ", "expected a column record"}},
      {"bad_header.op4", "       3       3       6\n", {":1: ", "expected a matrix header"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    const std::string p = put(c.file, c.text);
    std::vector<std::string> parts = {p + ":"};
    parts.insert(parts.end(), c.parts.begin(), c.parts.end());
    for (std::string& part : parts)
      if (part.rfind(":", 0) == 0 && part.size() > 1) part = p + part;  // "file:line: "
    try {
      Op4Reader r(p, "");
      std::int64_t col;
      std::vector<std::int64_t> rows;
      std::vector<double> vals;
      while (r.next(&col, &rows, &vals)) {
      }
      ADD_FAILURE() << "no error reading " << p;
    } catch (const morse::Error& e) {
      const std::string msg = e.what();
      for (const std::string& part : parts)
        EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
    }
  }
  expect_error(path("missing.op4"), "", {path("missing.op4") + ": cannot open"});
  expect_error(put("empty.op4", ""), "", {path("empty.op4") + ": empty file"});
  expect_error(put("junk.op4", std::string("\x01\x02\x03\x04\x05\x06\x07\x08\x09", 9)), "",
               {path("junk.op4") + ": not an OP4 file"});
}

TEST_F(Op4Test, BinaryErrors) {
  Op4WriteOptions o;
  o.binary = true;
  const std::string good = path("good.op4");
  const Entries a = {{{0, 0}, 4.0}, {{0, 1}, -1.0}, {{1, 0}, -1.0}, {{1, 1}, 3.0}, {{2, 2}, 2.0}};
  write_csc(good, "KAA", to_csc(3, 3, a), o);
  const std::string bytes = slurp(good);
  // Layout: header record at byte 0 (4 + 24 + 4 bytes); the record of column 1 at byte 32:
  // marker 32, ICOL 36, IROW 40, NW 44, two values from 48, marker 64; columns 2 and 3; the end
  // record from byte 132; 160 bytes in all.
  ASSERT_EQ(bytes.size(), 160u);
  expect_same(a, read_all(good, "KAA"));
  auto patch_int = [&](std::string s, std::size_t off, std::int32_t v) {
    std::memcpy(&s[off], &v, 4);
    return s;
  };
  const std::string p_trunc = put("trunc.op4", bytes.substr(0, bytes.size() - 5));
  expect_error(p_trunc, "KAA", {p_trunc + ": byte ", "truncated file"});
  const std::string p_head = put("trunc_head.op4", bytes.substr(0, 20));
  expect_error(p_head, "KAA", {p_head + ": byte 0: ", "truncated file"});
  const std::string p_mark = put("marker.op4", patch_int(bytes, 32, 1000));
  expect_error(p_mark, "KAA", {p_mark + ": byte 32: ", "truncated file"});
  const std::int32_t len1 = get<std::int32_t>(bytes, 32);
  const std::string p_tail = put("tail.op4", patch_int(bytes, 36 + static_cast<std::size_t>(len1), len1 + 1));
  expect_error(p_tail, "KAA", {p_tail + ": byte ", "record-length markers differ"});
  const std::string p_nw = put("nw.op4", patch_int(bytes, 44, get<std::int32_t>(bytes, 44) + 2));
  expect_error(p_nw, "KAA", {p_nw + ": byte 44: ", "does not match the record length"});
  const std::string p_col = put("col.op4", patch_int(bytes, 36, 9));
  expect_error(p_col, "KAA", {p_col + ": byte 44: ", "column number 9 out of range 1..3"});
  const std::string p_row = put("row.op4", patch_int(bytes, 40, 4));
  expect_error(p_row, "KAA", {p_row + ": byte 44: ", "row 4 of column 1 out of range 1..3"});
  const std::string p_type = put("type.op4", patch_int(bytes, 16, 4));  // header word 4
  expect_error(p_type, "KAA", {p_type + ": byte 4: ", "complex matrices are not supported"});
  const std::string p_form = put("form.op4", patch_int(bytes, 12, 8));  // header word 3
  expect_error(p_form, "KAA", {p_form + ": byte 4: ", "form 8 (identity)"});
  // Found by bench/fuzz (op4, 10 minutes): a 64-bit header whose row count is INT64_MIN, whose
  // negation (the row count of a symmetric matrix) overflowed. Refused with the count named.
  const std::string p_min = put(
      "int64_min_rows.op4",
      std::string("\x30\x00\x00\x00\x00\x00\x00\x00\x00\x00\x34\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x00"
                  "\x00\x00\x00\x0a\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x48\x70\x61\x00\x00\x00\x00"
                  "\x00\x00\x00\x00\x00\x00\x30\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x60\xb0\x00",
                  72));
  expect_error(p_min, "", {p_min + ": byte ", "row count -9223372036854775808"});
}

TEST_F(Op4Test, WriterErrors) {
  const Csc a = to_csc(2, 2, {{{0, 0}, 1.0}, {{1, 1}, 2.0}});
  const std::string p = path("w.op4");
  Op4WriteOptions o;
  EXPECT_THROW(write_csc(p, "TOOLONGNAME", a, o), morse::Error);
  EXPECT_THROW(write_csc(p, "K A", a, o), morse::Error);
  Csc unsorted = to_csc(3, 1, {{{0, 0}, 1.0}, {{0, 2}, 2.0}});
  std::swap(unsorted.idx[0], unsorted.idx[1]);
  EXPECT_THROW(write_csc(p, "U", unsorted, o), morse::Error);
  Csc nan = a;
  nan.val[1] = std::nan("");
  EXPECT_THROW(write_csc(p, "N", nan, o), morse::Error);
  o.form = 6;
  EXPECT_THROW(write_csc(p, "R", to_csc(2, 3, {{{0, 0}, 1.0}}), o), morse::Error);
  o.form = 0;
  o.single = true;
  EXPECT_THROW(write_csc(p, "S", to_csc(1, 1, {{{0, 0}, 1e300}}), o), morse::Error);
}

}  // namespace
