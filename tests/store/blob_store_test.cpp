// BlobStore: content addressing, resumable uploads, crash safety (a blob is whole or absent), verification on read,
// and eviction that never touches pinned blobs.
#include "daemon/store/blob_store.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>
#include <vector>

#include "daemon/store/sha256.h"
#include "tests/support/temp_dir.h"

namespace fs = std::filesystem;
using namespace kiln::store;

namespace {

class TempDir : public kiln::test::TempDir {
 public:
  TempDir() : kiln::test::TempDir("kiln-blob-test") {}
};

std::string pattern(size_t n, unsigned seed) {
  std::string s(n, '\0');
  uint32_t x = seed * 2654435761u + 1;
  for (auto& c : s) {
    x = x * 1664525u + 1013904223u;
    c = static_cast<char>(x >> 24);
  }
  return s;
}

BlobId id_of(const std::string& bytes) { return {sha256_hex(bytes), bytes.size()}; }

void write_file(const fs::path& p, const std::string& bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f << bytes;
}

fs::path blob_file(const fs::path& dir, const BlobId& id) { return dir / "blobs" / id.digest.substr(0, 2) / id.digest; }

template <class F>
StoreError expect_store_error(F&& f, StoreErrc code) {
  try {
    f();
  } catch (const StoreError& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    return e;
  }
  ADD_FAILURE() << "expected a StoreError (" << to_string(code) << ")";
  return StoreError(code, "");
}

}  // namespace

TEST(Sha256, KnownVectors) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  Sha256 h;  // in pieces, as uploads arrive
  h.update("a");
  h.update("bc");
  EXPECT_EQ(h.finish(), sha256_hex("abc"));
}

TEST(BlobStore, PutStoresUnderItsDigestAndReadsBack) {
  TempDir tmp;
  BlobStore store(tmp.path());
  std::string bytes = pattern(100000, 1);
  BlobId id = store.put(bytes);
  EXPECT_EQ(id, id_of(bytes));
  EXPECT_TRUE(fs::is_regular_file(blob_file(tmp.path(), id)));
  EXPECT_TRUE(store.contains(id));
  EXPECT_EQ(store.read(id), bytes);
  EXPECT_EQ(store.put(bytes), id);  // again: same blob, nothing new
  EXPECT_EQ(store.list().size(), 1u);
  EXPECT_TRUE(fs::is_empty(tmp.path() / "tmp"));
}

TEST(BlobStore, EmptyBlobByPutAndByUpload) {
  TempDir tmp;
  BlobStore store(tmp.path());
  BlobId empty = id_of("");
  EXPECT_EQ(store.received(empty), 0u);
  store.complete(empty);
  EXPECT_TRUE(store.contains(empty));
  EXPECT_EQ(store.read(empty), "");
  EXPECT_EQ(store.put(""), empty);
}

TEST(BlobStore, ChunkedUploadThenComplete) {
  TempDir tmp;
  BlobStore store(tmp.path());
  std::string bytes = pattern(10000, 2);
  BlobId id = id_of(bytes);
  uint64_t off = 0;
  while (off < bytes.size()) {
    size_t n = std::min<size_t>(3000, bytes.size() - off);
    off = store.append(id, off, std::string_view(bytes).substr(off, n));
    EXPECT_EQ(store.received(id), off);
    EXPECT_FALSE(store.contains(id));  // not before it is complete and verified
  }
  store.complete(id);
  EXPECT_TRUE(store.contains(id));
  EXPECT_EQ(store.received(id), bytes.size());
  EXPECT_EQ(store.read(id), bytes);
  EXPECT_TRUE(fs::is_empty(tmp.path() / "partial"));
  store.complete(id);  // completing a complete blob changes nothing
  EXPECT_EQ(store.read(id), bytes);
  expect_store_error([&] { store.append(id, 0, "x"); }, StoreErrc::failed_precondition);
}

TEST(BlobStore, BrokenUploadResumesAfterReopen) {
  TempDir tmp;
  std::string bytes = pattern(50000, 3);
  BlobId id = id_of(bytes);
  {
    BlobStore store(tmp.path());
    store.append(id, 0, std::string_view(bytes).substr(0, 20000));
  }  // the connection (and here the whole daemon) went away half-way
  BlobStore store(tmp.path());
  ASSERT_EQ(store.received(id), 20000u);
  EXPECT_FALSE(store.contains(id));
  expect_store_error([&] { store.read(id); }, StoreErrc::not_found);
  store.append(id, 20000, std::string_view(bytes).substr(20000));
  store.complete(id);
  EXPECT_EQ(store.read(id), bytes);
}

