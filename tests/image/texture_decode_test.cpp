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
#include "bakers/image/exr_header.h"
#include "bakers/image/gif_header.h"
#include "bakers/image/icc_profiles.h"
#include "bakers/image/jpeg_metadata.h"
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
std::string encoded(const std::string& extension, OIIO::TypeDesc type = OIIO::TypeDesc::UINT8,
                    const std::vector<std::pair<std::string, std::string>>& attributes = {},
                    const std::string& icc_profile = "") {
  test::TempDir dir("kiln-texture");
  const std::string path = (dir.path() / ("t." + extension)).string();
  auto out = OIIO::ImageOutput::create(path);
  if (!out) {
    ADD_FAILURE() << "OpenImageIO has no writer for ." << extension;
    return "";
  }
  OIIO::ImageSpec spec(kW, kH, 3, type);
  for (const auto& [name, value] : attributes) spec.attribute(name, value);
  if (!icc_profile.empty()) {
    spec.attribute("ICCProfile", OIIO::TypeDesc(OIIO::TypeDesc::UINT8, static_cast<int>(icc_profile.size())),
                   icc_profile.data());
  }
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
  EXPECT_NE(cut.find("texture cut.tif: could not read the header of the 12-byte tiff image"), std::string::npos) << cut;
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
  for (const std::string& message : {test::error_of([&] { image::decode_png(png); }),
                                     test::error_of([&] { image::decode_texture(png, "", "t.png"); }),
                                     test::error_of([&] { envmap::decode_environment(png); }),
                                     test::error_of([&] { envmap::probe_environment(png); })}) {
    EXPECT_NE(message.find("PNG chunk \"tEXt\" at byte 33 declares 1811939349 bytes of data"), std::string::npos)
        << message;
  }
  EXPECT_LT(peak_rss_bytes() - rss_before, int64_t{256} << 20);
  // A whole file passes the check.
  EXPECT_NO_THROW(image::check_png_chunk_lengths(image::encode_png(small), "t.png"));
}

