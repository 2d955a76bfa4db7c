// SHA-256 against the FIPS 180-2 test vectors, one-shot and incremental.
#include "proto/digest.h"

#include <gtest/gtest.h>

#include <string>

namespace kiln::proto {
namespace {

// FIPS 180-2, appendix B.1, B.2 and B.3.
constexpr const char* kAbc = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad";
constexpr const char* k448Bits = "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1";
constexpr const char* kMillionA = "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0";
constexpr const char* k448BitMessage = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";

TEST(Digest, FipsVectorsOneShot) {
  EXPECT_EQ(sha256_hex("abc"), kAbc);
  EXPECT_EQ(sha256_hex(k448BitMessage), k448Bits);
  EXPECT_EQ(sha256_hex(std::string(1000000, 'a')), kMillionA);
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

TEST(Digest, IncrementalMatchesOneShotWhateverTheChunks) {
  const std::string million(1000000, 'a');
  // Chunk sizes around SHA-256's 64-byte block, so every alignment of a block boundary with a chunk edge occurs.
  for (std::size_t chunk : {1u, 3u, 63u, 64u, 65u, 1000u, 4096u, 999999u}) {
    Sha256 h;
    for (std::size_t at = 0; at < million.size(); at += chunk) h.update(std::string_view(million).substr(at, chunk));
    EXPECT_EQ(h.finish(), kMillionA) << "chunk " << chunk;
  }
  Sha256 h;
  h.update("ab");
  h.update("");
  h.update("c");
  EXPECT_EQ(h.finish(), kAbc);
}

TEST(Digest, FinishStartsAfresh) {
  Sha256 h;
  h.update("abc");
  EXPECT_EQ(h.finish(), kAbc);
  h.update(k448BitMessage);
  EXPECT_EQ(h.finish(), k448Bits);
  Sha256 moved = std::move(h);
  moved.update("abc");
  EXPECT_EQ(moved.finish(), kAbc);
}

TEST(Digest, ValidHexIsExactly64LowercaseDigits) {
  EXPECT_TRUE(is_valid_sha256_hex(kAbc));
  EXPECT_TRUE(is_valid_sha256_hex(std::string(64, '0')));
  EXPECT_FALSE(is_valid_sha256_hex(""));
  EXPECT_FALSE(is_valid_sha256_hex(std::string(kAbc).substr(0, 63)));
  EXPECT_FALSE(is_valid_sha256_hex(std::string(kAbc) + "0"));
  std::string upper(kAbc);
  upper[0] = 'B';  // one spelling per digest: uppercase is refused
  EXPECT_FALSE(is_valid_sha256_hex(upper));
  for (char bad : {'g', ' ', '\0', '-', 'x', '\xff'}) {
    std::string s(kAbc);
    s[10] = bad;
    EXPECT_FALSE(is_valid_sha256_hex(s)) << static_cast<int>(bad);
  }
}

}  // namespace
}  // namespace kiln::proto
