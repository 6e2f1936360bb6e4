// Proves that outputs are written whole or not at all, into devices and FIFOs, through symlinks, never over
// an input or a file of another kind, that the stale-temporary cleanup removes only its own exact names,
// and that bad paths are InvalidInput.
#include "porthole/core/output.h"

#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <thread>

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "porthole/core/error.h"

namespace porthole {
namespace {

std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(AtomicFile, WritesAndReplaces) {
  const auto dir = std::filesystem::temp_directory_path() / "porthole_atomic_test";
  std::filesystem::create_directories(dir);
  const auto file = dir / "out.txt";
  WriteFileAtomically(file, "first");
  EXPECT_EQ(Slurp(file), "first");
  WriteFileAtomically(file, "second");
  EXPECT_EQ(Slurp(file), "second");
  // Only the one file: no temporary left behind.
  int n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++n;
  EXPECT_EQ(n, 1);
  std::filesystem::remove_all(dir);
}

TEST(AtomicFile, MissingDirectoryIsInvalidInput) {
  EXPECT_THROW(WriteFileAtomically("/nonexistent-porthole-dir/x.json", "x", "--out"), InvalidInput);
  try {
    WriteFileAtomically("/nonexistent-porthole-dir/x.json", "x", "--out");
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "--out");
  }
}

TEST(Error, RequireHelpersNameTheField) {
  EXPECT_THROW(RequirePositive("radius_mm", -1.0), InvalidInput);
  EXPECT_THROW(RequireFinite("radius_mm", std::nan("")), InvalidInput);
  EXPECT_EQ(RequireNonNegative("t", 0.0), 0.0);
}

TEST(AtomicFile, StaleTemporariesOfKilledRunsAreRemoved) {
  const auto dir = std::filesystem::temp_directory_path() / "porthole_atomic_stale";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::ofstream(dir / ".cal.json.tmp.1234.0123456789abcdef") << "half-written by a run that was killed";
  std::ofstream(dir / ".other.json.tmp.99.0123456789abcdef") << "not ours";
  WriteFileAtomically(dir / "cal.json", "{}");
  EXPECT_FALSE(std::filesystem::exists(dir / ".cal.json.tmp.1234.0123456789abcdef"));
  EXPECT_TRUE(std::filesystem::exists(dir / ".other.json.tmp.99.0123456789abcdef"));
  EXPECT_EQ(Slurp(dir / "cal.json"), "{}");
  std::filesystem::remove_all(dir);
}

// Issue 24, reproducer 5: `.x.json.tmpl` (a folder) and `.x.json.tmp_notes` were deleted by a write of x.json.
TEST(Output, CleanupTouchesOnlyItsOwnExactTemporaryNames) {
  const auto dir = std::filesystem::temp_directory_path() / "porthole_output_cleanup";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / ".x.json.tmpl");
  std::ofstream(dir / ".x.json.tmpl" / "keep.txt") << "the user's";
  std::ofstream(dir / ".x.json.tmp_notes") << "the user's notes";
  std::ofstream(dir / ".x.json.tmp.12.0123456789abcde") << "15 hex digits: not ours";
  std::ofstream(dir / ".x.json.tmp.12.0123456789ABCDEF") << "upper case: not ours";
  std::filesystem::create_directories(dir / ".x.json.tmp.12.0123456789abcdef");  // our name, but a folder
  std::ofstream(dir / ".x.json.tmp.12.0123456789abcdef" / "keep.txt") << "x";
  WriteFileAtomically(dir / "x.json", "{}");
  EXPECT_TRUE(std::filesystem::exists(dir / ".x.json.tmpl" / "keep.txt"));
  EXPECT_TRUE(std::filesystem::exists(dir / ".x.json.tmp_notes"));
  EXPECT_TRUE(std::filesystem::exists(dir / ".x.json.tmp.12.0123456789abcde"));
  EXPECT_TRUE(std::filesystem::exists(dir / ".x.json.tmp.12.0123456789ABCDEF"));
  EXPECT_TRUE(std::filesystem::exists(dir / ".x.json.tmp.12.0123456789abcdef" / "keep.txt"));
  EXPECT_TRUE(IsTemporaryNameOf(".x.json.tmp.12.0123456789abcdef", "x.json"));
  EXPECT_FALSE(IsTemporaryNameOf(".x.json.tmp.12.0123456789abcdef0", "x.json"));
  EXPECT_FALSE(IsTemporaryNameOf(".x.json.tmp..0123456789abcdef", "x.json"));
  EXPECT_FALSE(IsTemporaryNameOf(".x.json.tmp.12.0123456789abcdef", "x.jso"));
  std::filesystem::remove_all(dir);
}

