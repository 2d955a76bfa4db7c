#include "bakers/image/texture_decode.h"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "bakers/image/color.h"
#include "bakers/image/image_format.h"
#include "bakers/image/image_reader.h"
#include "bakers/image/oiio_memory.h"
#include "bakers/image/reader_bytes.h"

namespace kiln::image {
namespace {

// The reader on the bytes (image_reader.h), its header checked against the texture limits.
std::unique_ptr<OIIO::ImageInput> open_texture(const std::string& bytes, const ImageFormat& format,
                                               OIIO::Filesystem::IOMemReader& proxy,
                                               std::unique_ptr<TempImageFile>& temp, const std::string& who) {
  std::unique_ptr<OIIO::ImageInput> in = open_image_reader(bytes, format, proxy, temp, who);
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width < 1 || spec.height < 1 || spec.width > kMaxTextureDimension || spec.height > kMaxTextureDimension ||
      spec.depth > 1) {
    throw std::runtime_error(who + ": " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                             " pixels; textures may be at most " + std::to_string(kMaxTextureDimension) + " on a side");
  }
  if (spec.nchannels < 1) throw std::runtime_error(who + ": the image has no channels");
  return in;
}

// The pixels as interleaved RGB floats: the first three channels, or the grey channel repeated.
std::vector<float> read_texture_rgb(OIIO::ImageInput& in, const std::string& who) {
  const OIIO::ImageSpec& spec = in.spec();
  const int take = spec.nchannels >= 3 ? 3 : 1;
  const size_t pixels = static_cast<size_t>(spec.width) * spec.height;
  std::vector<float> data(pixels * take);
  if (!in.read_image(0, 0, 0, take, OIIO::TypeDesc::FLOAT, data.data())) {
    throw std::runtime_error(who + ": could not read the pixels (truncated or corrupt?): " + in.geterror());
  }
  in.close();
  std::vector<float> rgb(pixels * 3);
  for (size_t p = 0; p < pixels; ++p) {
    for (int c = 0; c < 3; ++c) rgb[3 * p + c] = data[p * take + (take == 3 ? c : 0)];
  }
  return rgb;
}

// out.texels from RGB in `space`: non-finite values replaced by 0 (OpenColorIO's transforms do not define them),
// converted to the working space, then negatives (and NaN made by the conversion) replaced by 0 and values above 1
// clamped, with the counts.
void to_texels(std::vector<float>& rgb, const ColorConfig& config, const std::string& space, DecodedTexture& out) {
  const size_t pixels = rgb.size() / 3;
  for (size_t p = 0; p < pixels; ++p) {
    bool bad = false;
    for (int c = 0; c < 3; ++c) {
      float& v = rgb[3 * p + c];
      if (!std::isfinite(v)) v = 0.0f, bad = true;
    }
    out.replaced += bad;
  }
  const std::string working = config.working_space();
  if (space != working) config.convert(rgb.data(), pixels, 3, space, working);
  out.texels.resize(pixels);
  for (size_t p = 0; p < pixels; ++p) {
    bool negative = false, above = false;
    double v[3];
    for (int c = 0; c < 3; ++c) {
      v[c] = rgb[3 * p + c];
      if (!(v[c] >= 0)) v[c] = 0, negative = true;  // NaN made by the conversion too
      if (v[c] > 1) v[c] = 1, above = true;
    }
    out.replaced += negative;
    out.clamped += above;
    out.texels[p] = Rgb{v[0], v[1], v[2]};
  }
}

}  // namespace

DecodedTexture decode_texture(const std::string& bytes, const std::string& color_space, const std::string& name) {
  const std::string who = "texture " + name;
  const ImageFormat* format = detect_texture_format(bytes);
  if (!format) {
    throw std::runtime_error(who + ": the " + std::to_string(bytes.size()) +
                             " bytes are not an image kiln reads (they start with " + hex_prefix(bytes, 8) +
                             "); upload a " + kAcceptedTextureFormats + " file");
  }
  std::string storage;
  const std::string& readable = reader_bytes(bytes, *format, who, storage);
  const ColorConfig& config = ColorConfig::active();
  if (!color_space.empty() && !config.has_space(color_space)) {
    throw std::invalid_argument(who + ": colour space '" + color_space + "' is not in the active OpenColorIO config");
  }
  detail::BoundedMemReader proxy(readable.data(), readable.size());
  std::unique_ptr<TempImageFile> temp;
  std::unique_ptr<OIIO::ImageInput> in = open_texture(readable, *format, proxy, temp, who);
  // The default colour space follows the pixels: floats (EXR, HDR, and float TIFF, DDS, PFM, ...) are scene-linear,
  // integers (8- and 16-bit) are sRGB-encoded, as texture tools write them.
  const bool float_pixels = format->is_float || in->spec().format.is_floating_point();
  const std::string space = !color_space.empty() ? color_space : (float_pixels ? "lin_rec709" : "srgb_texture");
  if (!config.has_space(space)) {
    throw std::invalid_argument(who + ": colour space '" + space + "' is not in the active OpenColorIO config");
  }
  DecodedTexture out;
  out.width = in->spec().width;
  out.height = in->spec().height;
  out.format = format->name;
  std::vector<float> rgb = read_texture_rgb(*in, who);
  to_texels(rgb, config, space, out);
  return out;
}

}  // namespace kiln::image
