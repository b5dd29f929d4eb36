# The libraries morse's sources need, found once for the main build (CMakeLists.txt) and for the
# fuzz targets (bench/fuzz/CMakeLists.txt): MPI, PETSc, SLEPc, HDF5 (PETSc.pc does not carry its
# include directory), METIS, LAPACK and BLAS. Sets MORSE_DEP_LIBRARIES (link) and
# METIS_INCLUDE_DIR (a private include directory of the sources).
find_package(MPI REQUIRED COMPONENTS C CXX)
find_package(PkgConfig REQUIRED)
pkg_check_modules(PETSC REQUIRED IMPORTED_TARGET PETSc)
pkg_check_modules(SLEPC REQUIRED IMPORTED_TARGET SLEPc)
pkg_check_modules(HDF5MPI REQUIRED IMPORTED_TARGET hdf5-openmpi)
find_path(METIS_INCLUDE_DIR metis.h REQUIRED)
find_library(METIS_LIBRARY metis REQUIRED)
find_package(LAPACK REQUIRED)
find_package(BLAS REQUIRED)
set(MORSE_DEP_LIBRARIES PkgConfig::SLEPC PkgConfig::PETSC PkgConfig::HDF5MPI MPI::MPI_CXX ${METIS_LIBRARY}
    LAPACK::LAPACK BLAS::BLAS)
