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

}  // namespace
}  // namespace porthole
