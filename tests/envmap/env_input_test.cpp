// decode_environment and environment_to_cube: formats by content, limits from the header, colour spaces, the
// sanitising rule, rotation about +Y.
#include "bakers/envmap/env_input.h"

#include <gtest/gtest.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/image/exr.h"

namespace kiln::envmap {
namespace {

image::FloatImage make_float(int w, int h, int channels) {
  image::FloatImage img;
  img.width = w;
  img.height = h;
  img.channels = channels;
  img.pixels.resize(static_cast<size_t>(w) * h * channels);
  for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = 0.25f * static_cast<float>(i % 37) + 0.125f;
  return img;
}

// An 8-bit PNG written by OpenImageIO into memory.
std::string make_png(int w, int h, int channels, unsigned char value) {
  std::vector<unsigned char> pixels(static_cast<size_t>(w) * h * channels, value);
  std::vector<unsigned char> buffer;
  OIIO::Filesystem::IOVecOutput proxy(buffer);
  auto out = OIIO::ImageOutput::create("test.png");
  EXPECT_TRUE(out);
  EXPECT_TRUE(out->set_ioproxy(&proxy));
  OIIO::ImageSpec spec(w, h, channels, OIIO::TypeDesc::UINT8);
  EXPECT_TRUE(out->open("test.png", spec)) << out->geterror();
  EXPECT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, pixels.data())) << out->geterror();
  EXPECT_TRUE(out->close());
  return std::string(buffer.begin(), buffer.end());
}

// The message of the std::exception `fn` throws (fails the test if it throws nothing).
template <class Fn>
std::string error_of(Fn fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an exception";
  return "";
}

double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

TEST(EnvInput, ExrRoundTripsItsValues) {
  const image::FloatImage img = make_float(16, 8, 3);
  const EnvironmentInput env = decode_environment(image::encode_exr(img));
  EXPECT_EQ(env.format, "openexr");
  EXPECT_EQ(env.color_space, "lin_rec709");
  EXPECT_EQ(env.working_space, "lin_rec709");
  ASSERT_EQ(env.width, 16);
  ASSERT_EQ(env.height, 8);
  ASSERT_EQ(env.image.width, 16);
  ASSERT_EQ(env.image.height, 8);
  EXPECT_EQ(env.sanitized.total(), 0);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 16; ++x) {
      const Rgb& p = env.image.at(x, y);
      EXPECT_EQ(p.r, img.at(x, y, 0));
      EXPECT_EQ(p.g, img.at(x, y, 1));
      EXPECT_EQ(p.b, img.at(x, y, 2));
    }
  }
}

TEST(EnvInput, AlphaIsDroppedGreyIsSpreadAndIntensityScales) {
  const image::FloatImage rgba = make_float(8, 4, 4);
  EnvDecodeOptions opt;
  opt.intensity = 2.0;
  const EnvironmentInput env = decode_environment(image::encode_exr(rgba), opt);
  EXPECT_EQ(env.image.at(3, 2).r, 2.0 * rgba.at(3, 2, 0));
  EXPECT_EQ(env.image.at(3, 2).b, 2.0 * rgba.at(3, 2, 2));

  image::FloatImage grey = make_float(9, 4, 1);  // 2·4 + 1: the ±1 slack
  const EnvironmentInput g = decode_environment(image::encode_exr(grey));
  EXPECT_EQ(g.image.at(5, 1), Rgb(grey.at(5, 1, 0)));
}

