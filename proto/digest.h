// SHA-256, the content address of blobs and results, as 64 lowercase hex digits.
#pragma once

#include <memory>
#include <string>
#include <string_view>

struct evp_md_ctx_st;  // OpenSSL's EVP_MD_CTX, kept out of this header

namespace kiln::proto {

// The SHA-256 of `data` in lowercase hex.
std::string sha256_hex(std::string_view data);

// SHA-256 of data that arrives in pieces (uploads, fetches, files).
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(Sha256&&) noexcept;  // a moved-from Sha256 may only be destroyed or assigned to
  Sha256& operator=(Sha256&&) noexcept;
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void update(std::string_view data);
  // The digest of everything updated since construction or the last finish(), in lowercase hex; starts afresh.
  std::string finish();

 private:
  struct Free {
    void operator()(evp_md_ctx_st* ctx) const;
  };
  std::unique_ptr<evp_md_ctx_st, Free> ctx_;
};

// True for exactly 64 lowercase hex digits, the only spelling of a digest the protocol accepts (so that one blob
// has one name).
bool is_valid_sha256_hex(std::string_view text);

}  // namespace kiln::proto
