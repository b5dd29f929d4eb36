// Fuzz target: /nlrom stored model reader (nlrom::read_stored_model on PETSC_COMM_SELF).
#include "fuzz_common.hpp"
#include "morse/nlrom/nlrom.hpp"

MORSE_FUZZ_TARGET(".h5", { (void)morse::nlrom::read_stored_model(PETSC_COMM_SELF, path, {}); })
