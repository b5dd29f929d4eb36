// Fuzz target: Abaqus / CalculiX .inp reader (mesh::read_abaqus).
#include "fuzz_common.hpp"
#include "morse/mesh/abaqus.hpp"

MORSE_FUZZ_TARGET(".inp", { (void)morse::mesh::read_abaqus(path, false); })
