// EXR encoding in memory: exact round trips, the promised compression, and clear errors for bad bytes.
#include "bakers/image/exr.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/image/oiio_memory.h"
#include "bakers/math/rng.h"
#include "tests/support/sanitizers.h"

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

// Scanline images are read a 64 MiB strip at a time: 2048 x 4100 pixels of two channels (64 MiB and 64 KiB as
// floats) take two strips. Each pixel holds its own (x, y), so a row put in the wrong place or missed shows.
TEST(Exr, AnImageLargerThanOneStripIsReadExactly) {
  FloatImage img;
  img.width = 2048;
  img.height = 4100;
  img.channels = 2;
  img.channel_names = {"x", "y"};
  img.pixels.resize(size_t(img.width) * img.height * 2);
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      img.pixels[2 * (size_t(y) * img.width + x)] = static_cast<float>(x);
      img.pixels[2 * (size_t(y) * img.width + x) + 1] = static_cast<float>(y);
    }
  }
  const FloatImage back = decode_exr(encode_exr(img));
  ASSERT_EQ(back.width, img.width);
  ASSERT_EQ(back.height, img.height);
  EXPECT_TRUE(same_bits(plane(back, "x"), plane(img, "x")));
  EXPECT_TRUE(same_bits(plane(back, "y"), plane(img, "y")));
}

// A file whose channels are stored in different types (half, float, half) is converted channel by channel.
TEST(Exr, ChannelsOfDifferentTypesAreEachConverted) {
  OIIO::ImageSpec spec(3, 2, 3, OIIO::TypeDesc::FLOAT);
  spec.channelnames = {"a", "b", "c"};
  spec.channelformats = {OIIO::TypeDesc::HALF, OIIO::TypeDesc::FLOAT, OIIO::TypeDesc::HALF};
  // Exact in half and float: what comes back must be these values, bit for bit.
  const std::vector<float> pixels = {0.5f, 1e-7f, -2.0f, 1024.0f, 3.0f, 0.25f, -0.125f, 1e30f, 6.0f,
                                     0.0f, -1.0f, 2048.0f, 1.5f,  7.0f,  -0.5f, 8.0f,   0.75f, 4.0f};
  std::vector<unsigned char> buffer;
  OIIO::Filesystem::IOVecOutput proxy(buffer);
  auto out = OIIO::ImageOutput::create("t.exr");
  ASSERT_TRUE(out);
  ASSERT_TRUE(out->set_ioproxy(&proxy));
  ASSERT_TRUE(out->open("t.exr", spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data())) << out->geterror();
  ASSERT_TRUE(out->close());
  const FloatImage back = decode_exr(std::string(buffer.begin(), buffer.end()));
  ASSERT_EQ(back.width, 3);
  ASSERT_EQ(back.channels, 3);
  for (int c = 0; c < 3; ++c) {
    std::vector<float> expected;
    for (int p = 0; p < 6; ++p) expected.push_back(pixels[3 * p + c]);
    EXPECT_TRUE(same_bits(plane(back, spec.channelnames[c]), expected)) << spec.channelnames[c];
  }
}

// This process's address space limited to what it maps now and `extra` bytes more (in a death test's child).
void limit_address_space(uint64_t extra) {
  std::ifstream statm("/proc/self/statm");
  uint64_t pages = 0;
  statm >> pages;
  const rlim_t limit = pages * static_cast<uint64_t>(sysconf(_SC_PAGESIZE)) + extra;
  const rlimit r{limit, limit};
  setrlimit(RLIMIT_AS, &r);
}

// The input the exr fuzz target found: 424 bytes declaring 2,097,156 x 2 float pixels of 3 channels (12.6 M values,
// within the limit). OpenEXR allocated line buffers of 16 such scanlines when the file was opened, and OpenImageIO's
// read_image a buffer of 256 (6.4 GB), whatever the height: where memory is limited, std::bad_alloc, no clear error.
// Decoded in a child process whose address space may grow by 2 GiB only, it is refused from its header.
TEST(ExrDeathTest, AWideImageIsReadWithoutABufferOf256OfItsScanlines) {
  if (test::kUnderAddressSanitizer)
    GTEST_SKIP() << "AddressSanitizer maps terabytes of shadow memory: an address-space limit cannot apply";
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  std::ifstream in(KILN_SOURCE_DIR "/tests/fuzz/regressions/exr/read_scanlines_allocates_6_gb.exr", std::ios::binary);
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ASSERT_EQ(bytes.size(), 424u);
  EXPECT_EXIT(
      {
        limit_address_space(uint64_t{2} << 30);
        try {
          decode_exr(bytes);
          std::fprintf(stderr, "decoded without an error\n");
          std::exit(1);
        } catch (const std::runtime_error& e) {
          std::fprintf(stderr, "%s\n", e.what());
          std::exit(0);
        } catch (const std::exception& e) {
          std::fprintf(stderr, "not a clear error: %s\n", e.what());
          std::exit(2);
        }
      },
      ::testing::ExitedWithCode(0),
      "decode_exr: the EXR header at byte 8 declares 2097156 pixels a scanline of 12 bytes each: reading them takes "
      "more than the limit of 256 MiB for 256 scanlines");
}

// OpenImageIO 2.4.7's IOMemReader::pread copies from outside its buffer when a damaged EXR's chunk offsets point
// before or past the upload (the exr fuzz target's finding, tests/fuzz/regressions/exr/). kiln reads through
// BoundedMemReader, which copies only bytes of the buffer.
TEST(Exr, TheMemoryReaderNeverReadsOutsideItsBuffer) {
  const std::string bytes = "0123456789";
  detail::BoundedMemReader proxy(bytes.data(), bytes.size());
  char out[16] = {};
  EXPECT_EQ(proxy.pread(out, 4, 8), 2u) << "a read across the end is cut at the end";
  EXPECT_EQ(std::string(out, 2), "89");
  EXPECT_EQ(proxy.pread(out, 4, 10), 0u) << "at the end";
  EXPECT_EQ(proxy.pread(out, 4, 1000), 0u) << "past the end";
  EXPECT_EQ(proxy.pread(out, 4, -4), 0u) << "before the start (offset + size wraps to 0)";
  EXPECT_EQ(proxy.pread(out, std::numeric_limits<size_t>::max(), 3), 7u) << "a size that wraps offset + size";
  EXPECT_EQ(std::string(out, 7), "3456789");
  proxy.seek(12);
  EXPECT_EQ(proxy.read(out, 4), 0u) << "read() after a seek past the end";
  proxy.seek(6);
  EXPECT_EQ(proxy.read(out, 16), 4u);
  EXPECT_EQ(std::string(out, 4), "6789");
}

// The two inputs of that finding decode to a clear error (under AddressSanitizer: without reading outside them).
TEST(Exr, DamagedChunkOffsetsAreRefusedWithoutReadingOutsideTheUpload) {
  for (const char* name : {"exr/iomemreader_pread_overread.exr", "environment/iomemreader_pread_overread.exr"}) {
    std::ifstream in(std::string(KILN_SOURCE_DIR "/tests/fuzz/regressions/") + name, std::ios::binary);
    const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    ASSERT_FALSE(bytes.empty()) << name;
    try {
      decode_exr(bytes);
      ADD_FAILURE() << name << " decoded";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("decode_exr"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace kiln::image
