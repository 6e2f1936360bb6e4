// Proves that outputs are written whole or not at all, and that bad paths are InvalidInput.
#include "porthole/core/atomic_file.h"

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
  std::ofstream(dir / ".cal.json.tmp1234") << "half-written by a run that was killed";
  std::ofstream(dir / ".other.json.tmp99") << "not ours";
  WriteFileAtomically(dir / "cal.json", "{}");
  EXPECT_FALSE(std::filesystem::exists(dir / ".cal.json.tmp1234"));
  EXPECT_TRUE(std::filesystem::exists(dir / ".other.json.tmp99"));
  EXPECT_EQ(Slurp(dir / "cal.json"), "{}");
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
