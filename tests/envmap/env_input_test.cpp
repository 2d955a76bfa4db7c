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
#include "tests/support/error_of.h"

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

using test::error_of;

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

// The per-pixel passes run in parallel over blocks of 65536 pixels: a 512 × 256 image has two, and every pixel of
// both must be converted (here from a declared sRGB curve, checked against the formula) and sanitised, with the
// counts summed over the blocks and the largest finite value (for +Inf) taken over the whole image.
TEST(EnvInput, EveryBlockOfALargeImageIsConvertedAndSanitised) {
  image::FloatImage img = make_float(512, 256, 3);
  for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = static_cast<float>((i * 7919) % 1000) / 1000.0f;
  const float inf = std::numeric_limits<float>::infinity();
  img.at(511, 255, 1) = 2.5f;                                   // the largest finite value, in the last block
  img.at(3, 2, 0) = std::numeric_limits<float>::quiet_NaN();    // first block
  img.at(7, 200, 2) = std::numeric_limits<float>::quiet_NaN();  // second block
  img.at(9, 1, 1) = inf;
  img.at(400, 250, 0) = -inf;
  EnvDecodeOptions opt;
  opt.color_space = "srgb_texture";
  const EnvironmentInput env = decode_environment(image::encode_exr(img), opt);
  EXPECT_EQ(env.sanitized.nan, 2);
  EXPECT_EQ(env.sanitized.inf, 2);
  EXPECT_EQ(env.sanitized.negative, 0);
  // +Inf became 2.5 before the curve: the curve's value at 2.5 (OpenColorIO extends it above 1).
  EXPECT_NEAR(env.image.at(9, 1).g, srgb_to_linear(2.5), 1e-4 * srgb_to_linear(2.5));
  EXPECT_EQ(env.image.at(3, 2).r, 0.0);
  EXPECT_EQ(env.image.at(7, 200).b, 0.0);
  EXPECT_EQ(env.image.at(400, 250).r, 0.0);
  // OpenColorIO's CPU processor evaluates the curve in float: 1e-5 absolute is ample (as for the 8-bit PNG).
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 512; ++x) {
      if ((x == 3 && y == 2) || (x == 7 && y == 200) || (x == 9 && y == 1) || (x == 400 && y == 250) ||
          (x == 511 && y == 255))
        continue;
      for (int c = 0; c < 3; ++c) {
        const double expected = srgb_to_linear(img.at(x, y, c));
        ASSERT_NEAR(env.image.at(x, y)[c], expected, 1e-5) << "pixel (" << x << ", " << y << "), channel " << c;
      }
    }
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

// ---- Six-face input --------------------------------------------------------------------------------------------

// A smooth function of the direction (degree 2, positive, different per channel).
Rgb face_fn(const Vec3& d) {
  return {1.0 + 0.5 * d.x + 0.3 * d.y * d.y, 0.8 + 0.4 * d.y, 1.0 + 0.3 * d.z + 0.2 * d.x * d.y};
}

// The six faces of `cube` as EXR images (first row of the picture = row t ≈ 0, cubemap.h).
std::vector<std::string> encode_faces(const Cubemap& cube) {
  std::vector<std::string> faces;
  for (int f = 0; f < kFaceCount; ++f) {
    image::FloatImage img;
    img.width = img.height = cube.size();
    img.channels = 3;
    img.channel_names = {"R", "G", "B"};
    for (int y = 0; y < cube.size(); ++y)
      for (int x = 0; x < cube.size(); ++x) {
        const Rgb& c = cube.at(f, x, y);
        img.pixels.insert(img.pixels.end(), {float(c.r), float(c.g), float(c.b)});
      }
    faces.push_back(image::encode_exr(img));
  }
  return faces;
}

// Faces holding a known function decode to that function's cube (to float rounding, 1e-6 relative), and to the
// same cube as the equirectangular image of the function within the resampling tolerance: the equirect path averages
// each cube texel over its area (supersampled), the faces hold the value at the texel centre, and for a degree-2
// function the two differ by ≈ h²/24 · |∇²f| ≤ (2/32)²/24 · 2 ≈ 3e-4 plus the equirect's own bilinear
// reconstruction (512 × 256: ~(π/256)²/8 · 2 ≈ 4e-5): held to 2e-3 relative.
TEST(EnvInput, SixFacesOfAFunctionMatchTheEquirectOfThatFunction) {
  const Cubemap expected = cubemap_from(32, &face_fn);
  const CubeFacesInput faces = decode_cube_faces(encode_faces(expected));
  EXPECT_EQ(faces.face_size, 32);
  EXPECT_EQ(faces.format, "openexr");
  EXPECT_EQ(faces.sanitized.total(), 0);
  const Cubemap from_faces = faces_to_cube(faces, 32);
  image::FloatImage eq;
  eq.width = 512;
  eq.height = 256;
  eq.channels = 3;
  for (int y = 0; y < eq.height; ++y)
    for (int x = 0; x < eq.width; ++x) {
      const Rgb c = face_fn(equirect_uv_to_direction((x + 0.5) / eq.width, (y + 0.5) / eq.height));
      eq.pixels.insert(eq.pixels.end(), {float(c.r), float(c.g), float(c.b)});
    }
  const Cubemap from_equirect = environment_to_cube(decode_environment(image::encode_exr(eq)), 32);
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 32; ++x) {
        const Rgb a = from_faces.at(f, x, y), b = expected.at(f, x, y), c = from_equirect.at(f, x, y);
        ASSERT_NEAR(a.g, b.g, 1e-6 * b.g) << f << " " << x << " " << y;
        ASSERT_NEAR(a.r, c.r, 2e-3 * c.r) << f << " " << x << " " << y;
        ASSERT_NEAR(a.g, c.g, 2e-3 * c.g) << f << " " << x << " " << y;
        ASSERT_NEAR(a.b, c.b, 2e-3 * c.b) << f << " " << x << " " << y;
      }
  // Downsampling by a power of two is area-correct: the mean of each 2 × 2 block, weighted by solid angle.
  const Cubemap half = faces_to_cube(faces, 16);
  const Cubemap ref = downsample_2x(from_faces);
  for (int f = 0; f < kFaceCount; ++f) EXPECT_EQ(half.face(f), ref.face(f));
}

