// A JPEG file's pixels without its metadata segments, for OpenImageIO's JPEG reader. Debian's OpenImageIO 2.4.7
// (JpgInput::open, read_icc_profile) parses the APP1 (Exif, XMP), APP2 (ICC profile) and APP13 (IPTC) segments that
// libjpeg saves for it as if they were C strings ending in a NUL, which libjpeg does not add: strcmp runs past a
// segment that holds no NUL; an "Exif\0" segment under 6 bytes makes it read Exif over 2^64 bytes (its length minus
// 6, unsigned); an "ICC_PROFILE" segment under 14 bytes, or a profile whose "text" tag is under 8, the same; and an
// IPTC block is read for the size it declares. kiln reads the pixels only, which libjpeg decodes without those
// segments, so they are dropped before OpenImageIO sees the bytes.
#pragma once

#include <string>

namespace kiln::image {

// `bytes` (a JPEG file: they start with FF D8) without their APP1-APP13, APP15 and COM segments, wherever they are
// (between scans too). APP0 (JFIF) and APP14 (Adobe), which libjpeg reads itself to choose the colour transform,
// and everything else are kept byte for byte. Throws std::runtime_error naming `who`, the segment and its offset if a
// segment's length field is under 2 or runs past the end of the file.
std::string jpeg_without_metadata(const std::string& bytes, const std::string& who);

}  // namespace kiln::image
