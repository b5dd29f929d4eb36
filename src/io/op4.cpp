// Nastran OUTPUT4 (OP4) reader and writer; the format is described in morse/io/op4.hpp.
#include "morse/io/op4.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <string_view>
#include <tuple>
#include <utility>

#include "morse/core/error.hpp"

namespace morse::io {

namespace {

// ------------------------------------------------------------------------------------------------
// Text helpers

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\0'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

std::string_view rtrim(std::string_view s) {
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

std::string upper(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return r;
}

std::vector<std::string_view> split_blanks(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_blank(s[i])) ++i;
    const std::size_t b = i;
    while (i < s.size() && !is_blank(s[i])) ++i;
    if (i > b) out.push_back(s.substr(b, i - b));
  }
  return out;
}

bool parse_int(std::string_view s, std::int64_t* v) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

/// Parses a Fortran real: E or D exponent, or Fortran's exponent without letter when its
/// magnitude exceeds 99 ("1.0000000000000000-300").
bool parse_real(std::string_view s, double* v) {
  s = trim(s);
  if (s.empty() || s.size() > 60) return false;
  char buf[64];
  std::size_t n = 0;
  bool has_exp = false;
  for (char c : s) {
    if (c == 'D' || c == 'd') c = 'E';
    if (c == 'E' || c == 'e') has_exp = true;
    buf[n++] = c;
  }
  if (!has_exp) {
    for (std::size_t i = n; i-- > 1;) {
      if ((buf[i] == '+' || buf[i] == '-') && (is_digit(buf[i - 1]) || buf[i - 1] == '.')) {
        std::memmove(buf + i + 1, buf + i, n - i);
        buf[i] = 'E';
        ++n;
        break;
      }
    }
  }
  buf[n] = '\0';
  const char* b = buf;
  if (*b == '+') ++b;
  if (*b == '+' || *b == '-' ? !(is_digit(b[1]) || b[1] == '.') : !(is_digit(*b) || *b == '.'))
    return false;  // no "inf"/"nan" and no other words
  const auto r = std::from_chars(b, buf + n, *v);
  if (r.ec == std::errc()) return r.ptr == buf + n;
  if (r.ec != std::errc::result_out_of_range || r.ptr != buf + n) return false;
  // Out of range for from_chars (possibly a subnormal number): strtod gives the nearest value.
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(b, &end);
  if (end != buf + n || !std::isfinite(x)) return false;
  *v = x;
  return true;
}

/// Reads `count` integers from a line: whitespace-separated tokens, or fixed fields of `width`
/// characters when the numbers run together.
bool parse_ints(std::string_view line, std::size_t count, int width, std::int64_t* out) {
  const auto tok = split_blanks(line);
  if (tok.size() == count) {
    for (std::size_t i = 0; i < count; ++i)
      if (!parse_int(tok[i], &out[i])) return false;
    return true;
  }
  const std::string_view s = rtrim(line);
  const std::size_t w = static_cast<std::size_t>(width);
  if (s.size() <= (count - 1) * w || s.size() > count * w) return false;
  for (std::size_t i = 0; i < count; ++i)
    if (!parse_int(s.substr(i * w, w), &out[i])) return false;
  return true;
}

/// Splits a line of Fortran reals without knowing their width: "0.0E+00-1.2E+03" is two numbers.
void scan_reals(std::string_view line, std::vector<std::string_view>* out) {
  out->clear();
  const std::size_t n = line.size();
  std::size_t i = 0;
  while (i < n) {
    while (i < n && is_blank(line[i])) ++i;
    if (i >= n) break;
    const std::size_t s = i;
    if (line[i] == '+' || line[i] == '-') ++i;
    while (i < n && (is_digit(line[i]) || line[i] == '.')) ++i;
    if (i < n && line[i] != '\0' && std::strchr("EeDd", line[i]) != nullptr) {
      ++i;
      if (i < n && (line[i] == '+' || line[i] == '-')) ++i;
      while (i < n && is_digit(line[i])) ++i;
    } else if (i + 1 < n && i > s && (line[i] == '+' || line[i] == '-') && is_digit(line[i + 1])) {
      ++i;
      while (i < n && is_digit(line[i])) ++i;
    }
    if (i == s || (i == s + 1 && !is_digit(line[s]))) {  // not a number: keep the word for the message
      while (i < n && !is_blank(line[i])) ++i;
    }
    out->push_back(line.substr(s, i - s));
  }
}

/// The Fortran format of an ASCII header, "1P,3E23.16": per = 3, width = 23, digits = 16.
struct ValueFormat {
  int per = 0, width = 0, digits = -1;  // width 0: unknown, values are scanned
};

ValueFormat parse_format(std::string_view text) {
  std::string f;
  for (char c : upper(text)) {
    if (c == '|') break;
    if (!is_blank(c) && c != '(' && c != ')') f += c;
  }
  std::size_t i = 0;
  // Optional scale factor "1P," (or "1P").
  std::size_t j = i;
  while (j < f.size() && is_digit(f[j])) ++j;
  if (j < f.size() && f[j] == 'P') {
    i = j + 1;
    if (i < f.size() && f[i] == ',') ++i;
  }
  auto number = [&](int* v) {
    const std::size_t b = i;
    while (i < f.size() && is_digit(f[i])) ++i;
    if (i == b || i - b > 6) return false;
    *v = std::atoi(f.substr(b, i - b).c_str());
    return true;
  };
  ValueFormat vf, none;
  if (!number(&vf.per)) vf.per = 1;
  if (i >= f.size() || (f[i] != 'E' && f[i] != 'D' && f[i] != 'G')) return none;
  ++i;
  if (!number(&vf.width) || vf.width <= 0) return none;
  if (i < f.size() && f[i] == '.') {
    ++i;
    if (!number(&vf.digits)) return none;
  }
  if (vf.per <= 0) return none;
  return vf;
}

const char* form_name(std::int64_t form) {
  switch (form) {
    case 1:
      return " (square)";
    case 2:
      return " (rectangular)";
    case 3:
      return " (diagonal)";
    case 4:
      return " (lower triangular factor)";
    case 5:
      return " (upper triangular factor)";
    case 6:
      return " (symmetric)";
    case 8:
      return " (identity)";
    case 9:
      return " (pseudo-identity)";
    case 10:
      return " (Cholesky factor)";
    case 11:
      return " (trapezoidal factor)";
    case 13:
      return " (sparse lower triangular factor)";
    case 15:
      return " (sparse upper triangular factor)";
    default:
      return "";
  }
}

bool same_name(std::string_view a, std::string_view b) { return upper(rtrim(a)) == upper(rtrim(b)); }

// ------------------------------------------------------------------------------------------------
// Binary helpers

std::int64_t load_int(const unsigned char* p, int size, bool swap) {
  unsigned char b[8];
  for (int i = 0; i < size; ++i) b[i] = swap ? p[size - 1 - i] : p[i];
  if (size == 4) {
    std::int32_t v;
    std::memcpy(&v, b, 4);
    return v;
  }
  std::int64_t v;
  std::memcpy(&v, b, 8);
  return v;
}

double load_real(const unsigned char* p, int size, bool swap) {
  unsigned char b[8];
  for (int i = 0; i < size; ++i) b[i] = swap ? p[size - 1 - i] : p[i];
  if (size == 4) {
    float v;
    std::memcpy(&v, b, 4);
    return v;
  }
  double v;
  std::memcpy(&v, b, 8);
  return v;
}

// ------------------------------------------------------------------------------------------------
// Sources: the ASCII and binary layouts behind one interface. Every error is thrown by fail(),
// prefixed with the location of the item read last ("file:line: " or "file: byte N: ").

class Source {
 public:
  explicit Source(std::string path) : path_(std::move(path)) {}
  virtual ~Source() = default;
  virtual bool binary() const = 0;
  /// Reads the next matrix header; false at the end of the file. *nrow_raw is NROW as stored.
  virtual bool read_header(Op4Header* h, std::int64_t* nrow_raw) = 0;
  /// Reads the first three words of the next column record.
  virtual void read_record(std::int64_t* icol, std::int64_t* irow, std::int64_t* nw) = 0;
  /// Checks the record length against NW (binary); after read_record of a column record.
  virtual void check_nw(std::int64_t nw) = 0;
  /// Number of values of a non-sparse record of NW words (real types).
  virtual std::int64_t dense_count(std::int64_t nw, int type) = 0;
  /// Reads the header of a string of a sparse record: row, L (words of values), header words.
  virtual void read_string_header(bool bigmat, std::int64_t* irow, std::int64_t* len, int* header_words) = 0;
  /// Number of values of a string of L words (real types).
  virtual std::int64_t string_count(std::int64_t len, int type) = 0;
  /// Reads n values (real types) into out.
  virtual void read_values(std::int64_t n, int type, std::vector<double>* out) = 0;
  /// Called when every word of a column record has been read.
  virtual void end_record() = 0;
  /// Consumes what follows the words ICOL, IROW, NW of an end-of-matrix record.
  virtual void skip_end_record() = 0;
  /// Skips a matrix whose header was just read (any type).
  virtual void skip_matrix(const Op4Header& h, bool bigmat) = 0;
  virtual std::string where() const = 0;

