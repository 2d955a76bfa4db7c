// The protocol's text helpers (proto/text.h): UTF-8 checked and made valid for protobuf's string fields, cut without
// cutting a character, and the printable form of strings from the wire for logs and terminals.
#include <gtest/gtest.h>

#include <string>

#include "proto/text.h"

namespace kiln {
namespace {

using namespace std::string_literals;

TEST(Utf8, WellFormedUtf8IsRecognisedAndKept) {
  for (const std::string s : {""s, "plain"s, "caf\xc3\xa9"s, "\xe6\x9c\xa8"s, "\xf0\x9f\x94\xa5"s, "nul\0in"s,
                              "\xf4\x8f\xbf\xbf"s /* U+10FFFF */}) {
    EXPECT_TRUE(proto::is_utf8(s)) << s;
    EXPECT_EQ(proto::to_utf8(s), s);
  }
}

TEST(Utf8, EveryByteThatIsNotUtf8BecomesTheReplacementCharacter) {
  const std::string fffd = "\xef\xbf\xbd";
  // Latin-1 (as the OBJ files of assimp-testmodels carry), a lone continuation byte, an overlong '/', a surrogate,
  // beyond U+10FFFF, a sequence cut short at the end.
  EXPECT_EQ(proto::to_utf8("Mat\xe9riau"), "Mat" + fffd + "riau");
  EXPECT_EQ(proto::to_utf8("\x80"), fffd);
  EXPECT_EQ(proto::to_utf8("\xc0\xaf"), fffd + fffd);
  EXPECT_EQ(proto::to_utf8("\xed\xa0\x80"), fffd + fffd + fffd);
  EXPECT_EQ(proto::to_utf8("\xf4\x90\x80\x80"), fffd + fffd + fffd + fffd);
  EXPECT_EQ(proto::to_utf8("ok\xe6\x9c"), "ok" + fffd + fffd);
  for (const std::string s : {"Mat\xe9riau"s, "\xc0\xaf"s, "\xff\xfe"s}) {
    EXPECT_FALSE(proto::is_utf8(s));
    EXPECT_TRUE(proto::is_utf8(proto::to_utf8(s)));
  }
}

TEST(Utf8, PrefixesDoNotCutACharacter) {
  const std::string s = "ab\xe6\x9c\xa8" "c";  // a, b, 木 (3 bytes), c
  EXPECT_EQ(proto::utf8_prefix(s, 10), s);
  EXPECT_EQ(proto::utf8_prefix(s, 5), "ab\xe6\x9c\xa8");
  EXPECT_EQ(proto::utf8_prefix(s, 4), "ab");
  EXPECT_EQ(proto::utf8_prefix(s, 3), "ab");
  EXPECT_EQ(proto::utf8_prefix(s, 0), "");
}

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
