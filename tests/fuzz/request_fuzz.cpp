// kilnd's side of a connection, minus the socket: bytes as a client sends them, split into reads of a size the
// input chooses, through the frame decoder, each frame parsed as a kiln.v1.Request, and a Submit's job spec
// validated and translated into a bake (with its canonical text and cache key), as Session and Service::submit do.
// Every input must end in a frame, a decoder error or a clear InvalidField, never a crash.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "daemon/translate.h"
#include "proto/digest.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"

namespace {

void handle(const kiln::v1::Request& request) {
  using kiln::v1::Request;
  switch (request.body_case()) {
    case Request::kSubmit:
      try {
        const kiln::daemon::BakeRequest bake = kiln::daemon::translate(request.submit().job());
        kiln::daemon::cache_key(bake, kiln::daemon::baker_version(bake));
      } catch (const kiln::daemon::InvalidField&) {
      }
      break;
    case Request::kBlobQuery:
      for (const auto& d : request.blob_query().digests()) kiln::proto::is_valid_sha256_hex(d.sha256());
      break;
    case Request::kBlobPut:
      kiln::proto::is_valid_sha256_hex(request.blob_put().digest().sha256());
      break;
    default:
      break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  // The first byte sets the size of each read (1 to 256 bytes), as a socket delivers them in pieces.
  const size_t read_size = size_t{data[0]} + 1;
  const std::string_view stream(reinterpret_cast<const char*>(data) + 1, size - 1);
  kiln::proto::FrameDecoder decoder;
  for (size_t at = 0; at < stream.size(); at += read_size) {
    if (!decoder.feed(stream.substr(at, read_size))) return 0;
    std::string_view payload;
    while (decoder.next(payload) == kiln::proto::FrameDecoder::Status::frame) {
      kiln::v1::Request request;
      if (!kiln::proto::parse_frame(payload, request) || request.id() == 0) return 0;  // the session drops it
      handle(request);
    }
    if (decoder.error() != kiln::proto::FrameDecoder::Error::none) return 0;
  }
  return 0;
}
