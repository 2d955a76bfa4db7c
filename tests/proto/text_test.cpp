// The protocol's text helpers (proto/text.h): the printable form of strings from the wire for logs and terminals.
#include <gtest/gtest.h>

#include <string>

#include "proto/text.h"

namespace kiln {
namespace {

using namespace std::string_literals;

TEST(Printable, PrintableUtf8IsKeptAsItIs) {
  EXPECT_EQ(proto::printable("ggx 0.3 (lightmap cornell_box.gltf)"), "ggx 0.3 (lightmap cornell_box.gltf)");
  EXPECT_EQ(proto::printable("caf\xc3\xa9 \xe6\x9c\xa8 \xf0\x9f\x94\xa5"), "caf\xc3\xa9 \xe6\x9c\xa8 \xf0\x9f\x94\xa5");
  EXPECT_EQ(proto::printable(""), "");
}

TEST(Printable, ControlCharactersAreEscapedOnOneLine) {
  EXPECT_EQ(proto::printable("a\nb\rc\td"), "a\\nb\\rc\\td");
  EXPECT_EQ(proto::printable("\x1b[2J\x7f"s), "\\x1b[2J\\x7f");
  EXPECT_EQ(proto::printable("nul\0end"s), "nul\\x00end");
  EXPECT_EQ(proto::printable("csi \xc2\x9b next \xc2\x85"), "csi \\u009b next \\u0085");  // C1 controls
  EXPECT_EQ(proto::printable("nbsp \xc2\xa0"), "nbsp \xc2\xa0");                          // U+00A0 is printable
}

TEST(Printable, BackslashesAndInvalidBytesAreEscapedSoThatNothingIsAmbiguous) {
  // A name holding the text "\n" is not shown as one holding a newline.
  EXPECT_EQ(proto::printable("a\\nb"), "a\\\\nb");
  // Latin-1 bytes, a lone continuation byte, an overlong '/', a surrogate, a truncated sequence.
  EXPECT_EQ(proto::printable("Mat\xe9riau"), "Mat\\xe9riau");
  EXPECT_EQ(proto::printable("\x80"), "\\x80");
  EXPECT_EQ(proto::printable("\xc0\xaf"), "\\xc0\\xaf");
  EXPECT_EQ(proto::printable("\xed\xa0\x80"), "\\xed\\xa0\\x80");
  EXPECT_EQ(proto::printable("\xe6\x9c"), "\\xe6\\x9c");
}

}  // namespace
}  // namespace kiln
