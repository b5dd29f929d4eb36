// Fuzz target: OP4 reader (io::Op4Reader: the names, then every column of the first matrix).
#include <vector>

#include "fuzz_common.hpp"
#include "morse/io/op4.hpp"

MORSE_FUZZ_TARGET(".op4", {
  (void)morse::io::Op4Reader::names_in_file(path);
  morse::io::Op4Reader r(path);
  std::int64_t col = 0;
  std::vector<std::int64_t> rows;
  std::vector<double> values;
  while (r.next(&col, &rows, &values)) {
  }
})
