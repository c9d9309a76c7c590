#include <gtest/gtest.h>

#include "rtukit/core.hpp"
TEST(Crc, Placeholder) {
  EXPECT_EQ(rtukit::crc16({}), 0xFFFF);
}
