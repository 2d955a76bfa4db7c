// Texture decoding (bakers/image/texture_decode.h): the image formats OpenImageIO reads are read (from memory, or
// from a temporary file where its reader cannot read memory), recognised by its bytes (TGA, which has no signature,
// by its header), with the default colour space following the pixels
// (float: lin_rec709, integer: srgb_texture); sizes are checked on the header; anything else is refused naming what
// kiln reads. The images are written here by OpenImageIO (DDS, which it cannot write, by hand; PSD, which it cannot
// write either, is recognised by its signature but not tested).
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "bakers/envmap/env_input.h"
#include "bakers/image/exr.h"
#include "bakers/image/png.h"
#include "bakers/image/texture_decode.h"
#include "tests/support/error_of.h"
#include "tests/support/temp_dir.h"

namespace kiln {
namespace {

constexpr int kW = 4, kH = 2;
// One colour on every pixel, 8-bit: (255, 128, 0).
constexpr unsigned char kRgb[3] = {255, 128, 0};

double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

// A kW × kH image of kRgb (or of 0.5 as floats) in the format `extension` picks, through a temporary file (not every
// OpenImageIO writer writes to memory).
std::string encoded(const std::string& extension, OIIO::TypeDesc type = OIIO::TypeDesc::UINT8) {
  test::TempDir dir("kiln-texture");
  const std::string path = (dir.path() / ("t." + extension)).string();
  auto out = OIIO::ImageOutput::create(path);
  if (!out) {
    ADD_FAILURE() << "OpenImageIO has no writer for ." << extension;
    return "";
  }
  OIIO::ImageSpec spec(kW, kH, 3, type);
  // Debian's OpenImageIO 2.4.7 HEIF writer reads far past the pixels it is given (192 bytes from this 24-byte image,
  // AddressSanitizer found): the buffers have room to spare, which the other writers never read.
  constexpr size_t kSlack = 4096;
  std::vector<unsigned char> bytes(kW * kH * 3 + kSlack);
  std::vector<float> floats(kW * kH * 3 + kSlack, 0.5f);
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = kRgb[i % 3];
  EXPECT_TRUE(out->open(path, spec)) << out->geterror();
  if (type == OIIO::TypeDesc::FLOAT) {
    EXPECT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, floats.data())) << out->geterror();
  } else {
    EXPECT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, bytes.data())) << out->geterror();
  }
  EXPECT_TRUE(out->close());
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// An uncompressed 32-bit BGRA DDS of kRgb (Microsoft's DDS_HEADER with a DDS_PIXELFORMAT of RGB masks).
std::string dds() {
  std::vector<uint32_t> h(32, 0);  // "DDS " then the 124-byte header: 31 words
  std::memcpy(&h[0], "DDS ", 4);
  h[1] = 124;                                  // dwSize
  h[2] = 0x1 | 0x2 | 0x4 | 0x1000;             // CAPS, HEIGHT, WIDTH, PIXELFORMAT
  h[3] = kH, h[4] = kW, h[5] = kW * 4;         // height, width, pitch
  h[19] = 32, h[20] = 0x40 | 0x1, h[22] = 32;  // pixel format: size, RGB | ALPHAPIXELS, 32 bits
  h[23] = 0x00ff0000, h[24] = 0x0000ff00, h[25] = 0x000000ff, h[26] = 0xff000000;  // R, G, B, A masks
  h[27] = 0x1000;                                                                  // caps: TEXTURE
  std::string out(reinterpret_cast<const char*>(h.data()), 128);
  for (int p = 0; p < kW * kH; ++p)
    out += {static_cast<char>(kRgb[2]), static_cast<char>(kRgb[1]), static_cast<char>(kRgb[0]), static_cast<char>(255)};
  return out;
}

using test::error_of;

struct Case {
  std::string extension, format;  // the file's, and OpenImageIO's name for it
  double tolerance;               // on linear texels: 1e-4 for lossless formats; lossy ones move an 8-bit value
};