TEST(EnvInput, EightBitPngIsDecodedAsSrgb) {
  const EnvironmentInput env = decode_environment(make_png(8, 4, 3, 128));
  EXPECT_EQ(env.format, "png");
  EXPECT_EQ(env.color_space, "srgb_texture");
  const double expected = srgb_to_linear(128.0 / 255.0);
  EXPECT_NEAR(expected, 0.2158, 1e-4);
  // OpenColorIO's CPU processor evaluates the curve in float: 1e-5 absolute is ample.
  for (const Rgb& p : env.image.pixels) {
    EXPECT_NEAR(p.r, expected, 1e-5);
    EXPECT_NEAR(p.g, expected, 1e-5);
    EXPECT_NEAR(p.b, expected, 1e-5);
  }
  // Grey + alpha: the grey goes to all three channels.
  const EnvironmentInput ga = decode_environment(make_png(8, 4, 2, 128));
  EXPECT_NEAR(ga.image.at(1, 1).g, expected, 1e-5);
  // Declared linear: the code values are taken as they are.
  EnvDecodeOptions lin;
  lin.color_space = "lin_rec709";
  EXPECT_NEAR(decode_environment(make_png(8, 4, 3, 128), lin).image.at(0, 0).r, 128.0 / 255.0, 1e-6);
}

TEST(EnvInput, NanInfAndNegativeTexelsAreReplacedAndCounted) {
  image::FloatImage img = make_float(8, 4, 3);
  for (float& v : img.pixels) v = 1.0f;
  img.at(5, 3, 2) = 7.5f;  // the largest finite value
  const float inf = std::numeric_limits<float>::infinity();
  img.at(0, 0, 0) = std::numeric_limits<float>::quiet_NaN();
  img.at(0, 0, 1) = std::numeric_limits<float>::quiet_NaN();  // same texel: counted once
  img.at(1, 0, 1) = inf;
  img.at(2, 0, 2) = -inf;
  img.at(3, 0, 0) = -2.0f;
  img.at(4, 0, 1) = std::numeric_limits<float>::quiet_NaN();
  const EnvironmentInput env = decode_environment(image::encode_exr(img));
  EXPECT_EQ(env.sanitized.nan, 2);
  EXPECT_EQ(env.sanitized.inf, 2);
  EXPECT_EQ(env.sanitized.negative, 1);
  EXPECT_EQ(env.image.at(0, 0), Rgb(0, 0, 1));
  EXPECT_EQ(env.image.at(1, 0), Rgb(1, 7.5, 1));
  EXPECT_EQ(env.image.at(2, 0), Rgb(1, 1, 0));
  EXPECT_EQ(env.image.at(3, 0), Rgb(0, 1, 1));
  EXPECT_EQ(env.image.at(4, 0), Rgb(1, 0, 1));
  for (const Rgb& p : env.image.pixels) {
    EXPECT_TRUE(p.is_finite());
    EXPECT_GE(p.min(), 0.0);
  }

  // Only non-finite values: +Inf has no finite value to become, so it becomes 0.
  image::FloatImage all_bad = make_float(2, 1, 3);
  for (float& v : all_bad.pixels) v = inf;
  const EnvironmentInput b = decode_environment(image::encode_exr(all_bad));
  EXPECT_EQ(b.sanitized.inf, 2);
  EXPECT_EQ(b.image.at(0, 0), Rgb(0));
}

TEST(EnvInput, NegativesMadeByTheColourConversionAreCounted) {
  image::FloatImage img = make_float(4, 2, 3);
  for (size_t i = 0; i < img.pixels.size(); i += 3) img.pixels[i] = 1, img.pixels[i + 1] = 0, img.pixels[i + 2] = 0;
  EnvDecodeOptions opt;
  opt.color_space = "acescg";
  const EnvironmentInput env = decode_environment(image::encode_exr(img), opt);
  EXPECT_EQ(env.color_space, "acescg");
  // ACEScg red lies outside Rec.709: R ≈ 1.705 and negative G, B, which the rule clamps to 0.
  EXPECT_NEAR(env.image.at(0, 0).r, 1.705, 0.01);
  EXPECT_EQ(env.image.at(0, 0).g, 0.0);
  EXPECT_EQ(env.sanitized.negative, 8);
}