  [[noreturn]] void fail(const std::string& msg) const { throw Error(cat(where(), msg)); }
  const std::string& path() const { return path_; }

 protected:
  std::string path_;
};

std::int64_t words_to_count(const Source& src, std::int64_t words, std::int64_t per_value, const char* what) {
  if (words % per_value != 0)
    src.fail(cat(what, " = ", words, " is not a multiple of ", per_value, " (the words of one value of this type)"));
  return words / per_value;
}

// ---- ASCII

class AsciiSource : public Source {
 public:
  explicit AsciiSource(const std::string& path) : Source(path), f_(path, std::ios::binary) {
    if (!f_) throw Error(cat(path, ": cannot open the OP4 file"));
  }
  bool binary() const override { return false; }

  std::string where() const override { return cat(path_, ":", line_no_, ": "); }

  bool read_header(Op4Header* h, std::int64_t* nrow_raw) override {
    do {
      if (!next_line()) return false;
    } while (trim(line_).empty());
    const std::string up = upper(line_);
    const int first = up.find("|I16") != std::string::npos ? 16 : 8;
    for (int iw : {first, 24 - first}) {
      const std::size_t w = static_cast<std::size_t>(iw);
      if (line_.size() <= 4 * w) continue;
      std::int64_t v[4];
      bool ok = true;
      for (std::size_t k = 0; k < 4 && ok; ++k) ok = parse_int(std::string_view(line_).substr(k * w, w), &v[k]);
      if (!ok) continue;
      *h = Op4Header();
      h->ncols = v[0];
      *nrow_raw = v[1];
      h->nrows = v[1] < 0 ? -v[1] : v[1];
      h->form = static_cast<int>(std::clamp<std::int64_t>(v[2], -1000000, 1000000));
      h->type = static_cast<int>(std::clamp<std::int64_t>(v[3], -1000000, 1000000));
      h->name = std::string(rtrim(std::string_view(line_).substr(4 * w, 8)));
      h->binary = false;
      fmt_ = line_.size() > 4 * w + 8 ? parse_format(std::string_view(line_).substr(4 * w + 8)) : ValueFormat();
      if (h->ncols < 1 || h->nrows < 1)
        fail(cat("matrix '", h->name, "' has ", h->ncols, " columns and ", v[1], " rows in its header"));
      return true;
    }
    fail(cat("expected a matrix header (NCOL, NROW, NF, NTYPE in 4I8 or 4I16, then the name), got '", line_, "'"));
  }