TEST(TextureDecode, TgaTiffBmpDdsAndTheOtherFormatsOpenImageIoReadsAreRead) {
  const std::vector<Case> cases = {
      {"tga", "targa", 1e-4}, {"tif", "tiff", 1e-4}, {"bmp", "bmp", 1e-4},   {"png", "png", 1e-4},
      {"gif", "gif", 1e-4},   {"pnm", "pnm", 1e-4},  {"dpx", "dpx", 1e-4},   {"iff", "iff", 1e-4},
      {"sgi", "sgi", 1e-4},   {"jpg", "jpeg", 0.03}, {"webp", "webp", 0.03}, {"heic", "heif", 0.03},
  };
  const double expected[3] = {srgb_to_linear(kRgb[0] / 255.0), srgb_to_linear(kRgb[1] / 255.0),
                              srgb_to_linear(kRgb[2] / 255.0)};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.extension);
    const std::string bytes = encoded(c.extension);
    image::DecodedTexture t;
    ASSERT_NO_THROW(t = image::decode_texture(bytes, "", "t." + c.extension));
    EXPECT_EQ(t.format, c.format);
    ASSERT_EQ(t.width, kW);
    ASSERT_EQ(t.height, kH);
    ASSERT_EQ(t.texels.size(), static_cast<size_t>(kW * kH));
    // 8-bit pixels default to srgb_texture.
    EXPECT_NEAR(t.texels[5].r, expected[0], c.tolerance);
    EXPECT_NEAR(t.texels[5].g, expected[1], c.tolerance);
    EXPECT_NEAR(t.texels[5].b, expected[2], c.tolerance);
  }
  const image::DecodedTexture d = image::decode_texture(dds(), "", "t.dds");
  EXPECT_EQ(d.format, "dds");
  ASSERT_EQ(d.texels.size(), static_cast<size_t>(kW * kH));
  EXPECT_NEAR(d.texels[3].r, expected[0], 1e-4);
  EXPECT_NEAR(d.texels[3].g, expected[1], 1e-4);
  EXPECT_NEAR(d.texels[3].b, expected[2], 1e-4);
}

TEST(TextureDecode, FloatPixelsDefaultToLinearWhateverTheFormat) {
  // A float TIFF of 0.5: scene-linear by default (as EXR), so the texel is 0.5, not sRGB-decoded (0.214).
  const image::DecodedTexture t = image::decode_texture(encoded("tif", OIIO::TypeDesc::FLOAT), "", "t.tif");
  EXPECT_NEAR(t.texels[0].g, 0.5, 1e-6);
  // The colour space a job declares still wins.
  const image::DecodedTexture s = image::decode_texture(encoded("tif", OIIO::TypeDesc::FLOAT), "srgb_texture", "t");
  EXPECT_NEAR(s.texels[0].g, srgb_to_linear(0.5), 1e-4);
}

TEST(TextureDecode, SizesAreCheckedOnTheHeaderAndOtherBytesAreRefusedNamingWhatIsRead) {
  // A TGA header that claims 9000 × 9000 pixels of 24 bits, and no pixels: refused before anything is allocated.
  std::string tga(18, '\0');
  tga[2] = 2;  // uncompressed true colour
  tga[12] = static_cast<char>(9000 & 0xff), tga[13] = static_cast<char>(9000 >> 8);
  tga[14] = static_cast<char>(9000 & 0xff), tga[15] = static_cast<char>(9000 >> 8);
  tga[16] = 24;
  const std::string big = error_of([&] { image::decode_texture(tga, "", "huge.tga"); });
  EXPECT_NE(big.find("texture huge.tga: 9000x9000 pixels; textures may be at most 8192 on a side"), std::string::npos)
      << big;
  const std::string other = error_of([] { image::decode_texture("\x01\x02these bytes are no image", "", "x.bin"); });
  EXPECT_NE(other.find("texture x.bin: the 26 bytes are not an image kiln reads (they start with 01 02 74"),
            std::string::npos)
      << other;
  EXPECT_NE(other.find("TGA, TIFF, BMP, DDS"), std::string::npos) << other;
  // A TIFF cut short: its reader says so.
  const std::string tif = encoded("tif");
  const std::string cut = error_of([&] { image::decode_texture(tif.substr(0, 12), "", "cut.tif"); });
  EXPECT_NE(cut.find("texture cut.tif: could not read the tiff header"), std::string::npos) << cut;
}

