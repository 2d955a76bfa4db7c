#include "bakers/image/oiio_memory.h"

#include <stdexcept>
#include <vector>

namespace kiln::image::detail {

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

std::unique_ptr<OIIO::ImageInput> open_from_memory(const char* virtual_name, OIIO::Filesystem::IOMemReader& proxy) {
  void* proxy_ptr = &proxy;
  OIIO::ImageSpec config;
  config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy_ptr);
  std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(virtual_name, &config);
  if (in) in->threads(1);
  return in;
}

std::unique_ptr<OIIO::ImageInput> open_or_throw(const char* virtual_name, OIIO::Filesystem::IOMemReader& proxy,
                                                size_t bytes, const std::string& codec, const std::string& format) {
  std::unique_ptr<OIIO::ImageInput> in = open_from_memory(virtual_name, proxy);
  if (!in) {
    throw std::runtime_error(codec + ": could not read the header of the " + std::to_string(bytes) + "-byte " + format +
                             " image (truncated or corrupt?): " + OIIO::geterror());
  }
  return in;
}

void check_decoded_values(const OIIO::ImageSpec& spec, uint64_t values, uint64_t limit, const std::string& codec) {
  if (values == 0 || values > limit) {
    throw std::runtime_error(codec + ": the header describes a " + std::to_string(spec.width) + "x" +
                             std::to_string(spec.height) + " image with " + std::to_string(spec.nchannels) +
                             " channels, which is empty or larger than the limit of " + std::to_string(limit) +
                             " values");
  }
}

void read_pixels(OIIO::ImageInput& in, OIIO::TypeDesc pixel_type, void* pixels, const std::string& codec,
                 const std::string& format) {
  const OIIO::ImageSpec& spec = in.spec();
  if (!in.read_image(0, 0, 0, spec.nchannels, pixel_type, pixels)) {
    throw std::runtime_error(codec + ": could not read the pixels of the " + std::to_string(spec.width) + "x" +
                             std::to_string(spec.height) + " " + format +
                             " image (truncated or corrupt?): " + in.geterror());
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
