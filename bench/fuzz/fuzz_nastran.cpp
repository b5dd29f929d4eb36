// Fuzz target: Nastran bulk data reader (mesh::read_nastran).
#include "fuzz_common.hpp"
#include "morse/mesh/nastran.hpp"

MORSE_FUZZ_TARGET(".bdf", { (void)morse::mesh::read_nastran(path, false); })
