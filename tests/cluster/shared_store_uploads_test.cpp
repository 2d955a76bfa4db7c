// Partial uploads in a store folder that several farm nodes share (daemon/store/blob_store.h): two nodes receiving
// the same blob at once take turns on its partial file (an exclusive flock), so neither writes into the other's
// chunk or into the blob the other just completed, and one node's sweep of abandoned uploads never deletes an
// upload another node is writing. Each node is a BlobStore of its own on the same folder, as in kilnd --cluster;
// "another node writing" is a lock held on the partial by the test, as that node's append holds it.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <sstream>
#include <string>
#include <thread>

#include "daemon/store/blob_store.h"
#include "daemon/store/sha256.h"

namespace kiln::store {
namespace {

namespace fs = std::filesystem;

class SharedStoreUploadsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "kiln-shared-store-XXXXXX").string();
    ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
    dir_ = pattern;
    BlobStoreOptions a, b;
    a.tmp_subdir = "tmp/node-a";
    b.tmp_subdir = "tmp/node-b";
    node_a_ = std::make_unique<BlobStore>(dir_, a);
    node_b_ = std::make_unique<BlobStore>(dir_, b);
  }
  void TearDown() override {
    node_a_.reset();
    node_b_.reset();
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path partial(const BlobId& id) const { return dir_ / "partial" / (id.digest + ".part"); }

  // Another node in the middle of writing the partial: its lock, held until release().
  struct OtherNodeWriting {
    explicit OtherNodeWriting(const fs::path& part) : fd(::open(part.c_str(), O_RDWR | O_CREAT, 0644)) {
      EXPECT_GE(fd, 0);
      EXPECT_EQ(::flock(fd, LOCK_EX), 0);
    }
    ~OtherNodeWriting() { release(); }
    void release() {
      if (fd >= 0) ::close(fd);
      fd = -1;
    }
    int fd;
  };

  // True once some thread waits for a flock on the file (a "->" line of /proc/locks for its inode); false if
  // `done` is ready first (the call did not wait). The bound only keeps a broken build from hanging.
  template <class Future>
  static bool waits_for_lock(const fs::path& file, Future& done) {
    struct stat st {};
    if (::stat(file.c_str(), &st) != 0) return false;
    const std::string inode = ":" + std::to_string(st.st_ino) + " ";
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < give_up) {
      if (done.wait_for(std::chrono::milliseconds(5)) == std::future_status::ready) return false;
      std::ifstream locks("/proc/locks");
      for (std::string line; std::getline(locks, line);) {
        if (line.find("->") != std::string::npos && line.find("FLOCK") != std::string::npos &&
            line.find(inode) != std::string::npos) {
          return true;
        }
      }
    }
    return false;
  }

  fs::path dir_;
  std::unique_ptr<BlobStore> node_a_, node_b_;
};

TEST_F(SharedStoreUploadsTest, AChunkForTheSameBlobWaitsForTheOtherNodesAppend) {
  const std::string bytes = std::string(3000, 'x') + std::string(3000, 'y');
  const BlobId id = make_blob_id(sha256_hex(bytes), bytes.size());
  ASSERT_EQ(node_a_->append(id, 0, bytes.substr(0, 2000)), 2000u);
  // Node a is writing its next chunk, 2000..4000, when node b receives the same chunk from its own client.
  OtherNodeWriting a(partial(id));
  auto b = std::async(std::launch::async, [&] { return node_b_->append(id, 2000, bytes.substr(2000, 2000)); });
  ASSERT_TRUE(waits_for_lock(partial(id), b)) << "node b wrote while node a held the partial";
  ASSERT_EQ(::pwrite(a.fd, bytes.data() + 2000, 2000, 2000), 2000);
  a.release();
  // Node b finds a's chunk there: refused with the offset to resume from, nothing written twice.
  try {
    b.get();
    ADD_FAILURE() << "node b appended at an offset node a had just written";
  } catch (const StoreError& e) {
    EXPECT_EQ(e.code(), StoreErrc::failed_precondition);
    EXPECT_NE(std::string(e.what()).find("resume from offset 4000"), std::string::npos) << e.what();
  }
  EXPECT_EQ(node_b_->append(id, 4000, bytes.substr(4000)), bytes.size());
  node_b_->complete(id);
  EXPECT_EQ(node_a_->read(id), bytes);
}

TEST_F(SharedStoreUploadsTest, AnAppendThatWaitedOnACompletionNeverWritesIntoTheCompletedBlob) {
  const std::string bytes(5000, 'z');
  const BlobId id = make_blob_id(sha256_hex(bytes), bytes.size());
  ASSERT_EQ(node_a_->append(id, 0, bytes), bytes.size());
  // Node a completes (its lock held while it verifies and renames); node b's client sends a chunk meanwhile that
  // its own view (offset 0) would put at the start.
  const fs::path part = partial(id);
  OtherNodeWriting a(part);
  auto b = std::async(std::launch::async, [&] { return node_b_->append(id, 0, std::string(100, '!')); });
  ASSERT_TRUE(waits_for_lock(part, b)) << "node b wrote while node a was completing";
  const fs::path blob = dir_ / "blobs" / id.digest.substr(0, 2) / id.digest;
  fs::create_directories(blob.parent_path());
  fs::rename(part, blob);  // what a's complete() does under its lock
  a.release();
  try {
    b.get();
    ADD_FAILURE() << "node b appended to a blob node a had completed";
  } catch (const StoreError& e) {
    EXPECT_EQ(e.code(), StoreErrc::failed_precondition);
    EXPECT_NE(std::string(e.what()).find("already stored complete"), std::string::npos) << e.what();
  }
  EXPECT_EQ(node_b_->read(id), bytes) << "the completed blob was changed";
  EXPECT_FALSE(fs::exists(part)) << "node b started a new partial of a complete blob";
}

TEST_F(SharedStoreUploadsTest, ASweepNeverDeletesAnUploadAnotherNodeIsWriting) {
  const std::string bytes(4000, 'q');
  const BlobId id = make_blob_id(sha256_hex(bytes), bytes.size());
  ASSERT_EQ(node_a_->append(id, 0, bytes.substr(0, 1000)), 1000u);
  // Its last change looks two days old (a slow client, or the shared file system's clock), but node a is writing
  // a chunk now.
  fs::last_write_time(partial(id), fs::file_time_type::clock::now() - std::chrono::hours(48));
  {
    OtherNodeWriting a(partial(id));
    EXPECT_EQ(node_b_->remove_partials_older_than(std::chrono::hours(24)), 0u);
    EXPECT_TRUE(fs::exists(partial(id)));
  }
  EXPECT_EQ(node_a_->append(id, 1000, bytes.substr(1000)), bytes.size());
  node_a_->complete(id);
  EXPECT_EQ(node_b_->read(id), bytes);
  // Once nobody writes it and it is old, the sweep does delete an abandoned partial.
  const std::string other(2000, 'w');
  const BlobId gone = make_blob_id(sha256_hex(other), other.size());
  ASSERT_EQ(node_a_->append(gone, 0, other.substr(0, 500)), 500u);
  fs::last_write_time(partial(gone), fs::file_time_type::clock::now() - std::chrono::hours(48));
  EXPECT_EQ(node_b_->remove_partials_older_than(std::chrono::hours(24)), 1u);
  EXPECT_EQ(node_a_->received(gone), 0u);
}

}  // namespace
}  // namespace kiln::store