// A 118-byte upload the texture fuzz target found: a GIF whose logical screen claims 22,597 × 20,304 pixels.
// OpenImageIO's GIF reader allocated that canvas (1.9 GB) when it opened the file; the screen is now checked
// first, and the file refused naming its size. The RSS bound as above.
TEST(TextureDecode, AGifScreenLargerThanAnImageMayBeIsRefusedBeforeAnythingIsAllocated) {
  const std::string gif(
      "\x47\x49\x46\x38\x37\x61\x45\x58\x50\x4f\x53\x55\x52\x45\x3d\x00\x01\x00\x00\x00\x00\x00\x00\x0f"
      "\x00\x00\x00\x00\x00\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\xff\xff\xff\xff\xe8\xff\xff\xff\xff\xff"
      "\xff\xff\x06\x01\x00\x00\xfa\x00\x00\x00\x80\xe8\x00\x00\x75\x35\x01\x00\x00\x00\x00\x00\x00\x0f"
      "\x00\x00\xea\x60\x00\x00\x3a\x98\x00\x00\x17\x70\x65\x78\x00\x45\x4e\x44\xae\x42\x60\x82\xf0\x35"
      "\xde\x74\x00\x49\x63\x68\x61\x6e\x6e\x65\x6c\x73\x45\x4e\x44\x01\x31\x44\xae\x42\x60\x82",
      118);
  ASSERT_EQ(gif.size(), 118u);
  const int64_t rss_before = peak_rss_bytes();
  const std::string message = test::error_of([&] { image::decode_texture(gif, "", "t.gif"); });
  EXPECT_NE(message.find("the GIF's screen is 22597x20304 pixels"), std::string::npos) << message;
  test::error_of([&] { envmap::decode_environment(gif); });
  EXPECT_LT(peak_rss_bytes() - rss_before, int64_t{256} << 20);
  EXPECT_NO_THROW(image::check_gif_screen(std::string("GIF89a\x00\x01\x00\x01\x00\x00\x00", 13), "t.gif"));
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
  for (const std::string& message : {test::error_of([&] { image::decode_exr(exr); }),
                                     test::error_of([&] { image::decode_texture(exr, "", "t.exr"); }),
                                     test::error_of([&] { envmap::decode_environment(exr); }),
                                     test::error_of([&] { envmap::probe_environment(exr); })}) {
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
  EXPECT_LT(peak_rss_bytes() - rss_before, int64_t{256} << 20);
  const int32_t negative = -1;
  std::memcpy(exr.data() + type_end + 1, &negative, 4);
  EXPECT_NE(test::error_of([&] { image::decode_exr(exr); }).find("declares a value of -1 bytes"), std::string::npos);
  EXPECT_NO_THROW(image::check_exr_header(good, "t.exr"));
}

// The exr fuzz target's input: 424 bytes declaring 2,097,156 x 2 float pixels, for which OpenEXR and OpenImageIO
// allocated buffers of 16 and 256 such scanlines (6.4 GB). Every decoder of uploaded EXRs refuses it from its header,
// before OpenEXR opens it (exr_test checks the allocation itself).
TEST(TextureDecode, AnExrWhoseScanlinesTakeMoreThanTheReadLimitIsRefusedFromItsHeader) {
  std::ifstream in(KILN_SOURCE_DIR "/tests/fuzz/regressions/exr/read_scanlines_allocates_6_gb.exr", std::ios::binary);
  const std::string exr{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ASSERT_EQ(exr.size(), 424u);
  for (const std::string& message : {test::error_of([&] { image::decode_exr(exr); }),
                                     test::error_of([&] { image::decode_texture(exr, "", "t.exr"); }),
                                     test::error_of([&] { envmap::decode_environment(exr); }),
                                     test::error_of([&] { envmap::probe_environment(exr); })}) {
    EXPECT_NE(message.find("the EXR header at byte 8 declares 2097156 pixels a scanline of 12 bytes each"),
              std::string::npos)
        << message;
  }
}

// An EXR the texture fuzz target found: its channel list's size field says 52 bytes, OpenEXR's reader takes the 55
// the list holds (a walk by the size fields, as check_exr_attribute_sizes was, went astray), and the next attribute, a
// "comment" string of 1,996,488,713 bytes, is where OpenEXR looks, not where the size field points (a NUL, which ended
// the header for a walk by the size fields). OpenEXR allocated 2 GB.
TEST(TextureDecode, AnExrAttributeHiddenByAShortSizeFieldIsFoundWhereOpenExrReadsIt) {
  std::ifstream in(KILN_SOURCE_DIR "/tests/fuzz/regressions/texture/exr_short_chlist_size_hides_a_2_gb_string.exr",
                   std::ios::binary);
  const std::string exr{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ASSERT_EQ(exr.size(), 504u);
  for (const std::string& message : {test::error_of([&] { image::decode_exr(exr); }),
                                     test::error_of([&] { image::decode_texture(exr, "", "t.exr"); }),
                                     test::error_of([&] { envmap::decode_environment(exr); })}) {
    EXPECT_NE(message.find("EXR header attribute \"comment\" at byte 102 declares a value of 1996488713 bytes, but "
                           "only 383 follow it"),
              std::string::npos)
        << message;
  }
  // The exr target's, the other way round: a channel list 18 bytes longer than its size field hid an attribute of an
  // unknown type whose 1,818,848,000 bytes OpenEXR allocated.
  std::ifstream other(KILN_SOURCE_DIR "/tests/fuzz/regressions/exr/chlist_size_hides_a_1_8_gb_attribute.exr",
                      std::ios::binary);
  const std::string exr2{std::istreambuf_iterator<char>(other), std::istreambuf_iterator<char>()};
  const std::string message = test::error_of([&] { image::decode_exr(exr2); });
  EXPECT_NE(message.find("declares a value of 1818848000 bytes, but only "), std::string::npos) << message;
}

// A JPEG segment: FF, its code, its length (the payload's and the field's own 2 bytes, big-endian), the payload.
std::string jpeg_segment(unsigned char code, const std::string& payload) {
  const size_t length = payload.size() + 2;
  return std::string{'\xff', static_cast<char>(code), static_cast<char>(length >> 8),
                     static_cast<char>(length & 0xff)} +
         payload;
}

void put_big_endian_u32(std::string& bytes, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) bytes[at + i] = static_cast<char>(v >> (24 - 8 * i));
}

// A 148-byte ICC profile whose one tag, of type "text", is 4 bytes long: shorter than the 8 bytes that type's own
// header takes, so OpenImageIO 2.4.7's decode_icc_profile makes a string of 4 - 8 bytes (unsigned: 4 GiB) from it.
std::string icc_profile_with_a_short_text_tag() {
  std::string p(148, '\0');
  put_big_endian_u32(p, 0, 148);  // the profile's size
  std::memcpy(&p[36], "acsp", 4);
  put_big_endian_u32(p, 128, 1);  // one tag: signature, offset, size
  std::memcpy(&p[132], "cprt", 4);
  put_big_endian_u32(p, 136, 144);
  put_big_endian_u32(p, 140, 4);
  std::memcpy(&p[144], "text", 4);
  return p;
}

bool same_texels(const image::DecodedTexture& a, const image::DecodedTexture& b) {
  if (a.texels.size() != b.texels.size()) return false;
  for (size_t i = 0; i < a.texels.size(); ++i) {
    if (a.texels[i].r != b.texels[i].r || a.texels[i].g != b.texels[i].g || a.texels[i].b != b.texels[i].b)
      return false;
  }
  return true;
}

// Metadata segments that Debian's OpenImageIO 2.4.7 reads past (JpgInput::open, read_icc_profile, jpeg_decode_iptc,
// decode_icc_profile), each put after the SOI of a valid JPEG. The first is the texture fuzz target's input (strcmp
// past an APP1 without a NUL, which AddressSanitizer reports); the ICC profile crashes the reader in any build (SIGSEGV
// hashing 4 GiB, as `iinfo -v` does on the file). The segments are dropped, so every decoder of uploaded images reads
// the pixels, the same as without them; under the sanitizers nothing is read out of bounds.
TEST(TextureDecode, JpegMetadataThatOpenImageIoReadsPastIsDroppedAndThePixelsAreRead) {
  const std::string plain = encoded("jpg");
  const image::DecodedTexture expected = image::decode_texture(plain, "", "t.jpg");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"APP1 without a NUL", jpeg_segment(0xe1, "ExHHHHHHHHHHHHHHHHHH")},
      {"APP1 Exif of 5 bytes (Exif read over 2^64 - 1 bytes)", jpeg_segment(0xe1, std::string("Exif\0", 5))},
      {"APP2 ICC profile with a 4-byte text tag",
       jpeg_segment(0xe2, std::string("ICC_PROFILE\0\x01\x01", 14) + icc_profile_with_a_short_text_tag())},
      {"APP13 IPTC block claiming 65535 bytes", jpeg_segment(0xed, std::string("Photoshop 3.0\0"
                                                                               "8BIM\x04\x04\0\0\0\0\xff\xff",
                                                                               26))},
      {"APP2 of 0 bytes", jpeg_segment(0xe2, "")},
  };
  for (const auto& [what, segment] : cases) {
    SCOPED_TRACE(what);
    std::string jpeg = plain;
    jpeg.insert(2, segment);
    EXPECT_EQ(image::jpeg_without_metadata(jpeg, "t.jpg"), image::jpeg_without_metadata(plain, "t.jpg"));
    image::DecodedTexture t;
    ASSERT_NO_THROW(t = image::decode_texture(jpeg, "", "t.jpg"));
    EXPECT_TRUE(same_texels(t, expected));
    EXPECT_NO_THROW(envmap::decode_environment(jpeg));
    EXPECT_NO_THROW(envmap::probe_environment(jpeg));
  }
}