// Issue 24, reproducer 1: a symlink was replaced by a regular file instead of written through.
TEST(Output, WritesThroughASymlinkToItsTarget) {
  const auto dir = std::filesystem::temp_directory_path() / "porthole_output_link";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "real");
  std::ofstream(dir / "real" / "out.txt") << "old";
  std::filesystem::create_symlink("real/out.txt", dir / "link.txt");
  WriteOutput(dir / "link.txt", "new", "--out", OutputRules{.force = true, .inputs = {}});
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "link.txt"));
  EXPECT_EQ(Slurp(dir / "real" / "out.txt"), "new");
  // A dangling link: its target is created, the link stays.
  std::filesystem::create_symlink("real/fresh.txt", dir / "dangling.txt");
  WriteOutput(dir / "dangling.txt", "made", "--out", OutputRules{});
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "dangling.txt"));
  EXPECT_EQ(Slurp(dir / "real" / "fresh.txt"), "made");
  std::filesystem::remove_all(dir);
}

// Issue 24, reproducer 1: a FIFO was replaced by a regular file.
TEST(Output, WritesIntoAFifo) {
  const auto dir = std::filesystem::temp_directory_path() / "porthole_output_fifo";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto fifo = dir / "pipe";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  std::string got;
  std::thread reader([&] { got = Slurp(fifo); });
  WriteOutput(fifo, "through the pipe", "--out", OutputRules{});
  reader.join();
  EXPECT_EQ(got, "through the pipe");
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  std::filesystem::remove_all(dir);
}

