// Messages on a byte stream: protobuf's varint-delimited framing (the length of the payload as a base-128 varint,
// then the payload), the format of SerializeDelimitedToZeroCopyStream, Java's writeDelimitedTo and the Python
// helpers. The peer is not trusted: a declared length is checked against a maximum before any payload is buffered.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

namespace google::protobuf {
class MessageLite;
}

namespace kiln::proto {

inline constexpr std::uint32_t kProtocolVersion = 1;
// Defaults of the protocol (HelloReply.limits may say otherwise).
inline constexpr std::size_t kDefaultMaxFrameBytes = std::size_t{4} << 20;
inline constexpr std::size_t kDefaultMaxChunkBytes = std::size_t{1} << 20;
// A varint of a 64-bit value takes at most 10 bytes.
inline constexpr std::size_t kMaxVarintBytes = 10;

// append_frame could not frame a message (it is larger than the limit).
class FrameTooLarge : public std::length_error {
 public:
  using std::length_error::length_error;
};

// Appends one frame (varint length, then the serialized message) to `out`. Throws FrameTooLarge, leaving `out`
// unchanged, if the serialized message is longer than max_frame_bytes.
void append_frame(const google::protobuf::MessageLite& message, std::string& out,
                  std::size_t max_frame_bytes = kDefaultMaxFrameBytes);

// The frame as a new string.
std::string encode_frame(const google::protobuf::MessageLite& message,
                         std::size_t max_frame_bytes = kDefaultMaxFrameBytes);

// Parses a payload that FrameDecoder returned. False if the bytes are not a valid message of that type.
bool parse_frame(std::string_view payload, google::protobuf::MessageLite& message);

// Splits a byte stream into frame payloads as the bytes arrive, in chunks of any size:
//
//   decoder.feed(bytes_from_socket);
//   std::string_view payload;
//   while ((status = decoder.next(payload)) == FrameDecoder::Status::frame) handle(payload);
//   if (status == FrameDecoder::Status::error) drop the connection (decoder.error() says why);
//
// Errors are final: a stream that had one cannot be resynchronised, and the decoder then drops its buffer.
// Memory: the decoder holds at most one frame's payload plus the bytes fed since the last next() that returned
// need_more, so draining with next() after every feed() bounds it by max_frame_bytes plus the chunk size.
class FrameDecoder {
 public:
  enum class Status {
    frame,      // a whole payload is ready
    need_more,  // the next frame is not complete yet (also: nothing buffered)
    error,      // the stream is malformed or a frame is too large; see error()
  };
  enum class Error {
    none,
    bad_varint,       // the length varint is longer than 10 bytes or overflows 64 bits
    frame_too_large,  // the declared length exceeds max_frame_bytes
  };

  explicit FrameDecoder(std::size_t max_frame_bytes = kDefaultMaxFrameBytes);

  // Appends received bytes and checks the length of the pending frame at once, so that a bad or oversized length
  // is an error as soon as its bytes arrive, even before next() is called. Returns false once in the error state
  // (bytes fed then are ignored).
  bool feed(std::string_view bytes);

  // The next complete payload. It stays valid until the next call of feed() or next().
  Status next(std::string_view& payload);

  Error error() const { return error_; }
  // The error for people, e.g. "frame of 1099511627776 bytes exceeds the limit of 4194304".
  const std::string& error_message() const { return error_message_; }

  // True if part of a frame has arrived but not all of it: the server's "stalled mid-frame" deadline runs then.
  bool mid_frame() const { return error_ == Error::none && buffer_.size() > consumed_; }
  // Bytes received and not yet returned as a payload.
  std::size_t buffered() const { return buffer_.size() - consumed_; }
  std::size_t max_frame_bytes() const { return max_frame_bytes_; }
  // Changes the limit for frames whose length has not been read yet (e.g. after a hello negotiated another).
  void set_max_frame_bytes(std::size_t max_frame_bytes) { max_frame_bytes_ = max_frame_bytes; }

 private:
  // Reads the pending frame's length if its varint is complete; sets the error state if it is bad or too large.
  void read_header();
  void fail(Error error, std::string message);

  std::size_t max_frame_bytes_;
  std::string buffer_;
  std::size_t consumed_ = 0;       // bytes of buffer_ already returned (or skipped) as frames
  bool have_length_ = false;       // the pending frame's varint has been read
  std::size_t header_bytes_ = 0;   // its size
  std::size_t payload_bytes_ = 0;  // the payload length it declared
  Error error_ = Error::none;
  std::string error_message_;
};

}  // namespace kiln::proto
