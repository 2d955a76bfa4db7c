// DFG tables kept as files between processes (dfg_file.h, dfg_cache.h's folder): the bytes give back the table bit
// for bit and only for the key they were written for; damaged bytes, another key's file and a file whose values
// another version of the integration would have written are all refused and recomputed; a folder that cannot be
// written costs nothing but the time; the folder keeps a bounded number of tables.
#include "bakers/envmap/dfg_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "bakers/envmap/dfg_cache.h"

namespace kiln::envmap {
namespace {

namespace fs = std::filesystem;

bool same_bits(const DfgTable& a, const DfgTable& b) {
  if (a.size_mu != b.size_mu || a.size_roughness != b.size_roughness || a.entries.size() != b.entries.size())
    return false;
  for (size_t k = 0; k < a.entries.size(); ++k) {
    const DfgEntry &x = a.entries[k], &y = b.entries[k];
    for (auto [u, v] : {std::pair{x.scale, y.scale}, std::pair{x.bias, y.bias}, std::pair{x.energy, y.energy},
                        std::pair{x.scale_error, y.scale_error}, std::pair{x.bias_error, y.bias_error},
                        std::pair{x.energy_error, y.energy_error}}) {
      if (std::memcmp(&u, &v, sizeof u) != 0) return false;
    }
    if (x.samples != y.samples) return false;
  }
  return true;
}

DfgKey key(int size, int samples, uint64_t seed, EnvLobe lobe = EnvLobe::ggx) {
  DfgKey k;
  k.lobe = lobe;
  k.masking = dfg_masking(lobe);
  k.size = size;
  k.options.samples = samples;
  k.options.seed = seed;
  return k;
}

DfgTable computed(const DfgKey& k) { return compute_dfg(lobe_model(k.lobe, k.masking), k.size, k.size, k.options); }

TEST(DfgFile, TheBytesGiveBackTheTableBitForBitForTheirKeyOnly) {
  const DfgKey k = key(6, 64, 3);
  const DfgTable t = computed(k);
  const std::string bytes = encode_dfg_table(k, t);
  EXPECT_EQ(bytes.size(), dfg_encoded_size(k));
  const auto back = decode_dfg_table(bytes, k);
  ASSERT_TRUE(back);
  EXPECT_TRUE(same_bits(*back, t));
  // Any field of the key that differs is another table.
  DfgKey other = k;
  for (int field = 0; field < 5; ++field) {
    other = k;
    if (field == 0) other.lobe = EnvLobe::beckmann;
    if (field == 1) other.masking = brdf::Masking::separable;
    if (field == 2) other.options.samples = 65;
    if (field == 3) other.options.replicates = 9;
    if (field == 4) other.options.seed = 4;
    std::string why;
    EXPECT_FALSE(decode_dfg_table(bytes, other, &why)) << field;
    EXPECT_EQ(why, "the header names another table") << field;
  }
  other = k;
  other.size = 5;
  EXPECT_FALSE(decode_dfg_table(bytes, other));  // another length
}

TEST(DfgFile, DamagedOrCutBytesAreRefused) {
  const DfgKey k = key(4, 32, 5);
  const std::string bytes = encode_dfg_table(k, computed(k));
  std::string why;
  EXPECT_FALSE(decode_dfg_table(bytes.substr(0, bytes.size() - 1), k, &why));
  EXPECT_NE(why.find("bytes where the table takes"), std::string::npos) << why;
  for (size_t at : {size_t{60}, bytes.size() / 2, bytes.size() - 9}) {
    std::string flipped = bytes;
    flipped[at] = static_cast<char>(flipped[at] ^ 0x10);
    EXPECT_FALSE(decode_dfg_table(flipped, k, &why)) << at;
    EXPECT_EQ(why, "the checksum does not match (the bytes were damaged)") << at;
  }
  // A non-finite value under a valid checksum.
  DfgTable bad = computed(k);
  bad.entries[3].bias = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(decode_dfg_table(encode_dfg_table(k, bad), k, &why));
  EXPECT_EQ(why, "a value is not finite");
}

TEST(DfgFile, ASampleOfEntriesRecomputesToTheSameBitsOrTheTableIsRefused) {
  const DfgKey k = key(8, 32, 7);
  DfgTable t = computed(k);
  EXPECT_TRUE(verify_dfg_sample(t, k));
  // What an older integration would have left: every value a little off.
  DfgTable older = t;
  for (DfgEntry& e : older.entries) e.scale *= 1 + 1e-12;
  EXPECT_FALSE(verify_dfg_sample(older, k));
  // One sampled entry off (the first and the last are always among the sample).
  DfgTable one_off = t;
  one_off.entries.back().bias = std::nextafter(one_off.entries.back().bias, 1.0);
  EXPECT_FALSE(verify_dfg_sample(one_off, k));
  EXPECT_FALSE(verify_dfg_sample(t, key(8, 32, 8)));  // another seed's table
}

// A folder of its own, and the folder setting put back (empty) when the test ends.
class DfgFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("kiln-dfg-test-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    keep_dfg_tables_in(dir_);
  }
  void TearDown() override {
    keep_dfg_tables_in({});
    fs::remove_all(dir_);
  }
  // Asks for enough other tables that the process no longer holds `k`: what a later process sees.
  static void forget_in_process(uint64_t seed_base) {
    for (int i = 0; i < kDfgCacheTables; ++i)
      cached_dfg(EnvLobe::ggx, dfg_masking(EnvLobe::ggx), 2, o(16, seed_base + i));
  }
  static brdf::AlbedoOptions o(int samples, uint64_t seed) {
    brdf::AlbedoOptions a;
    a.samples = samples;
    a.seed = seed;
    return a;
  }
  std::shared_ptr<const DfgTable> ask(const DfgKey& k, DfgSource& source) {
    return cached_dfg(k.lobe, k.masking, k.size, k.options, &source);
  }
  fs::path dir_;
};

TEST_F(DfgFolderTest, ALaterProcessTakesTheTableFromTheFolderBitForBit) {
  const DfgKey k = key(8, 64, 101);
  DfgSource source = DfgSource::process;
  const auto first = ask(k, source);
  EXPECT_EQ(source, DfgSource::computed);
  ASSERT_TRUE(fs::exists(dir_ / dfg_file_name(k)));
  forget_in_process(10'000);
  const auto later = ask(k, source);
  EXPECT_EQ(source, DfgSource::file);
  EXPECT_TRUE(same_bits(*later, computed(k)));
  EXPECT_STREQ(to_string(DfgSource::file), "kept in the store");
  // No temporary file is left beside the tables.
  for (const auto& e : fs::directory_iterator(dir_)) EXPECT_EQ(e.path().extension(), ".bin") << e.path();
}

TEST_F(DfgFolderTest, ADamagedOrStaleFileIsRecomputedAndWrittenAgain) {
  const DfgKey k = key(8, 64, 202);
  DfgSource source = DfgSource::process;
  ask(k, source);
  const fs::path file = dir_ / dfg_file_name(k);
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto write = [&](const std::string& b) { std::ofstream(file, std::ios::binary | std::ios::trunc) << b; };
  std::string damaged = bytes;
  damaged[damaged.size() / 2] ^= 1;
  DfgTable stale = computed(k);
  for (DfgEntry& e : stale.entries) e.energy *= 1 + 1e-9;
  uint64_t others = 20'000;
  for (const std::string& b : {damaged, bytes.substr(0, 100), encode_dfg_table(k, stale)}) {
    write(b);
    forget_in_process(others += 100);
    const auto table = ask(k, source);
    EXPECT_EQ(source, DfgSource::computed);
    EXPECT_TRUE(same_bits(*table, computed(k)));
    std::ifstream in(file, std::ios::binary);
    EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), bytes) << "written again, whole";
  }
}

TEST_F(DfgFolderTest, AFolderThatCannotBeWrittenCostsOnlyTheTime) {
  std::ofstream(dir_.string() + "-file") << "not a folder";
  keep_dfg_tables_in(fs::path(dir_.string() + "-file") / "tables");  // under a regular file: nothing can be made
  DfgSource source = DfgSource::process;
  const DfgKey k = key(4, 32, 303);
  const auto table = ask(k, source);
  EXPECT_EQ(source, DfgSource::computed);
  EXPECT_TRUE(same_bits(*table, computed(k)));
  fs::remove(dir_.string() + "-file");
}

TEST_F(DfgFolderTest, TheFolderKeepsABoundedNumberOfTables) {
  for (int i = 0; i < kDfgFilesKept + 5; ++i) cached_dfg(EnvLobe::ggx, dfg_masking(EnvLobe::ggx), 2, o(16, 30'000 + i));
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir_)) files += e.path().extension() == ".bin";
  EXPECT_EQ(files, kDfgFilesKept);
  // The one written last is among them.
  EXPECT_TRUE(fs::exists(dir_ / dfg_file_name(key(2, 16, 30'000 + kDfgFilesKept + 4))));
}

}  // namespace
}  // namespace kiln::envmap
