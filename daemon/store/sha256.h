// SHA-256 through OpenSSL's EVP interface: the digest that names every blob and result in the store.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace kiln::store {

// Incremental hashing, for data that arrives or is read in pieces.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void update(std::string_view data);
  // The digest as 64 lowercase hex digits. The hasher cannot be updated afterwards.
  std::string finish_hex();

 private:
  struct Ctx;
  std::unique_ptr<Ctx> ctx_;
  bool finished_ = false;
};

std::string sha256_hex(std::string_view data);

struct FileDigest {
  std::string digest;  // 64 lowercase hex digits
  uint64_t size = 0;   // bytes hashed
};
// Hashes a whole file in bounded memory. Throws StoreError (kIo) if it cannot be read.
FileDigest sha256_file(const std::filesystem::path& file);

// True for exactly 64 hex digits (either case).
bool is_sha256_hex(std::string_view s);

}  // namespace kiln::store
