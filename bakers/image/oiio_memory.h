// OpenImageIO reading and writing in memory (IOProxy), shared by the image codecs. This header includes OpenImageIO:
// include it from bakers/image/*.cpp only.
#pragma once

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <memory>
#include <string>

namespace kiln::image::detail {

// The bytes of one image written by the plugin that `virtual_name`'s extension picks ("x.png", "x.exr"), with one
// thread (the caller owns the thread budget). `codec` names the caller and `format` the file type in errors:
// "encode_png: could not write the pixels of a 640x160 PNG image with 3 channels: ...". Throws std::runtime_error.
std::string write_to_memory(const char* virtual_name, const OIIO::ImageSpec& spec, OIIO::TypeDesc pixel_type,
                            const void* pixels, const std::string& codec, const std::string& format);

// The reader for `virtual_name`'s plugin opened on `proxy` (which must outlive it), with one thread; nullptr if the
// header cannot be read (OIIO::geterror() says why).
std::unique_ptr<OIIO::ImageInput> open_from_memory(const char* virtual_name, OIIO::Filesystem::IOMemReader& proxy);

}  // namespace kiln::image::detail