// The peak resident set of this process so far, in bytes.
int64_t peak_rss_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return int64_t{usage.ru_maxrss} * 1024;
}

// A 4x2 PNG with a tEXt chunk that declares 1,811,939,349 bytes of data after its IHDR (the shape of the input the
// png fuzz target found): libpng allocated that much before finding the file too short, so every decoder of uploaded
// PNGs (decode_png, textures, environments) allocated 1.8 GB for a 250-byte upload. Each now refuses the file from its
// chunk lengths, naming the chunk, before libpng sees it. Peak RSS only grows, so a jump of 1.8 GB would show; 256 MB
// is far above what decoding a 4x2 image needs and far below the claim.
TEST(TextureDecode, APngChunkLongerThanTheFileIsRefusedBeforeAnythingIsAllocated) {
  image::Png8Image small;
  small.width = kW;
  small.height = kH;
  small.channels = 3;
  small.pixels.assign(kW * kH * 3, 100);
  std::string png = image::encode_png(small);
  const size_t after_ihdr = 8 + 12 + 13;
  const std::string lying_chunk = std::string("\x6c\x00\x00\x15tEXtComment", 15) + std::string(20, 'x');
  png.insert(after_ihdr, lying_chunk);
  const int64_t rss_before = peak_rss_bytes();
  for (const std::string& message :
       {test::error_of([&] { image::decode_png(png); }), test::error_of([&] { image::decode_texture(png, "", "t.png"); }),
        test::error_of([&] { envmap::decode_environment(png); }),
        test::error_of([&] { envmap::probe_environment(png); })}) {
    EXPECT_NE(message.find("PNG chunk \"tEXt\" at byte 33 declares 1811939349 bytes of data"), std::string::npos)
        << message;
  }
  EXPECT_LT(peak_rss_bytes() - rss_before, int64_t{256} << 20);
  // A whole file passes the check.
  EXPECT_NO_THROW(image::check_png_chunk_lengths(image::encode_png(small), "t.png"));
}

// An EXR whose first header attribute declares a value of 1.7 GB (the shape of the input the exr fuzz target found):
// OpenEXR sized the string from that field and zeroed it, 1.7 GB for a 500-byte upload, in every decoder of uploaded
// EXRs. Each now refuses the file from the attribute sizes, naming the attribute. The RSS bound as above.
TEST(TextureDecode, AnExrAttributeLongerThanTheFileIsRefusedBeforeAnythingIsAllocated) {
  image::FloatImage small;
  small.width = kW;
  small.height = kH;
  small.channels = 3;
  small.pixels.assign(kW * kH * 3, 0.5f);
  const std::string good = image::encode_exr(small);
  std::string exr = good;
  const size_t name_end = exr.find('\0', 8);
  const size_t type_end = exr.find('\0', name_end + 1);
  const std::string name = exr.substr(8, name_end - 8);
  const int32_t claim = 1711276032;
  std::memcpy(exr.data() + type_end + 1, &claim, 4);
  const int64_t rss_before = peak_rss_bytes();
  const std::string expected =
      "EXR header attribute \"" + name + "\" at byte 8 declares a value of 1711276032 bytes, but only ";
  for (const std::string& message :
       {test::error_of([&] { image::decode_exr(exr); }), test::error_of([&] { image::decode_texture(exr, "", "t.exr"); }),
        test::error_of([&] { envmap::decode_environment(exr); }),
        test::error_of([&] { envmap::probe_environment(exr); })}) {
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
  EXPECT_LT(peak_rss_bytes() - rss_before, int64_t{256} << 20);
  const int32_t negative = -1;
  std::memcpy(exr.data() + type_end + 1, &negative, 4);
  EXPECT_NE(test::error_of([&] { image::decode_exr(exr); }).find("declares a value of -1 bytes"), std::string::npos);
  EXPECT_NO_THROW(image::check_exr_attribute_sizes(good, "t.exr"));
}

}  // namespace
}  // namespace kiln
