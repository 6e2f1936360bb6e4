// placeholder
#include <gtest/gtest.h>
TEST(CodedDetect, Placeholder) {}
