#include "bakers/image/oiio_memory.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace kiln::image::detail {

size_t BoundedMemReader::pread(void* buf, size_t size, int64_t offset) {
  const size_t available = m_buf.size();
  // An offset before the buffer or at or past its end: nothing to read (OpenEXR then reports a short read).
  if (offset < 0 || static_cast<uint64_t>(offset) >= available || size == 0) return 0;
  const size_t n = std::min(size, available - static_cast<size_t>(offset));
  std::memcpy(buf, m_buf.data() + offset, n);
  return n;
}

std::string write_to_memory(const char* virtual_name, const OIIO::ImageSpec& spec, OIIO::TypeDesc pixel_type,
                            const void* pixels, const std::string& codec, const std::string& format,
                            const std::string& writer) {
  std::vector<unsigned char> buffer;
  OIIO::Filesystem::IOVecOutput proxy(buffer);
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(virtual_name);
  if (!out) throw std::runtime_error(codec + ": OpenImageIO has no " + writer + " writer: " + OIIO::geterror());
  out->threads(1);
  const auto fail = [&](const std::string& what) {
    throw std::runtime_error(codec + ": could not " + what + " a " + std::to_string(spec.width) + "x" +
                             std::to_string(spec.height) + " " + format + " image with " +
                             std::to_string(spec.nchannels) + " channels: " + out->geterror());
  };
  if (!out->set_ioproxy(&proxy)) fail("attach the memory buffer to");
  if (!out->open(virtual_name, spec)) fail("start");
  if (!out->write_image(pixel_type, pixels)) fail("write the pixels of");
  if (!out->close()) fail("finish");
  return std::string(buffer.begin(), buffer.end());
}

std::unique_ptr<OIIO::ImageInput> create_reader(const std::string& virtual_name) {
  // By the extension alone: given a file name, 2.4.7's create() looks for the file even when not asked to open it.
  // do_open = false: this plugin and no other.
  std::unique_ptr<OIIO::ImageInput> in =
      OIIO::ImageInput::create(virtual_name.substr(virtual_name.find_last_of('.') + 1), false);
  if (in) in->threads(1);
  return in;
}

std::unique_ptr<OIIO::ImageInput> open_or_throw(const char* virtual_name, OIIO::Filesystem::IOMemReader& proxy,
                                                size_t bytes, const std::string& codec, const std::string& format) {
  const std::string failed = codec + ": could not read the header of the " + std::to_string(bytes) + "-byte " + format +
                             " image (truncated or corrupt?): ";
  std::unique_ptr<OIIO::ImageInput> in = create_reader(virtual_name);
  if (!in) throw std::runtime_error(failed + OIIO::geterror());
  if (!open_on_proxy(*in, virtual_name, proxy)) throw std::runtime_error(failed + in->geterror());
  return in;
}

bool open_on_proxy(OIIO::ImageInput& in, const std::string& virtual_name, OIIO::Filesystem::IOMemReader& proxy) {
  // Handed over in the open's configuration, where every 2.4 reader looks for it (set_ioproxy before a plain
  // open(name, spec) is ignored by the PNG reader, which then looks for a file of that name).
  void* proxy_ptr = &proxy;
  OIIO::ImageSpec config;
  config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy_ptr);
  OIIO::ImageSpec spec;
  return in.open(virtual_name, spec, config);
}

void check_decoded_values(const OIIO::ImageSpec& spec, uint64_t values, uint64_t limit, const std::string& codec) {
  if (values == 0 || values > limit) {
    throw std::runtime_error(codec + ": the header describes a " + std::to_string(spec.width) + "x" +
                             std::to_string(spec.height) + " image with " + std::to_string(spec.nchannels) +
                             " channels, which is empty or larger than the limit of " + std::to_string(limit) +
                             " values");
  }
}

namespace {

// Native bytes read at a time. OpenImageIO 2.4.7's read_image converts through a buffer of at least 256 scanlines
// whatever the image's height (ImageInput::read_scanlines): 2 GB for a PNG of 1,000,000 x 1 16-bit RGBA pixels, 6.4
// GB for a 2-row EXR 2,097,156 pixels wide. The pixels are read natively a bounded strip at a time and converted here.
// (A tiled image, EXR only, is read by read_image: check_exr_header bounds its row of tiles.)
constexpr size_t kStripBytes = size_t{64} << 20;

// `rows` scanlines of native pixels (each channel in its own format when the file mixes them) as `pixel_type`.
bool convert_rows(const OIIO::ImageSpec& spec, const char* native, int rows, OIIO::TypeDesc pixel_type, char* out) {
  if (spec.channelformats.empty()) {
    return OIIO::convert_image(spec.nchannels, spec.width, rows, 1, native, spec.format, OIIO::AutoStride,
                               OIIO::AutoStride, OIIO::AutoStride, out, pixel_type, OIIO::AutoStride,
                               OIIO::AutoStride, OIIO::AutoStride);
  }
  const OIIO::stride_t in_pixel = spec.pixel_bytes(true);
  const OIIO::stride_t out_pixel = pixel_type.size() * spec.nchannels;
  size_t offset = 0;
  bool ok = true;
  for (int c = 0; c < spec.nchannels; ++c) {
    ok &= OIIO::convert_image(1, spec.width, rows, 1, native + offset, spec.channelformats[c], in_pixel,
                              in_pixel * spec.width, OIIO::AutoStride, out + c * pixel_type.size(), pixel_type,
                              out_pixel, out_pixel * spec.width, OIIO::AutoStride);
    offset += spec.channelformats[c].size();
  }
  return ok;
}

// A scanline image through a strip of at most kStripBytes (one scanline if a scanline is larger).
bool read_scanline_image(OIIO::ImageInput& in, OIIO::TypeDesc pixel_type, char* out) {
  const OIIO::ImageSpec& spec = in.spec();
  const size_t native_row = spec.scanline_bytes(true);
  const size_t out_row = size_t(spec.width) * spec.nchannels * pixel_type.size();
  const int strip = static_cast<int>(std::clamp<size_t>(kStripBytes / native_row, 1, spec.height));
  std::vector<char> native(strip * native_row);
  for (int z = 0; z < std::max(1, spec.depth); ++z) {
    for (int y = 0; y < spec.height; y += strip) {
      const int rows = std::min(strip, spec.height - y);
      if (!in.read_native_scanlines(0, 0, spec.y + y, spec.y + y + rows, spec.z + z, native.data()) ||
          !convert_rows(spec, native.data(), rows, pixel_type, out + (size_t(z) * spec.height + y) * out_row)) {
        return false;
      }
    }
  }
  return true;
}

}  // namespace

void read_pixels(OIIO::ImageInput& in, OIIO::TypeDesc pixel_type, void* pixels, const std::string& codec,
                 const std::string& format) {
  const OIIO::ImageSpec& spec = in.spec();
  const std::string image = std::to_string(spec.width) + "x" + std::to_string(spec.height) + " " + format + " image";
  const bool ok = spec.tile_width > 0 ? in.read_image(0, 0, 0, spec.nchannels, pixel_type, pixels)
                                      : read_scanline_image(in, pixel_type, static_cast<char*>(pixels));
  if (!ok) {
    throw std::runtime_error(codec + ": could not read the pixels of the " + image +
                             " (truncated or corrupt?): " + in.geterror());
  }
}

std::vector<std::pair<std::string, std::string>> string_attributes(const OIIO::ImageSpec& spec) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& attr : spec.extra_attribs) {
    if (attr.type() == OIIO::TypeDesc::STRING) out.emplace_back(attr.name().string(), attr.get_string());
  }
  return out;
}

}  // namespace kiln::image::detail
