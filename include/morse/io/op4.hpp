// morse/io/op4.hpp: serial reader and reference writer of Nastran OUTPUT4 (OP4) matrix files.
//
// ================================================================================================
// The format (MSC / NX Nastran DMAP module OUTPUT4)
// ================================================================================================
// An OP4 file is a sequence of matrices. Each matrix is
//
//   1. a header record:
//        word 1  NCOL   number of columns
//        word 2  NROW   number of rows; NROW < 0 flags the BIGMAT sparse layout (|NROW| rows)
//        word 3  NF     form: 1 square, 2 rectangular, 3 diagonal, 4/5 lower/upper triangular,
//                       6 symmetric, 8 identity, 9 pseudo-identity, ...
//        word 4  NTYPE  type: 1 real single, 2 real double, 3 complex single, 4 complex double
//        words 5-6      NAME, 8 characters (2A4), blank padded
//        word 7         ASCII only: the Fortran format of the values, "1P,rEw.d" with d = DIGITS,
//                       w = d + 7, r = 80 / w (DIGITS = 9: 1P,5E16.9; DIGITS = 16: 1P,3E23.16)
//   2. one record per stored column, in increasing column order; null columns are omitted.
//      Words 1-3 are ICOL (1-based column), IROW, NW (the number of words that follow); then
//        IROW > 0  "non-sparse" column: the values of rows IROW, IROW+1, ... from the first to the
//                  last nonzero term of the column, zeros in between included.
//        IROW = 0  sparse column: NW words of strings. A string is a header then L words of values
//                  of consecutive rows:
//                    non-BIGMAT (NROW > 0): one word IS = IROW + 65536 * (L + 1),
//                                           i.e. L = IS / 65536 - 1, IROW = IS - 65536 * (L + 1)
//                    BIGMAT (NROW < 0):     two words, L + 1 and IROW.
//      Lengths count words of the file: a real single value is 1 word, a real double 2 words
//      (complex: 2 and 4). A 7-value real double column has NW = 14.
//   3. an end-of-matrix record: ICOL = NCOL + 1, IROW = 1, NW = 1, followed by one value (1.0).
//
// Binary files (ASSIGN ... FORM=UNFORMATTED) are Fortran sequential unformatted files: every
// record above is one Fortran record framed by its byte length before and after (4-byte markers).
// The header record is 24 bytes (4 int32 + 8 characters). Words are 4 bytes, so an NTYPE 2 value
// is an 8-byte IEEE double (2 words) and an NTYPE 1 value a 4-byte float. A column record holds
// 3 + NW words.
//
// ASCII files (FORM=FORMATTED) print the same records as lines:
//   header       (4I8, 2A4, A)     e.g. "       3       3       6       2KAA     1P,3E23.16"
//                                  When a dimension does not fit in I8, Nastran prints the four
//                                  integers as 4I16 and appends "|I16" to the format.
//   column       (3I8)             ICOL, IROW, NW
//   string hdr   (I8) or (2I8)     IS (non-BIGMAT) or L+1, IROW (BIGMAT), on their own line
//   values       announced format  e.g. 1P,3E23.16: 3 fields of 23 characters per line; each
//                                  column run and each string starts on a new line
//   end          (3I8) + 1 value   "NCOL+1       1       1" then " 1.0000000000000000E+00"
// One irregularity of the ASCII layout (as found in published OP4 files written by Nastran): in a
// non-sparse column record NW is the number of values printed, not of words (a 17-value real
// double column has NW = 17), while in sparse records NW and L count words as in binary files
// (a 1-value real double string has L = 2).
//
// ================================================================================================
// What the reader accepts
// ================================================================================================
// - ASCII or binary, detected from the first bytes.
// - Binary: little- or big-endian (from the first record marker), 4-byte or 8-byte record markers,
//   and files written with 64-bit integers (header record of 48 bytes: 4 int64 + 16 characters;
//   every word, integer or real, is then 8 bytes and NTYPE 1 values are 8-byte reals).
//   Fortran sub-records (negative markers of records longer than 2 GiB) are refused.
// - ASCII: the header in 4I8 or 4I16 layout; integers of column and string-header lines are read
//   free-format (whitespace separated; fixed I8 fields if they run together); values in the
//   field width of the announced format (free-format scan when the header carries no format),
//   with E or D exponents and Fortran's exponent without letter for |exponent| > 99
//   ("1.0000000000000000-100"). NTYPE 1 values printed with fewer than 16 decimals are rounded
//   to float (they are single precision numbers; 16 decimals reproduce a float exactly and are
//   what 64-bit-integer Nastran builds print for their 8-byte "single" reals).
// - Forms 1 (square), 2 (rectangular), 6 (symmetric; OUTPUT4 stores both triangles and the
//   reader returns what is stored). Other forms are refused, naming the form. Types 1 and 2;
//   complex types 3 and 4 are refused ("complex matrices are not supported").
// - Sparse strings: BIGMAT when NROW < 0 or |NROW| >= 65536 (binary); in ASCII a string-header
//   line with two integers is read as BIGMAT and one with a single integer as the packed IS.
// - A column may be split into several records (same ICOL, rows increasing); zero columns may be
//   omitted. Explicit zeros (inside non-sparse runs, or in strings) are dropped.
// - Checks (morse::Error, "file:line: ..." for ASCII, "file: byte OFFSET: ..." for binary):
//   truncated file or record, end of file before the end-of-matrix record, mismatched record
//   markers, record length != 3 + NW words, column number < 1, > NCOL + 1 or decreasing, row
//   runs outside 1..|NROW| or not increasing within a column, strings overrunning NW, malformed
//   numbers, unsupported form or type.
//
// ================================================================================================
// What the writer writes (the layout MSC Nastran's OUTPUT4 produces)
// ================================================================================================
// - ASCII: header 4I8 (4I16 + "|I16" if needed), name in upper case padded to 8, format
//   "1P,3E23.16" for doubles (17 significant digits: doubles round-trip exactly) or "1P,5E16.9"
//   for singles; values Fortran-style (1P,Ew.d, exponent letter dropped when |exponent| > 99).
// - Binary: native byte order, 4-byte markers, 4-byte integers, header record of 24 bytes.
// - Non-sparse: one record per nonzero column from its first to its last nonzero row.
//   Sparse (BIGMAT unless Op4WriteOptions::bigmat = false): one record per nonzero column, one
//   string per run of consecutive nonzero rows; BIGMAT writes NROW < 0.
// - End-of-matrix record NCOL+1, 1, NW, 1.0 with NW = 1 in ASCII and NW = words of one value in
//   binary (2 for doubles, 1 for singles).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace morse::io {