  void read_record(std::int64_t* icol, std::int64_t* irow, std::int64_t* nw) override {
    if (!next_line()) fail("end of file before the end-of-matrix record (column NCOL+1)");
    std::int64_t v[3];
    if (!parse_ints(line_, 3, 8, v)) fail(cat("expected a column record (ICOL, IROW, NW in 3I8), got '", line_, "'"));
    *icol = v[0];
    *irow = v[1];
    *nw = v[2];
  }

  void check_nw(std::int64_t) override {}

  std::int64_t dense_count(std::int64_t nw, int) override { return nw; }  // values printed

  void read_string_header(bool bigmat, std::int64_t* irow, std::int64_t* len, int* header_words) override {
    if (!next_line()) fail("end of file inside a sparse column record");
    const auto tok = split_blanks(line_);
    std::int64_t v[2];
    if (tok.size() == 2 || (bigmat && tok.size() == 1 && rtrim(line_).size() > 8)) {
      if (!parse_ints(line_, 2, 8, v))
        fail(cat("expected a BIGMAT string header (L+1, IROW in 2I8), got '", line_, "'"));
      *len = v[0] - 1;
      *irow = v[1];
      *header_words = 2;
      return;
    }
    if (tok.size() != 1 || !parse_int(tok[0], &v[0]))
      fail(cat("expected a string header (IS = IROW + 65536*(L+1), or L+1 and IROW), got '", line_, "'"));
    *len = v[0] / 65536 - 1;
    *irow = v[0] - 65536 * (*len + 1);
    *header_words = 1;
  }

  std::int64_t string_count(std::int64_t len, int type) override {
    return words_to_count(*this, len, type == 2 ? 2 : 1, "string length L");
  }

  void read_values(std::int64_t n, int type, std::vector<double>* out) override {
    out->clear();
    read_numbers(n, out, type == 1 && fmt_.digits < 16);
  }

  void end_record() override {}

  void skip_end_record() override {
    // The end-of-matrix record is followed by (at least) one value; skip every value line.
    while (next_line()) {
      const auto tok = split_blanks(line_);
      if (!tok.empty() && tok[0].find('.') == std::string_view::npos) {
        pushed_back_ = true;
        return;
      }
    }
  }

  void skip_matrix(const Op4Header& h, bool bigmat) override {
    if (h.type < 1 || h.type > 4) fail(cat("matrix '", h.name, "' has unknown type ", h.type));
    const std::int64_t words_per_number = h.type % 2 == 0 ? 2 : 1;
    for (;;) {
      std::int64_t icol, irow, nw;
      read_record(&icol, &irow, &nw);
      if (icol > h.ncols) {
        skip_end_record();
        return;
      }
      if (nw < 0) fail(cat("negative NW = ", nw));
      if (irow != 0) {
        read_numbers(nw, nullptr, false);
        continue;
      }
      for (std::int64_t left = nw; left > 0;) {
        std::int64_t r, len;
        int hw;
        read_string_header(bigmat, &r, &len, &hw);
        if (len <= 0 || hw + len > left) fail(cat("string length L = ", len, " inconsistent with the column record"));
        read_numbers(words_to_count(*this, len, words_per_number, "string length L"), nullptr, false);
        left -= hw + len;
      }
    }
  }

 private:
  bool next_line() {
    if (pushed_back_) {
      pushed_back_ = false;
      return true;
    }
    if (!std::getline(f_, line_)) return false;
    ++line_no_;
    while (!line_.empty() && (line_.back() == '\r' || line_.back() == '\n')) line_.pop_back();
    return true;
  }

  /// Splits the current line into values; false (with *bad set) if a field is not a number.
  bool parse_value_line(std::vector<double>* vals, std::string* bad) {
    vals->clear();
    const std::string_view s = rtrim(line_);
    if (fmt_.width > 0) {
      const std::size_t w = static_cast<std::size_t>(fmt_.width);
      bool ok = true;
      for (std::size_t p = 0; p < s.size() && ok; p += w) {
        double x;
        ok = parse_real(s.substr(p, w), &x);
        if (ok)
          vals->push_back(x);
        else
          *bad = std::string(s.substr(p, w));
      }
      if (ok) return true;
      vals->clear();  // fields not aligned with the format: try a free-format scan of the line
    }
    scan_reals(s, &fields_);
    for (const auto& f : fields_) {
      double x;
      if (!parse_real(f, &x)) {
        if (bad->empty()) *bad = std::string(f);
        return false;
      }
      vals->push_back(x);
    }
    return true;
  }