// Where the segments are: after the entropy-coded data too (libjpeg saves the markers between the scans of a
// progressive file before OpenImageIO looks), with stuffed FF 00 bytes and restart markers passed over as libjpeg
// does; APP0 (JFIF) and APP14 (Adobe), which libjpeg reads to choose the colour transform, are kept.
TEST(TextureDecode, JpegMetadataIsFoundAsLibjpegFindsMarkersAndPixelSegmentsAreKept) {
  // OpenImageIO's writer puts these in Exif (APP1), IPTC (APP13) and a comment; its reader finds none once dropped.
  const std::string plain = encoded(
      "jpg", OIIO::TypeDesc::UINT8,
      {{"IPTC:Caption", "a caption"}, {"Exif:ImageUniqueID", "0123456789abcdef"}, {"ImageDescription", "a comment"}});
  const std::string stripped = image::jpeg_without_metadata(plain, "t.jpg");
  auto attribute_count = [](const std::string& bytes, const std::string& prefix) {
    OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
    void* proxy_ptr = &proxy;
    OIIO::ImageSpec config;
    config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy_ptr);
    auto in = OIIO::ImageInput::open("t.jpg", &config);
    if (!in) return -1;
    int n = 0;
    for (const auto& a : in->spec().extra_attribs) n += a.name().string().rfind(prefix, 0) == 0;
    return n;
  };
  for (const std::string prefix : {"IPTC:", "Exif:", "ImageDescription"}) {
    EXPECT_GT(attribute_count(plain, prefix), 0) << prefix;
    EXPECT_EQ(attribute_count(stripped, prefix), 0) << prefix;
  }
  EXPECT_TRUE(same_texels(image::decode_texture(stripped, "", "t.jpg"), image::decode_texture(plain, "", "t.jpg")));
  const size_t eoi = plain.rfind("\xff\xd9");
  std::string jpeg = plain;
  jpeg.insert(eoi, jpeg_segment(0xfe, "a comment after the scan") + jpeg_segment(0xe1, "Exif"));
  EXPECT_EQ(image::jpeg_without_metadata(jpeg, "t.jpg"), stripped);
  // An FF 00 or a restart marker in a segment's place is data to libjpeg: what follows it is not a segment.
  const std::string app0 = jpeg_segment(0xe0, std::string("JFIF\0\x01\x01\0\0\x01\0\x01\0\0", 14));
  const std::string app14 = jpeg_segment(0xee, std::string("Adobe\0\x64\0\0\0\0\x01", 12));
  const std::string kept = std::string("\xff\xd8") + app0 + app14 + std::string("\xff\xda\x00\x02", 4) +
                           std::string("\x12\xff\x00\xe1", 4) + "\xff\xd3\x34" + "\xff\xd9";
  EXPECT_EQ(image::jpeg_without_metadata(kept, "k.jpg"), kept);
}

