// Fuzz target: /rom superelement reader (io::read_superelement) on a mutated HDF5 file.
#include "fuzz_common.hpp"
#include "morse/io/superelement.hpp"

MORSE_FUZZ_TARGET(".h5", {
  auto se = morse::io::read_superelement(path);
  (void)morse::io::read_nodal_shapes(se);
})