/// Header of one matrix of an OP4 file.
struct Op4Header {
  std::string name;                   // as stored, trailing blanks removed
  std::int64_t nrows = 0, ncols = 0;  // nrows = |NROW|
  int form = 0, type = 0;             // NF, NTYPE
  bool sparse = false;                // columns stored as strings (IROW = 0 in column records)
  bool binary = false;                // Fortran unformatted file (false: ASCII)
  bool bigmat = false;                // BIGMAT string headers (NROW < 0 or nrows >= 65536)
};

/// Streaming reader of one matrix of an OP4 file: holds at most one column record in memory.
/// Serial; call on one rank (every rank may read the same file independently).
class Op4Reader {
 public:
  /// Opens path and positions at the matrix called `name` (case-insensitive, trailing blanks
  /// ignored; empty: the first one). Throws morse::Error if the file is missing or malformed, if
  /// it has no such matrix (the message lists the names found), or if the matrix has an
  /// unsupported form or type.
  explicit Op4Reader(const std::string& path, const std::string& name = "");
  ~Op4Reader();
  Op4Reader(Op4Reader&&) noexcept;
  Op4Reader& operator=(Op4Reader&&) noexcept;
  Op4Reader(const Op4Reader&) = delete;
  Op4Reader& operator=(const Op4Reader&) = delete;

  const Op4Header& header() const;

  /// Reads the next stored run of one column: *col (0-based), *rows (0-based, increasing) and
  /// *values of its nonzero entries (zeros of the run are dropped; runs with no nonzero entry are
  /// skipped). Columns come in non-decreasing order and a column may span several runs, with
  /// rows increasing from one run to the next. Returns false at the end of the matrix (after the
  /// end-of-matrix record has been read) and on every later call.
  bool next(std::int64_t* col, std::vector<std::int64_t>* rows, std::vector<double>* values);

  /// Names of the matrices of the file at path, in file order. Throws like the constructor.
  static std::vector<std::string> names_in_file(const std::string& path);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct Op4WriteOptions {
  bool binary = false;  // Fortran unformatted (native byte order); false: ASCII
  bool sparse = false;  // sparse strings; false: non-sparse column runs
  bool bigmat = true;   // sparse only: BIGMAT string headers and NROW < 0; false: packed IS
                        // headers (needs nrows < 65536 and strings of < 16384 doubles)
  bool single = false;  // NTYPE 1 (values rounded to float); false: NTYPE 2
  int form = 0;         // 0: 6 if the matrix is square and exactly symmetric, else 1 (square)
                        // or 2 (rectangular); otherwise 1, 2 or 6
};

/// Writes the nrows x ncols matrix given in CSC form (col_ptr of size ncols + 1, 0-based row
/// indices strictly increasing within each column, values; explicit zeros are not written) as
/// matrix `name` (1 to 8 characters, no blanks; written in upper case) to path: a new file if
/// append is false, appended to the file otherwise. Serial. Throws morse::Error on invalid input
/// (including non-finite values) or I/O failure.
void write_op4(const std::string& path, const std::string& name, std::int64_t nrows, std::int64_t ncols,
               const std::vector<std::int64_t>& col_ptr, const std::vector<std::int64_t>& row_idx,
               const std::vector<double>& values, const Op4WriteOptions& o, bool append = false);

}  // namespace morse::io
