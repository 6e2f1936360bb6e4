// Proves the edit distance behind "did you mean …": the classic cases, a swap of two neighbours as
// one edit, and the nearest names kept within the typo distance, nearest first.
#include "porthole/core/nearest.h"

#include <gtest/gtest.h>

namespace porthole {
namespace {

TEST(Nearest, EditDistance) {
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3u);
  EXPECT_EQ(EditDistance("", "abc"), 3u);
  EXPECT_EQ(EditDistance("radius_mm", "radius_mm"), 0u);
  EXPECT_EQ(EditDistance("radus_mm", "radius_mm"), 1u);
  EXPECT_EQ(EditDistance("tpye", "type"), 1u);   // one swap
  EXPECT_EQ(EditDistance("widht_px", "width_px"), 1u);
  EXPECT_EQ(EditDistance("ab", "ba"), 1u);
  EXPECT_EQ(EditDistance("abc", "ca"), 3u);      // optimal string alignment: no edit of a swapped pair
}

TEST(Nearest, NearestNamesWithinTheTypoDistance) {
  const std::vector<std::string> keys = {"center_mm", "radius_mm", "rim_z_mm", "thickness_mm"};
  EXPECT_EQ(NearestNames("radus_mm", keys, 3, TypoDistance("radus_mm")), std::vector<std::string>({"radius_mm"}));
  EXPECT_TRUE(NearestNames("colour", keys, 3, TypoDistance("colour")).empty());
  EXPECT_EQ(NearestNames("rim_mm", keys, 2, 4), std::vector<std::string>({"rim_z_mm", "radius_mm"}));
  EXPECT_EQ(TypoDistance("x"), 1u);
  EXPECT_EQ(TypoDistance("a_very_long_key_name"), 3u);
}

}  // namespace
}  // namespace porthole