TEST(BlobStore, WrongOffsetIsRefusedWithTheOffsetToResumeFrom) {
  TempDir tmp;
  BlobStore store(tmp.path());
  std::string bytes = pattern(1000, 4);
  BlobId id = id_of(bytes);
  store.append(id, 0, std::string_view(bytes).substr(0, 400));
  // A retried chunk (already received) and a gap are both refused, and nothing is written.
  StoreError e1 = expect_store_error([&] { store.append(id, 0, std::string_view(bytes).substr(0, 400)); },
                                     StoreErrc::failed_precondition);
  EXPECT_NE(std::string(e1.what()).find("resume from offset 400"), std::string::npos) << e1.what();
  expect_store_error([&] { store.append(id, 500, std::string_view(bytes).substr(500, 100)); },
                     StoreErrc::failed_precondition);
  EXPECT_EQ(store.received(id), 400u);
  // Past the declared size: refused, nothing written.
  StoreError e2 = expect_store_error([&] { store.append(id, 400, pattern(601, 5)); }, StoreErrc::out_of_range);
  EXPECT_NE(std::string(e2.what()).find(id.digest), std::string::npos) << e2.what();
  EXPECT_EQ(store.received(id), 400u);
  // Completing early: refused, the partial is kept.
  expect_store_error([&] { store.complete(id); }, StoreErrc::failed_precondition);
  EXPECT_EQ(store.received(id), 400u);
  store.append(id, 400, std::string_view(bytes).substr(400));
  store.complete(id);
  EXPECT_EQ(store.read(id), bytes);
}

TEST(BlobStore, DigestMismatchIsRejectedAndDiscarded) {
  TempDir tmp;
  BlobStore store(tmp.path());
  std::string claimed = pattern(4096, 6);
  std::string sent = claimed;
  sent[1234] ^= 1;  // one bit off
  BlobId id = id_of(claimed);
  store.append(id, 0, sent);
  StoreError e = expect_store_error([&] { store.complete(id); }, StoreErrc::data_loss);
  EXPECT_NE(std::string(e.what()).find("upload the blob again from offset 0"), std::string::npos) << e.what();
  EXPECT_FALSE(store.contains(id));
  EXPECT_EQ(store.received(id), 0u);
  EXPECT_TRUE(store.list().empty());
  // The right bytes then go through.
  store.append(id, 0, claimed);
  store.complete(id);
  EXPECT_EQ(store.read(id), claimed);
}