  /// Reads `count` numbers on the following lines (out null: skip them).
  void read_numbers(std::int64_t count, std::vector<double>* out, bool round_to_float) {
    while (count > 0) {
      if (!next_line()) fail(cat("end of file while ", count, " more values were expected"));
      std::string bad;
      if (!parse_value_line(&vals_, &bad))
        fail(cat("'", std::string(trim(bad)), "' is not a real number (values in ",
                 fmt_.width > 0 ? cat("fields of ", fmt_.width, " characters") : "free format", " expected)"));
      if (vals_.empty()) fail(cat("blank line where ", count, " more values were expected"));
      const auto got = static_cast<std::int64_t>(vals_.size());
      if (got > count) fail(cat("the line holds ", got, " values where ", count, " were expected"));
      if (out != nullptr) {
        for (double x : vals_) out->push_back(round_to_float ? static_cast<double>(static_cast<float>(x)) : x);
      }
      count -= got;
    }
  }

  std::ifstream f_;
  std::string line_;
  std::int64_t line_no_ = 0;
  bool pushed_back_ = false;
  ValueFormat fmt_;
  std::vector<double> vals_;
  std::vector<std::string_view> fields_;
};

// ---- Binary

struct BinaryLayout {
  int marker = 4;     // bytes of a record-length marker
  int word = 4;       // bytes of a word (4, or 8 for 64-bit-integer files)
  bool swap = false;  // file byte order differs from the host's
};

class BinarySource : public Source {
 public:
  BinarySource(const std::string& path, std::int64_t size, BinaryLayout layout)
      : Source(path), f_(path, std::ios::binary), size_(size), lay_(layout) {
    if (!f_) throw Error(cat(path, ": cannot open the OP4 file"));
  }
  bool binary() const override { return true; }

  std::string where() const override { return cat(path_, ": byte ", item_, ": "); }

  bool read_header(Op4Header* h, std::int64_t* nrow_raw) override {
    if (!load_record(true)) return false;
    const std::int64_t w = lay_.word;
    if (static_cast<std::int64_t>(rec_.size()) < 6 * w)
      fail(cat("matrix header record of ", rec_.size(), " bytes, expected ", 6 * w, " (4 integers and 8 characters)"));
    *h = Op4Header();
    h->ncols = word();
    *nrow_raw = word();
    if (*nrow_raw == std::numeric_limits<std::int64_t>::min())  // its negation overflows (found by fuzzing)
      fail(cat("row count ", *nrow_raw, " in the matrix header"));
    h->nrows = *nrow_raw < 0 ? -*nrow_raw : *nrow_raw;
    h->form = static_cast<int>(std::clamp<std::int64_t>(word(), -1000000, 1000000));
    h->type = static_cast<int>(std::clamp<std::int64_t>(word(), -1000000, 1000000));
    std::string raw(reinterpret_cast<const char*>(rec_.data()) + 4 * w, static_cast<std::size_t>(2 * w));
    if (w == 4) {
      h->name = std::string(rtrim(raw));
    } else {  // two 8-byte words holding 4 characters each (2A4): drop every blank
      for (char c : raw)
        if (!is_blank(c)) h->name += c;
    }
    h->binary = true;
    item_ = rec_start_;
    if (h->ncols < 1 || h->nrows < 1)
      fail(cat("matrix '", h->name, "' has ", h->ncols, " columns and ", *nrow_raw, " rows in its header"));
    return true;
  }

  void read_record(std::int64_t* icol, std::int64_t* irow, std::int64_t* nw) override {
    if (!load_record(false)) fail("end of file before the end-of-matrix record (column NCOL+1)");
    if (static_cast<std::int64_t>(rec_.size()) < 3 * lay_.word)
      fail(cat("record of ", rec_.size(), " bytes, too short for a column record"));
    *icol = word();
    *irow = word();
    *nw = word();
  }

  void check_nw(std::int64_t nw) override {
    const auto bytes = static_cast<std::int64_t>(rec_.size());
    if (nw < 0 || nw > bytes || (3 + nw) * lay_.word != bytes)
      fail(cat("NW = ", nw, " does not match the record length of ", bytes, " bytes (3 + NW words of ", lay_.word,
               " bytes)"));
  }

  std::int64_t dense_count(std::int64_t nw, int type) override {
    return words_to_count(*this, nw, words_per_value(type), "NW");
  }

  void read_string_header(bool bigmat, std::int64_t* irow, std::int64_t* len, int* header_words) override {
    if (bigmat) {
      *len = word() - 1;
      *irow = word();
      *header_words = 2;
    } else {
      const std::int64_t is = word();
      *len = is / 65536 - 1;
      *irow = is - 65536 * (*len + 1);
      *header_words = 1;
    }
  }

  std::int64_t string_count(std::int64_t len, int type) override {
    return words_to_count(*this, len, words_per_value(type), "string length L");
  }

  void read_values(std::int64_t n, int type, std::vector<double>* out) override {
    const int vs = type == 2 || lay_.word == 8 ? 8 : 4;
    item_ = rec_start_ + static_cast<std::int64_t>(pos_);
    if (n < 0 || n > static_cast<std::int64_t>((rec_.size() - pos_) / vs))
      fail(cat("record too short for ", n, " values"));
    out->resize(static_cast<std::size_t>(n));
    const unsigned char* p = rec_.data() + pos_;
    for (std::int64_t k = 0; k < n; ++k) (*out)[k] = load_real(p + k * vs, vs, lay_.swap);
    pos_ += static_cast<std::size_t>(n * vs);
  }

  void end_record() override {
    if (pos_ != rec_.size()) {
      item_ = rec_start_ + static_cast<std::int64_t>(pos_);
      fail(cat(rec_.size() - pos_, " bytes left over at the end of the column record"));
    }
  }

  void skip_end_record() override {}  // the whole record was read by read_record

