// Sparse all-to-all of int64 words: rank r sends send[q] to each rank q and receives, per source
// rank, the words sent to it. Collective.
#pragma once

#include <mpi.h>

#include <cstdint>
#include <vector>

namespace morse::detail {

/// Received words, concatenated by source rank; recv[q] spans [offset[q], offset[q + 1]).
struct Received {
  std::vector<std::int64_t> words;
  std::vector<int> offset;
};

inline Received exchange(MPI_Comm comm, const std::vector<std::vector<std::int64_t>>& send) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  std::vector<int> sn(size), rn(size), sd(size + 1, 0);
  Received r;
  r.offset.assign(size + 1, 0);
  for (int q = 0; q < size; ++q) sn[q] = static_cast<int>(send[q].size());
  MPI_Alltoall(sn.data(), 1, MPI_INT, rn.data(), 1, MPI_INT, comm);
  for (int q = 0; q < size; ++q) {
    sd[q + 1] = sd[q] + sn[q];
    r.offset[q + 1] = r.offset[q] + rn[q];
  }
  std::vector<std::int64_t> sbuf(sd[size]);
  for (int q = 0; q < size; ++q) std::copy(send[q].begin(), send[q].end(), sbuf.begin() + sd[q]);
  r.words.resize(r.offset[size]);
  MPI_Alltoallv(sbuf.data(), sn.data(), sd.data(), MPI_INT64_T, r.words.data(), rn.data(), r.offset.data(), MPI_INT64_T,
                comm);
  return r;
}

}  // namespace morse::detail