// Rotation about +Y applies to faces as to an equirect image: rotating by 90° moves what was seen towards −Z to −X.
// Tolerance: the rotated faces are resampled (bilinear in the source, supersampled), ≤ 2e-3 for this smooth
// function as above.
TEST(EnvInput, SixFacesAreRotatedAndScaled) {
  EnvDecodeOptions o;
  o.rotation_degrees = 90.0;
  o.intensity = 2.0;
  const CubeFacesInput faces = decode_cube_faces(encode_faces(cubemap_from(32, &face_fn)), o);
  const Cubemap cube = faces_to_cube(faces, 32);
  // R_y(−90°) maps d to the lookup direction (d.x c − d.z s, d.y, d.x s + d.z c) with c = 0, s = 1: (−d.z, d.y, d.x).
  const Cubemap expected = cubemap_from(32, [](const Vec3& d) { return face_fn({-d.z, d.y, d.x}) * 2.0; });
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < 32; y += 3)
      for (int x = 0; x < 32; x += 3)
        ASSERT_NEAR(cube.at(f, x, y).b, expected.at(f, x, y).b, 2e-3 * expected.at(f, x, y).b) << f;
}

TEST(EnvInput, BadFacesAreClearErrorsNamingTheFace) {
  const std::vector<std::string> good = encode_faces(Cubemap(8, Rgb{1.0}));
  std::string msg = error_of([&] { decode_cube_faces({good.begin(), good.begin() + 5}); });
  EXPECT_NE(msg.find("5 face images"), std::string::npos) << msg;
  EXPECT_NE(msg.find("exactly 6"), std::string::npos) << msg;
  auto with = [&](int face, std::string bytes) {
    std::vector<std::string> f = good;
    f[face] = std::move(bytes);
    return f;
  };
  msg = error_of([&] { decode_cube_faces(with(3, image::encode_exr(make_float(8, 6, 3)))); });
  EXPECT_NE(msg.find("face 3 (-Y)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not square"), std::string::npos) << msg;
  msg = error_of([&] { decode_cube_faces(with(4, image::encode_exr(make_float(4, 4, 3)))); });
  EXPECT_NE(msg.find("face 4 (+Z)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("same size"), std::string::npos) << msg;
  msg = error_of([&] { decode_cube_faces(with(2, "hello")); });
  EXPECT_NE(msg.find("face 2 (+Y)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not an image"), std::string::npos) << msg;
  // The header probe gives the same errors before any pixel is read.
  msg = error_of([&] { probe_cube_faces(with(4, image::encode_exr(make_float(4, 4, 3)))); });
  EXPECT_NE(msg.find("face 4 (+Z)"), std::string::npos) << msg;
  // An 8-bit face is sRGB like an 8-bit equirect; mixed formats are accepted (same size).
  const CubeFacesInput mixed = decode_cube_faces(with(5, make_png(8, 8, 3, 255)));
  EXPECT_NEAR(mixed.cube.at(5, 3, 3).g, 1.0, 1e-6);  // sRGB 1.0 is linear 1.0
  EXPECT_NE(mixed.format.find("png"), std::string::npos);
}

TEST(EnvInput, FaceTexelsAreSanitisedAndCounted) {
  Cubemap c(4, Rgb{1.0});
  c.at(1, 2, 2) = Rgb{std::nan(""), 1.0, 1.0};
  c.at(4, 0, 0) = Rgb{INFINITY, 1.0, 1.0};
  c.at(5, 1, 3) = Rgb{-1.0, 1.0, 1.0};
  const CubeFacesInput f = decode_cube_faces(encode_faces(c));
  EXPECT_EQ(f.sanitized.nan, 1);
  EXPECT_EQ(f.sanitized.inf, 1);
  EXPECT_EQ(f.sanitized.negative, 1);
  EXPECT_EQ(f.cube.at(1, 2, 2).r, 0.0);
  EXPECT_EQ(f.cube.at(4, 0, 0).r, 1.0);  // +Inf → the largest finite value of that face
  EXPECT_EQ(f.cube.at(5, 1, 3).r, 0.0);
}

}  // namespace
}  // namespace kiln::envmap
