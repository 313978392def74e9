// Output files (issue 13, item 1): devices, FIFOs, symlinks, modes, read-only files, hard
// links, outputs that are inputs, full disks, temporary files removed on errors.
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <csignal>
#include <unistd.h>

#include <fmt/format.h>

#include <cstdlib>
#include <cstring>
#include <functional>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "temp_dir.hpp"
#include "test_util.hpp"
#include "hysteron/plant.hpp"
#include "hysteron/error.hpp"
#include "hysteron/io/files.hpp"
#include "hysteron/io/table.hpp"

namespace fs = std::filesystem;
namespace io = hysteron::io;
using hysteron::Error;

namespace {

using hysteron::test::TempDir;

using hysteron::test::slurp;

void put(const std::string& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

// Files in dir whose names contain ".tmp-" (the temporary files of write_file_atomically).
std::vector<std::string> temp_files(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) out.push_back(e.path().string());
  return out;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(OutputFiles, DeviceNodeIsWrittenNotReplaced) {
  if (::geteuid() != 0) GTEST_SKIP() << "mknod needs root: device-node case not tested";
  TempDir d;
  const std::string dev = d.file("null");
  ASSERT_EQ(::mknod(dev.c_str(), S_IFCHR | 0666, ::makedev(1, 3)), 0) << "mknod /dev/null twin failed";
  io::write_columns(dev, {"a", "b"}, {{1, 2, 3}, {4, 5, 6}});
  io::write_text_file(dev, "text\n");
  io::write_columns(d.file("null") , {"a"}, {{1.0}});
  struct stat st {};
  ASSERT_EQ(::lstat(dev.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode)) << "the device node was replaced";
  EXPECT_EQ(::major(st.st_rdev), 1u);
  EXPECT_EQ(::minor(st.st_rdev), 3u);
  EXPECT_TRUE(temp_files(d.path()).empty());
  // /dev/null itself, as the issue reported
  io::write_text_file("/dev/null", "x\n");
  ASSERT_EQ(::lstat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

TEST(OutputFiles, FifoIsWrittenDirectly) {
  TempDir d;
  const std::string fifo = d.file("pipe.csv");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string got;
  std::thread reader([&] { got = slurp(fifo); });
  io::write_columns(fifo, {"x", "y"}, {{1, 2}, {3, 4}});
  reader.join();
  EXPECT_EQ(got, "x,y\n1,3\n2,4\n");
  struct stat st {};
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_TRUE(temp_files(d.path()).empty());
}

TEST(OutputFiles, SymlinkTargetIsReplacedLinkStays) {
  TempDir d;
  fs::create_directory(d.path() / "real");
  put(d.file("real/data.csv"), "old\n");
  fs::create_symlink("real/data.csv", d.path() / "link.csv");
  io::write_text_file(d.file("link.csv"), "new\n");
  EXPECT_TRUE(fs::is_symlink(d.path() / "link.csv"));
  EXPECT_EQ(slurp(d.file("real/data.csv")), "new\n");
  EXPECT_TRUE(temp_files(d.path() / "real").empty());
  // a dangling link: its target is created
  fs::create_symlink("real/new.csv", d.path() / "dangling.csv");
  io::write_text_file(d.file("dangling.csv"), "created\n");
  EXPECT_TRUE(fs::is_symlink(d.path() / "dangling.csv"));
  EXPECT_EQ(slurp(d.file("real/new.csv")), "created\n");
}

TEST(OutputFiles, ModeIsKept) {
  TempDir d;
  const std::string f = d.file("secret.csv");
  put(f, "old\n");
  ASSERT_EQ(::chmod(f.c_str(), 0600), 0);
  io::write_columns(f, {"a"}, {{1.0}});
  struct stat st {};
  ASSERT_EQ(::stat(f.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0600u);
  const std::string m = d.file("secret.mat");
  io::write_columns(m, {"a"}, {{1.0}});
  ASSERT_EQ(::chmod(m.c_str(), 0640), 0);
  io::write_columns(m, {"a"}, {{2.0}});
  ASSERT_EQ(::stat(m.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
}

TEST(OutputFiles, ReadOnlyFileIsRefusedAndUntouched) {
  TempDir d;
  const std::string f = d.file("ro.csv");
  put(f, "keep me\n");
  ASSERT_EQ(::chmod(f.c_str(), 0444), 0);
  const std::string e = error_of([&] { io::write_columns(f, {"a"}, {{1.0}}); });
  EXPECT_NE(e.find(f), std::string::npos) << e;
  EXPECT_NE(e.find("read-only (mode 444)"), std::string::npos) << e;
  EXPECT_EQ(slurp(f), "keep me\n");
  EXPECT_TRUE(temp_files(d.path()).empty());
}

TEST(OutputFiles, HardLinksAreKept) {
  TempDir d;
  const std::string f = d.file("a.csv"), g = d.file("b.csv");
  put(f, "old\n");
  fs::create_hard_link(f, g);
  io::write_columns(f, {"x"}, {{1.5}});
  EXPECT_EQ(fs::hard_link_count(f), 2u);
  EXPECT_EQ(slurp(g), "x\n1.5\n");
  EXPECT_TRUE(temp_files(d.path()).empty());
}

TEST(OutputFiles, ErrorsLeaveNoTemporaryFileAndTheOldFile) {
  TempDir d;
  const std::string f = d.file("out.csv");
  put(f, "old\n");
  EXPECT_THROW(io::write_file_atomically(f, [](const std::string&) { throw Error("boom"); }), Error);
  EXPECT_THROW(io::write_file_atomically(f, [](const std::string&) { throw std::runtime_error("boom"); }),
               std::runtime_error);
  EXPECT_EQ(slurp(f), "old\n");
  EXPECT_TRUE(temp_files(d.path()).empty());
}

// A FileBatch: nothing replaced until commit(); the temporary files complete meanwhile (and
// removed if the batch is dropped); symbolic links and hard links kept as without a batch.
TEST(OutputFiles, BatchReplacesTheFilesTogether) {
  TempDir d;
  const std::string a = d.file("a.txt"), b = d.file("b.txt"), target = d.file("target.txt"),
                    link = d.file("link.txt"), twin = d.file("twin.txt");
  put(a, "old a\n");
  put(target, "old target\n");
  fs::create_symlink(target, link);
  fs::create_hard_link(a, twin);
  {
    io::FileBatch batch;
    io::write_text_file(a, "new a\n");
    io::write_text_file(b, "new b\n");
    io::write_text_file(link, "new target\n");
    EXPECT_EQ(slurp(a), "old a\n");
    EXPECT_FALSE(fs::exists(b));
    EXPECT_EQ(temp_files(d.path()).size(), 3u);  // complete, waiting
    EXPECT_THROW(io::FileBatch nested, Error);
    batch.commit();
  }
  EXPECT_EQ(slurp(a), "new a\n");
  EXPECT_EQ(slurp(twin), "new a\n");  // the hard link kept
  EXPECT_EQ(slurp(b), "new b\n");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(slurp(target), "new target\n");
  EXPECT_TRUE(temp_files(d.path()).empty());
  // an error in the batch: nothing replaced, no temporary file left
  try {
    io::FileBatch batch;
    io::write_text_file(a, "newer a\n");
    io::write_file_atomically(b, [](const std::string&) { throw Error("boom"); });
    batch.commit();
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("boom"), std::string::npos);
  }
  EXPECT_EQ(slurp(a), "new a\n");
  EXPECT_EQ(slurp(b), "new b\n");
  EXPECT_TRUE(temp_files(d.path()).empty());
  // without a batch (after one) files are replaced at once again
  io::write_text_file(a, "a again\n");
  EXPECT_EQ(slurp(a), "a again\n");
}

TEST(OutputFiles, RemoveTemporaryFilesRemovesLiveOnes) {
  TempDir d;
  const std::string f = d.file("out.csv");
  std::string seen;
  io::write_file_atomically(f, [&](const std::string& tmp) {
    put(tmp, "partial");
    seen = tmp;
    ASSERT_TRUE(fs::exists(tmp));
    io::remove_temporary_files();  // what the CLI's signal handler does
    EXPECT_FALSE(fs::exists(tmp));
    put(tmp, "done\n");  // (recreated so that this write can finish)
  });
  EXPECT_EQ(slurp(f), "done\n");
  EXPECT_NE(seen.find("/.out.csv.tmp-"), std::string::npos) << seen;
}

// A batch of more than 64 files (a user's many references): every temporary file is removed by
// the handler's call, however many are waiting (the registry once had 64 fixed slots).
TEST(OutputFiles, RemoveTemporaryFilesRemovesEveryFileOfALargeBatch) {
  TempDir d;
  constexpr int kFiles = 100;
  std::size_t waiting = 0;
  {
    io::FileBatch batch;
    for (int i = 0; i < kFiles - 1; ++i) io::write_text_file(d.file(fmt::format("f{}.csv", i)), "x\n");
    io::write_file_atomically(d.file("last.csv"), [&](const std::string& tmp) {
      put(tmp, "partial");
      waiting = temp_files(d.path()).size();
      io::remove_temporary_files();  // what the CLI's signal handler does
      EXPECT_TRUE(temp_files(d.path()).empty()) << temp_files(d.path()).size() << " left";
      put(tmp, "done\n");
    });
  }  // dropped without commit()
  EXPECT_EQ(waiting, static_cast<std::size_t>(kFiles));
  EXPECT_TRUE(temp_files(d.path()).empty());
  EXPECT_TRUE(fs::is_empty(d.path()));
}

// The same through a real SIGINT in a child process whose handler is the CLI's (remove, re-raise):
// it dies by the signal, and neither a temporary file nor a target is left.
TEST(OutputFiles, SignalDuringALargeBatchLeavesNoTemporaryFile) {
  TempDir d;
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    struct sigaction sa {};
    sa.sa_handler = [](int sig) {
      io::remove_temporary_files();
      std::signal(sig, SIG_DFL);
      std::raise(sig);
    };
    ::sigaction(SIGINT, &sa, nullptr);
    io::FileBatch batch;
    for (int i = 0; i < 100; ++i) io::write_text_file(d.file(fmt::format("f{}.csv", i)), "x\n");
    std::raise(SIGINT);  // before commit()
    batch.commit();
    std::_Exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGINT) << status;
  EXPECT_TRUE(temp_files(d.path()).empty()) << temp_files(d.path()).size() << " left";
  EXPECT_TRUE(fs::is_empty(d.path()));
}

// A TemporaryPath (the plots' gnuplot directory and its files): removed by the handler's call,
// files before their directory; after its destruction no longer (its owner removes it).
TEST(OutputFiles, TemporaryPathsAreRemovedFilesFirst) {
  TempDir d;
  const std::string dir = d.file("plotdir"), f1 = dir + "/plot.gp", f2 = dir + "/gnuplot.log";
  fs::create_directory(dir);
  {
    io::TemporaryPath reg_dir(dir, true);
    io::TemporaryPath reg1(f1), reg2(f2);
    put(f1, "set term svg\n");
    put(f2, "");
    io::remove_temporary_files();
    EXPECT_FALSE(fs::exists(f1));
    EXPECT_FALSE(fs::exists(f2));
    EXPECT_FALSE(fs::exists(dir));
  }
  fs::create_directory(dir);
  put(f1, "kept\n");
  { io::TemporaryPath gone(f1); }
  io::remove_temporary_files();
  EXPECT_EQ(slurp(f1), "kept\n");
}

TEST(OutputFiles, FullDeviceFailsDirectWrites) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  const std::string e = error_of([] { io::write_text_file("/dev/full", std::string(100000, 'x')); });
  EXPECT_NE(e.find("/dev/full"), std::string::npos) << e;
  EXPECT_NE(e.find("No space left"), std::string::npos) << e;
  EXPECT_NE(error_of([] { io::write_columns("/dev/full", {"a"}, {std::vector<double>(100000, 1.0)}); }),
            "(no error)");
}

// A small tmpfs holding an existing output: a write that does not fit fails and the old file
// stays byte-identical (root only; skipped if mount fails).
TEST(OutputFiles, FullFilesystemKeepsTheOldFile) {
  TempDir d;
  const std::string mnt = d.file("small");
  fs::create_directory(mnt);
  if (::mount("tmpfs", mnt.c_str(), "tmpfs", 0, "size=64k") != 0)
    GTEST_SKIP() << "cannot mount a 64 KiB tmpfs (" << std::strerror(errno) << "): full-disk case not tested";
  struct Unmount {
    std::string p;
    ~Unmount() { ::umount2(p.c_str(), MNT_DETACH); }
  } unmount{mnt};
  const std::string csv = mnt + "/out.csv", mat = mnt + "/out.mat";
  io::write_columns(csv, {"a"}, {{1, 2, 3}});
  io::write_columns(mat, {"a"}, {{1, 2, 3}});
  const std::string old_csv = slurp(csv), old_mat = slurp(mat);
  std::vector<double> big(20000);
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = 1.0 / (static_cast<double>(i) + 3.0);  // incompressible-ish
  const std::string e1 = error_of([&] { io::write_columns(csv, {"a"}, {big}); });
  EXPECT_NE(e1.find(csv), std::string::npos) << e1;
  const std::string e2 = error_of([&] { io::write_columns(mat, {"a", "b"}, {big, big}); });
  EXPECT_NE(e2.find(mat), std::string::npos) << e2;
  EXPECT_EQ(slurp(csv), old_csv);
  EXPECT_EQ(slurp(mat), old_mat);
  EXPECT_TRUE(temp_files(mnt).empty());
}

TEST(OutputFiles, OutputThatIsAnInputIsRefused) {
  TempDir d;
  const std::string data = d.file("d.csv");
  put(data, "x,y\n1,2\n");
  fs::create_symlink(data, d.path() / "link.csv");
  fs::create_hard_link(data, d.path() / "hard.csv");
  for (const std::string& out : {data, d.file("link.csv"), d.file("hard.csv"), d.file("./d.csv")}) {
    const std::string e = error_of([&] { io::check_outputs_distinct({{"--out", out}}, {{"--data", data}}); });
    EXPECT_NE(e.find("--out " + out + " and --data " + data + " are the same file"), std::string::npos) << e;
  }
  // outputs: the same existing file, or the same new path
  EXPECT_NE(error_of([&] { io::check_outputs_distinct({{"--out", data}, {"--report", d.file("hard.csv")}}, {}); }),
            "(no error)");
  EXPECT_NE(error_of([&] {
              io::check_outputs_distinct({{"--out", d.file("new.json")}, {"--report", d.file("./new.json")}}, {});
            }),
            "(no error)");
  // distinct files, "-", empty paths and devices pass
  io::check_outputs_distinct({{"--out", d.file("m.json")}, {"--report", ""}}, {{"--data", data}, {"--model", "-"}});
  io::check_outputs_distinct({{"--out", "/dev/null"}, {"--report", "/dev/null"}}, {{"--data", "/dev/null"}});
  EXPECT_EQ(slurp(data), "x,y\n1,2\n");
}

// save_rig_params goes through the same writer (it used a plain std::ofstream: as root it wrote
// into a read-only file, replaced nothing atomically and followed no rules for devices).
TEST(OutputFiles, RigParametersAreWrittenThroughTheSafeWriter) {
  TempDir dir;
  hysteron::PamRigParams p;
  p.load.mass = 12.5;
  const std::string ro = dir.file("ro.json");
  put(ro, "precious\n");
  ::chmod(ro.c_str(), 0444);
  const std::string msg = hysteron::test::error_of([&] { hysteron::save_rig_params(p, ro); });
  EXPECT_TRUE(hysteron::test::has(msg, "is read-only")) << msg;
  EXPECT_EQ(slurp(ro), "precious\n");
  // invalid parameters: refused, named after the file, nothing created
  hysteron::PamRigParams bad = p;
  bad.load.mass = -1;
  const std::string msg2 = hysteron::test::error_of([&] { hysteron::save_rig_params(bad, dir.file("bad.json")); });
  EXPECT_TRUE(hysteron::test::has(msg2, "bad.json.load.mass")) << msg2;
  // a mode-600 file stays 600 and reads back
  const std::string ok = dir.file("ok.json");
  put(ok, "{}");
  ::chmod(ok.c_str(), 0600);
  hysteron::save_rig_params(p, ok);
  struct stat st {};
  ASSERT_EQ(::stat(ok.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(hysteron::load_rig_params(ok).load.mass, 12.5);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"ok.json", "ro.json"}));
}