  void skip_matrix(const Op4Header& h, bool) override {
    for (;;) {
      std::int64_t icol, irow, nw;
      read_record(&icol, &irow, &nw);
      if (icol > h.ncols) return;
    }
  }

 private:
  int words_per_value(int type) const { return type == 2 && lay_.word == 4 ? 2 : 1; }

  std::int64_t word() {
    item_ = rec_start_ + static_cast<std::int64_t>(pos_);
    if (pos_ + static_cast<std::size_t>(lay_.word) > rec_.size()) fail("record too short for the words it announces");
    const std::int64_t v = load_int(rec_.data() + pos_, lay_.word, lay_.swap);
    pos_ += static_cast<std::size_t>(lay_.word);
    return v;
  }

  /// Reads the record at off_ into rec_; false at the end of the file if eof_ok.
  bool load_record(bool eof_ok) {
    item_ = off_;
    if (off_ >= size_) {
      if (eof_ok) return false;
      fail("end of file before the end-of-matrix record (column NCOL+1)");
    }
    const int m = lay_.marker;
    if (off_ + m > size_) fail("truncated file: incomplete record-length marker");
    unsigned char mk[8];
    f_.clear();
    f_.seekg(off_);
    f_.read(reinterpret_cast<char*>(mk), m);
    if (!f_) fail("read error");
    const std::int64_t len = load_int(mk, m, lay_.swap);
    if (len < 0)
      fail(cat("negative record length ", len, " (Fortran sub-records of records over 2 GiB are not supported)"));
    if (len > size_ - off_ - 2 * m)
      fail(cat("truncated file: record of ", len, " bytes starting here does not fit in the ", size_,
               " bytes of the file"));
    rec_.resize(static_cast<std::size_t>(len));
    if (len > 0) f_.read(reinterpret_cast<char*>(rec_.data()), len);
    f_.read(reinterpret_cast<char*>(mk), m);
    if (!f_) fail("read error");
    const std::int64_t tail = load_int(mk, m, lay_.swap);
    if (tail != len) {
      item_ = off_ + m + len;
      fail(cat("record-length markers differ (", len, " before the record, ", tail, " after it)"));
    }
    rec_start_ = off_ + m;
    pos_ = 0;
    off_ += 2 * m + len;
    return true;
  }

  std::ifstream f_;
  std::int64_t size_ = 0;
  BinaryLayout lay_;
  std::int64_t off_ = 0;  // offset of the next record
  std::vector<unsigned char> rec_;
  std::int64_t rec_start_ = 0;  // offset of the current record's first data byte
  std::size_t pos_ = 0;         // read position in rec_
  std::int64_t item_ = 0;       // offset of the item read last (for messages)
};

/// Opens path and picks the layout from its first bytes.
std::unique_ptr<Source> open_source(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(cat(path, ": cannot open the OP4 file"));
  f.seekg(0, std::ios::end);
  const std::int64_t size = static_cast<std::int64_t>(f.tellg());
  f.seekg(0);
  if (size <= 0) throw Error(cat(path, ": empty file, not an OP4 file"));
  unsigned char head[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  f.read(reinterpret_cast<char*>(head), std::min<std::int64_t>(size, 8));
  // Binary: the first record is the 24-byte header (48 bytes with 64-bit integers), framed by
  // 4-byte (or 8-byte) length markers in either byte order.
  for (int marker : {4, 8}) {
    if (size < marker) continue;
    for (bool swap : {false, true}) {
      const std::int64_t len = load_int(head, marker, swap);
      if (len != 24 && len != 48) continue;
      const BinaryLayout lay{marker, static_cast<int>(len / 6), swap};
      if (size >= 2 * marker + len) {
        unsigned char tail[8];
        f.clear();
        f.seekg(marker + len);
        f.read(reinterpret_cast<char*>(tail), marker);
        if (!f || load_int(tail, marker, swap) != len) continue;
      }
      return std::make_unique<BinarySource>(path, size, lay);
    }
  }
  const unsigned char c = head[0];
  if (c == ' ' || c == '-' || c == '+' || is_digit(static_cast<char>(c)) || c == '\n' || c == '\r')
    return std::make_unique<AsciiSource>(path);
  throw Error(cat(path,
                  ": not an OP4 file (neither a Fortran unformatted file starting with a "
                  "24-byte header record nor an ASCII header line)"));
}

}  // namespace

// ================================================================================================
// Op4Reader

struct Op4Reader::Impl {
  std::unique_ptr<Source> src;
  Op4Header h;
  bool pending = false;  // the first column record was read by the constructor
  std::int64_t p_icol = 0, p_irow = 0, p_nw = 0;
  bool done = false;
  std::int64_t col = 0;        // 1-based column of the current record (0 before the first)
  std::int64_t last_row = 0;   // 1-based last row stored so far in column col
  std::int64_t remaining = 0;  // words left in the current sparse record
  std::vector<double> buf;

  void check_run(std::int64_t irow, std::int64_t n) {
    if (irow < 1 || irow > h.nrows) src->fail(cat("row ", irow, " of column ", col, " out of range 1..", h.nrows));
    if (n > h.nrows - irow + 1)
      src->fail(cat("run of ", n, " values from row ", irow, " of column ", col, " passes the last row ", h.nrows));
    if (irow <= last_row)
      src->fail(cat("run from row ", irow, " of column ", col, " does not follow row ", last_row,
                    " (rows must increase within a column)"));
    if (n > 0) last_row = irow + n - 1;
  }

