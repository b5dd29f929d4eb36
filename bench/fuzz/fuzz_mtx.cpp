// Fuzz target: MatrixMarket reader (io::read_matrix on PETSC_COMM_SELF).
#include "fuzz_common.hpp"
#include "morse/io/matrices.hpp"

MORSE_FUZZ_TARGET(".mtx", { (void)morse::io::read_matrix(PETSC_COMM_SELF, path, "fuzz"); })
