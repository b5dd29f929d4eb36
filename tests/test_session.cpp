// The process set-up of morse::use_huge_pages (called first in the test main, as in morse's).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <new>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/log.hpp"
#include "morse/core/session.hpp"
#include "scratch.hpp"

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
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer replaces glibc's malloc: glibc.malloc.hugetlb does not apply";
#endif
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

// The options files are checked before PETSc reads them: a file that includes itself, directly or
// through another, is refused naming the chain (PETSc would recurse until the stack overflows); a
// missing file, a directory and a -options_file without a name give one line naming the file;
// nested, valid files and a file included twice (not a cycle) pass.
TEST(Session, OptionsFileChecks) {
  morse::test::ScratchDir tmp("options_files");
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(tmp.path(name)) << text;
    return tmp.path(name);
  };
  auto error = [](std::vector<std::string> args) {
    args.insert(args.begin(), "morse");
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    return morse::options_file_error(static_cast<int>(args.size()), argv.data());
  };
  const std::string self = tmp.path("self.opts");
  write("self.opts", "# a comment\n-modes_nev 3\n-options_file " + self + "\n");
  EXPECT_EQ(error({"modes", "-options_file", self}),
            "options file " + self + " includes itself (" + self + ":3: -options_file " + self + ")");
  const std::string a = tmp.path("a.opts"), b = tmp.path("b.opts");
  write("a.opts", "-options_file\t" + b + "   # to b\n");
  write("b.opts", "-modes_nev 3\n-OPTIONS_FILE " + a + "\n");
  EXPECT_EQ(error({"-options_file", a}), "options files include each other: " + a + " -> " + b + " -> " + a);
  EXPECT_EQ(error({"-options_file", b}), "options files include each other: " + b + " -> " + a + " -> " + b);
  const std::string nope = tmp.path("nope.opts");
  EXPECT_EQ(error({"-options_file", nope}), "-options_file " + nope + ": cannot open (No such file or directory)");
  const std::string m = write("m.opts", "-modes_nev 3\n\n-options_file " + nope + "\n");
  EXPECT_EQ(error({"-mesh", "x.msh", "-options_file", m}),
            m + ":3: -options_file " + nope + ": cannot open (No such file or directory)");
  EXPECT_EQ(error({"-options_file", tmp.dir().string()}),
            "-options_file " + tmp.dir().string() + ": is a directory, not an options file");
  EXPECT_EQ(error({"-options_file"}), "-options_file needs a file name");
  EXPECT_EQ(error({"-options_file", "-modes_nev", "3"}), "-options_file needs a file name");
  const std::string e = write("e.opts", "-options_file\n");
  EXPECT_EQ(error({"-options_file", e}), e + ":1: -options_file needs a file name");
  // Valid: nested files, one file included twice (a diamond, no cycle), a commented-out include.
  const std::string leaf = write("leaf.opts", "-modes_nev 2\n");
  const std::string mid = write("mid.opts", "-options_file " + leaf + "\n# -options_file " + nope + "\n");
  const std::string top = write("top.opts", "-options_file " + mid + "\n-options_file " + leaf + "\n");
  EXPECT_EQ(error({"modes", "-options_file", top, "-options_file", leaf}), "");
  EXPECT_EQ(error({"modes", "-modes_nev", "3"}), "");
  // More options than PETSc's database holds ("Out of memory" in PETSc): refused naming the file.
  std::string many;
  for (int i = 0; i < 100000; ++i) many += morse::cat("-opt", i, " ", -i, "\n");
  const std::string big = write("big.opts", many);
  EXPECT_EQ(
      error({"modes", "-modes_nev", "3", "-options_file", big}),
      morse::cat("100002 options given (100000 in ", big, "): PETSc's options database holds at most 512, and morse's ",
                 "solvers add their defaults; give at most ", morse::kMaxGivenOptions));
}

// Sizes checked before allocating: the memory available is known on Linux, a need above it is
// refused naming what needs it and what is available, and a std::bad_alloc that escapes anyway
// is reported as "out of memory", not as a bare "std::bad_alloc".
TEST(Session, MemoryChecksAndOutOfMemoryMessage) {
  const double avail = morse::available_bytes();
  ASSERT_GT(avail, 0) << "no MemAvailable in /proc/meminfo";
  EXPECT_EQ(morse::memory_error("a small thing", 1e3, "its bytes"), "");
  const std::string err = morse::memory_error("nlrom r = 324", 1e18, "the cubic tensor");
  EXPECT_EQ(err.rfind("nlrom r = 324 needs 1e+03 PB for the cubic tensor; ", 0), 0u) << err;
  EXPECT_NE(err.find(" available"), std::string::npos) << err;
  EXPECT_NO_THROW(morse::check_memory(PETSC_COMM_WORLD, "a small thing", 1e3, "its bytes"));
  try {
    morse::check_memory(PETSC_COMM_WORLD, "a huge thing", 1e18, "its bytes");
    ADD_FAILURE() << "no error for 1 EB";
  } catch (const morse::Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("a huge thing needs ", 0), 0u) << e.what();
  }
  EXPECT_EQ(morse::message_of(std::bad_alloc()).rfind("out of memory: an allocation failed (std::bad_alloc)", 0), 0u);
  EXPECT_EQ(morse::message_of(morse::Error("plain")), "plain");
}