// Issue 24, reproducer 1: `convert … /dev/null` as root replaced the device. A null device made in a
// temporary folder (needs root: skipped otherwise).
TEST(Output, WritesIntoADeviceWithoutReplacingIt) {
  if (geteuid() != 0) GTEST_SKIP() << "mknod needs root";
  const auto dir = std::filesystem::temp_directory_path() / "porthole_output_dev";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto dev = dir / "null";
  if (mknod(dev.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0) GTEST_SKIP() << "mknod refused here";
  WriteOutput(dev, "into the device", "--out", OutputRules{});
  WriteFileAtomically(dev, "again");
  EXPECT_TRUE(std::filesystem::is_character_file(dev));
  struct stat st {};
  ASSERT_EQ(stat(dev.c_str(), &st), 0);
  EXPECT_EQ(st.st_rdev, makedev(1, 3));
  std::filesystem::remove_all(dir);
}

TEST(Output, OverwriteRule) {
  const auto dir = std::filesystem::temp_directory_path() / "porthole_output_rule";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string cal = R"({"model": "brown", "camera": {"c_mm": 24}})";
  const std::string truth = R"({"image": "a.png", "pose": {}, "camera": {"model": "brown"}, "points": []})";
  std::ofstream(dir / "cal.json") << cal;
  // Without --force an existing file is kept, and the message says what it is.
  try {
    WriteOutput(dir / "cal.json", cal, "--out", OutputRules{});
    ADD_FAILURE() << "replaced without --force";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("a porthole calibration"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("`force`"), std::string::npos) << e.what();  // the field; the CLI says --force
  }
  // With --force a file of another kind is still kept; one of the same kind is replaced.
  EXPECT_THROW(WriteOutput(dir / "cal.json", truth, "--out", OutputRules{.force = true, .inputs = {}}), InvalidInput);
  EXPECT_EQ(Slurp(dir / "cal.json"), cal);
  WriteOutput(dir / "cal.json", cal + " ", "--out", OutputRules{.force = true, .inputs = {}});
  EXPECT_EQ(Slurp(dir / "cal.json"), cal + " ");
  // An input is never replaced, even with --force, whatever the path it is reached by.
  std::filesystem::create_symlink("cal.json", dir / "alias.json");
  EXPECT_THROW(WriteOutput(dir / "alias.json", cal, "--out", OutputRules{.force = true, .inputs = {dir / "cal.json"}}),
               InvalidInput);
  EXPECT_EQ(Slurp(dir / "cal.json"), cal + " ");
  std::filesystem::remove_all(dir);
}

TEST(Output, ValidUtf8ReplacesOnlyWhatIsNotUtf8) {
  EXPECT_EQ(ValidUtf8("d\xc3\xb4me \xe2\x80\x94 ok"), "d\xc3\xb4me \xe2\x80\x94 ok");
  EXPECT_EQ(ValidUtf8("caf\xe9.png"), "caf\xef\xbf\xbd.png");        // Latin-1 é
  EXPECT_EQ(ValidUtf8("a\xff"), "a\xef\xbf\xbd");                    // byte 0xff at the end
  EXPECT_EQ(ValidUtf8("\xe2\x80"), "\xef\xbf\xbd\xef\xbf\xbd");  // cut short
  EXPECT_EQ(ValidUtf8("\xed\xa0\x80"), "\xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd");  // a surrogate
}

TEST(Output, KindsReadFromTheContent) {
  EXPECT_EQ(KindOfText(R"({"model": "brown", "camera": {"c_mm": 24}, "sigma": {}})"), FileKind::kCalibration);
  EXPECT_EQ(KindOfText(R"({"image": "a.png", "pose": {}, "camera": {}, "points": []})"), FileKind::kGroundTruth);
  EXPECT_EQ(KindOfText(R"({"image": "a.png", "ids": [1], "points_px": [[1, 2]]})"), FileKind::kDetections);
  EXPECT_EQ(KindOfText(R"({"target": "chessboard:9x6:40", "images": [], "skipped": []})"), FileKind::kDetectionSet);
  EXPECT_EQ(KindOfText(R"({"porthole_report": 1})"), FileKind::kReport);
  EXPECT_EQ(KindOfText(R"({"a": {"camera": {}}})"), FileKind::kOther);  // only top-level keys count
  EXPECT_EQ(KindOfText("%YAML:1.0\ncamera_matrix: 1"), FileKind::kOther);
  EXPECT_EQ(KindOfText("{\"camera\": {"), FileKind::kCalibration);  // cut short: still protected
  EXPECT_EQ(KindOfText(std::string(100, '{')), FileKind::kOther);
}

TEST(Error, MessagesStayOnOneBoundedLine) {
  const InvalidInput e(std::string("key\nporthole: error: forged") + std::string(2000, 'k'), "bad\r\x1b[31m\xe9");
  const std::string m = e.what();
  EXPECT_EQ(m.find('\n'), std::string::npos);
  EXPECT_EQ(m.find('\r'), std::string::npos);
  EXPECT_EQ(m.find('\x1b'), std::string::npos);
  EXPECT_NE(m.find("key\\nporthole"), std::string::npos) << m;
  EXPECT_NE(m.find("\\x1b[31m\\xe9"), std::string::npos) << m;  // escape and Latin-1 byte shown, not sent
  EXPECT_LT(m.size(), 1100u);
  EXPECT_EQ(OneLineMessage("d\xc3\xb4me \xe2\x80\x94 ok"), "d\xc3\xb4me \xe2\x80\x94 ok");  // UTF-8 kept
  EXPECT_STREQ(InvalidInput("f", "not JSON: [json.exception.parse_error.101] parse error").what(), "f: not JSON: parse error");
}

}  // namespace
}  // namespace porthole
