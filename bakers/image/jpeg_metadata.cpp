#include "bakers/image/jpeg_metadata.h"

#include <cstdio>
#include <stdexcept>

namespace kiln::image {
namespace {

unsigned char byte_at(const std::string& bytes, size_t at) { return static_cast<unsigned char>(bytes[at]); }

// Markers without a length field: SOI, EOI, RST0-RST7 and TEM.
bool stands_alone(unsigned char code) {
  return code == 0xd8 || code == 0xd9 || (code >= 0xd0 && code <= 0xd7) || code == 0x01;
}

// The segments OpenImageIO's reader would parse as metadata, and the application segments no decoder needs: every
// APPn but APP0 (JFIF) and APP14 (Adobe), and comments.
bool is_metadata(unsigned char code) { return (code >= 0xe1 && code <= 0xed) || code == 0xef || code == 0xfe; }

// The offset of the FF before the next marker's code at or after `from`, found as libjpeg's next_marker and its
// entropy decoders find it: other bytes skipped (entropy-coded data, garbage), fill FFs skipped, FF 00 (a stuffed
// data byte) passed over. npos if the bytes end first.
size_t next_marker(const std::string& bytes, size_t from) {
  for (size_t at = from; at < bytes.size(); ++at) {
    if (byte_at(bytes, at) != 0xff) continue;
    size_t code = at + 1;
    while (code < bytes.size() && byte_at(bytes, code) == 0xff) ++code;
    if (code == bytes.size()) return std::string::npos;
    if (byte_at(bytes, code) != 0) return code - 1;
    at = code;  // FF 00
  }
  return std::string::npos;
}

// "APP1", "COM", "SOS", ... or "FF C4"-style for the others: how people find a segment in a hex dump.
std::string marker_name(unsigned char code) {
  char name[8];
  if (code >= 0xe0 && code <= 0xef) {
    std::snprintf(name, sizeof name, "APP%d", code - 0xe0);
  } else if (code == 0xfe || code == 0xda || code == 0xdb || code == 0xc4) {
    return code == 0xfe ? "COM" : code == 0xda ? "SOS" : code == 0xdb ? "DQT" : "DHT";
  } else {
    std::snprintf(name, sizeof name, "FF %02X", code);
  }
  return name;
}

}  // namespace

std::string jpeg_without_metadata(const std::string& bytes, const std::string& who) {
  std::string out;
  out.reserve(bytes.size());
  size_t kept = 0;  // bytes before this offset are copied to `out` or dropped
  for (size_t at = next_marker(bytes, 2); at != std::string::npos; at = next_marker(bytes, at)) {
    const unsigned char code = byte_at(bytes, at + 1);
    if (code == 0xd9) break;  // EOI: libjpeg reads nothing after it
    at += 2;
    if (stands_alone(code)) continue;
    // A length field cut off by the end of the file: libjpeg reports the truncation; nothing follows to drop.
    if (at + 2 > bytes.size()) break;
    const size_t length = size_t{byte_at(bytes, at)} << 8 | byte_at(bytes, at + 1);
    if (length < 2 || length > bytes.size() - at) {
      throw std::runtime_error(who + ": the JPEG " + marker_name(code) + " segment at byte " +
                               std::to_string(at - 2) + " declares " + std::to_string(length) +
                               " bytes (its length field included), but " +
                               (length < 2 ? std::string("a segment holds at least its 2-byte length")
                                           : "only " + std::to_string(bytes.size() - at) + " follow its marker") +
                               " (truncated or corrupt?); re-export the file and upload it again");
    }
    if (is_metadata(code)) {
      out.append(bytes, kept, at - 2 - kept);
      kept = at + length;
    }
    at += length;  // after an SOS header, next_marker skips the entropy-coded data
  }
  out.append(bytes, kept, std::string::npos);
  return out;
}

}  // namespace kiln::image
