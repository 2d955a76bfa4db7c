#include "proto/framing.h"

#include <google/protobuf/message_lite.h>
#include <google/protobuf/stubs/logging.h>

#include <algorithm>
#include <climits>
#include <utility>

namespace kiln::proto {
namespace {

std::size_t write_varint(std::uint64_t value, char* out) {
  std::size_t n = 0;
  while (value >= 0x80) {
    out[n++] = static_cast<char>((value & 0x7f) | 0x80);
    value >>= 7;
  }
  out[n++] = static_cast<char>(value);
  return n;
}

// After a big frame, a connection's idle buffer gives its memory back rather than keep the peak forever.
constexpr std::size_t kKeepCapacityBytes = std::size_t{256} << 10;

}  // namespace

void append_frame(const google::protobuf::MessageLite& message, std::string& out, std::size_t max_frame_bytes) {
  const std::size_t size = message.ByteSizeLong();
  // protobuf itself cannot serialize more than INT_MAX bytes, whatever limit the caller allows.
  if (size > max_frame_bytes || size > static_cast<std::size_t>(INT_MAX)) {
    throw FrameTooLarge("message of " + std::to_string(size) + " bytes exceeds the frame limit of " +
                        std::to_string(max_frame_bytes) + " bytes");
  }
  char header[kMaxVarintBytes];
  const std::size_t header_size = write_varint(size, header);
  const std::size_t start = out.size();
  out.resize(start + header_size + size);
  std::copy(header, header + header_size, out.data() + start);
  // ByteSizeLong() above cached the sizes that this serialization relies on.
  message.SerializeWithCachedSizesToArray(reinterpret_cast<std::uint8_t*>(out.data() + start + header_size));
}

std::string encode_frame(const google::protobuf::MessageLite& message, std::size_t max_frame_bytes) {
  std::string out;
  append_frame(message, out, max_frame_bytes);
  return out;
}

bool parse_frame(std::string_view payload, google::protobuf::MessageLite& message) {
  if (payload.size() > static_cast<std::size_t>(INT_MAX)) return false;
  // Bad bytes from a peer (e.g. invalid UTF-8 in a string field) would make protobuf log to stderr on every frame;
  // the caller reports the failure once, in its own words.
  google::protobuf::LogSilencer quiet;
  return message.ParseFromArray(payload.data(), static_cast<int>(payload.size()));
}

FrameDecoder::FrameDecoder(std::size_t max_frame_bytes) : max_frame_bytes_(max_frame_bytes) {}

bool FrameDecoder::feed(std::string_view bytes) {
  if (error_ != Error::none) return false;
  // Drop the payloads earlier next() calls returned (their views end here).
  if (consumed_ > 0) {
    buffer_.erase(0, consumed_);
    consumed_ = 0;
  }
  if (buffer_.empty() && buffer_.capacity() > kKeepCapacityBytes && bytes.size() <= kKeepCapacityBytes) {
    std::string().swap(buffer_);
  }
  if (!have_length_) {
    // Judge the length before copying the rest of the chunk: a bad or oversized length costs no buffering.
    const std::size_t pending = buffer_.size();
    const std::size_t take = pending >= kMaxVarintBytes ? 0 : std::min(bytes.size(), kMaxVarintBytes - pending);
    buffer_.append(bytes.data(), take);
    bytes.remove_prefix(take);
    read_header();
    if (error_ != Error::none) return false;
  }
  buffer_.append(bytes.data(), bytes.size());
  return true;
}

void FrameDecoder::read_header() {
  if (have_length_ || error_ != Error::none) return;
  const std::size_t available = buffer_.size() - consumed_;
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < available && i < kMaxVarintBytes; ++i) {
    const auto byte = static_cast<std::uint8_t>(buffer_[consumed_ + i]);
    const std::uint64_t bits = byte & 0x7f;
    if (i == kMaxVarintBytes - 1 && (byte & 0xfe) != 0) {
      // The 10th byte carries bit 63 only; anything more (a continuation or higher bits) is not a 64-bit varint.
      fail(Error::bad_varint, "frame length varint is longer than 10 bytes or overflows 64 bits");
      return;
    }
    value |= bits << (7 * i);
    if ((byte & 0x80) == 0) {
      if (value > max_frame_bytes_) {
        fail(Error::frame_too_large, "frame of " + std::to_string(value) + " bytes exceeds the limit of " +
                                         std::to_string(max_frame_bytes_) + " bytes");
        return;
      }
      have_length_ = true;
      header_bytes_ = i + 1;
      payload_bytes_ = static_cast<std::size_t>(value);
      return;
    }
    // More bytes follow, and they can only make the length larger: too large already is too large.
    if (value > max_frame_bytes_) {
      fail(Error::frame_too_large, "frame of at least " + std::to_string(value) + " bytes exceeds the limit of " +
                                       std::to_string(max_frame_bytes_) + " bytes");
      return;
    }
  }
}

FrameDecoder::Status FrameDecoder::next(std::string_view& payload) {
  read_header();
  if (error_ != Error::none) return Status::error;
  if (!have_length_ || buffer_.size() - consumed_ - header_bytes_ < payload_bytes_) return Status::need_more;
  payload = std::string_view(buffer_).substr(consumed_ + header_bytes_, payload_bytes_);
  consumed_ += header_bytes_ + payload_bytes_;
  have_length_ = false;
  return Status::frame;
}

void FrameDecoder::fail(Error error, std::string message) {
  error_ = error;
  error_message_ = std::move(message);
  std::string().swap(buffer_);
  consumed_ = 0;
  have_length_ = false;
}

}  // namespace kiln::proto