// Checks that `disable` changes exactly the 4 signature bytes of `profile` in `with_profile` (a `name` file holding
// it), leaves a file cut inside the profile as it is, and that the texture decoder reads the same texels as from
// `plain`.
void expect_profile_disabled(const std::string& with_profile, const std::string& plain, const std::string& profile,
                             std::string (*disable)(const std::string&), const std::string& name) {
  const size_t signature = with_profile.find(profile);
  ASSERT_NE(signature, std::string::npos);
  std::string expected = with_profile;
  std::memset(expected.data() + signature + 36, 0, 4);
  EXPECT_EQ(disable(with_profile), expected);
  image::DecodedTexture t;
  ASSERT_NO_THROW(t = image::decode_texture(with_profile, "", name));
  EXPECT_TRUE(same_texels(t, image::decode_texture(plain, "", name)));
  EXPECT_EQ(disable(with_profile.substr(0, signature + 20)), with_profile.substr(0, signature + 20));
}

// The same profile in a TIFF (tag 34675, written by OpenImageIO's own TIFF writer): OpenImageIO's TIFF reader parses
// it too, and died of SIGSEGV; the texture decoder reads TIFF. Its signature is cleared, the one change to the file,
// so the parser stops there and the pixels are read as without a profile.
TEST(TextureDecode, ATiffIccProfileThatOpenImageIoReadsPastIsNotParsed) {
  const std::string profile = icc_profile_with_a_short_text_tag();
  expect_profile_disabled(encoded("tif", OIIO::TypeDesc::UINT8, {}, profile), encoded("tif"), profile,
                          image::tiff_without_icc_profile, "t.tif");
  EXPECT_EQ(image::tiff_without_icc_profile("II*\0 not much more"), "II*\0 not much more");
}

