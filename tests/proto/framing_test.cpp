// The varint-delimited framing: round trips in any chunking, byte-for-byte compatibility with protobuf's own
// delimited functions, lengths rejected before allocation, and no crash on arbitrary bytes.
#include "proto/framing.h"

#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/util/delimited_message_util.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "proto/kiln.pb.h"

// The largest single heap allocation since the last reset: shows that an oversized declared length is refused
// without allocating anything of its size. Replacing the global operator new is allowed in a program of our own.
namespace {
std::atomic<std::size_t> g_largest_allocation{0};
}
// Out of line, so that GCC does not inline malloc/free pairs into callers and then warn that new and free mismatch.
[[gnu::noinline]] void* operator new(std::size_t size) {
  std::size_t seen = g_largest_allocation.load(std::memory_order_relaxed);
  while (size > seen && !g_largest_allocation.compare_exchange_weak(seen, size, std::memory_order_relaxed)) {
  }
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace kiln::proto {
namespace {

using Status = FrameDecoder::Status;

std::string varint(std::uint64_t v) {
  std::string out;
  while (v >= 0x80) {
    out.push_back(static_cast<char>((v & 0x7f) | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<char>(v));
  return out;
}

// Messages whose payloads span empty, 1-, 2- and 3-byte length varints.
std::vector<v1::Request> sample_messages() {
  std::vector<v1::Request> out;
  out.emplace_back();  // empty: a zero-length frame
  v1::Request hello;
  hello.set_id(1);
  hello.mutable_hello()->set_protocol_version(kProtocolVersion);
  hello.mutable_hello()->set_token("secret");
  out.push_back(hello);
  for (std::size_t size : {0u, 1u, 100u, 127u, 128u, 300u, 20000u}) {
    v1::Request put;
    put.set_id(100 + size);
    put.mutable_blob_put()->mutable_digest()->set_sha256(std::string(64, 'a'));
    put.mutable_blob_put()->mutable_digest()->set_size(size);
    std::string data(size, '\0');
    for (std::size_t i = 0; i < size; ++i) data[i] = static_cast<char>(i * 7 + size);
    put.mutable_blob_put()->set_data(data);
    out.push_back(put);
  }
  v1::Request submit;
  submit.set_id(7);
  submit.mutable_submit()->mutable_job()->mutable_material()->mutable_ggx()->set_alpha(0.3);
  submit.mutable_submit()->set_priority(-5);
  out.push_back(submit);
  return out;
}

std::string frames_of(const std::vector<v1::Request>& messages) {
  std::string stream;
  for (const auto& m : messages) append_frame(m, stream);
  return stream;
}

// Feeds `pieces` in order, draining after each, and returns the payloads; fails the test on an error.
std::vector<std::string> decode_all(FrameDecoder& decoder, const std::vector<std::string_view>& pieces) {
  std::vector<std::string> payloads;
  for (std::string_view piece : pieces) {
    EXPECT_TRUE(decoder.feed(piece));
    std::string_view payload;
    Status s;
    while ((s = decoder.next(payload)) == Status::frame) payloads.emplace_back(payload);
    EXPECT_EQ(s, Status::need_more) << decoder.error_message();
  }
  return payloads;
}

void expect_payloads_are(const std::vector<std::string>& payloads, const std::vector<v1::Request>& messages) {
  ASSERT_EQ(payloads.size(), messages.size());
  for (std::size_t i = 0; i < messages.size(); ++i) {
    EXPECT_EQ(payloads[i], messages[i].SerializeAsString()) << "message " << i;
    v1::Request parsed;
    EXPECT_TRUE(parse_frame(payloads[i], parsed));
    EXPECT_EQ(parsed.id(), messages[i].id());
  }
}

TEST(Framing, RoundTripSplitAtEveryByteBoundary) {
  const auto messages = sample_messages();
  const std::string stream = frames_of(messages);
  const std::string_view all(stream);
  for (std::size_t split = 0; split <= stream.size(); ++split) {
    FrameDecoder decoder;
    const auto payloads = decode_all(decoder, {all.substr(0, split), all.substr(split)});
    ASSERT_NO_FATAL_FAILURE(expect_payloads_are(payloads, messages)) << "split at " << split;
    EXPECT_EQ(decoder.buffered(), 0u);
    EXPECT_FALSE(decoder.mid_frame());
  }
}

TEST(Framing, RoundTripOneByteAtATimeAndRandomChunks) {
  const auto messages = sample_messages();
  const std::string stream = frames_of(messages);
  {
    FrameDecoder decoder;
    std::vector<std::string_view> bytes;
    for (std::size_t i = 0; i < stream.size(); ++i) bytes.push_back(std::string_view(stream).substr(i, 1));
    expect_payloads_are(decode_all(decoder, bytes), messages);
  }
  std::mt19937_64 rng(42);
  for (int round = 0; round < 200; ++round) {
    FrameDecoder decoder;
    std::vector<std::string_view> pieces;
    for (std::size_t at = 0; at < stream.size();) {
      const std::size_t n = std::uniform_int_distribution<std::size_t>(0, 3000)(rng);
      pieces.push_back(std::string_view(stream).substr(at, n));
      at += n;
    }
    expect_payloads_are(decode_all(decoder, pieces), messages);
  }
}

TEST(Framing, SameBytesAsProtobufSerializeDelimited) {
  const auto messages = sample_messages();
  std::string theirs;
  {
    google::protobuf::io::StringOutputStream out(&theirs);
    for (const auto& m : messages) ASSERT_TRUE(google::protobuf::util::SerializeDelimitedToZeroCopyStream(m, &out));
  }  // the stream trims the string to what was written when it goes
  EXPECT_EQ(theirs, frames_of(messages));
  FrameDecoder decoder;
  expect_payloads_are(decode_all(decoder, {theirs}), messages);
}

TEST(Framing, ProtobufParseDelimitedReadsOurFrames) {
  const auto messages = sample_messages();
  const std::string ours = frames_of(messages);
  google::protobuf::io::ArrayInputStream in(ours.data(), static_cast<int>(ours.size()), /*block_size=*/7);
  for (const auto& expected : messages) {
    v1::Request parsed;
    bool clean_eof = false;
    ASSERT_TRUE(google::protobuf::util::ParseDelimitedFromZeroCopyStream(&parsed, &in, &clean_eof));
    EXPECT_EQ(parsed.SerializeAsString(), expected.SerializeAsString());
  }
  v1::Request after_end;
  bool clean_eof = false;
  EXPECT_FALSE(google::protobuf::util::ParseDelimitedFromZeroCopyStream(&after_end, &in, &clean_eof));
  EXPECT_TRUE(clean_eof);
}

TEST(Framing, OversizedLengthIsRejectedBeforeAllocation) {
  constexpr std::size_t kLimit = kDefaultMaxFrameBytes;
  // A declared length of 2^40 followed by 64 KiB of "payload", all in one chunk as a socket read could bring it.
  const std::string chunk = varint(std::uint64_t{1} << 40) + std::string(64 << 10, 'x');
  FrameDecoder decoder(kLimit);
  g_largest_allocation = 0;
  const bool accepted = decoder.feed(chunk);
  const std::size_t largest = g_largest_allocation.load();
  EXPECT_FALSE(accepted);
  // Only the error message is allocated: nothing of the declared size, nor a copy of the chunk.
  EXPECT_LT(largest, 1024u);
  EXPECT_EQ(decoder.error(), FrameDecoder::Error::frame_too_large);
  EXPECT_NE(decoder.error_message().find("1099511627776"), std::string::npos) << decoder.error_message();
  EXPECT_EQ(decoder.buffered(), 0u);
  std::string_view payload;
  EXPECT_EQ(decoder.next(payload), Status::error);
  EXPECT_FALSE(decoder.feed("more"));  // errors are final
}

TEST(Framing, LimitIsInclusive) {
  constexpr std::size_t kLimit = 1000;
  {
    FrameDecoder decoder(kLimit);
    const std::string frame = varint(kLimit) + std::string(kLimit, 'p');
    EXPECT_TRUE(decoder.feed(frame));
    std::string_view payload;
    EXPECT_EQ(decoder.next(payload), Status::frame);
    EXPECT_EQ(payload.size(), kLimit);
  }
  {
    FrameDecoder decoder(kLimit);
    EXPECT_FALSE(decoder.feed(varint(kLimit + 1)));
    EXPECT_EQ(decoder.error(), FrameDecoder::Error::frame_too_large);
  }
}

TEST(Framing, TooLargeIsKnownBeforeTheVarintEnds) {
  // 0xff says "at least 127, more bytes follow": with a limit of 100 that is already too large.
  FrameDecoder decoder(100);
  EXPECT_FALSE(decoder.feed("\xff"));
  EXPECT_EQ(decoder.error(), FrameDecoder::Error::frame_too_large);
}

TEST(Framing, MalformedVarints) {
  const std::size_t unlimited = std::numeric_limits<std::size_t>::max();
  {
    // Ten bytes that all say "more follows": no 64-bit varint is that long.
    FrameDecoder decoder(unlimited);
    EXPECT_TRUE(decoder.feed(std::string(9, '\x80')));  // still undecided
    EXPECT_FALSE(decoder.feed("\x80"));
    EXPECT_EQ(decoder.error(), FrameDecoder::Error::bad_varint);
  }
  {
    // A 10th byte above 1 overflows 64 bits.
    FrameDecoder decoder(unlimited);
    EXPECT_FALSE(decoder.feed(std::string(9, '\xff') + "\x02"));
    EXPECT_EQ(decoder.error(), FrameDecoder::Error::bad_varint);
  }
  {
    // 2^64 - 1 is a valid length (just never complete): need more.
    FrameDecoder decoder(unlimited);
    EXPECT_TRUE(decoder.feed(std::string(9, '\xff') + "\x01"));
    std::string_view payload;
    EXPECT_EQ(decoder.next(payload), Status::need_more);
  }
  {
    // Non-minimal encodings are valid protobuf varints (0x80 0x00 is 0): an empty frame.
    FrameDecoder decoder;
    EXPECT_TRUE(decoder.feed(std::string("\x80\x00", 2)));
    std::string_view payload = "not empty";
    EXPECT_EQ(decoder.next(payload), Status::frame);
    EXPECT_TRUE(payload.empty());
  }
}

TEST(Framing, TruncatedFramesNeedMore) {
  for (const auto& message : sample_messages()) {
    const std::string frame = encode_frame(message);
    for (std::size_t cut = 0; cut < frame.size(); ++cut) {
      FrameDecoder decoder;
      EXPECT_TRUE(decoder.feed(std::string_view(frame).substr(0, cut)));
      std::string_view payload;
      EXPECT_EQ(decoder.next(payload), Status::need_more);
      EXPECT_EQ(decoder.mid_frame(), cut > 0);
      EXPECT_EQ(decoder.buffered(), cut);
      EXPECT_TRUE(decoder.feed(std::string_view(frame).substr(cut)));
      EXPECT_EQ(decoder.next(payload), Status::frame);
      EXPECT_EQ(payload, message.SerializeAsString());
    }
  }
}

TEST(Framing, AppendFrameRefusesTooLargeMessagesAndLeavesOutputAlone) {
  v1::Request put;
  put.mutable_blob_put()->set_data(std::string(2000, 'd'));
  std::string out = "prefix";
  EXPECT_THROW(append_frame(put, out, 1000), FrameTooLarge);
  EXPECT_EQ(out, "prefix");
  append_frame(put, out, put.ByteSizeLong());  // exactly at the limit is fine
  EXPECT_EQ(out.size(), 6 + varint(put.ByteSizeLong()).size() + put.ByteSizeLong());
}

TEST(Framing, ParseFrameRejectsGarbage) {
  v1::Request r;
  EXPECT_FALSE(parse_frame("\xff\xff\xff", r));
  EXPECT_FALSE(
      parse_frame("\x0a\x05"
                  "ab",
                  r));              // a length-delimited field running past the end
  EXPECT_TRUE(parse_frame("", r));  // the empty message
}

// A plain whole-buffer decoder with the same rules, to check the incremental one against.
struct Reference {
  std::vector<std::string> frames;
  Status end = Status::need_more;
  FrameDecoder::Error error = FrameDecoder::Error::none;
};
Reference reference_decode(std::string_view s, std::size_t max) {
  Reference r;
  std::size_t pos = 0;
  while (true) {
    std::uint64_t value = 0;
    std::size_t i = 0;
    bool complete = false;
    for (; pos + i < s.size() && i < 10; ++i) {
      const auto b = static_cast<std::uint8_t>(s[pos + i]);
      if (i == 9 && b > 1) {
        r.end = Status::error;
        r.error = FrameDecoder::Error::bad_varint;
        return r;
      }
      value |= std::uint64_t{b & 0x7fu} << (7 * i);
      if (value > max) {  // complete or not, it can only grow
        r.end = Status::error;
        r.error = FrameDecoder::Error::frame_too_large;
        return r;
      }
      if (!(b & 0x80)) {
        complete = true;
        ++i;
        break;
      }
    }
    if (!complete || s.size() - pos - i < value) return r;
    r.frames.emplace_back(s.substr(pos + i, value));
    pos += i + value;
  }
}

TEST(Framing, RandomBytesNeverCrashAndMatchAPlainDecoder) {
  std::mt19937_64 rng(2024);
  const auto samples = sample_messages();
  const std::size_t limits[] = {0, 1, 16, 200, kDefaultMaxFrameBytes, std::numeric_limits<std::size_t>::max()};
  std::size_t frames_seen = 0, errors_seen = 0;
  for (int round = 0; round < 100000; ++round) {
    std::string buffer;
    const int kind = round % 3;
    if (kind == 0) {  // pure noise
      buffer.resize(std::uniform_int_distribution<int>(0, 64)(rng));
      for (char& c : buffer) c = static_cast<char>(rng());
    } else {  // real frames of small messages, then damaged: bytes flipped, cut short
      for (int n = std::uniform_int_distribution<int>(1, 4)(rng); n > 0; --n) {
        append_frame(samples[rng() % 3], buffer);  // the small ones
      }
      if (kind == 2 && !buffer.empty()) {
        for (int flips = std::uniform_int_distribution<int>(1, 3)(rng); flips > 0; --flips) {
          buffer[rng() % buffer.size()] = static_cast<char>(rng());
        }
      }
      buffer.resize(std::uniform_int_distribution<std::size_t>(0, buffer.size())(rng));
    }
    const std::size_t limit = limits[rng() % std::size(limits)];
    const Reference expected = reference_decode(buffer, limit);

    FrameDecoder decoder(limit);
    std::vector<std::string> frames;
    Status end = Status::need_more;
    for (std::size_t at = 0; at < buffer.size() && end != Status::error;) {
      const std::size_t n = std::uniform_int_distribution<std::size_t>(1, 16)(rng);
      decoder.feed(std::string_view(buffer).substr(at, n));
      at += n;
      std::string_view payload;
      while ((end = decoder.next(payload)) == Status::frame) {
        frames.emplace_back(payload);
        v1::Response parsed;
        (void)parse_frame(payload, parsed);  // may or may not parse; must not crash
      }
    }
    ASSERT_EQ(frames, expected.frames) << "round " << round;
    ASSERT_EQ(end, expected.end) << "round " << round;
    ASSERT_EQ(decoder.error(), expected.error) << "round " << round;
    frames_seen += frames.size();
    errors_seen += end == Status::error;
  }
  // The generator did exercise both outcomes.
  EXPECT_GT(frames_seen, 10000u);
  EXPECT_GT(errors_seen, 10000u);
}

}  // namespace
}  // namespace kiln::proto
