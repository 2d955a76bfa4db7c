#include "bakers/image/exr.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <set>
#include <stdexcept>

#include "bakers/image/exr_header.h"
#include "bakers/image/image_format.h"
#include "bakers/image/oiio_memory.h"

namespace kiln::image {
namespace {

// Any name works for the plugin lookup: with an IOProxy nothing touches the file system.
constexpr const char* kVirtualName = "kiln-memory.exr";
// Written by kiln before channels were read by name: it listed the writer's order, which is not the order EXR stores
// (sorted by name), so a reader going by position swapped channels. No longer written; refused in metadata and
// dropped from files that still carry it.
constexpr const char* kLegacyChannelOrderKey = "kiln:channel_order";
// A header may claim any size; refuse to allocate more than this many floats (1 GiB) for one image.
constexpr uint64_t kMaxDecodedValues = uint64_t{1} << 28;

bool reserved_key(const std::string& key) {
  return key == "compression" || key == kLegacyChannelOrderKey || key.rfind("oiio:", 0) == 0;
}

void check_image(const FloatImage& image) {
  if (image.width < 1 || image.height < 1 || image.channels < 1) {
    throw std::invalid_argument("encode_exr: width, height and channels must be at least 1, got " +
                                std::to_string(image.width) + "x" + std::to_string(image.height) + "x" +
                                std::to_string(image.channels));
  }
  const uint64_t expected =
      static_cast<uint64_t>(image.width) * static_cast<uint64_t>(image.height) * static_cast<uint64_t>(image.channels);
  if (image.pixels.size() != expected) {
    throw std::invalid_argument("encode_exr: pixels holds " + std::to_string(image.pixels.size()) + " floats, but a " +
                                std::to_string(image.width) + "x" + std::to_string(image.height) + " image with " +
                                std::to_string(image.channels) + " channels needs " + std::to_string(expected));
  }
  if (!image.channel_names.empty()) {
    if (image.channel_names.size() != static_cast<size_t>(image.channels)) {
      throw std::invalid_argument("encode_exr: channel_names has " + std::to_string(image.channel_names.size()) +
                                  " names for " + std::to_string(image.channels) + " channels");
    }
    std::set<std::string> seen;
    for (const auto& n : image.channel_names) {
      if (n.empty() || n.find(',') != std::string::npos) {
        throw std::invalid_argument("encode_exr: channel name '" + n + "' must be non-empty and without commas");
      }
      if (!seen.insert(n).second) throw std::invalid_argument("encode_exr: channel name '" + n + "' appears twice");
    }
  }
  for (const auto& [key, value] : image.metadata) {
    if (key.empty() || reserved_key(key)) {
      throw std::invalid_argument("encode_exr: metadata key '" + key +
                                  "' is reserved for the file layout (compression, oiio:*, kiln:channel_order); "
                                  "choose another name");
    }
  }
}

}  // namespace

int FloatImage::channel_index(const std::string& name) const {
  const auto it = std::find(channel_names.begin(), channel_names.end(), name);
  if (it == channel_names.end()) {
    std::string there;
    for (const auto& n : channel_names) there += (there.empty() ? "" : ", ") + n;
    throw std::out_of_range("no channel '" + name +
                            "' in this image; its channels are: " + (there.empty() ? "(unnamed)" : there));
  }
  return static_cast<int>(it - channel_names.begin());
}

std::string encode_exr(const FloatImage& image) {
  check_image(image);
  OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::FLOAT);
  if (!image.channel_names.empty()) spec.channelnames = image.channel_names;
  spec.attribute("compression", "zip");
  // OpenImageIO stamps the current time unless DateTime is given; an empty value leaves it out, so that the same
  // image always gives the same bytes (the daemon addresses results by their digest).
  spec.attribute("DateTime", "");
  for (const auto& [key, value] : image.metadata) spec.attribute(key, value);

  return detail::write_to_memory(kVirtualName, spec, OIIO::TypeDesc::FLOAT, image.pixels.data(), "encode_exr", "EXR",
                                 "OpenEXR");
}

FloatImage decode_exr(const std::string& bytes) {
  // Checked here so that the common mistake (handing over some other file) gets a plain answer.
  static constexpr unsigned char kMagic[4] = {0x76, 0x2f, 0x31, 0x01};
  if (bytes.size() < 4 || !std::equal(kMagic, kMagic + 4, reinterpret_cast<const unsigned char*>(bytes.data()))) {
    throw std::runtime_error("decode_exr: the " + std::to_string(bytes.size()) +
                             " bytes are not an OpenEXR image: they start with " + hex_prefix(bytes, 4) +
                             ", an EXR file starts with 76 2f 31 01");
  }
  check_exr_header(bytes, "decode_exr");
  detail::BoundedMemReader proxy(bytes.data(), bytes.size());
  std::unique_ptr<OIIO::ImageInput> in = detail::open_or_throw(kVirtualName, proxy, bytes.size(), "decode_exr", "EXR");
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.deep) throw std::runtime_error("decode_exr: deep EXR images are not supported; expected flat pixels");
  const uint64_t values = static_cast<uint64_t>(std::max(0, spec.width)) * std::max(0, spec.height) *
                          std::max(0, spec.depth) * std::max(0, spec.nchannels);
  detail::check_decoded_values(spec, values, kMaxDecodedValues, "decode_exr");
  FloatImage image;
  image.width = spec.width;
  image.height = spec.height * std::max(1, spec.depth);
  image.channels = spec.nchannels;
  image.pixels.resize(values);
  detail::read_pixels(*in, OIIO::TypeDesc::FLOAT, image.pixels.data(), "decode_exr", "EXR");
  image.channel_names = spec.channelnames;
  for (const auto& [name, value] : detail::string_attributes(spec)) {
    if (reserved_key(name)) continue;
    image.metadata[name] = value;
  }
  in->close();
  return image;
}

}  // namespace kiln::image
