// Fuzz target: load-history CSV reader (dyn::read_load_table; errors are returned as text).
#include "fuzz_common.hpp"
#include "morse/dyn/dyn.hpp"

MORSE_FUZZ_TARGET(".csv", {
  morse::dyn::LoadTable t;
  (void)morse::dyn::read_load_table(path, &t);
})
