#include "morse/core/error.hpp"

#include <new>
#include <vector>

namespace morse {
namespace detail {

void throw_petsc_error(PetscErrorCode ierr, const char* expr, const char* file, int line) {
  const char* text = nullptr;
  char* specific = nullptr;
  PetscErrorMessage(ierr, &text, &specific);
  // A bad option value (an unknown enum choice, a value out of range) is the user's input: its
  // message names the option; PETSc's code and morse's source line would only bury it.
  const bool input = ierr == PETSC_ERR_USER || ierr == PETSC_ERR_USER_INPUT || ierr == PETSC_ERR_ARG_OUTOFRANGE ||
                     ierr == PETSC_ERR_ARG_WRONG;
  if (input && specific && *specific) {
    std::string m = specific;
    while (!m.empty() && (m.back() == ' ' || m.back() == '\n')) m.pop_back();
    throw Error(m);
  }
  std::string msg = cat("PETSc error ", ierr, " (", text ? text : "unknown", ")");
  if (specific && *specific) msg += cat(": ", specific);
  msg += cat("\n  in ", expr, " at ", file, ":", line);
  throw Error(msg);
}

}  // namespace detail

std::string message_of(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e))
    return cat("out of memory: an allocation failed (", e.what(),
               "); the run needs more memory than this machine has available (a smaller problem, fewer ranks per "
               "node, or more nodes)");
  return e.what();
}

void collective_check(MPI_Comm comm, const std::string& local_error) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  int mine = local_error.empty() ? size : rank;
  int first = size;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == size) return;
  int len = rank == first ? static_cast<int>(local_error.size()) : 0;
  MPI_Bcast(&len, 1, MPI_INT, first, comm);
  std::vector<char> buf(local_error.begin(), local_error.end());
  buf.resize(len);
  MPI_Bcast(buf.data(), len, MPI_CHAR, first, comm);
  throw Error(std::string(buf.begin(), buf.end()));
}

bool any_rank(MPI_Comm comm, bool flag) {
  int in = flag ? 1 : 0, out = 0;
  MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_MAX, comm);
  return out != 0;
}

}  // namespace morse
