// Scratch directories of the tests (one per rank, or one shared by the ranks), as scope objects
// and as fixtures, and the check that a call throws a morse::Error naming every expected part.
#pragma once

#include <petscsys.h>
#include <gtest/gtest.h>
#include <mpi.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <memory>
#include <string>

#include "morse/core/error.hpp"
#include "morse/core/session.hpp"

namespace morse::test {

/// A fresh empty directory of this rank, /tmp/morse_test_<tag>_r<rank>_p<pid>, removed with its
/// content by the destructor. Not collective.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& tag)
      : dir_(std::filesystem::path("/tmp") / cat("morse_test_", tag, "_r", world_rank(), "_p", getpid())) {
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  /// Path of rel inside the directory.
  std::string path(const std::string& rel) const { return (dir_ / rel).string(); }
  /// Writes text (or bytes) to rel, creating subdirectories, and returns the path.
  std::string write(const std::string& rel, const std::string& text) const {
    const auto p = dir_ / rel;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }

 private:
  std::filesystem::path dir_;
};

/// A fresh empty directory shared by the ranks of PETSC_COMM_WORLD, /tmp/morse_test_<tag>_p<pid
/// of rank 0>: rank 0 creates it, and removes it once every rank is done with it (destructor).
/// Collective (constructor, destructor and write()).
class SharedScratchDir {
 public:
  explicit SharedScratchDir(const std::string& tag) {
    long pid = getpid();
    MPI_Bcast(&pid, 1, MPI_LONG, 0, PETSC_COMM_WORLD);
    dir_ = std::filesystem::path("/tmp") / cat("morse_test_", tag, "_p", pid);
    if (world_rank() == 0) {
      std::filesystem::remove_all(dir_);
      std::filesystem::create_directories(dir_);
    }
    MPI_Barrier(PETSC_COMM_WORLD);
  }
  ~SharedScratchDir() {
    MPI_Barrier(PETSC_COMM_WORLD);
    std::error_code ec;
    if (world_rank() == 0) std::filesystem::remove_all(dir_, ec);
  }
  SharedScratchDir(const SharedScratchDir&) = delete;
  SharedScratchDir& operator=(const SharedScratchDir&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  /// Path of rel inside the directory.
  std::string path(const std::string& rel) const { return (dir_ / rel).string(); }
  /// Rank 0 writes text to rel (creating subdirectories); every rank returns its path once it
  /// is written.
  std::string write(const std::string& rel, const std::string& text) const {
    const auto p = dir_ / rel;
    if (world_rank() == 0) {
      std::filesystem::create_directories(p.parent_path());
      std::ofstream(p, std::ios::binary) << text;
    }
    MPI_Barrier(PETSC_COMM_WORLD);
    return p.string();
  }

 private:
  std::filesystem::path dir_;
};

/// Fixture: a fresh scratch directory per test, `Dir` = ScratchDir (one per rank,
/// /tmp/morse_test_<tag>_<test name>_r<rank>_p<pid>) or SharedScratchDir (shared by the ranks,
/// /tmp/morse_test_<tag>_<test name>_p<pid of rank 0>; SetUp, TearDown and write() collective).
template <class Dir>
class BasicScratchDirTest : public ::testing::Test {
 protected:
  explicit BasicScratchDirTest(std::string tag) : tag_(std::move(tag)) {}
  void SetUp() override {
    scratch_ = std::make_unique<Dir>(cat(tag_, "_", ::testing::UnitTest::GetInstance()->current_test_info()->name()));
    dir_ = scratch_->dir();
  }
  void TearDown() override { scratch_.reset(); }

  /// Path of rel inside the scratch directory.
  std::string path(const std::string& rel) const { return scratch_->path(rel); }
  /// Writes text (or bytes) to rel (Dir::write) and returns the path.
  std::string write(const std::string& rel, const std::string& text) const { return scratch_->write(rel, text); }

  std::filesystem::path dir_;

 private:
  std::string tag_;
  std::unique_ptr<Dir> scratch_;
};

class ScratchDirTest : public BasicScratchDirTest<ScratchDir> {
 protected:
  using BasicScratchDirTest::BasicScratchDirTest;
};
class SharedScratchDirTest : public BasicScratchDirTest<SharedScratchDir> {
 protected:
  using BasicScratchDirTest::BasicScratchDirTest;
};

/// Path of rel in the shared data directory (the meshes that are not in the repository):
/// $MORSE_SHARED_DIR (ctest sets it), else ../shared beside the source tree. The file may be
/// absent: the tests that need it skip with a notice.
inline std::string shared_data_path(const std::string& rel) {
  const char* env = std::getenv("MORSE_SHARED_DIR");
  const std::string dir = env && *env ? env : MORSE_SOURCE_DIR "/../shared";
  return (std::filesystem::path(dir) / rel).string();
}

/// Expects f() to throw a morse::Error whose message contains every part; `what` names the call
/// in the failure message.
template <class F>
void expect_error_parts(F f, std::initializer_list<std::string> parts, const std::string& what) {
  try {
    f();
    ADD_FAILURE() << "no error: " << what;
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const std::string& part : parts)
      EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
  }
}

}  // namespace morse::test
