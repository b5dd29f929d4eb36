// Fuzz target: Gmsh .msh reader (mesh::read_gmsh).
#include "fuzz_common.hpp"
#include "morse/mesh/gmsh.hpp"

MORSE_FUZZ_TARGET(".msh", { (void)morse::mesh::read_gmsh(path); })