TEST(EnvInput, NotAnImageIsAClearError) {
  const std::string msg = error_of([] { decode_environment("hello, this is a text file"); });
  EXPECT_NE(msg.find("not an image"), std::string::npos) << msg;
  EXPECT_NE(msg.find("68 65 6c 6c"), std::string::npos) << msg;
  EXPECT_NE(msg.find("OpenEXR, Radiance HDR, PNG or JPEG"), std::string::npos) << msg;
  EXPECT_NE(error_of([] { decode_environment(""); }).find("not an image"), std::string::npos);
}

TEST(EnvInput, TruncatedExrIsAClearError) {
  const std::string full = image::encode_exr(make_float(64, 32, 3));
  for (size_t keep : {size_t{10}, full.size() / 2, full.size() - 8}) {
    const std::string msg = error_of([&] { decode_environment(full.substr(0, keep)); });
    EXPECT_NE(msg.find("truncated or corrupt"), std::string::npos) << keep << ": " << msg;
  }
}

TEST(EnvInput, AbsurdSizesAreRefusedFromTheHeader) {
  // Radiance headers without pixels: only the header is read before the refusal.
  for (const char* res : {"-Y 20000 +X 40000", "-Y 8192 +X 16384", "-Y 16385 +X 32769"}) {
    const std::string hdr = std::string("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n") + res + "\n";
    const std::string msg = error_of([&] { decode_environment(hdr); });
    EXPECT_NE(msg.find("larger than the limits"), std::string::npos) << res << ": " << msg;
    EXPECT_NE(msg.find("downscale"), std::string::npos) << msg;
  }
}

TEST(EnvInput, NonEquirectShapeIsAClearError) {
  const std::string msg = error_of([] { decode_environment(image::encode_exr(make_float(10, 10, 3))); });
  EXPECT_NE(msg.find("10x10"), std::string::npos) << msg;
  EXPECT_NE(msg.find("20x10"), std::string::npos) << msg;
  EXPECT_NE(msg.find("2:1"), std::string::npos) << msg;
  EXPECT_NE(error_of([] { decode_environment(make_png(11, 4, 3, 9)); }).find("11x4"), std::string::npos);
}

