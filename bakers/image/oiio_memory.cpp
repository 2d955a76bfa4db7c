#include "bakers/image/oiio_memory.h"

#include <stdexcept>
#include <vector>

namespace kiln::image::detail {

std::string write_to_memory(const char* virtual_name, const OIIO::ImageSpec& spec, OIIO::TypeDesc pixel_type,
                            const void* pixels, const std::string& codec, const std::string& format) {
  std::vector<unsigned char> buffer;
  OIIO::Filesystem::IOVecOutput proxy(buffer);
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(virtual_name);
  if (!out) throw std::runtime_error(codec + ": OpenImageIO has no " + format + " writer: " + OIIO::geterror());
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

}  // namespace kiln::image::detail
