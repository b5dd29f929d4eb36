// morse/core/error.hpp: the C++ error zone of morse.
//
// Everything that is not a PETSc callback throws morse::Error. PETSc calls are wrapped in
// MORSE_CALL(...), which turns a non-zero PetscErrorCode into a morse::Error carrying PETSc's
// message. Input errors that may be detected on a single rank are turned into collective
// exceptions with collective_check(), so that every rank throws the same message and no rank is
// left waiting in a collective call.
#pragma once

#include <petscsys.h>
#include <mpi.h>

#include <exception>
#include <sstream>
#include <stdexcept>
#include <string>

#ifndef PETSC_SUCCESS
#define PETSC_SUCCESS 0  // PETSc 3.18 compatibility
#endif

namespace morse {

/// The one exception type of morse. what() is a complete, user-readable message.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& msg) : std::runtime_error(msg) {}
};

/// Builds an error message from stream-able pieces: throw Error(cat("file ", f, " line ", n)).
template <class... T>
std::string cat(const T&... pieces) {
  std::ostringstream os;
  (os << ... << pieces);
  return os.str();
}

namespace detail {
[[noreturn]] void throw_petsc_error(PetscErrorCode ierr, const char* expr, const char* file, int line);
}

/// The message of an exception for the user: what() of a morse::Error or any std::exception, but
/// "out of memory: ..." for a std::bad_alloc (whose what() is a bare "std::bad_alloc"). Not
/// collective.
std::string message_of(const std::exception& e);

/// Collective verdict. Every rank of comm passes its own (possibly empty) error message; if any
/// rank has a message, every rank throws Error with the message of the lowest such rank.
/// Collective on comm.
void collective_check(MPI_Comm comm, const std::string& local_error);

/// Collective logical OR of a local flag.  Collective on comm.
bool any_rank(MPI_Comm comm, bool flag);

}  // namespace morse

/// Calls a PETSc function and throws morse::Error if it fails.
#define MORSE_CALL(...)                                                                                 \
  do {                                                                                                  \
    PetscErrorCode morse_ierr_ = (__VA_ARGS__);                                                         \
    if (morse_ierr_) ::morse::detail::throw_petsc_error(morse_ierr_, #__VA_ARGS__, __FILE__, __LINE__); \
  } while (0)

/// Throws morse::Error(message pieces...) if cond is false. Not collective.
#define MORSE_CHECK(cond, ...)                                    \
  do {                                                            \
    if (!(cond)) throw ::morse::Error(::morse::cat(__VA_ARGS__)); \
  } while (0)