TEST(EnvInput, BadOptionsAreClearErrors) {
  const std::string exr = image::encode_exr(make_float(8, 4, 3));
  for (double k : {0.0, -1.0, 2e6, std::nan("")}) {
    EnvDecodeOptions o;
    o.intensity = k;
    EXPECT_NE(error_of([&] { decode_environment(exr, o); }).find("(0, 1e6]"), std::string::npos) << k;
  }
  EnvDecodeOptions r;
  r.rotation_degrees = std::numeric_limits<double>::infinity();
  EXPECT_NE(error_of([&] { decode_environment(exr, r); }).find("rotation"), std::string::npos);
  EnvDecodeOptions c;
  c.color_space = "no_such_space";
  const std::string msg = error_of([&] { decode_environment(exr, c); });
  EXPECT_NE(msg.find("'no_such_space'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("srgb_texture"), std::string::npos) << msg;
}

// A bright square around the image centre, which looks along −Z.
std::string feature_at_minus_z(int w, int h) {
  image::FloatImage img = make_float(w, h, 3);
  for (float& v : img.pixels) v = 0.0f;
  for (int y = h / 2 - 2; y < h / 2 + 2; ++y) {
    for (int x = w / 2 - 2; x < w / 2 + 2; ++x) {
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = 100.0f;
    }
  }
  return image::encode_exr(img);
}

TEST(EnvInput, RotationBy90DegreesMovesMinusZToTheExpectedFace) {
  // The convention: the image centre looks along −Z.
  const Vec3 centre = equirect_uv_to_direction(0.5, 0.5);
  EXPECT_NEAR(centre.x, 0.0, 1e-12);
  EXPECT_NEAR(centre.z, -1.0, 1e-12);
  // Right-handed 90° about +Y: (x, y, z) → (x cos α + z sin α, y, −x sin α + z cos α), so −Z goes to −X.
  const double a = M_PI / 2;
  const Vec3 moved{centre.x * std::cos(a) + centre.z * std::sin(a), centre.y,
                   -centre.x * std::sin(a) + centre.z * std::cos(a)};
  const int expected_face = direction_to_face_uv(moved).face;
  EXPECT_EQ(expected_face, static_cast<int>(Face::nx));

  const std::string exr = feature_at_minus_z(64, 32);
  EnvDecodeOptions opt;
  opt.rotation_degrees = 90.0;
  const EnvironmentInput env = decode_environment(exr, opt);
  const EnvironmentInput plain = decode_environment(exr);

  const Cubemap before = environment_to_cube(plain, 8);
  const Cubemap after = environment_to_cube(env, 8);
  const auto face_sum = [](const Cubemap& c, int f) {
    double s = 0;
    for (const Rgb& p : c.face(f)) s += p.r;
    return s;
  };
  EXPECT_GT(face_sum(before, static_cast<int>(Face::nz)), 0.0);
  EXPECT_EQ(face_sum(before, expected_face), 0.0);
  EXPECT_GT(face_sum(after, expected_face), 0.0);
  EXPECT_EQ(face_sum(after, static_cast<int>(Face::nz)), 0.0);
  // The feature is carried over whole: the same energy on the new face as on the old one.
  EXPECT_NEAR(face_sum(after, expected_face), face_sum(before, static_cast<int>(Face::nz)),
              1e-9 * face_sum(before, static_cast<int>(Face::nz)));
  // Point lookups agree: the rotated environment seen along −X is the input seen along −Z.
  EXPECT_EQ(sample_environment(env, moved).r, sample_environment(plain, centre).r);
  EXPECT_GT(sample_environment(env, moved).r, 50.0);
}

TEST(EnvInput, RotationByWholeColumnsIsAnExactPermutation) {
  EnvDecodeOptions opt;
  opt.rotation_degrees = -90.0;  // a multiple of 360/64
  const EnvironmentInput env = decode_environment(image::encode_exr(make_float(64, 32, 3)), opt);
  const RgbImage r = rotated_equirect(env);
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 64; ++x) EXPECT_EQ(r.at(x, y), env.image.at((x + 48) % 64, y));
  }
  // Half a column: the mean of the two neighbours, per row.
  EnvironmentInput half = env;
  half.rotation_degrees = 0.5 * 360.0 / 64;
  const RgbImage h = rotated_equirect(half);
  const Rgb mid = (env.image.at(63, 5) + env.image.at(0, 5)) * 0.5;
  EXPECT_NEAR(h.at(63, 5).r, mid.r, 1e-12);
  EXPECT_NEAR(h.at(63, 5).g, mid.g, 1e-12);
}

}  // namespace
}  // namespace kiln::envmap

namespace kiln::envmap {
namespace {

TEST(EnvInput, RadianceHdrIsDecodedAsLinear) {
  // Written by OpenImageIO (to a temporary file: its HDR writer may not write to memory).
  const std::string path = ::testing::TempDir() + "/env_input_test.hdr";
  {
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(8, 4, 3, OIIO::TypeDesc::FLOAT);
    std::vector<float> px(8 * 4 * 3, 3.0f);
    ASSERT_TRUE(out->open(path, spec)) << out->geterror();
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
    ASSERT_TRUE(out->close());
  }
  std::string bytes;
  ASSERT_TRUE(OIIO::Filesystem::read_text_file(path, bytes));
  std::remove(path.c_str());
  const EnvironmentInput env = decode_environment(bytes);
  EXPECT_EQ(env.format, "hdr");
  EXPECT_EQ(env.color_space, "lin_rec709");
  // RGBE keeps 8 bits of mantissa: 3.0 is exact in it.
  EXPECT_NEAR(env.image.at(2, 1).g, 3.0, 3.0 / 128);
}

}  // namespace
}  // namespace kiln::envmap
