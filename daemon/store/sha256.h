// SHA-256 of files: the digest that names every blob and result in the store, checked when they are read.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "proto/digest.h"

namespace kiln::store {

// The hashing itself is the protocol's (proto/digest.h, library kiln_digest): one implementation for the wire and
// the store.
using proto::Sha256;
using proto::sha256_hex;

struct FileDigest {
  std::string digest;  // 64 lowercase hex digits
  uint64_t size = 0;   // bytes hashed
};
// Hashes a whole file in bounded memory. Throws StoreError (io) if it cannot be read.
FileDigest sha256_file(const std::filesystem::path& file);

// True for exactly 64 hex digits (either case).
bool is_sha256_hex(std::string_view s);

}  // namespace kiln::store
