// src/eigen/detail/testing.hpp: fault injection for the tests of the eigen solvers (private: the
// tests include it, the library never sets it).
#pragma once

#include <petscsys.h>

namespace morse::eigen::detail {

/// Pairs dropped before the Sylvester check, which must then fail: the highest of a cutoff solve
/// (or count by slicing, or the highest block slice), the lowest of a count solve with one
/// shift. 0 in production. Process-wide; set it through DropForTest around the solve of a test.
PetscInt& drop_for_test();

/// Sets drop_for_test() for its lifetime and restores the previous value.
class DropForTest {
 public:
  explicit DropForTest(PetscInt n) : old_(drop_for_test()) { drop_for_test() = n; }
  ~DropForTest() { drop_for_test() = old_; }
  DropForTest(const DropForTest&) = delete;
  DropForTest& operator=(const DropForTest&) = delete;

 private:
  PetscInt old_;
};

}  // namespace morse::eigen::detail
