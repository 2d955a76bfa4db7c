// The KTX 2.0 writer/reader and the half conversion, checked against the KTX 2.0 specification (byte offsets of the
// header, the level index, the Data Format Descriptor, key/value layout, mip padding) and against IEEE 754
// round-to-nearest-even computed independently here. Tolerances: none — every comparison is bit exact, because the
// container must store what it is given (rgba32f) or exactly the correctly rounded half (rgba16f).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/image/half.h"
#include "bakers/image/ktx2.h"

namespace kiln::image {
namespace {

// ---- half ----------------------------------------------------------------------------------------------------

// The value of every non-negative half code from 0x0000 up to 0x7c00, computed from the definition
// (m·2^-24 for denormals, (1024 + m)·2^(e−25) for normals). 0x7c00 (infinity) gets 65536, the value the next code
// would have with an unbounded exponent: round-to-nearest-even then sends [65520, ∞) to infinity, as IEEE 754 says.
const std::vector<double>& half_values() {
  static const std::vector<double> table = [] {
    std::vector<double> t(0x7c01);
    for (uint32_t b = 0; b <= 0x7c00; ++b) {
      const int e = static_cast<int>(b >> 10), m = static_cast<int>(b & 0x3ff);
      t[b] = e == 0 ? std::ldexp(m, -24) : std::ldexp(1024 + m, e - 25);
    }
    return t;
  }();
  return table;
}

// Independent reference rounding of a finite float to half: the nearest representable value, ties to the even code.
uint16_t reference_half(float f) {
  const std::vector<double>& v = half_values();
  const double a = std::fabs(static_cast<double>(f));
  const uint16_t sign = std::signbit(f) ? 0x8000 : 0;
  const size_t lo = static_cast<size_t>(std::upper_bound(v.begin(), v.end(), a) - v.begin()) - 1;
  if (lo >= 0x7c00) return sign | 0x7c00;
  const double below = a - v[lo], above = v[lo + 1] - a;
  size_t pick = lo;
  if (above < below || (above == below && (lo & 1))) pick = lo + 1;
  return static_cast<uint16_t>(sign | pick);
}

TEST(Half, HalfToFloatToHalfIsIdentityForAll65536Codes) {
  for (uint32_t b = 0; b < 0x10000; ++b) {
    const uint16_t h = static_cast<uint16_t>(b);
    ASSERT_EQ(float_to_half(half_to_float(h)), h) << "half code 0x" << std::hex << b;
  }
}

TEST(Half, HalfToFloatGivesTheDefinedValue) {
  const std::vector<double>& v = half_values();
  for (uint32_t b = 0; b < 0x7c00; ++b) {
    ASSERT_EQ(static_cast<double>(half_to_float(static_cast<uint16_t>(b))), v[b]) << std::hex << b;
    ASSERT_EQ(static_cast<double>(half_to_float(static_cast<uint16_t>(b | 0x8000))), -v[b]) << std::hex << b;
  }
  EXPECT_EQ(half_to_float(0x7c00), std::numeric_limits<float>::infinity());
  EXPECT_EQ(half_to_float(0xfc00), -std::numeric_limits<float>::infinity());
  EXPECT_TRUE(std::isnan(half_to_float(0x7e00)));
  EXPECT_TRUE(std::isnan(half_to_float(0x7c01)));  // a signalling NaN stays a NaN
  EXPECT_TRUE(std::signbit(half_to_float(0x8000)));
}

TEST(Half, FloatToHalfMatchesReferenceRoundingOnASweep) {
  uint64_t checked = 0;
  auto check = [&](uint32_t bits) {
    const float f = std::bit_cast<float>(bits);
    if (std::isnan(f)) return;
    ASSERT_EQ(float_to_half(f), reference_half(f)) << "float bits 0x" << std::hex << bits << " = " << f;
    ++checked;
  };
  // 1. A strided sweep over every float bit pattern (both signs, every exponent).
  for (uint64_t bits = 0; bits <= 0xffffffffull; bits += 997) check(static_cast<uint32_t>(bits));
  // 2. Every tie and its neighbours: the midpoint between consecutive half values (exact in float: 12 significant
  //    bits) and the 4 floats on either side of it, both signs. This is where rounding modes differ.
  const std::vector<double>& v = half_values();
  for (size_t b = 0; b < 0x7c00; ++b) {
    const uint32_t mid = std::bit_cast<uint32_t>(static_cast<float>((v[b] + v[b + 1]) / 2));
    ASSERT_EQ(static_cast<double>(std::bit_cast<float>(mid)), (v[b] + v[b + 1]) / 2);
    for (int d = -4; d <= 4; ++d) {
      check(mid + d);
      check((mid + d) | 0x80000000u);
    }
    const uint32_t exact = std::bit_cast<uint32_t>(static_cast<float>(v[b]));
    for (int d = -2; d <= 2; ++d)
      if (exact + d < 0x7f800000u) check(exact + d);
  }
  // 3. Random floats in the half range and below it (denormals of half, and floats far below).
  std::mt19937 rng(4);
  std::uniform_int_distribution<uint32_t> in_range(0x30000000u, 0x47900000u);
  for (int i = 0; i < 2000000; ++i) check(in_range(rng) | (i & 1 ? 0x80000000u : 0));
  EXPECT_GT(checked, 6000000u);
}

TEST(Half, SpecialValues) {
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_EQ(float_to_half(0.0f), 0x0000);
  EXPECT_EQ(float_to_half(-0.0f), 0x8000);
  EXPECT_EQ(float_to_half(1.0f), 0x3c00);
  EXPECT_EQ(float_to_half(65504.0f), 0x7bff);
  EXPECT_EQ(float_to_half(65519.996f), 0x7bff);  // just below the tie at 65520
  EXPECT_EQ(float_to_half(65520.0f), 0x7c00);    // the tie goes to the even code, infinity
  EXPECT_EQ(float_to_half(1e10f), 0x7c00);
  EXPECT_EQ(float_to_half(-1e10f), 0xfc00);
  EXPECT_EQ(float_to_half(inf), 0x7c00);
  EXPECT_EQ(float_to_half(-inf), 0xfc00);
  EXPECT_EQ(float_to_half(std::ldexp(1.0f, -24)), 0x0001);  // smallest half denormal
  EXPECT_EQ(float_to_half(std::ldexp(1.0f, -25)), 0x0000);  // tie between 0 and 2^-24: even, 0
  EXPECT_EQ(float_to_half(std::nextafter(std::ldexp(1.0f, -25), 1.0f)), 0x0001);
  EXPECT_EQ(float_to_half(std::ldexp(3.0f, -25)), 0x0002);  // tie between 1 and 2 ulps: even, 2
  EXPECT_EQ(float_to_half(std::numeric_limits<float>::denorm_min()), 0x0000);
  EXPECT_EQ(float_to_half(-std::numeric_limits<float>::denorm_min()), 0x8000);
  EXPECT_EQ(float_to_half(std::ldexp(1023.5f, -24)), 0x0400);  // rounds up out of the denormals into 2^-14
  // NaN: stays NaN (exponent all ones, mantissa non-zero), keeps its sign, whatever its payload.
  for (uint32_t bits : {0x7fc00000u, 0xffc00000u, 0x7f800001u, 0x7f801fffu, 0xff800001u, 0x7fffffffu}) {
    const uint16_t h = float_to_half(std::bit_cast<float>(bits));
    EXPECT_EQ(h & 0x7c00, 0x7c00) << std::hex << bits;
    EXPECT_NE(h & 0x03ff, 0) << std::hex << bits;
    EXPECT_EQ(h >> 15, bits >> 31) << std::hex << bits;
  }
}

// ---- KTX2 -----------------------------------------------------------------------------------------------------

uint32_t u32(const std::string& s, size_t at) {
  uint32_t v;
  std::memcpy(&v, s.data() + at, 4);  // the test machine is little-endian, like the file
  return v;
}
uint64_t u64(const std::string& s, size_t at) {
  uint64_t v;
  std::memcpy(&v, s.data() + at, 8);
  return v;
}
void set_u32(std::string& s, size_t at, uint32_t v) { std::memcpy(s.data() + at, &v, 4); }
void set_u64(std::string& s, size_t at, uint64_t v) { std::memcpy(s.data() + at, &v, 8); }

// A cube (or 2-D image) whose texels encode where they are, so a swapped face, level or row shows up.
Ktx2Image make_image(int width, int height, int faces, int levels, Ktx2Image::Format format) {
  Ktx2Image img;
  img.width = width;
  img.height = height;
  img.faces = faces;
  img.levels = levels;
  img.format = format;
  img.key_values = {{"KTXorientation", "rd"},
                    {"KTXwriter", "kiln"},
                    {"kiln:brdf", "ggx"},
                    {"kiln:roughness", "0 0.25 0.5 0.75 1"},
                    {"kiln:colorspace", "lin_rec709"},
                    {"kiln:x", ""}};  // an empty value
  img.data.resize(static_cast<size_t>(levels) * faces);
  std::mt19937 rng(static_cast<uint32_t>(width * 131 + levels));
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  for (int level = 0; level < levels; ++level)
    for (int face = 0; face < faces; ++face) {
      auto& px = img.image(level, face);
      const int w = img.level_width(level), h = img.level_height(level);
      px.resize(static_cast<size_t>(w) * h * 4);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          float* p = &px[(static_cast<size_t>(y) * w + x) * 4];
          p[0] = static_cast<float>(level * 10 + face);
          p[1] = static_cast<float>(x) + 0.25f * static_cast<float>(y);
          p[2] = u(rng) * 1000.0f;  // not representable in half: exercises the rounding
          p[3] = u(rng);
        }
    }
  return img;
}

uint32_t bits_of(float f) { return std::bit_cast<uint32_t>(f); }

void expect_same_pixels(const Ktx2Image& written, const Ktx2Image& read) {
  ASSERT_EQ(read.data.size(), written.data.size());
  for (int level = 0; level < written.levels; ++level)
    for (int face = 0; face < written.faces; ++face) {
      const auto& a = written.image(level, face);
      const auto& b = read.image(level, face);
      ASSERT_EQ(a.size(), b.size()) << "level " << level << " face " << face;
      for (size_t i = 0; i < a.size(); ++i) {
        const float want = written.format == Ktx2Image::rgba16f ? half_to_float(float_to_half(a[i])) : a[i];
        ASSERT_EQ(bits_of(b[i]), bits_of(want)) << "level " << level << " face " << face << " value " << i;
      }
    }
}

TEST(Ktx2, CubeWithFiveLevelsRoundTripsEveryLevelFaceAndKeyValue) {
  for (auto format : {Ktx2Image::rgba16f, Ktx2Image::rgba32f}) {
    const Ktx2Image img = make_image(16, 16, 6, 5, format);
    const Ktx2Image back = decode_ktx2(encode_ktx2(img));
    EXPECT_EQ(back.width, 16);
    EXPECT_EQ(back.height, 16);
    EXPECT_EQ(back.faces, 6);
    EXPECT_EQ(back.levels, 5);
    EXPECT_EQ(back.format, format);
    EXPECT_EQ(back.key_values, img.key_values);
    expect_same_pixels(img, back);
  }
}

TEST(Ktx2, NonSquarePartialChainAndSpecialValuesRoundTrip) {
  Ktx2Image img = make_image(13, 6, 1, 3, Ktx2Image::rgba32f);  // 13×6, 6×3, 3×1 (of 4 possible levels)
  auto& px = img.image(0, 0);
  px[0] = std::numeric_limits<float>::infinity();
  px[1] = -std::numeric_limits<float>::infinity();
  px[2] = std::bit_cast<float>(0x7fc01234u);  // NaN with a payload
  px[3] = std::numeric_limits<float>::denorm_min();
  px[4] = -0.0f;
  expect_same_pixels(img, decode_ktx2(encode_ktx2(img)));

  img.format = Ktx2Image::rgba16f;
  px[5] = 1e6f;   // overflows half: +inf
  px[6] = 3e-8f;  // a half denormal (2^-25 < 3e-8 < 2^-24·1.5: rounds to 2^-24)
  const Ktx2Image back = decode_ktx2(encode_ktx2(img));
  expect_same_pixels(img, back);
  EXPECT_TRUE(std::isinf(back.image(0, 0)[0]));
  EXPECT_TRUE(std::isnan(back.image(0, 0)[2]));
  EXPECT_EQ(back.image(0, 0)[5], std::numeric_limits<float>::infinity());
  EXPECT_EQ(back.image(0, 0)[6], std::ldexp(1.0f, -24));
  EXPECT_TRUE(std::signbit(back.image(0, 0)[4]));
}

TEST(Ktx2, HeaderFieldsSitAtTheirSpecifiedOffsets) {
  const Ktx2Image img = make_image(16, 16, 6, 5, Ktx2Image::rgba16f);
  const std::string f = encode_ktx2(img);
  const unsigned char id[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
  ASSERT_GE(f.size(), 80u);
  EXPECT_EQ(std::memcmp(f.data(), id, 12), 0);
  EXPECT_EQ(u32(f, 12), 97u);  // vkFormat VK_FORMAT_R16G16B16A16_SFLOAT
  EXPECT_EQ(u32(f, 16), 2u);   // typeSize
  EXPECT_EQ(u32(f, 20), 16u);  // pixelWidth
  EXPECT_EQ(u32(f, 24), 16u);  // pixelHeight
  EXPECT_EQ(u32(f, 28), 0u);   // pixelDepth
  EXPECT_EQ(u32(f, 32), 0u);   // layerCount
  EXPECT_EQ(u32(f, 36), 6u);   // faceCount
  EXPECT_EQ(u32(f, 40), 5u);   // levelCount
  EXPECT_EQ(u32(f, 44), 0u);   // supercompressionScheme
  const uint32_t dfd_at = u32(f, 48), dfd_len = u32(f, 52);
  EXPECT_EQ(dfd_at, 80u + 24u * 5u);  // right after the level index
  EXPECT_EQ(dfd_len, 4u + 24u + 16u * 4u);
  EXPECT_EQ(u32(f, dfd_at), dfd_len);       // dfdTotalSize
  EXPECT_EQ(u32(f, 56), dfd_at + dfd_len);  // kvdByteOffset: right after the DFD
  EXPECT_EQ(u64(f, 64), 0u);                // sgdByteOffset
  EXPECT_EQ(u64(f, 72), 0u);                // sgdByteLength

  // The basic descriptor block, word by word (Khronos Data Format Specification, basic descriptor block).
  const size_t b = dfd_at + 4;
  EXPECT_EQ(u32(f, b), 0u);                     // vendorId 0 (Khronos), descriptorType 0 (basic)
  EXPECT_EQ(u32(f, b + 4), 2u | (88u << 16));   // versionNumber 2, descriptorBlockSize 24 + 16·4
  EXPECT_EQ(u32(f, b + 8) & 0xff, 1u);          // colorModel RGBSDA
  EXPECT_EQ((u32(f, b + 8) >> 8) & 0xff, 1u);   // colorPrimaries BT709
  EXPECT_EQ((u32(f, b + 8) >> 16) & 0xff, 1u);  // transferFunction LINEAR
  EXPECT_EQ(u32(f, b + 12), 0u);                // texel block 1×1×1×1
  EXPECT_EQ(u32(f, b + 16), 8u);                // bytesPlane0 = 8 bytes per texel
  EXPECT_EQ(u32(f, b + 20), 0u);
  const uint32_t channel_ids[4] = {0, 1, 2, 15};
  for (uint32_t c = 0; c < 4; ++c) {
    const uint32_t s = u32(f, b + 24 + 16 * c);
    EXPECT_EQ(s & 0xffff, 16 * c) << "bitOffset of sample " << c;
    EXPECT_EQ((s >> 16) & 0xff, 15u) << "bitLength − 1 of sample " << c;
    EXPECT_EQ((s >> 24) & 0x0f, channel_ids[c]) << "channelType of sample " << c;
    EXPECT_EQ(s >> 28, 0x8u | 0x4u) << "qualifiers FLOAT | SIGNED of sample " << c;
    EXPECT_EQ(u32(f, b + 24 + 16 * c + 4), 0u);  // sample position
    EXPECT_EQ(u32(f, b + 24 + 16 * c + 8), bits_of(-1.0f));
    EXPECT_EQ(u32(f, b + 24 + 16 * c + 12), bits_of(1.0f));
  }

  const std::string g = encode_ktx2(make_image(8, 4, 1, 2, Ktx2Image::rgba32f));
  EXPECT_EQ(u32(g, 12), 109u);  // VK_FORMAT_R32G32B32A32_SFLOAT
  EXPECT_EQ(u32(g, 16), 4u);
  EXPECT_EQ(u32(g, 20), 8u);
  EXPECT_EQ(u32(g, 24), 4u);
  EXPECT_EQ(u32(g, 36), 1u);
  EXPECT_EQ(u32(g, 40), 2u);
  const uint32_t gb = u32(g, 48) + 4;
  EXPECT_EQ(u32(g, gb + 16), 16u);  // bytesPlane0
  for (uint32_t c = 0; c < 4; ++c) {
    EXPECT_EQ(u32(g, gb + 24 + 16 * c) & 0xffff, 32 * c);
    EXPECT_EQ((u32(g, gb + 24 + 16 * c) >> 16) & 0xff, 31u);
  }
}

TEST(Ktx2, KeyValueEntriesAreSortedNulTerminatedAndFourByteAligned) {
  Ktx2Image img = make_image(4, 4, 1, 1, Ktx2Image::rgba16f);
  img.key_values = {{"kiln:b", "12345"}, {"KTXorientation", "rd"}, {"kiln:a", "x"}};  // no KTXwriter given
  const std::string f = encode_ktx2(img);
  const uint32_t at = u32(f, 56), length = u32(f, 60);
  ASSERT_EQ(at % 4, 0u);
  ASSERT_LE(static_cast<size_t>(at) + length, f.size());
  std::vector<std::pair<std::string, std::string>> entries;
  size_t p = at;
  while (p < at + length) {
    ASSERT_EQ(p % 4, 0u) << "every entry starts 4-byte aligned";
    const uint32_t n = u32(f, p);
    const std::string kv = f.substr(p + 4, n);
    const size_t nul = kv.find('\0');
    ASSERT_NE(nul, std::string::npos);
    ASSERT_EQ(kv.back(), '\0') << "string values are NUL-terminated";
    entries.emplace_back(kv.substr(0, nul), kv.substr(nul + 1, n - nul - 2));
    const size_t next = (p + 4 + n + 3) / 4 * 4;
    for (size_t q = p + 4 + n; q < next; ++q) EXPECT_EQ(f[q], '\0') << "valuePadding is zero";
    p = next;
  }
  EXPECT_EQ(p, static_cast<size_t>(at) + length) << "kvdByteLength includes the last entry's padding";
  const std::vector<std::pair<std::string, std::string>> want = {
      {"KTXorientation", "rd"}, {"KTXwriter", "kiln"}, {"kiln:a", "x"}, {"kiln:b", "12345"}};  // byte order
  EXPECT_EQ(entries, want);
  // The writer added KTXwriter; everything else reads back as given.
  auto expected = img.key_values;
  expected["KTXwriter"] = "kiln";
  EXPECT_EQ(decode_ktx2(f).key_values, expected);
}

TEST(Ktx2, LevelsAreStoredSmallestFirstAlignedAndTightlyPacked) {
  for (auto format : {Ktx2Image::rgba16f, Ktx2Image::rgba32f}) {
    const Ktx2Image img = make_image(16, 16, 6, 5, format);
    const std::string f = encode_ktx2(img);
    const uint64_t texel = format == Ktx2Image::rgba16f ? 8 : 16;
    const uint64_t alignment = texel;  // lcm(texel block size, 4)
    const uint64_t kvd_end = u32(f, 56) + u32(f, 60);
    uint64_t previous_end = kvd_end;
    for (int level = 4; level >= 0; --level) {  // file order: smallest level first
      const size_t entry = 80 + 24 * static_cast<size_t>(level);
      const uint64_t offset = u64(f, entry), length = u64(f, entry + 8), uncompressed = u64(f, entry + 16);
      const uint64_t w = static_cast<uint64_t>(16 >> level);
      EXPECT_EQ(offset % alignment, 0u) << "level " << level;
      EXPECT_EQ(length, 6 * w * w * texel) << "level " << level;
      EXPECT_EQ(uncompressed, length) << "level " << level;
      // mipPadding: the minimum number of zero bytes to reach the alignment.
      EXPECT_EQ(offset, (previous_end + alignment - 1) / alignment * alignment) << "level " << level;
      for (uint64_t q = previous_end; q < offset; ++q) EXPECT_EQ(f[q], '\0');
      // Face k of this level starts k·w·w texels in; its first texel's red channel is level·10 + k.
      for (int face = 0; face < 6; ++face) {
        const uint64_t at = offset + face * w * w * texel;
        const float red = format == Ktx2Image::rgba16f
                              ? half_to_float(static_cast<uint16_t>(static_cast<unsigned char>(f[at]) |
                                                                    (static_cast<unsigned char>(f[at + 1]) << 8)))
                              : std::bit_cast<float>(u32(f, at));
        EXPECT_EQ(red, static_cast<float>(level * 10 + face)) << "level " << level << " face " << face;
      }
      previous_end = offset + length;
    }
    EXPECT_EQ(previous_end, f.size()) << "level 0 ends the file";
  }
}

TEST(Ktx2, EncoderRejectsInconsistentImagesWithAReason) {
  auto rejects = [](Ktx2Image img, const std::string& needle) {
    try {
      encode_ktx2(img);
      ADD_FAILURE() << "accepted; expected a complaint about " << needle;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  const Ktx2Image good = make_image(8, 8, 6, 4, Ktx2Image::rgba16f);
  Ktx2Image bad = good;
  bad.faces = 3;
  rejects(bad, "faces");
  bad = make_image(8, 4, 1, 1, Ktx2Image::rgba16f);
  bad.faces = 6;
  bad.data.resize(6, bad.data[0]);
  rejects(bad, "square");
  bad = good;
  bad.levels = 5;
  rejects(bad, "levels");
  bad = good;
  bad.image(2, 3).pop_back();
  rejects(bad, "level 2, face 3");
  bad = good;
  bad.data.pop_back();
  rejects(bad, "data holds");
  bad = good;
  bad.key_values[""] = "x";
  rejects(bad, "empty key");
  bad = good;
  bad.key_values[std::string("a\0b", 3)] = "x";
  rejects(bad, "NUL");
  bad = good;
  bad.width = 0;
  rejects(bad, "width");
}

void expect_rejected(const std::string& bytes, const std::string& needle) {
  try {
    decode_ktx2(bytes);
    ADD_FAILURE() << "accepted; expected a complaint about " << needle;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(Ktx2, EveryTruncationIsRejected) {
  const std::string f = encode_ktx2(make_image(8, 8, 6, 4, Ktx2Image::rgba16f));
  for (size_t n = 0; n < f.size(); ++n) {
    EXPECT_THROW(decode_ktx2(f.substr(0, n)), std::runtime_error) << "truncated to " << n << " of " << f.size();
  }
  expect_rejected(f.substr(0, 40), "header");
  expect_rejected(f.substr(0, 5), "identifier");
}

TEST(Ktx2, SpecificCorruptionsGiveClearErrors) {
  const std::string good = encode_ktx2(make_image(8, 8, 6, 4, Ktx2Image::rgba16f));
  ASSERT_NO_THROW(decode_ktx2(good));
  auto with = [&](size_t at, uint32_t v) {
    std::string s = good;
    set_u32(s, at, v);
    return s;
  };
  expect_rejected("not a ktx file at all, just some text", "identifier");
  expect_rejected(with(12, 37), "vkFormat");  // R8G8B8A8_UNORM
  expect_rejected(with(16, 4), "typeSize");
  expect_rejected(with(20, 0xffffffffu), "pixelWidth");
  expect_rejected(with(20, 4), "cube map");
  expect_rejected(with(24, 0), "1-D");
  expect_rejected(with(28, 2), "pixelDepth");
  expect_rejected(with(32, 3), "layerCount");
  expect_rejected(with(36, 2), "faceCount");
  expect_rejected(with(40, 0), "levelCount");
  expect_rejected(with(40, 0xffffffffu), "levelCount");
  expect_rejected(with(44, 2), "supercompressionScheme");  // Zstandard
  expect_rejected(with(48, 0xfffffff0u), "Data Format Descriptor");
  expect_rejected(with(52, 12), "Data Format Descriptor");
  expect_rejected(with(60, 0xfffffff0u), "key/value");
  std::string s = good;
  set_u64(s, 72, 16);
  expect_rejected(s, "global data");
  const uint32_t dfd = u32(good, 48);
  expect_rejected(with(dfd + 4 + 24, u32(good, dfd + 4 + 24 + 16)), "sample 0");  // G where R belongs
  expect_rejected(with(dfd + 4 + 16, 16), "bytesPlane0");
  const size_t level0 = 80;
  s = good;
  set_u64(s, level0, 0xfffffffffffffff8ull);  // offset + length overflows 64 bits
  expect_rejected(s, "level 0");
  s = good;
  set_u64(s, level0, u64(good, level0) + 4);  // misaligned
  expect_rejected(s, "multiple of 8");
  s = good;
  set_u64(s, level0 + 8, u64(good, level0 + 8) - 8);
  expect_rejected(s, "byteLength");
  s = good;
  set_u64(s, level0 + 16, 0);
  expect_rejected(s, "uncompressedByteLength");
  s = good;
  set_u64(s, level0, 0);  // overlaps the header
  expect_rejected(s, "outside");
  // Keys out of order: rename the first key ("KTXorientation") so that it sorts after the second.
  s = good;
  const size_t first_key = u32(good, 56) + 4;
  ASSERT_EQ(s.substr(first_key, 14), "KTXorientation");
  s[first_key] = 'z';
  expect_rejected(s, "sorted");
}

TEST(Ktx2, RandomByteFlipsInTheHeaderNeverCrash) {
  const std::string good = encode_ktx2(make_image(8, 8, 6, 4, Ktx2Image::rgba16f));
  const size_t metadata_end = u32(good, 56) + u32(good, 60);
  std::mt19937 rng(20240604);
  std::uniform_int_distribution<size_t> header_byte(0, metadata_end - 1), any_byte(0, good.size() - 1);
  std::uniform_int_distribution<int> value(0, 255), count(1, 4);
  int rejected = 0, accepted = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    std::string s = good;
    const int n = count(rng);
    for (int k = 0; k < n; ++k) {
      const size_t at = trial % 4 == 3 ? any_byte(rng) : header_byte(rng);
      s[at] = static_cast<char>(value(rng));
    }
    try {
      const Ktx2Image img = decode_ktx2(s);
      // Whatever is accepted is self-consistent.
      ASSERT_EQ(img.data.size(), static_cast<size_t>(img.levels) * img.faces);
      ++accepted;
    } catch (const std::runtime_error&) {
      ++rejected;
    }  // any other exception type fails the test
  }
  EXPECT_GT(rejected, 10000);  // most flips land in checked fields
  EXPECT_GT(accepted, 0);      // flips in values and pixels are legitimately accepted
}

}  // namespace
}  // namespace kiln::image
