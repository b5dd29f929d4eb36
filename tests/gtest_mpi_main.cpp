// gtest main for MPI: initializes morse::Session, silences output on ranks > 0 and makes the
// verdict collective (every rank fails if one fails).
#include <gtest/gtest.h>

#include "morse/core/session.hpp"

int main(int argc, char** argv) {
  morse::use_huge_pages(argv);
  ::testing::InitGoogleTest(&argc, argv);
  int result = 0;
  {
    morse::Session session(&argc, &argv);
    int rank = morse::world_rank();
    if (rank != 0) {
      auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
      delete listeners.Release(listeners.default_result_printer());
    }
    int local = RUN_ALL_TESTS();
    MPI_Allreduce(&local, &result, 1, MPI_INT, MPI_MAX, PETSC_COMM_WORLD);
  }
  return result;
}