TEST(BlobStore, MalformedDigestsAreRefusedNotUsedAsPaths) {
  TempDir tmp;
  BlobStore store(tmp.path());
  for (std::string bad :
       {std::string("../../etc/passwd"), std::string("abc"), std::string(64, 'g'), std::string(63, 'a') + "/"}) {
    expect_store_error([&] { make_blob_id(bad, 1); }, StoreErrc::invalid_argument);
    expect_store_error([&] { store.append(BlobId{bad, 1}, 0, "x"); }, StoreErrc::invalid_argument);
    expect_store_error([&] { store.read(BlobId{bad, 1}); }, StoreErrc::invalid_argument);
  }
  // Upper case is a valid spelling of a digest; the store's name for it is lower case.
  std::string upper = sha256_hex("abc");
  for (auto& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  EXPECT_EQ(make_blob_id(upper, 3), id_of("abc"));
  BlobStore limited(tmp.path(), BlobStoreOptions{.max_blob_size = 1000});
  expect_store_error([&] { limited.append(BlobId{std::string(64, 'a'), 1001}, 0, "x"); }, StoreErrc::invalid_argument);
}

TEST(BlobStore, CrashLeftoverTmpFileIsNeverServedAndIsCleanedUp) {
  TempDir tmp;
  std::string bytes = pattern(3000, 7);
  BlobId id = id_of(bytes);
  { BlobStore store(tmp.path()); }
  // A put() that died between writing its temporary file and renaming it: the file names its (dead) writer.
  pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  ASSERT_GT(dead, 0);
  ::waitpid(dead, nullptr, 0);
  write_file(tmp.path() / "tmp" / (id.digest + "." + std::to_string(dead) + "-456.tmp"), bytes);
  write_file(tmp.path() / "tmp" / (id.digest + ".garbage.tmp"), bytes);
  BlobStore store(tmp.path());
  EXPECT_FALSE(store.contains(id));
  expect_store_error([&] { store.read(id); }, StoreErrc::not_found);
  EXPECT_TRUE(fs::is_empty(tmp.path() / "tmp"));
  EXPECT_EQ(store.put(bytes), id);
  EXPECT_EQ(store.read(id), bytes);
}

TEST(BlobStore, TmpFilesOfALiveWriterAreLeftAlone) {
  TempDir tmp;
  { BlobStore store(tmp.path()); }
  // Our parent process stands in for another daemon still writing into this directory.
  fs::path theirs = tmp.path() / "tmp" / (std::string(64, 'a') + "." + std::to_string(::getppid()) + "-1.tmp");
  write_file(theirs, "in progress");
  BlobStore store(tmp.path());
  EXPECT_TRUE(fs::exists(theirs));
  EXPECT_TRUE(store.list().empty());
}

TEST(BlobStore, CrashLeftoverPartialIsResumedNotServed) {
  TempDir tmp;
  std::string bytes = pattern(3000, 8);
  BlobId id = id_of(bytes);
  { BlobStore store(tmp.path()); }
  // All bytes arrived but the daemon died before complete(): still only a partial.
  write_file(tmp.path() / "partial" / (id.digest + ".part"), bytes);
  BlobStore store(tmp.path());
  EXPECT_FALSE(store.contains(id));
  expect_store_error([&] { store.read(id); }, StoreErrc::not_found);
  expect_store_error([&] { store.read_range(id, 0, 10); }, StoreErrc::not_found);
  EXPECT_EQ(store.received(id), bytes.size());
  store.complete(id);
  EXPECT_EQ(store.read(id), bytes);
}

TEST(BlobStore, PartialFromALargerDeclarationStartsOver) {
  TempDir tmp;
  std::string bytes = pattern(100, 9);
  BlobId id = id_of(bytes);
  BlobStore store(tmp.path());
  store.append(BlobId{id.digest, 500}, 0, pattern(300, 10));  // a client that declared the wrong size
  EXPECT_EQ(store.received(id), 0u);
  store.append(id, 0, bytes);
  store.complete(id);
  EXPECT_EQ(store.read(id), bytes);
}

TEST(BlobStore, DamagedBlobIsRefusedQuarantinedAndReplaceable) {
  TempDir tmp;
  std::string bytes = pattern(5000, 11);
  BlobId id;
  {
    BlobStore store(tmp.path());
    id = store.put(bytes);
  }
  std::string damaged = bytes;
  damaged[17] ^= 0x40;  // bit rot, same size
  write_file(blob_file(tmp.path(), id), damaged);
  BlobStore store(tmp.path());  // a new process: nothing verified yet
  StoreError e = expect_store_error([&] { store.read(id); }, StoreErrc::data_loss);
  EXPECT_NE(std::string(e.what()).find("damaged"), std::string::npos) << e.what();
  EXPECT_FALSE(store.contains(id));
  EXPECT_FALSE(fs::is_empty(tmp.path() / "corrupt"));  // kept for inspection, never served
  EXPECT_EQ(store.put(bytes), id);
  EXPECT_EQ(store.read(id), bytes);
}

// Damage to a blob this same process wrote (or verified) used to go unseen until a restart: the first verification
// was remembered. Every read from offset 0 (the start of a fetch) hashes the file again; the whole read always does.
TEST(BlobStore, DamageToABlobThisProcessWroteIsFoundWhenServed) {
  TempDir tmp;
  BlobStore store(tmp.path());
  const std::string bytes = pattern(5000, 14);
  const BlobId written = store.put(bytes);
  EXPECT_EQ(store.read_range(written, 0, 100), bytes.substr(0, 100));  // verified once, and fine
  std::string damaged = bytes;
  damaged[4000] ^= 0x01;
  write_file(blob_file(tmp.path(), written), damaged);
  expect_store_error([&] { store.read_range(written, 0, 100); }, StoreErrc::data_loss);
  EXPECT_FALSE(store.contains(written));

  // The same for an uploaded blob, and for a read in the middle that is the first since the write.
  const std::string more = pattern(5000, 15);
  const BlobId uploaded = id_of(more);
  store.append(uploaded, 0, more);
  store.complete(uploaded);
  std::string bad = more;
  bad[10] ^= 0x01;
  write_file(blob_file(tmp.path(), uploaded), bad);
  expect_store_error([&] { store.read_range(uploaded, 4096, 100); }, StoreErrc::data_loss);
}

TEST(BlobStore, TruncatedBlobIsRefusedByRangeReads) {
  TempDir tmp;
  std::string bytes = pattern(5000, 12);
  BlobId id;
  {
    BlobStore store(tmp.path());
    id = store.put(bytes);
  }
  fs::resize_file(blob_file(tmp.path(), id), 2500);
  BlobStore store(tmp.path());
  expect_store_error([&] { store.read_range(id, 0, 100); }, StoreErrc::data_loss);
  EXPECT_FALSE(store.contains(id));
}

TEST(BlobStore, RangeReads) {
  TempDir tmp;
  BlobStore store(tmp.path());
  std::string bytes = pattern(10000, 13);
  BlobId id = store.put(bytes);
  EXPECT_EQ(store.read_range(id, 0, 4096), bytes.substr(0, 4096));
  EXPECT_EQ(store.read_range(id, 8192, 4096), bytes.substr(8192));  // fewer at the end
  EXPECT_EQ(store.read_range(id, 10000, 4096), "");
  expect_store_error([&] { store.read_range(id, 10001, 1); }, StoreErrc::out_of_range);
  // Asking with the wrong size is not found under that name, and the stored blob is left alone.
  expect_store_error([&] { store.read_range(BlobId{id.digest, 9999}, 0, 1); }, StoreErrc::not_found);
  expect_store_error([&] { store.read(BlobId{id.digest, 10001}); }, StoreErrc::not_found);
  EXPECT_EQ(store.read(id), bytes);
}

TEST(BlobStore, RangeReadsHashABlobOncePerProcess) {
  TempDir tmp;
  std::string bytes = pattern(8000, 14);
  BlobId id;
  {
    BlobStore writer(tmp.path());
    id = writer.put(bytes);
  }
  BlobStore reader(tmp.path());
  ASSERT_EQ(reader.read_range(id, 0, 1000), bytes.substr(0, 1000));  // hashes the whole blob, once
  // Damage that keeps the size goes unnoticed by later range reads in this process (they only check the size)…
  std::string damaged = bytes;
  damaged[5000] ^= 1;
  write_file(blob_file(tmp.path(), id), damaged);
  EXPECT_EQ(reader.read_range(id, 4000, 2000), damaged.substr(4000, 2000));
  // …but a full read hashes what it returns, and a new process hashes again.
  BlobStore fresh(tmp.path());
  expect_store_error([&] { fresh.read_range(id, 0, 1000); }, StoreErrc::data_loss);
}

TEST(BlobStore, EvictionRemovesLeastRecentlyUsedFirstAndNeverPinned) {
  TempDir tmp;
  BlobStore store(tmp.path());
  std::vector<BlobId> ids;
  for (unsigned i = 0; i < 5; ++i) ids.push_back(store.put(pattern(100, 100 + i)));
  // ids[0] is the oldest but pinned (a queued job reads it).
  std::unordered_map<std::string, double> last_used;
  for (unsigned i = 0; i < 5; ++i) last_used[ids[i].digest] = 1000.0 + i;
  EvictionReport r = store.evict_to(250, {ids[0].digest}, last_used);
  ASSERT_EQ(r.removed.size(), 3u);
  EXPECT_EQ(r.removed[0], ids[1]);
  EXPECT_EQ(r.removed[1], ids[2]);
  EXPECT_EQ(r.removed[2], ids[3]);
  EXPECT_EQ(r.bytes_freed, 300u);
  EXPECT_EQ(r.bytes_after, 200u);
  EXPECT_FALSE(r.limit_unreachable);
  EXPECT_TRUE(store.contains(ids[0]));
  EXPECT_TRUE(store.contains(ids[4]));
  EXPECT_EQ(store.read(ids[0]), pattern(100, 100));
  // Under the limit already: nothing goes.
  EXPECT_TRUE(store.evict_to(250, {}, last_used).removed.empty());
}

TEST(BlobStore, EvictionKeepsPinnedBlobsEvenWhenTheLimitCannotBeMet) {
  TempDir tmp;
  BlobStore store(tmp.path());
  BlobId a = store.put(pattern(100, 1)), b = store.put(pattern(100, 2));
  EvictionReport r = store.evict_to(0, {a.digest, b.digest}, {});
  EXPECT_TRUE(r.removed.empty());
  EXPECT_TRUE(r.limit_unreachable);
  EXPECT_EQ(r.bytes_after, 200u);
  EXPECT_TRUE(store.contains(a) && store.contains(b));
}

TEST(BlobStore, EvictionFallsBackToFileTimesAndTouchRefreshesThem) {
  TempDir tmp;
  BlobStore store(tmp.path());
  BlobId a = store.put(pattern(100, 1)), b = store.put(pattern(100, 2)), c = store.put(pattern(100, 3));
  auto base = fs::file_time_type::clock::now() - std::chrono::hours(24);
  fs::last_write_time(blob_file(tmp.path(), a), base);
  fs::last_write_time(blob_file(tmp.path(), b), base + std::chrono::hours(1));
  fs::last_write_time(blob_file(tmp.path(), c), base + std::chrono::hours(2));
  EXPECT_TRUE(store.touch(a));  // a is now the most recently used
  EvictionReport r = store.evict_to(100, {}, {});
  ASSERT_EQ(r.removed.size(), 2u);
  EXPECT_EQ(r.removed[0], b);
  EXPECT_EQ(r.removed[1], c);
  EXPECT_TRUE(store.contains(a));
  EXPECT_FALSE(store.touch(b));
}

TEST(BlobStore, UsageCountsBlobsAndPartials) {
  TempDir tmp;
  BlobStore store(tmp.path());
  store.put(pattern(1000, 1));
  std::string big = pattern(5000, 2);
  store.append(id_of(big), 0, std::string_view(big).substr(0, 300));
  BlobUsage u = store.usage();
  EXPECT_EQ(u.blob_count, 1u);
  EXPECT_EQ(u.blob_bytes, 1000u);
  EXPECT_EQ(u.partial_count, 1u);
  EXPECT_EQ(u.partial_bytes, 300u);
  EXPECT_EQ(store.size_on_disk(), 1300u);
}

TEST(BlobStore, StalePartialsAreRemovedFreshOnesKept) {
  TempDir tmp;
  BlobStore store(tmp.path());
  std::string a = pattern(1000, 1), b = pattern(1000, 2);
  store.append(id_of(a), 0, std::string_view(a).substr(0, 10));
  store.append(id_of(b), 0, std::string_view(b).substr(0, 10));
  fs::last_write_time(tmp.path() / "partial" / (id_of(a).digest + ".part"),
                      fs::file_time_type::clock::now() - std::chrono::hours(48));
  EXPECT_EQ(store.remove_partials_older_than(std::chrono::hours(24)), 1u);
  EXPECT_EQ(store.received(id_of(a)), 0u);
  EXPECT_EQ(store.received(id_of(b)), 10u);
}

TEST(BlobStore, ConcurrentUploadsPutsAndReads) {
  TempDir tmp;
  BlobStore store(tmp.path());
  constexpr int kThreads = 6, kBlobs = 12;
  std::vector<std::string> contents;
  for (int i = 0; i < kBlobs; ++i) contents.push_back(pattern(20000 + 37 * i, 200 + i));
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < kBlobs; ++i) {
        const std::string& bytes = contents[(i + t) % kBlobs];
        BlobId id = id_of(bytes);
        try {
          if (t % 2 == 0) {
            store.put(bytes);
          } else {
            // Several uploaders of the same blob: whoever is at the right offset wins; the others resume.
            for (;;) {
              uint64_t at = store.received(id);
              if (at == id.size) break;
              try {
                store.append(id, at, std::string_view(bytes).substr(at, 4096));
              } catch (const StoreError& e) {
                if (e.code() != StoreErrc::failed_precondition) throw;
              }
            }
            store.complete(id);
          }
          if (store.read(id) != bytes) ++failures;
          if (store.read_range(id, 100, 50) != bytes.substr(100, 50)) ++failures;
        } catch (const StoreError& e) {
          ADD_FAILURE() << e.what();
          ++failures;
        }
      }
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(store.list().size(), static_cast<size_t>(kBlobs));
  EXPECT_EQ(store.usage().partial_count, 0u);
}
