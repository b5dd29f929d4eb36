// Fuzz target: /sweep checkpoint reader (sim::read_sweep; errors are returned as text).
#include "fuzz_common.hpp"
#include "morse/sim/sim.hpp"

MORSE_FUZZ_TARGET(".h5", {
  morse::sim::SweepRecord rec;
  std::string error;
  (void)morse::sim::read_sweep(path, &rec, &error);
})
