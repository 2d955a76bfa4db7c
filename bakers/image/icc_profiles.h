// Embedded ICC profiles made unreadable to OpenImageIO. Debian's OpenImageIO 2.4.7 parses the profile of a TIFF (tag
// 34675) or a PSD (image resource 1039) with decode_icc_profile, which trusts the tag table inside it: a 148-byte
// profile whose "text" tag is 4 bytes long, shorter than that type's 8-byte header, makes it hash a string of 4 - 8
// bytes (unsigned: 4 GiB) from the profile, and the reader dies of SIGSEGV (`iinfo -v` does on such files). JPEG
// files reach the same parser through their APP2 segments, which jpeg_metadata.h drops. kiln reads the pixels only,
// which the profile does not change, so the profile's signature is cleared: the parser stops there ("bad magic
// number").
#pragma once

#include <string>

namespace kiln::image {

// `bytes` (a TIFF or BigTIFF file) with bytes 36-39 of every ICC profile of every image file directory set to 0 (the
// "acsp" signature), and nothing else changed. Bytes that are not a TIFF file, or a profile libtiff will not find in
// the file, are left as they are.
std::string tiff_without_icc_profile(const std::string& bytes);

// `bytes` (a PSD or PSB file) with bytes 36-39 of its ICC profile resource set to 0, and nothing else changed; left as
// they are where the image resources section or the profile does not fit in the bytes.
std::string psd_without_icc_profile(const std::string& bytes);

}  // namespace kiln::image
