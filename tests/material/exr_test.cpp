// EXR encoding in memory: exact round trips, the promised compression, and clear errors for bad bytes.
#include "bakers/image/exr.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/math/rng.h"

namespace kiln::image {
namespace {

// Values chosen to break anything that is not a bit-for-bit float store: NaN payloads, signed zero, denormals,
// infinities, the extremes of float, and ordinary numbers.
FloatImage awkward_image() {
  FloatImage img;
  img.width = 7;
  img.height = 5;
  img.channels = 4;
  // Deliberately not alphabetical: EXR sorts channels by name, the round trip must not.
  img.channel_names = {"scale", "bias", "scale_err", "bias_err"};
  img.metadata = {{"kiln:model", "ggx(alpha=0.3)"}, {"kiln:x_axis", "mu = (x + 0.5) / 7"}, {"note", "ünïcode ok"}};
  Pcg32 rng(42);
  for (int i = 0; i < img.width * img.height * img.channels; ++i) {
    img.pixels.push_back(static_cast<float>(rng.uniform() * 2.0 - 0.5));
  }
  const float specials[] = {std::bit_cast<float>(0x7fc01234u),  // quiet NaN with a payload
                            -0.0f,
                            std::numeric_limits<float>::denorm_min(),
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::max(),
                            std::numeric_limits<float>::lowest(),
                            1e-30f};
  for (size_t i = 0; i < std::size(specials); ++i) img.pixels[i * 3] = specials[i];
  return img;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// One channel of an image as its own plane, found by name.
std::vector<float> plane(const FloatImage& img, const std::string& name) {
  const int c = img.channel_index(name);
  std::vector<float> out;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) out.push_back(img.at(x, y, c));
  return out;
}

// Channels are read back by name: every channel keeps its name and its bits, whatever position a reader gives it.
TEST(Exr, RoundTripIsBitExactByChannelNameWithMetadata) {
  const FloatImage img = awkward_image();
  const FloatImage back = decode_exr(encode_exr(img));
  EXPECT_EQ(back.width, img.width);
  EXPECT_EQ(back.height, img.height);
  ASSERT_EQ(back.channels, img.channels);
  for (const std::string& name : img.channel_names) {
    EXPECT_TRUE(same_bits(plane(back, name), plane(img, name))) << name;
  }
  EXPECT_EQ(back.metadata, img.metadata);
}

// What the file says is what it stores: no positional channel list (kiln:channel_order listed the writer's order,
// scale first, while EXR stores bias first), and a reader that goes by position sees the channels sorted by name,
// each under its own name, so reading by name is the only reading there is.
TEST(Exr, MetadataDoesNotDescribeChannelsByPosition) {
  const std::string bytes = encode_exr(awkward_image());
  EXPECT_EQ(bytes.find("kiln:channel_order"), std::string::npos);
  const FloatImage back = decode_exr(bytes);
  EXPECT_EQ(back.channel_names, (std::vector<std::string>{"bias", "bias_err", "scale", "scale_err"}));
  EXPECT_EQ(back.metadata.count("kiln:channel_order"), 0u);
  EXPECT_THROW((void)back.channel_index("energy"), std::out_of_range);
  // An older file's positional list is dropped when read, not passed on as if it were true.
  FloatImage img = awkward_image();
  img.metadata["kiln:channel_order"] = "scale,bias,scale_err,bias_err";
  EXPECT_THROW(encode_exr(img), std::invalid_argument);
}

TEST(Exr, SingleRowAndSingleChannelImages) {
  FloatImage row;
  row.width = 32;
  row.height = 1;
  row.channels = 1;
  row.channel_names = {"E"};
  for (int i = 0; i < 32; ++i) row.pixels.push_back(static_cast<float>(i) / 31.0f);
  const FloatImage back = decode_exr(encode_exr(row));
  EXPECT_TRUE(same_bits(back.pixels, row.pixels));
  EXPECT_EQ(back.channel_names, row.channel_names);
}

TEST(Exr, EncodingIsDeterministic) {
  // The daemon addresses results by digest: the same image must give the same bytes (no time stamp).
  const FloatImage img = awkward_image();
  EXPECT_EQ(encode_exr(img), encode_exr(img));
}

TEST(Exr, HeaderSaysZipCompressionAndFloatChannels) {
  const std::string bytes = encode_exr(awkward_image());
  // An EXR header attribute is: name\0 type\0 int32 size, value. ZIP_COMPRESSION is 3 in the OpenEXR spec.
  const std::string compression = std::string("compression\0compression\0", 24) + std::string("\1\0\0\0", 4);
  const size_t at = bytes.find(compression);
  ASSERT_NE(at, std::string::npos);
  EXPECT_EQ(static_cast<unsigned char>(bytes[at + compression.size()]), 3u) << "compression is not ZIP";
  // Pixel type FLOAT is 2 in the channel list: after each channel name come int32 pixel type, ...
  const size_t ch = bytes.find(std::string("bias\0", 5));
  ASSERT_NE(ch, std::string::npos);
  EXPECT_EQ(static_cast<unsigned char>(bytes[ch + 5]), 2u) << "channel 'bias' is not 32-bit float";
}

TEST(Exr, GarbageGivesAClearError) {
  const std::string inputs[] = {"", "hello", std::string(1000, '\0'), "\x89PNG\r\n\x1a\n and more bytes"};
  for (const std::string& in : inputs) {
    try {
      decode_exr(in);
      FAIL() << "decoding " << in.size() << " bytes of garbage succeeded";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("not an OpenEXR image"), std::string::npos) << e.what();
    }
  }
}

TEST(Exr, TruncatedOrCorruptFilesAreRejectedWithoutCrashing) {
  const std::string bytes = encode_exr(awkward_image());
  for (double keep : {0.01, 0.1, 0.5, 0.9}) {
    const std::string cut = bytes.substr(0, static_cast<size_t>(keep * bytes.size()));
    EXPECT_THROW(decode_exr(cut), std::runtime_error) << "kept " << cut.size() << " of " << bytes.size();
  }
  EXPECT_THROW(decode_exr(bytes.substr(0, bytes.size() - 1)), std::runtime_error);
  // A damaged body must not crash. Whether it decodes (into some numbers) or throws depends on where the damage
  // falls; both are acceptable, a crash is not.
  Pcg32 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    std::string bad = bytes;
    for (int k = 0; k < 8; ++k) bad[bytes.size() / 2 + rng.next_u32() % (bytes.size() / 2)] ^= 0x5a;
    try {
      (void)decode_exr(bad);
    } catch (const std::runtime_error&) {
    }
  }
}

TEST(Exr, InconsistentImagesAreRefusedWithTheReason) {
  FloatImage img = awkward_image();
  img.pixels.pop_back();
  try {
    encode_exr(img);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("pixels holds"), std::string::npos) << e.what();
  }
  img = awkward_image();
  img.channel_names[1] = "scale";
  EXPECT_THROW(encode_exr(img), std::invalid_argument);
  img = awkward_image();
  img.metadata["compression"] = "none";
  EXPECT_THROW(encode_exr(img), std::invalid_argument);
  img = awkward_image();
  img.width = 0;
  EXPECT_THROW(encode_exr(img), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::image