  bool emit(std::int64_t irow, std::int64_t* out_col, std::vector<std::int64_t>* rows, std::vector<double>* values) {
    rows->clear();
    values->clear();
    for (std::size_t k = 0; k < buf.size(); ++k) {
      if (buf[k] == 0.0) continue;
      rows->push_back(irow - 1 + static_cast<std::int64_t>(k));
      values->push_back(buf[k]);
    }
    *out_col = col - 1;
    return !rows->empty();
  }
};

Op4Reader::Op4Reader(const std::string& path, const std::string& name) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.src = open_source(path);
  std::vector<std::string> names;
  const std::string_view wanted = trim(name);
  bool found = false;
  std::int64_t nrow_raw = 0;
  while (m.src->read_header(&m.h, &nrow_raw)) {
    names.push_back(m.h.name);
    m.h.bigmat = nrow_raw < 0 || m.h.nrows >= 65536;
    if (wanted.empty() || same_name(m.h.name, wanted)) {
      found = true;
      break;
    }
    m.src->skip_matrix(m.h, m.h.bigmat);
  }
  if (!found) {
    if (names.empty()) throw Error(cat(path, ": no matrix in the file"));
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    throw Error(cat(path, ": no matrix named '", std::string(wanted), "'; matrices in the file: ", list));
  }
  const Op4Header& h = m.h;
  if (h.type == 3 || h.type == 4)
    m.src->fail(cat("matrix '", h.name, "' has type ", h.type, h.type == 3 ? " (complex single)" : " (complex double)",
                    ": complex matrices are not supported"));
  if (h.type != 1 && h.type != 2)
    m.src->fail(cat("matrix '", h.name, "' has unknown type ", h.type, " (1 real single, 2 real double)"));
  if (h.form != 1 && h.form != 2 && h.form != 6)
    m.src->fail(cat("matrix '", h.name, "' has form ", h.form, form_name(h.form),
                    ", which is not supported (supported forms: 1 square, 2 rectangular, "
                    "6 symmetric)"));
  // Peek at the first record to tell sparse from non-sparse storage.
  m.src->read_record(&m.p_icol, &m.p_irow, &m.p_nw);
  m.pending = true;
  m.h.sparse = m.p_irow == 0 || (m.p_icol == h.ncols + 1 && h.bigmat);
}

Op4Reader::~Op4Reader() = default;
Op4Reader::Op4Reader(Op4Reader&&) noexcept = default;
Op4Reader& Op4Reader::operator=(Op4Reader&&) noexcept = default;

const Op4Header& Op4Reader::header() const { return impl_->h; }

bool Op4Reader::next(std::int64_t* col, std::vector<std::int64_t>* rows, std::vector<double>* values) {
  Impl& m = *impl_;
  Source& src = *m.src;
  const int type = m.h.type;
  rows->clear();
  values->clear();
  while (!m.done) {
    if (m.remaining > 0) {  // next string of a sparse record
      std::int64_t irow, len;
      int hw;
      src.read_string_header(m.h.bigmat, &irow, &len, &hw);
      if (len <= 0) src.fail(cat("string length L = ", len, " in column ", m.col, " (must be > 0)"));
      if (hw + len > m.remaining)
        src.fail(cat("string of ", hw, " + ", len, " words overruns column ", m.col, " (", m.remaining,
                     " words left of its NW)"));
      const std::int64_t n = src.string_count(len, type);
      m.check_run(irow, n);
      src.read_values(n, type, &m.buf);
      m.remaining -= hw + len;
      if (m.remaining == 0) src.end_record();
      if (m.emit(irow, col, rows, values)) return true;
      continue;
    }
    std::int64_t icol, irow, nw;
    if (m.pending) {
      m.pending = false;
      icol = m.p_icol;
      irow = m.p_irow;
      nw = m.p_nw;
    } else {
      src.read_record(&icol, &irow, &nw);
    }
    if (icol == m.h.ncols + 1) {
      src.skip_end_record();
      m.done = true;
      break;
    }
    if (icol < 1 || icol > m.h.ncols)
      src.fail(cat("column number ", icol, " out of range 1..", m.h.ncols, " (", m.h.ncols + 1, " ends the matrix)"));
    if (icol < m.col) src.fail(cat("column ", icol, " after column ", m.col, " (columns must be in increasing order)"));
    if (icol != m.col) {
      m.col = icol;
      m.last_row = 0;
    }
    if (nw < 0) src.fail(cat("negative NW = ", nw));
    src.check_nw(nw);
    if (irow == 0) {  // sparse record: strings follow
      m.remaining = nw;
      if (nw == 0) src.end_record();
      continue;
    }
    if (irow < 0) src.fail(cat("negative IROW = ", irow, " in column ", icol));
    const std::int64_t n = src.dense_count(nw, type);
    m.check_run(irow, n);
    src.read_values(n, type, &m.buf);
    src.end_record();
    if (m.emit(irow, col, rows, values)) return true;
  }
  return false;
}

std::vector<std::string> Op4Reader::names_in_file(const std::string& path) {
  auto src = open_source(path);
  std::vector<std::string> names;
  Op4Header h;
  std::int64_t nrow_raw = 0;
  while (src->read_header(&h, &nrow_raw)) {
    names.push_back(h.name);
    src->skip_matrix(h, nrow_raw < 0 || h.nrows >= 65536);
  }
  return names;
}

// ================================================================================================
// Writer

