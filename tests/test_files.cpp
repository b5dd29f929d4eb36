// The output paths of a run (core/files.hpp): the start-of-run check against the inputs, the
// temporaries named with the process id, and the removal of the temporaries of killed runs.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "morse/core/error.hpp"
#include "morse/core/files.hpp"
#include "morse/core/session.hpp"
#include "morse/io/h5.hpp"
#include "scratch.hpp"

namespace fs = std::filesystem;
using namespace morse;

namespace {

class Files : public test::SharedScratchDirTest {
 protected:
  Files() : SharedScratchDirTest("files") {}
};

// A process id that runs nowhere: above the largest pid the kernel hands out.
long dead_pid() {
  long max = 4194304;
  std::ifstream("/proc/sys/kernel/pid_max") >> max;
  return max + 12345;
}

long rank0_pid() {
  long pid = getpid();
  MPI_Bcast(&pid, 1, MPI_LONG, 0, PETSC_COMM_WORLD);
  return pid;
}

std::string read_all(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

}  // namespace

// A serial writer's temporary carries its own pid; a collective writer's carries rank 0's on
// every rank (they all open it); an H5Output writes through it and leaves none.
TEST_F(Files, TemporariesCarryTheProcessId) {
  EXPECT_EQ(files::temp_path("a/b.h5"), cat("a/b.h5.tmp.", getpid()));
  EXPECT_EQ(files::temp_path(PETSC_COMM_WORLD, "a/b.h5"), cat("a/b.h5.tmp.", rank0_pid()));
  const std::string out = path("run.h5");
  {
    io::H5Output h(PETSC_COMM_WORLD, out);
    EXPECT_EQ(h.tmp_path(), cat(out, ".tmp.", rank0_pid()));
    if (world_rank() == 0) {
      EXPECT_TRUE(fs::exists(h.tmp_path()));
    }
    h.write("/x", std::vector<double>{1.0});
    h.commit();
  }
  if (world_rank() == 0) {
    EXPECT_TRUE(fs::exists(out));
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  }
  MPI_Barrier(PETSC_COMM_WORLD);
}

// An output that cannot be created is reported by the user's path, not by its temporary.
TEST_F(Files, AMissingDirectoryIsNamedByTheUsersPath) {
  const std::string out = path("no_such_dir/x.h5");
  try {
    io::H5Output h(PETSC_COMM_WORLD, out);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(out), std::string::npos) << m;
    EXPECT_EQ(m.find(".tmp"), std::string::npos) << m;
  }
  test::expect_error_parts(
      [&] {
        (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", out}}, {});
      },
      {"cannot write -out ", out, "the directory ", "does not exist"}, "missing directory");
}

// Symlinks, "./", "..", absolute and relative spellings and hard links of one file all match;
// an output that does not exist yet matches by its canonical directory and name.
TEST_F(Files, SameFileSeesThroughSpellings) {
  const std::string a = write("d/a.msh", "mesh");
  write("other.msh", "other");
  if (world_rank() == 0) {
    fs::create_symlink(a, path("link.msh"));
    fs::create_directory_symlink(dir_ / "d", path("dlink"));
    fs::create_hard_link(a, path("hard.msh"));
  }
  MPI_Barrier(PETSC_COMM_WORLD);
  EXPECT_TRUE(files::same_file(a, path("d/./a.msh")));
  EXPECT_TRUE(files::same_file(a, path("d/../d/a.msh")));
  EXPECT_TRUE(files::same_file(a, path("link.msh")));
  EXPECT_TRUE(files::same_file(a, path("dlink/a.msh")));
  EXPECT_TRUE(files::same_file(a, path("hard.msh")));
  EXPECT_FALSE(files::same_file(a, path("other.msh")));
  EXPECT_TRUE(files::same_file(path("d/new.h5"), path("dlink/./new.h5")));
  EXPECT_FALSE(files::same_file(path("d/new.h5"), path("d/new2.h5")));
  // Relative against absolute: from the working directory.
  const fs::path cwd = fs::current_path();
  fs::current_path(dir_ / "d");
  EXPECT_TRUE(files::same_file("a.msh", a));
  EXPECT_TRUE(files::same_file("./a.msh", path("link.msh")));
  EXPECT_TRUE(files::same_file("new.h5", path("d/new.h5")));
  fs::current_path(cwd);
  MPI_Barrier(PETSC_COMM_WORLD);
}

// The start-of-run check refuses an output that is an input (naming the options and both paths),
// an empty name, a directory, a missing directory and two outputs that are one file, on every
// rank alike; a good output passes.
TEST_F(Files, PrepareOutputsRefusesBadOutputs) {
  const std::string mesh = write("m.msh", "mesh");
  const std::string rom = write("rom.h5", "rom");
  if (world_rank() == 0) fs::create_symlink(rom, path("romlink.h5"));
  MPI_Barrier(PETSC_COMM_WORLD);
  const std::vector<files::Named> inputs{{"-mesh", mesh}, {"-rom", rom}, {"-sim", ""}};
  test::expect_error_parts(
      [&] {
        (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", path("./m.msh")}}, inputs);
      },
      {"-out ", path("./m.msh"), "is the input file -mesh ", mesh, "give another -out"}, "-out = -mesh");
  test::expect_error_parts(
      [&] {
        (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", path("romlink.h5")}}, inputs);
      },
      {"-out ", path("romlink.h5"), "-rom ", rom}, "-out = a symlink to -rom");
  test::expect_error_parts(
      [&] {
        (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", ""}}, inputs);
      },
      {"-out is empty"}, "empty -out");
  test::expect_error_parts(
      [&] {
        (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", dir_.string()}}, inputs);
      },
      {"-out ", dir_.string(), " is a directory"}, "directory -out");
  test::expect_error_parts(
      [&] {
        (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", path("d/")}}, inputs);
      },
      {"-out ", "is a directory"}, "-out ending in /");
  test::expect_error_parts(
      [&] {
        (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", path("x.h5")}, {"-matrices_write", path("./x.h5")}},
                                     {});
      },
      {"-out ", "-matrices_write ", "are the same output file"}, "two outputs");
  EXPECT_NO_THROW((void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", path("new.h5")}}, inputs));
  EXPECT_NO_THROW(
      (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", rom}}, {{"-mesh", mesh}}));  // an existing output
}

// Only "<out>.tmp.<digits>" is a temporary of <out>; it is removed when its process is gone or is
// this process (which has not written yet), kept while its process runs (a run writing <out> now).
TEST_F(Files, StaleTemporariesOfKilledRunsAreRemoved) {
  const std::string out = path("sweep.h5");
  const long dead = dead_pid();
  const std::string stale = write(cat("sweep.h5.tmp.", dead), "killed run");
  const std::string own = write(cat("sweep.h5.tmp.", rank0_pid()), "this process, earlier");
  const std::string live = write("sweep.h5.tmp.1", "init runs");
  const std::vector<std::string> kept{write("sweep.h5.tmp", "not the pattern"),
                                      write("sweep.h5.tmpx", "not the pattern"),
                                      write(cat("sweep.h5.tmp.", dead, "x"), "not the pattern"),
                                      write(cat("sweep.h5.tmp.", dead, ".h5"), "not the pattern"),
                                      write(cat("other.h5.tmp.", dead), "another output"),
                                      write(cat("xsweep.h5.tmp.", dead), "another output"),
                                      write("sweep.h5", "the output itself")};
  (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", out}}, {});
  MPI_Barrier(PETSC_COMM_WORLD);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_FALSE(fs::exists(own));
  EXPECT_TRUE(fs::exists(live));
  for (const auto& k : kept) EXPECT_TRUE(fs::exists(k)) << k;
  EXPECT_EQ(read_all(out), "the output itself");
  MPI_Barrier(PETSC_COMM_WORLD);
  // Serial: the removed files are returned (relative path in, relative names out).
  if (world_rank() == 0) {
    std::ofstream(path(cat("sweep.h5.tmp.", dead))) << "killed again";
    const fs::path cwd = fs::current_path();
    fs::current_path(dir_);
    EXPECT_EQ(files::remove_stale_temps("sweep.h5"), std::vector<std::string>{cat("sweep.h5.tmp.", dead)});
    EXPECT_TRUE(files::remove_stale_temps("sweep.h5").empty());
    fs::current_path(cwd);
  }
  MPI_Barrier(PETSC_COMM_WORLD);
}

// The lock of an output is refused to a second holder (a second open file description conflicts
// with flock even in one process), naming the output and the holder's pid, and granted again
// after release, which removes the lock file. Serial: one output per rank.
TEST_F(Files, OutputLockIsRefusedToASecondHolder) {
  const std::string out = path(cat("locked", world_rank(), ".h5"));
  const std::string lock_file = files::lock_path(out);
  EXPECT_EQ(lock_file, out + ".lock");
  files::OutputLock a;
  EXPECT_EQ(a.add({"-out", out}), "");
  EXPECT_EQ(a.paths(), std::vector<std::string>{out});
  EXPECT_EQ(read_all(lock_file).rfind(cat(getpid(), " "), 0), 0u) << read_all(lock_file);
  files::OutputLock b;
  EXPECT_EQ(b.add({"-out", out}), cat(out, " is being written by another morse run (pid ", getpid(),
                                      "); wait for it or choose another -out"));
  EXPECT_TRUE(b.paths().empty());
  a.release();
  EXPECT_FALSE(fs::exists(lock_file));
  EXPECT_EQ(b.add({"-out", out}), "");
  files::OutputLock c(std::move(b));  // moved: c holds it, b nothing
  EXPECT_TRUE(b.paths().empty());
  EXPECT_NE(a.add({"-out", out}), "");
  c.release();
  EXPECT_FALSE(fs::exists(lock_file));
  // A lock file left behind (its holder killed) does not block: only the lock does.
  std::ofstream(lock_file) << dead_pid() << " elsewhere\n";
  EXPECT_EQ(a.add({"-out", out}), "");
  a.release();
  MPI_Barrier(PETSC_COMM_WORLD);
}

// Another process holding the lock: refused while it lives (naming its pid), granted once it has
// died without releasing (the kernel drops the lock; its lock file stays and does not block).
TEST_F(Files, OutputLockOfADeadProcessIsFree) {
  const std::string out = path(cat("child", world_rank(), ".h5"));
  int to_parent[2], to_child[2];
  ASSERT_EQ(pipe(to_parent), 0);
  ASSERT_EQ(pipe(to_child), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {  // takes the lock, says so, waits for the parent, dies holding it
    close(to_parent[0]);
    close(to_child[1]);  // else the read below never sees the parent's close
    alarm(30);           // never outlive a hung test
    files::OutputLock l;
    const char ok = l.add({"-out", out}).empty() ? 'y' : 'n';
    if (::write(to_parent[1], &ok, 1) != 1) _exit(2);
    char c = 0;
    if (::read(to_child[0], &c, 1) < 0) _exit(3);
    _exit(0);
  }
  close(to_parent[1]);
  close(to_child[0]);
  char ok = 0;
  ASSERT_EQ(::read(to_parent[0], &ok, 1), 1);
  EXPECT_EQ(ok, 'y');
  files::OutputLock mine;
  EXPECT_EQ(mine.add({"-out", out}),
            cat(out, " is being written by another morse run (pid ", child, "); wait for it or choose another -out"));
  close(to_child[1]);  // the child ends
  close(to_parent[0]);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_TRUE(fs::exists(files::lock_path(out)));  // left by the dead holder
  EXPECT_EQ(mine.add({"-out", out}), "");
  MPI_Barrier(PETSC_COMM_WORLD);
}

// prepare_outputs returns the lock, held by rank 0 for the run: a second run on the same output
// is refused on every rank alike, naming the output and rank 0's pid; once the lock is gone the
// output may be written again, and its lock file is removed.
TEST_F(Files, PrepareOutputsLocksTheOutputs) {
  const std::string out = path("run_locked.h5");
  {
    const auto lock = files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", out}}, {});
    EXPECT_EQ(lock.paths(), world_rank() == 0 ? std::vector<std::string>{out} : std::vector<std::string>{});
    test::expect_error_parts(
        [&] {
          (void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", path("other.h5")}, {"-out", out}}, {});
        },
        {out, " is being written by another morse run (pid ", cat(rank0_pid()),
         "); wait for it or choose another -out"},
        "second run");
    // The refused run released the lock it had taken on the other output.
    if (world_rank() == 0) {
      EXPECT_FALSE(fs::exists(files::lock_path(path("other.h5"))));
    }
  }
  MPI_Barrier(PETSC_COMM_WORLD);
  if (world_rank() == 0) {
    EXPECT_FALSE(fs::exists(files::lock_path(out)));
  }
  EXPECT_NO_THROW((void)files::prepare_outputs(PETSC_COMM_WORLD, {{"-out", out}}, {}));
  MPI_Barrier(PETSC_COMM_WORLD);
}

// commit renames onto the output; a failed rename removes the temporary and names the output.
TEST_F(Files, CommitRenamesOrCleansUp) {
  if (world_rank() == 0) {
    const std::string out = path("c.txt");
    const std::string tmp = files::temp_path(out);
    std::ofstream(tmp) << "content";
    files::commit(tmp, out);
    EXPECT_EQ(read_all(out), "content");
    EXPECT_FALSE(fs::exists(tmp));
    const std::string bad = path("no_dir/c.txt"), tmp2 = files::temp_path(path("c2.txt"));
    std::ofstream(tmp2) << "x";
    test::expect_error_parts([&] { files::commit(tmp2, bad); }, {bad, "cannot rename"}, "commit into a missing dir");
    EXPECT_FALSE(fs::exists(tmp2));
  }
  MPI_Barrier(PETSC_COMM_WORLD);
}
