// Shared fixture of the serial reader tests: a fresh scratch directory per test and rank, and the
// check that a call throws a morse::Error naming every expected part.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>

#include "morse/core/error.hpp"
#include "morse/core/session.hpp"

namespace morse::test {

/// /tmp/morse_test_<tag>_r<rank>_p<pid>_<test name>, created empty before each test and removed
/// after it. Every rank has its own directory (the tests it serves are serial).
class ScratchDirTest : public ::testing::Test {
 protected:
  explicit ScratchDirTest(std::string tag) : tag_(std::move(tag)) {}
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::path("/tmp") / cat("morse_test_", tag_, "_r", world_rank(), "_p", getpid(), "_", info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  /// Path of rel inside the scratch directory.
  std::string path(const std::string& rel) const { return (dir_ / rel).string(); }
  /// Writes text (or bytes) to rel, creating subdirectories, and returns the path.
  std::string write(const std::string& rel, const std::string& text) const {
    const auto p = dir_ / rel;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }

  std::filesystem::path dir_;

 private:
  std::string tag_;
};

/// Expects f() to throw a morse::Error whose message contains every part; `what` names the call
/// in the failure message.
template <class F>
void expect_error_parts(F f, std::initializer_list<std::string> parts, const std::string& what) {
  try {
    f();
    ADD_FAILURE() << "no error: " << what;
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const std::string& part : parts) EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
  }
}

}  // namespace morse::test