namespace {

template <class... T>
[[noreturn]] void write_fail(const std::string& path, const std::string& name, const T&... msg) {
  throw Error(cat(path, ": cannot write OP4 matrix '", name, "': ", msg...));
}

/// Fortran 1P,Ew.d: one digit before the point, d after, exponent "E+xx", or "+xxx" without the
/// letter when its magnitude exceeds 99; right-justified in w characters.
void append_fortran_e(std::string* s, double x, int w, int d) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*E", d, x);
  const char* e = std::strchr(buf, 'E');
  std::string field(buf, static_cast<std::size_t>(e - buf));
  const char sign = e[1];
  std::string digits(e + 2);
  while (digits.size() < 2) digits.insert(digits.begin(), '0');
  if (digits.size() <= 2) field += 'E';
  field += sign;
  field += digits;
  if (static_cast<int>(field.size()) < w) s->append(static_cast<std::size_t>(w) - field.size(), ' ');
  *s += field;
}

void append_int(std::string* s, std::int64_t v, int width) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%*lld", width, static_cast<long long>(v));
  *s += buf;
}

template <class T>
void append_raw(std::string* s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  s->append(b, sizeof(T));
}

struct Entry {
  std::int64_t row;
  double value;
};

}  // namespace

void write_op4(const std::string& path, const std::string& name, std::int64_t nrows, std::int64_t ncols,
               const std::vector<std::int64_t>& col_ptr, const std::vector<std::int64_t>& row_idx,
               const std::vector<double>& values, const Op4WriteOptions& o, bool append) {
  // ---- checks
  if (name.empty() || name.size() > 8) write_fail(path, name, "the name must have 1 to 8 characters");
  for (char c : name)
    if (c <= ' ' || c > '~') write_fail(path, name, "the name must be printable, without blanks");
  const std::string uname = upper(name);
  if (nrows < 1 || ncols < 1) write_fail(path, name, "invalid size ", nrows, " x ", ncols);
  if (static_cast<std::int64_t>(col_ptr.size()) != ncols + 1 || col_ptr[0] != 0 ||
      col_ptr.back() != static_cast<std::int64_t>(row_idx.size()) || row_idx.size() != values.size())
    write_fail(path, name,
               "inconsistent CSC arrays (col_ptr must have ncols + 1 entries from 0 "
               "to the number of entries)");
  for (std::int64_t j = 0; j < ncols; ++j) {
    if (col_ptr[j + 1] < col_ptr[j]) write_fail(path, name, "col_ptr decreases at column ", j);
    for (std::int64_t k = col_ptr[j]; k < col_ptr[j + 1]; ++k) {
      if (row_idx[k] < 0 || row_idx[k] >= nrows)
        write_fail(path, name, "row index ", row_idx[k], " out of range in column ", j);
      if (k > col_ptr[j] && row_idx[k] <= row_idx[k - 1])
        write_fail(path, name, "row indices of column ", j, " are not strictly increasing");
      if (!std::isfinite(values[k])) write_fail(path, name, "non-finite value at row ", row_idx[k], ", column ", j);
    }
  }
  const int type = o.single ? 1 : 2;
  int form = o.form;
  if (form != 0 && form != 1 && form != 2 && form != 6)
    write_fail(path, name, "form ", form, " is not supported (0 automatic, 1, 2 or 6)");
  if ((form == 1 || form == 6) && nrows != ncols)
    write_fail(path, name, "form ", form, " needs a square matrix, not ", nrows, " x ", ncols);
  if (o.sparse && !o.bigmat && nrows >= 65536)
    write_fail(path, name, "non-BIGMAT sparse strings need fewer than 65536 rows");

  // The values as stored (rounded to float for NTYPE 1), zeros dropped.
  auto stored = [&](std::int64_t k) {
    double v = values[k];
    if (o.single) {
      v = static_cast<double>(static_cast<float>(v));
      if (!std::isfinite(v)) write_fail(path, name, "value ", values[k], " overflows single precision");
    }
    return v;
  };
  if (form == 0) {
    bool symmetric = nrows == ncols;
    if (symmetric) {
      std::vector<std::tuple<std::int64_t, std::int64_t, double>> a, t;
      for (std::int64_t j = 0; j < ncols; ++j)
        for (std::int64_t k = col_ptr[j]; k < col_ptr[j + 1]; ++k) {
          const double v = stored(k);
          if (v == 0.0) continue;
          a.emplace_back(j, row_idx[k], v);
          t.emplace_back(row_idx[k], j, v);
        }
      std::sort(t.begin(), t.end());
      symmetric = a == t;
    }
    form = symmetric ? 6 : (nrows == ncols ? 1 : 2);
  }

  // ---- layout
  const bool bigmat = o.sparse && o.bigmat;
  const std::int64_t nrow_field = bigmat ? -nrows : nrows;
  const int wpv = o.single ? 1 : 2;  // words per value
  const int per = o.single ? 5 : 3, w = o.single ? 16 : 23, d = o.single ? 9 : 16;
  const std::int64_t i32max = std::numeric_limits<std::int32_t>::max();
  if (o.binary && (ncols + 1 > i32max || nrows > i32max))
    write_fail(path, name, "dimensions exceed the 32-bit integers of binary OP4 files");

  std::ofstream out(path, append ? std::ios::binary | std::ios::app : std::ios::binary | std::ios::trunc);
  if (!out) throw Error(cat(path, ": cannot open for writing"));

  auto write_record = [&](const std::string& payload) {
    if (static_cast<std::int64_t>(payload.size()) > i32max) write_fail(path, name, "a column record exceeds 2 GiB");
    const auto len = static_cast<std::int32_t>(payload.size());
    out.write(reinterpret_cast<const char*>(&len), 4);
    out.write(payload.data(), static_cast<std::streamsize>(payload.size()));
    out.write(reinterpret_cast<const char*>(&len), 4);
  };
  auto add_value = [&](std::string* s, double v) {
    if (o.single)
      append_raw(s, static_cast<float>(v));
    else
      append_raw(s, v);
  };
  auto add_int = [&](std::string* s, std::int64_t v) {
    if (v > i32max || v < -i32max) write_fail(path, name, "integer ", v, " exceeds 32 bits");
    append_raw(s, static_cast<std::int32_t>(v));
  };
  auto add_lines = [&](std::string* s, const double* x, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      append_fortran_e(s, x[i], w, d);
      if ((i + 1) % per == 0 || i + 1 == n) *s += '\n';
    }
  };

  // ---- header
  std::string rec;
  if (o.binary) {
    add_int(&rec, ncols);
    add_int(&rec, nrow_field);
    add_int(&rec, form);
    add_int(&rec, type);
    std::string padded = uname;
    padded.resize(8, ' ');
    rec += padded;
    write_record(rec);
  } else {
    const std::int64_t ints[4] = {ncols, nrow_field, form, type};
    bool wide = false;
    for (std::int64_t v : ints) wide = wide || std::to_string(v).size() > 8;
    for (std::int64_t v : ints) append_int(&rec, v, wide ? 16 : 8);
    std::string padded = uname;
    padded.resize(8, ' ');
    rec += padded;
    rec += o.single ? "1P,5E16.9" : "1P,3E23.16";
    if (wide) rec += "|I16";
    rec += '\n';
    out << rec;
  }

  // ---- columns
  std::vector<Entry> e;
  std::vector<double> run;
  for (std::int64_t j = 0; j < ncols; ++j) {
    e.clear();
    for (std::int64_t k = col_ptr[j]; k < col_ptr[j + 1]; ++k) {
      const double v = stored(k);
      if (v != 0.0) e.push_back({row_idx[k], v});
    }
    if (e.empty()) continue;  // null columns are not written
    rec.clear();
    if (!o.sparse) {
      const std::int64_t first = e.front().row, count = e.back().row - first + 1;
      run.assign(static_cast<std::size_t>(count), 0.0);
      for (const Entry& x : e) run[static_cast<std::size_t>(x.row - first)] = x.value;
      if (o.binary) {
        add_int(&rec, j + 1);
        add_int(&rec, first + 1);
        add_int(&rec, count * wpv);
        for (double v : run) add_value(&rec, v);
        write_record(rec);
      } else {
        append_int(&rec, j + 1, 8);
        append_int(&rec, first + 1, 8);
        append_int(&rec, count, 8);  // ASCII non-sparse: NW = number of values printed
        rec += '\n';
        add_lines(&rec, run.data(), run.size());
        out << rec;
      }
      continue;
    }
    // Sparse: one string per run of consecutive rows.
    std::vector<std::pair<std::size_t, std::size_t>> strings;  // [begin, end) in e
    for (std::size_t b = 0; b < e.size();) {
      std::size_t k = b + 1;
      while (k < e.size() && e[k].row == e[k - 1].row + 1) ++k;
      strings.emplace_back(b, k);
      b = k;
    }
    std::int64_t nw = 0;
    for (const auto& s : strings) nw += (bigmat ? 2 : 1) + static_cast<std::int64_t>(s.second - s.first) * wpv;
    auto string_header = [&](std::int64_t len, std::int64_t irow) {
      if (!bigmat && len + 1 >= 32768)
        write_fail(path, name, "a non-BIGMAT string of ", len, " words is too long for IS");
      return irow + 65536 * (len + 1);
    };
    if (o.binary) {
      add_int(&rec, j + 1);
      add_int(&rec, 0);
      add_int(&rec, nw);
      for (const auto& s : strings) {
        const std::int64_t len = static_cast<std::int64_t>(s.second - s.first) * wpv;
        const std::int64_t irow = e[s.first].row + 1;
        if (bigmat) {
          add_int(&rec, len + 1);
          add_int(&rec, irow);
        } else {
          add_int(&rec, string_header(len, irow));
        }
        for (std::size_t k = s.first; k < s.second; ++k) add_value(&rec, e[k].value);
      }
      write_record(rec);
    } else {
      append_int(&rec, j + 1, 8);
      append_int(&rec, 0, 8);
      append_int(&rec, nw, 8);
      rec += '\n';
      for (const auto& s : strings) {
        const std::int64_t len = static_cast<std::int64_t>(s.second - s.first) * wpv;
        const std::int64_t irow = e[s.first].row + 1;
        if (bigmat) {
          append_int(&rec, len + 1, 8);
          append_int(&rec, irow, 8);
        } else {
          append_int(&rec, string_header(len, irow), 8);
        }
        rec += '\n';
        run.clear();
        for (std::size_t k = s.first; k < s.second; ++k) run.push_back(e[k].value);
        add_lines(&rec, run.data(), run.size());
      }
      out << rec;
    }
  }

  // ---- end-of-matrix record: column NCOL+1, row 1, one value
  rec.clear();
  const double one = 1.0;
  if (o.binary) {
    add_int(&rec, ncols + 1);
    add_int(&rec, 1);
    add_int(&rec, wpv);
    add_value(&rec, one);
    write_record(rec);
  } else {
    append_int(&rec, ncols + 1, 8);
    append_int(&rec, 1, 8);
    append_int(&rec, 1, 8);
    rec += '\n';
    add_lines(&rec, &one, 1);
    out << rec;
  }
  out.close();
  if (!out) throw Error(cat(path, ": write error"));
}

}  // namespace morse::io
