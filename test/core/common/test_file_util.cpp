// Files written as a whole: every failure is an error naming the file, and a failed write
// leaves the file that was there before.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <csignal>
#include <fstream>
#include <stdexcept>

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "../test_util.hpp"

namespace {

bool exists(const std::string& path) { return std::ifstream(path).good(); }

/// While alive, this process may write files of at most `bytes` (the kernel refuses more with
/// EFBIG, as a full disk refuses with ENOSPC); SIGXFSZ is ignored so that the write fails
/// instead of killing the test.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &saved_);
    handler_ = std::signal(SIGXFSZ, SIG_IGN);
    const rlimit small{bytes, saved_.rlim_max};
    setrlimit(RLIMIT_FSIZE, &small);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &saved_);
    std::signal(SIGXFSZ, handler_);
  }

 private:
  rlimit saved_{};
  void (*handler_)(int) = SIG_DFL;
};

TEST(AtomicTextFile, NothingIsWrittenBeforeCommitAndAllAfterIt) {
  llc_test::TempDir dir;
  llc::AtomicTextFile out(dir.file("a.csv"));
  out << "x,y\n" << 1 << ',' << 2.5 << '\n';
  EXPECT_FALSE(exists(dir.file("a.csv")));
  out.commit();
  EXPECT_EQ(llc_test::readText(dir.file("a.csv")), "x,y\n1,2.5\n");
  EXPECT_FALSE(exists(dir.file("a.csv.tmp")));
}

TEST(AtomicTextFile, AWriteThatFailsHalfwayLeavesTheOldFileAndNoTemporary) {
  llc_test::TempDir dir;
  const std::string path = dir.file("pairs.csv");
  llc_test::writeText(path, "the old contents\n");
  std::string error;
  {
    const FileSizeLimit limit(4096);
    llc::AtomicTextFile out(path);
    out << std::string(100000, 'x');
    try {
      out.commit();
    } catch (const std::runtime_error& e) {
      error = e.what();
    }
  }
  EXPECT_NE(error.find("File too large"), std::string::npos) << error;
  EXPECT_NE(error.find(path), std::string::npos) << "names the file: " << error;
  EXPECT_EQ(llc_test::readText(path), "the old contents\n");
  EXPECT_FALSE(exists(path + ".tmp"));
}

TEST(AtomicTextFile, AFullDeviceIsAnError) {
  if (!exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this machine";
  llc::AtomicTextFile out("/dev/full");  // a device: written in place, never renamed over
  out << std::string(10000, 'x');
  try {
    out.commit();
    ADD_FAILURE() << "a write to /dev/full passed";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(exists("/dev/full.tmp"));
}

TEST(AtomicTextFile, TheCoreSaversSayWhenTheDiskRefuses) {
  llc_test::TempDir dir;
  std::vector<llc::LabeledPair> pairs(2000, llc::LabeledPair{12345, 67890, 1});
  const FileSizeLimit limit(1024);
  EXPECT_THROW(llc::writePairs(dir.file("p.csv"), pairs), llc::PairFileError);
  EXPECT_FALSE(exists(dir.file("p.csv")));
}

TEST(WhyNotWritable, NamesWhatStandsInTheWay) {
  llc_test::TempDir dir;
  EXPECT_EQ(llc::whyNotWritable(dir.file("new.csv")), "");
  llc_test::writeText(dir.file("old.csv"), "x\n");
  EXPECT_EQ(llc::whyNotWritable(dir.file("old.csv")), "");
  EXPECT_NE(llc::whyNotWritable(dir.path()).find("is a folder"), std::string::npos);
  EXPECT_NE(llc::whyNotWritable(dir.file("no/such/folder/x.csv")).find("No such file"), std::string::npos);
  EXPECT_NE(llc::whyNotWritable(dir.file("old.csv") + "/x.csv").find("is not a folder"), std::string::npos);
  EXPECT_NE(llc::whyNotWritable("").find("empty"), std::string::npos);
}

}  // namespace
