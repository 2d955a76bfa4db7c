// OpenImageIO reading and writing in memory (IOProxy), shared by the image codecs. This header includes OpenImageIO:
// include it from bakers/image/*.cpp only.
#pragma once

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace kiln::image::detail {

// The bytes of one image written by the plugin that `virtual_name`'s extension picks ("x.png", "x.exr"), with one
// thread (the caller owns the thread budget). `codec` names the caller and `format` the file type in errors:
// "encode_png: could not write the pixels of a 640x160 PNG image with 3 channels: ...", and `writer` the plugin
// when there is none: "encode_png: OpenImageIO has no PNG writer: ...". Throws std::runtime_error.
std::string write_to_memory(const char* virtual_name, const OIIO::ImageSpec& spec, OIIO::TypeDesc pixel_type,
                            const void* pixels, const std::string& codec, const std::string& format,
                            const std::string& writer);

// The reader for `virtual_name`'s plugin opened on `proxy` (which must outlive it), with one thread; nullptr if the
// header cannot be read (OIIO::geterror() says why).
std::unique_ptr<OIIO::ImageInput> open_from_memory(const char* virtual_name, OIIO::Filesystem::IOMemReader& proxy);

// open_from_memory over `bytes` through `proxy`, throwing std::runtime_error when the header cannot be read:
// "decode_png: could not read the header of the 512-byte PNG image (truncated or corrupt?): ...".
std::unique_ptr<OIIO::ImageInput> open_or_throw(const char* virtual_name, OIIO::Filesystem::IOMemReader& proxy,
                                                size_t bytes, const std::string& codec, const std::string& format);

// Throws std::runtime_error unless 0 < values ≤ limit, where `values` is what the header `spec` asks to allocate (a
// header may claim any size): "decode_png: the header describes a WxH image with N channels, which is empty or
// larger than the limit of L values".
void check_decoded_values(const OIIO::ImageSpec& spec, uint64_t values, uint64_t limit, const std::string& codec);

// Every channel of the image as `pixel_type` into `pixels`; throws std::runtime_error when they cannot be read:
// "decode_png: could not read the pixels of the WxH PNG image (truncated or corrupt?): ...".
void read_pixels(OIIO::ImageInput& in, OIIO::TypeDesc pixel_type, void* pixels, const std::string& codec,
                 const std::string& format);

// The header's string attributes, in its order, as (name, value).
std::vector<std::pair<std::string, std::string>> string_attributes(const OIIO::ImageSpec& spec);

}  // namespace kiln::image::detail
