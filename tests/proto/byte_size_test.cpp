// Sizes in bytes as people write them (proto/byte_size.h): kilnd --memory-limit, kiln --memory-limit.
#include <gtest/gtest.h>

#include "proto/byte_size.h"

namespace kiln::proto {
namespace {

TEST(ByteSize, WholeBytesAndBinarySuffixes) {
  EXPECT_EQ(parse_byte_size("0"), 0u);
  EXPECT_EQ(parse_byte_size("536870912"), uint64_t{1} << 29);
  EXPECT_EQ(parse_byte_size("1K"), 1024u);
  EXPECT_EQ(parse_byte_size("512M"), uint64_t{512} << 20);
  EXPECT_EQ(parse_byte_size("4g"), uint64_t{4} << 30);
  EXPECT_EQ(parse_byte_size("1T"), uint64_t{1} << 40);
  EXPECT_EQ(parse_byte_size("8388607T"), uint64_t{8388607} << 40);  // just under 2^63
}

TEST(ByteSize, AnythingElseIsRefused) {
  for (const char* bad : {"", "M", "-1", "1.5G", "1 G", "4GB", "0x10", "1e9", "G4", " 1", "8388608T",
                          "9223372036854775808", "99999999999999999999999"}) {
    EXPECT_EQ(parse_byte_size(bad), std::nullopt) << "'" << bad << "'";
  }
}

}  // namespace
}  // namespace kiln::proto
