#include "bakers/envmap/dfg_file.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace kiln::envmap {
namespace {

// Layout (host byte order: a file from another architecture fails the header check and is recomputed):
//   magic "kiln-dfg", format version, lobe, masking, size, samples, replicates (int32 each), seed, entry count
//   (uint64 each), the entries (DfgEntry's six doubles and its int64 samples each), then FNV-1a 64 of all before.
constexpr char kMagic[8] = {'k', 'i', 'l', 'n', '-', 'd', 'f', 'g'};
constexpr int32_t kFormatVersion = 1;

struct Header {
  char magic[8];
  int32_t version, lobe, masking, size, samples, replicates;
  uint64_t seed, entries;
};

Header header_of(const DfgKey& key) {
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kFormatVersion;
  h.lobe = static_cast<int32_t>(key.lobe);
  h.masking = static_cast<int32_t>(key.masking);
  h.size = key.size;
  h.samples = key.options.samples;
  h.replicates = key.options.replicates;
  h.seed = key.options.seed;
  h.entries = static_cast<uint64_t>(key.size) * static_cast<uint64_t>(key.size);
  return h;
}

constexpr size_t kEntryBytes = 6 * sizeof(double) + sizeof(int64_t);

uint64_t fnv1a(std::string_view bytes) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : bytes) h = (h ^ c) * 0x100000001b3ULL;
  return h;
}

template <typename T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

template <typename T>
T get(std::string_view bytes, size_t& at) {
  T v;
  std::memcpy(&v, bytes.data() + at, sizeof v);
  at += sizeof v;
  return v;
}

// An entry's doubles, in the order the file stores them (then its samples).
std::array<double*, 6> values_of(DfgEntry& e) {
  return {&e.scale, &e.bias, &e.energy, &e.scale_error, &e.bias_error, &e.energy_error};
}
std::array<double, 6> values_of(const DfgEntry& e) {
  return {e.scale, e.bias, e.energy, e.scale_error, e.bias_error, e.energy_error};
}

bool finite(const DfgEntry& e) {
  for (double v : values_of(e)) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

// The same bits in every value and the same sample count.
bool identical(const DfgEntry& a, const DfgEntry& b) {
  const std::array<double, 6> x = values_of(a), y = values_of(b);
  return std::memcmp(x.data(), y.data(), sizeof x) == 0 && a.samples == b.samples;
}

std::optional<DfgTable> refuse(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return std::nullopt;
}

}  // namespace

std::string dfg_file_name(const DfgKey& key) {
  return "dfg-" + std::string(to_string(key.lobe)) + "-" + brdf::to_string(key.masking) + "-" +
         std::to_string(key.size) + "-" + std::to_string(key.options.samples) + "x" +
         std::to_string(key.options.replicates) + "-" + std::to_string(key.options.seed) + ".bin";
}

std::string encode_dfg_table(const DfgKey& key, const DfgTable& table) {
  std::string out;
  const Header h = header_of(key);
  out.reserve(sizeof h + table.entries.size() * kEntryBytes + sizeof(uint64_t));
  put(out, h);
  for (const DfgEntry& e : table.entries) {
    for (double v : values_of(e)) put(out, v);
    put(out, e.samples);
  }
  put(out, fnv1a(out));
  return out;
}

size_t dfg_encoded_size(const DfgKey& key) {
  return sizeof(Header) + header_of(key).entries * kEntryBytes + sizeof(uint64_t);
}

std::optional<DfgTable> decode_dfg_table(std::string_view bytes, const DfgKey& key, std::string* why) {
  const Header expected = header_of(key);
  const size_t length = dfg_encoded_size(key);
  if (bytes.size() != length) {
    return refuse(why, std::to_string(bytes.size()) + " bytes where the table takes " + std::to_string(length));
  }
  if (std::memcmp(bytes.data(), &expected, sizeof expected) != 0) return refuse(why, "the header names another table");
  size_t at = length - sizeof(uint64_t);
  if (get<uint64_t>(bytes, at) != fnv1a(bytes.substr(0, length - sizeof(uint64_t)))) {
    return refuse(why, "the checksum does not match (the bytes were damaged)");
  }
  DfgTable t;
  t.size_mu = t.size_roughness = key.size;
  t.entries.resize(expected.entries);
  at = sizeof expected;
  for (DfgEntry& e : t.entries) {
    for (double* v : values_of(e)) *v = get<double>(bytes, at);
    e.samples = get<int64_t>(bytes, at);
    if (!finite(e)) return refuse(why, "a value is not finite");
  }
  return t;
}

bool verify_dfg_sample(const DfgTable& table, const DfgKey& key, int count) {
  const int n = static_cast<int>(table.entries.size());
  if (n == 0 || table.size_mu != key.size || table.size_roughness != key.size) return false;
  const brdf::ModelSpec lobe = lobe_model(key.lobe, key.masking);
  for (int s = 0; s < count; ++s) {
    // Spread over the table, the first and last entries included.
    const int k = count > 1 ? static_cast<int>(static_cast<int64_t>(s) * (n - 1) / (count - 1)) : 0;
    if (!identical(dfg_table_entry(lobe, key.size, key.size, key.options, k), table.entries[k])) return false;
  }
  return true;
}

}  // namespace kiln::envmap
