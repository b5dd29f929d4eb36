// The process set-up of morse::use_huge_pages (called first in the test main, as in morse's).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include "morse/core/session.hpp"

namespace {

std::string read(const char* path) {
  std::ifstream f(path);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// kB of anonymous memory of this process on transparent huge pages, or -1 if unknown.
long anon_huge_kb() {
  std::ifstream f("/proc/self/smaps_rollup");
  std::string key;
  long kb = -1;
  std::string unit;
  while (f >> key) {
    if (key == "AnonHugePages:") {
      f >> kb;
      return kb;
    }
  }
  return -1;
}

}  // namespace

// Where the kernel offers huge pages on request, the re-exec happened (the variable is set and
// the arguments survived it: gtest parsed them), and a large block freshly allocated and touched
// lands on huge pages.
TEST(Session, HeapOnHugePages) {
  const std::string mode = read("/sys/kernel/mm/transparent_hugepage/enabled");
  const char* off = std::getenv("MORSE_HUGEPAGES");
  if (mode.find("[madvise]") == std::string::npos && mode.find("[always]") == std::string::npos)
    GTEST_SKIP() << "transparent huge pages not offered: " << mode;
  if (off && std::strcmp(off, "0") == 0) GTEST_SKIP() << "MORSE_HUGEPAGES=0";
  const char* t = std::getenv("GLIBC_TUNABLES");
  if (t && std::strstr(t, "glibc.malloc.hugetlb") && !morse::huge_pages_requested())
    GTEST_SKIP() << "the user's GLIBC_TUNABLES=" << t << " chose otherwise";
  ASSERT_TRUE(morse::huge_pages_requested()) << "GLIBC_TUNABLES: " << (std::getenv("GLIBC_TUNABLES") ?: "(unset)");
  const long before = anon_huge_kb();
  if (before < 0) GTEST_SKIP() << "no /proc/self/smaps_rollup";
  const std::size_t bytes = 64u << 20;
  auto* p = static_cast<volatile char*>(std::malloc(bytes));
  ASSERT_NE(p, nullptr);
  for (std::size_t i = 0; i < bytes; i += 4096) p[i] = 1;
  const long after = anon_huge_kb();
  std::free(const_cast<char*>(p));
  // At least half of the 64 MB block on 2 MB pages (its ends may be unaligned; the kernel may
  // fall back to small pages when memory is fragmented, which a fresh test process is not).
  EXPECT_GE(after - before, 32L * 1024) << "AnonHugePages " << before << " -> " << after << " kB";
}

// MORSE_HUGEPAGES=0 is respected, and a user's own setting is never looped on: calling it again
// (the variable now set) returns without re-executing.
TEST(Session, HugePagesNoLoop) {
  char self[] = "test_session";
  char* argv[] = {self, nullptr};
  morse::use_huge_pages(argv);  // returns: either off, not offered, or already requested
  SUCCEED();
}
