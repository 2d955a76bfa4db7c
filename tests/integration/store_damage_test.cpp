// Damaged files in kilnd's store: found when served, moved aside, and never answered from the result cache again.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "client/lib/client.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/service_client.h"

namespace kiln {
namespace {

using client::Client;
using test::connect;
using test::Daemon;
using test::ggx_job;

// Flips one byte in the middle of a stored blob, keeping its size (as bit rot or a stray write would).
void damage(const Daemon& d, const v1::Digest& digest) {
  const auto file = d.dir() / "store" / "blobs" / digest.sha256().substr(0, 2) / digest.sha256();
  ASSERT_TRUE(std::filesystem::exists(file)) << file;
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(static_cast<std::streamoff>(digest.size() / 2));
  const char c = static_cast<char>(f.get());
  f.seekp(static_cast<std::streamoff>(digest.size() / 2));
  f.put(static_cast<char>(c ^ 0x5a));
}

v1::Error::Code fetch_error(Client& c, const v1::Digest& digest) {
  try {
    c.fetch(digest);
  } catch (const client::ServerError& e) {
    return e.code();
  }
  return v1::Error::CODE_UNSPECIFIED;
}

// A result whose output was found damaged used to stay in the cache: resubmitting was a cache hit, and fetching
// said "submit again", a loop. Now the damaged output leaves the cache and the next submit bakes.
TEST(StoreDamage, ADamagedResultLeavesTheCache) {
  std::filesystem::path dir;
  v1::Output damaged;
  {
    Daemon d;
    d.keep();
    dir = d.dir();
    Client c = connect(d);
    const std::string id = c.submit(ggx_job(0.35, 256, 4)).job_id();
    ASSERT_EQ(c.watch(id).state(), v1::JOB_STATE_SUCCEEDED);
    damaged = c.result(id).outputs(0);
    ASSERT_EQ(d.terminate(), 0);
  }
  Daemon again({}, dir);
  damage(again, damaged.digest());
  Client c = connect(again);
  EXPECT_EQ(fetch_error(c, damaged.digest()), v1::Error::DATA_LOSS);
  const v1::SubmitReply resubmitted = c.submit(ggx_job(0.35, 256, 4));
  EXPECT_FALSE(resubmitted.cache_hit()) << "a result with a damaged output was answered from the cache";
  ASSERT_EQ(c.watch(resubmitted.job_id()).state(), v1::JOB_STATE_SUCCEEDED) << again.log();
  const v1::JobResult baked = c.result(resubmitted.job_id());
  for (const v1::Output& o : baked.outputs()) {
    EXPECT_EQ(proto::sha256_hex(c.fetch(o.digest())), o.digest().sha256()) << o.name();
  }
  // The fresh bake is cached again.
  EXPECT_TRUE(c.submit(ggx_job(0.35, 256, 4)).cache_hit());
}

// kilnd used to verify only files written before it started: an output it baked itself and then found damaged on
// disk was served as it was until a restart. Every fetch now hashes the blob when it starts.
TEST(StoreDamage, ADamagedOutputKilndWroteIsRefusedWithoutARestart) {
  Daemon d;
  Client c = connect(d);
  const std::string id = c.submit(ggx_job(0.35, 256, 4)).job_id();
  ASSERT_EQ(c.watch(id).state(), v1::JOB_STATE_SUCCEEDED);
  const v1::Output output = c.result(id).outputs(0);
  EXPECT_EQ(proto::sha256_hex(c.fetch(output.digest())), output.digest().sha256());  // served whole first
  damage(d, output.digest());
  EXPECT_EQ(fetch_error(c, output.digest()), v1::Error::DATA_LOSS);
  EXPECT_NE(d.log().find("damaged"), std::string::npos) << d.log();
}

}  // namespace
}  // namespace kiln
