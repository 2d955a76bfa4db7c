// Opening uploaded bytes with the reader of the format they were detected as (image_format.h), and that reader only
// (detail::create_reader says why). This header includes OpenImageIO: include it from bakers/image/ and
// bakers/envmap/env_input.cpp only.
#pragma once

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <memory>
#include <string>

#include "bakers/image/image_format.h"

namespace kiln::image {

// The bytes in a temporary file (suffix from `virtual_name`), removed when this goes: for the readers that cannot
// read from memory. Throws std::runtime_error naming `who` when the file cannot be made or written.
class TempImageFile {
 public:
  TempImageFile(const std::string& bytes, const std::string& virtual_name, const std::string& who);
  ~TempImageFile();
  TempImageFile(const TempImageFile&) = delete;
  TempImageFile& operator=(const TempImageFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// The reader of `format`'s plugin open on `bytes`, with one thread: from memory through `proxy` (which must outlive
// it) when the plugin reads from memory and the format is not marked from_file, else from a temporary copy kept in
// `temp`. Throws std::runtime_error: "WHO: could not read the header of the N-byte FORMAT image (truncated or
// corrupt?): WHY; re-export the file and upload it again".
std::unique_ptr<OIIO::ImageInput> open_image_reader(const std::string& bytes, const ImageFormat& format,
                                                    OIIO::Filesystem::IOMemReader& proxy,
                                                    std::unique_ptr<TempImageFile>& temp, const std::string& who);

}  // namespace kiln::image
