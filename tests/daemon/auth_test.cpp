// Tokens: the file must be private, tokens compare exactly.
#include "daemon/auth.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace kiln::daemon {
namespace {

std::filesystem::path temp_file(const std::string& name, const std::string& content, mode_t mode) {
  const auto dir = std::filesystem::temp_directory_path() / ("kiln_auth_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto p = dir / name;
  std::ofstream(p) << content;
  ::chmod(p.c_str(), mode);
  return p;
}

TEST(Auth, LoadsPrivateFileAndAcceptsOnlyItsTokens) {
  const auto p = temp_file("ok", "# comment\n\n  0123456789abcdef0123  \nsecond-token-0123456789\n", 0600);
  const TokenSet set = TokenSet::load(p);
  EXPECT_TRUE(set.accepts("0123456789abcdef0123"));
  EXPECT_TRUE(set.accepts("second-token-0123456789"));
  EXPECT_FALSE(set.accepts("0123456789abcdef012"));    // a prefix
  EXPECT_FALSE(set.accepts("0123456789abcdef01234"));  // longer
  EXPECT_FALSE(set.accepts(""));
  EXPECT_FALSE(set.accepts("# comment"));
}

TEST(Auth, RefusesFilesOthersCanRead) {
  for (mode_t mode : {0644, 0640, 0604, 0660, 0606}) {
    const auto p = temp_file("open", "0123456789abcdef0123\n", mode);
    try {
      TokenSet::load(p);
      FAIL() << "accepted mode " << std::oct << mode;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("chmod 600"), std::string::npos) << e.what();
    }
  }
}

TEST(Auth, RefusesMissingEmptyOrShortTokens) {
  EXPECT_THROW(TokenSet::load("/nonexistent/kiln/tokens"), std::runtime_error);
  EXPECT_THROW(TokenSet::load(temp_file("empty", "# only a comment\n", 0600)), std::runtime_error);
  try {
    TokenSet::load(temp_file("short", "abc\n", 0600));
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("line 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(TokenSet::load(std::filesystem::temp_directory_path()), std::runtime_error);  // a directory
}

TEST(Auth, GeneratedTokensAreLongDistinctAndWrittenPrivately) {
  const std::string a = generate_token(), b = generate_token();
  EXPECT_EQ(a.size(), 64u);
  EXPECT_NE(a, b);
  const auto p = temp_file("gen", "", 0600);
  write_token_file(p, a);
  struct stat st {};
  ASSERT_EQ(::stat(p.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_TRUE(TokenSet::load(p).accepts(a));
}

}  // namespace
}  // namespace kiln::daemon
