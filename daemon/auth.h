// Who may talk to kilnd: tokens read from a file only its owner can read, compared in constant time.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace kiln::daemon {

// Refuses a secret's file that is missing, not a regular file, or open to others (group or world bits), with a
// message naming `what` and the path and saying how to fix it. For the token file and the farm's Redis password.
void check_owner_only(const std::string& path, const std::string& what, const std::string& how_to_create);

class TokenSet {
 public:
  // Reads one token per line (blank lines and lines starting with '#' are ignored; surrounding spaces are trimmed).
  // Refuses, with an error for people, a file that others than its owner can read or write (mode & 077), that is
  // not a regular file, or that holds no token or a token shorter than 16 characters.
  static TokenSet load(const std::string& path);
  // For tests and for generated tokens.
  static TokenSet from_tokens(std::vector<std::string> tokens);

  // True if `token` equals one of the tokens. The comparison takes the same time whatever the token's content
  // (every stored token is compared in full, with CRYPTO_memcmp-style accumulation), so timing tells nothing.
  bool accepts(std::string_view token) const;
  bool empty() const { return tokens_.empty(); }

 private:
  std::vector<std::string> tokens_;
};

// A new random token (32 bytes from the OS, 64 hex digits).
std::string generate_token();

// Writes `token` to `path` with mode 0600, creating or replacing the file atomically.
void write_token_file(const std::string& path, const std::string& token);

}  // namespace kiln::daemon
