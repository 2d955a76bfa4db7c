// OpenImageIO reading and writing in memory (IOProxy), shared by the image codecs. This header includes OpenImageIO:
// include it from the .cpp files that read or write images only (bakers/image/, bakers/envmap/env_input.cpp).
#pragma once

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace kiln::image::detail {

// OpenImageIO's memory reader with every read kept inside the buffer. OpenImageIO 2.4.7's IOMemReader::pread clamps
// a read only when offset + size does not wrap and never checks the offset itself, so a damaged EXR whose chunk
// offsets point before or past the upload makes it copy bytes from outside the buffer (found by the exr fuzz target).
// A drop-in for IOMemReader: its read() goes through this pread.
class BoundedMemReader final : public OIIO::Filesystem::IOMemReader {
 public:
  using IOMemReader::IOMemReader;
  size_t pread(void* buf, size_t size, int64_t offset) override;
};

// The bytes of one image written by the plugin that `virtual_name`'s extension picks ("x.png", "x.exr"), with one
// thread (the caller owns the thread budget). `codec` names the caller and `format` the file type in errors:
// "encode_png: could not write the pixels of a 640x160 PNG image with 3 channels: ...", and `writer` the plugin
// when there is none: "encode_png: OpenImageIO has no PNG writer: ...". Throws std::runtime_error.
std::string write_to_memory(const char* virtual_name, const OIIO::ImageSpec& spec, OIIO::TypeDesc pixel_type,
                            const void* pixels, const std::string& codec, const std::string& format,
                            const std::string& writer);

// create_reader's reader for `virtual_name` open on `bytes`
// through `proxy` (which must outlive it), with one thread. Throws std::runtime_error when the header cannot be read:
// "decode_png: could not read the header of the 512-byte PNG image (truncated or corrupt?): ...".
std::unique_ptr<OIIO::ImageInput> open_or_throw(const char* virtual_name, OIIO::Filesystem::IOMemReader& proxy,
                                                size_t bytes, const std::string& codec, const std::string& format);

// The reader of the plugin `virtual_name`'s extension names ("x.png": PNG), not open, with one thread; nullptr if
// OpenImageIO has none (OIIO::geterror() says why). Only that plugin, ever: ImageInput::open tries every other
// reader on bytes its chosen one refuses, and some of them assert on input they never expected (Debian's 2.4.7 RLA
// reader aborts the process on a damaged PSD, a fuzz finding).
std::unique_ptr<OIIO::ImageInput> create_reader(const std::string& virtual_name);

// Opens `in` (a reader from create_reader) on the bytes of `proxy`, which must outlive it;
// false if the header cannot be read (in.geterror() says why).
bool open_on_proxy(OIIO::ImageInput& in, const std::string& virtual_name, OIIO::Filesystem::IOMemReader& proxy);

// Throws std::runtime_error unless 0 < values ≤ limit, where `values` is what the header `spec` asks to allocate (a
// header may claim any size): "decode_png: the header describes a WxH image with N channels, which is empty or
// larger than the limit of L values".
void check_decoded_values(const OIIO::ImageSpec& spec, uint64_t values, uint64_t limit, const std::string& codec);

// Every channel of the image as `pixel_type` into `pixels`; a scanline image is read natively a strip of at most
// 64 MiB at a time and converted (OpenImageIO's read_image converts through 256 scanlines, however few the image
// has). Throws std::runtime_error when they cannot be read:
// "decode_png: could not read the pixels of the WxH PNG image (truncated or corrupt?): ...".
void read_pixels(OIIO::ImageInput& in, OIIO::TypeDesc pixel_type, void* pixels, const std::string& codec,
                 const std::string& format);

// The header's string attributes, in its order, as (name, value).
std::vector<std::pair<std::string, std::string>> string_attributes(const OIIO::ImageSpec& spec);

}  // namespace kiln::image::detail