// A kW x kH RGB PSD of kRgb, 8-bit and raw, with `icc_profile` as its image resource 1039 if one is given (OpenImageIO
// writes no PSD; the layout is Adobe's: header, colour mode data, image resources, layers, image data by plane).
std::string psd(const std::string& icc_profile) {
  auto big_endian = [](uint64_t v, int n) {
    std::string s;
    for (int i = n - 1; i >= 0; --i) s += static_cast<char>(v >> (8 * i));
    return s;
  };
  std::string out = "8BPS" + big_endian(1, 2) + std::string(6, '\0') + big_endian(3, 2) + big_endian(kH, 4) +
                    big_endian(kW, 4) + big_endian(8, 2) + big_endian(3, 2);
  out += big_endian(0, 4);  // no colour mode data
  std::string resources;
  if (!icc_profile.empty()) {
    resources = "8BIM" + big_endian(1039, 2) + std::string(2, '\0') + big_endian(icc_profile.size(), 4) + icc_profile;
    if (icc_profile.size() % 2) resources += '\0';
  }
  out += big_endian(resources.size(), 4) + resources;
  out += big_endian(0, 4) + big_endian(0, 2);  // no layers; raw image data
  for (int c = 0; c < 3; ++c) out += std::string(kW * kH, static_cast<char>(kRgb[c]));
  return out;
}

// And in a PSD (image resource 1039), which OpenImageIO's PSD reader parses the same way: cleared the same way.
TEST(TextureDecode, APsdIccProfileThatOpenImageIoReadsPastIsNotParsed) {
  const std::string profile = icc_profile_with_a_short_text_tag();
  expect_profile_disabled(psd(profile), psd(""), profile, image::psd_without_icc_profile, "t.psd");
  EXPECT_EQ(image::decode_texture(psd(""), "", "t.psd").format, "psd");
}

// A PSD its reader refuses: OpenImageIO's ImageInput::open would hand the bytes to every other reader, and its RLA
// reader aborts the process on these (a fuzz finding). Only the PSD reader sees them, and its refusal is the error.
TEST(TextureDecode, BytesTheirFormatsReaderRefusesReachNoOtherReader) {
  std::ifstream in(KILN_SOURCE_DIR "/tests/fuzz/regressions/texture/psd_refused_then_rla_reader_aborts.psd",
                   std::ios::binary);
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ASSERT_EQ(bytes.size(), 786u);
  const std::string error = error_of([&] { image::decode_texture(bytes, "", "damaged.psd"); });
  EXPECT_NE(error.find("texture damaged.psd: could not read the header of the 786-byte psd image (truncated or "
                       "corrupt?): "),
            std::string::npos)
      << error;
  // The same for a format read from memory: a TIFF signature over a JPEG's bytes is the TIFF reader's to refuse.
  std::string tiff_then_jpeg = encoded("jpg");
  tiff_then_jpeg.replace(0, 4, std::string("II*\0", 4));
  const std::string tiff_error = error_of([&] { image::decode_texture(tiff_then_jpeg, "", "t.tif"); });
  EXPECT_NE(tiff_error.find("texture t.tif: could not read the header of the " + std::to_string(tiff_then_jpeg.size()) +
                            "-byte tiff image (truncated or corrupt?): "),
            std::string::npos)
      << tiff_error;
}

TEST(TextureDecode, AJpegSegmentLongerThanTheFileIsRefusedNamingIt) {
  const std::string plain = encoded("jpg");
  std::string jpeg = plain;
  jpeg.insert(2, std::string("\xff\xe1\xff\xff", 4));
  const std::string expected =
      "texture t.jpg: the JPEG APP1 segment at byte 2 declares 65535 bytes (its length field "
      "included), but only " +
      std::to_string(plain.size()) + " follow its marker";
  EXPECT_NE(error_of([&] { image::decode_texture(jpeg, "", "t.jpg"); }).find(expected), std::string::npos);
  EXPECT_NE(error_of([&] { envmap::decode_environment(jpeg); }).find("APP1 segment at byte 2 declares 65535"),
            std::string::npos);
  jpeg = plain;
  jpeg.insert(2, std::string("\xff\xfe\x00\x01", 4));
  EXPECT_NE(error_of([&] { image::decode_texture(jpeg, "", "t.jpg"); })
                .find("the JPEG COM segment at byte 2 declares 1 bytes (its length field included), but a segment "
                      "holds at least its 2-byte length"),
            std::string::npos);
}

}  // namespace
}  // namespace kiln
