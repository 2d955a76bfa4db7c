// Crash consistency at every point: kilnd is killed with SIGKILL at 50 places drawn at random from its crash points
// (daemon/store/crash_point.h: mid-upload, an upload verified but not renamed, a result written but not renamed, a
// blob renamed, a job committed but not answered, a job marked running, a result committed but not announced), each
// during a workload of uploads, submits and bakes. After each crash kilnd starts again on the same store, and:
//   - every blob whose upload the client saw complete is stored and verifies;
//   - every job whose submit was answered is there once (its idempotency key gives the same job back), and ends
//     SUCCEEDED with outputs that verify, or FAILED with a reason;
//   - no two jobs exist for one idempotency key (nothing duplicated).
// The draw is seeded: the same 50 points every run, so a failure names a trial that can be run again.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

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

constexpr int kTrials = 50;
constexpr int kJobs = 4;
// Two uploads of 2.5 MiB: three 1 MiB chunks each, so a crash can land between chunks.
constexpr size_t kBlobBytes = 5 * 512 * 1024;

// A crash point and how many times it is passed in one trial's workload (so that every hit count is reachable).
struct CrashPoint {
  const char* name;
  int passes;
};
// Material jobs write four outputs each (albedo.exr, split_sum.exr, preview.png, report.json).
const CrashPoint kPoints[] = {{"blob.append", 6},     {"blob.complete", 2}, {"blob.put", 4 * kJobs},
                              {"blob.installed", 2 + 4 * kJobs},         {"job.inserted", kJobs},
                              {"job.running", kJobs}, {"job.succeeded", kJobs}};

// What the client was told before the crash.
struct Accepted {
  std::vector<v1::Digest> blobs;
  std::map<std::string, std::string> jobs;  // idempotency key → job id, for answered submits
  int keys_tried = 0;                       // submits sent, answered or not
};

std::string random_bytes(std::mt19937_64& rng, size_t n) {
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng());
  return s;
}

v1::JobSpec job(int trial, int j) { return test::ggx_job(0.1 + 0.2 * j + 0.001 * trial, 256, 4); }

std::string key(int trial, int j) { return "crash-" + std::to_string(trial) + "-" + std::to_string(j); }

// Uploads, submits and waits for the bakes, until kilnd dies (a client call throws) or all is done.
void workload(const Daemon& d, int trial, std::mt19937_64& rng, Accepted& accepted) {
  try {
    Client c = connect(d);
    for (int b = 0; b < 2; ++b) {
      const std::string bytes = random_bytes(rng, kBlobBytes);
      accepted.blobs.push_back(c.upload_blob(bytes));
      for (int j = 2 * b; j < 2 * b + 2; ++j) {
        ++accepted.keys_tried;
        accepted.jobs[key(trial, j)] = c.submit(job(trial, j), 0, key(trial, j)).job_id();
      }
    }
    for (const auto& [k, id] : accepted.jobs) c.watch(id);
  } catch (const std::exception&) {
    // The connection died with kilnd: what was answered before is what must survive.
  }
}

struct Tally {
  int crashes = 0, jobs_accepted = 0, completed = 0, failed_with_reason = 0, lost = 0, duplicated = 0;
  int blobs_accepted = 0, blobs_lost = 0;
  std::map<std::string, int> by_point;
};

// After the restart: the checks at the top of this file, counted into `tally`.
void check_after_restart(const Daemon& d, int trial, const Accepted& accepted, Tally& tally) {
  Client c = connect(d);
  for (const v1::Digest& blob : accepted.blobs) {
    ++tally.blobs_accepted;
    const v1::BlobQueryReply q = c.query_blobs({blob});
    const bool whole = q.missing_size() == 0 && proto::sha256_hex(c.fetch(blob)) == blob.sha256();
    if (!whole) ++tally.blobs_lost;
    EXPECT_TRUE(whole) << "trial " << trial << ": an uploaded blob is missing or damaged: " << blob.sha256();
  }
  for (int j = 0; j < accepted.keys_tried; ++j) {
    const auto it = accepted.jobs.find(key(trial, j));
    // The same submit again: an answered job must come back as itself, an unanswered one once at most.
    const std::string id = c.submit(job(trial, j), 0, key(trial, j)).job_id();
    if (it == accepted.jobs.end()) continue;
    ++tally.jobs_accepted;
    if (id != it->second) {
      ++tally.duplicated;
      ADD_FAILURE() << "trial " << trial << ": " << key(trial, j) << " was " << it->second << ", now " << id;
    }
    const v1::JobEvent last = c.watch(it->second);
    if (last.state() == v1::JOB_STATE_SUCCEEDED) {
      ++tally.completed;
      const v1::JobResult result = c.result(it->second);
      for (const v1::Output& o : result.outputs()) {
        EXPECT_EQ(proto::sha256_hex(c.fetch(o.digest())), o.digest().sha256()) << "trial " << trial << " " << o.name();
      }
    } else if (last.state() == v1::JOB_STATE_FAILED && !last.message().empty()) {
      ++tally.failed_with_reason;
    } else {
      ++tally.lost;
      ADD_FAILURE() << "trial " << trial << ": job " << it->second << " ended " << v1::JobState_Name(last.state())
                    << ": " << last.message();
    }
  }
  // One job per key tried: the list holds no second copy of any.
  const v1::JobList list = c.list_jobs();
  EXPECT_LE(list.jobs_size(), accepted.keys_tried) << "trial " << trial;
}

TEST(CrashConsistency, KillNineAtFiftyRandomPointsLosesAndDuplicatesNothing) {
  std::mt19937_64 rng(20261203);
  Tally tally;
  for (int trial = 0; trial < kTrials; ++trial) {
    const CrashPoint& point = kPoints[rng() % std::size(kPoints)];
    const int hit = 1 + static_cast<int>(rng() % point.passes);
    const std::string at = std::string(point.name) + ":" + std::to_string(hit);
    SCOPED_TRACE("trial " + std::to_string(trial) + ", KILND_CRASH_AT=" + at);
    std::filesystem::path dir;
    Accepted accepted;
    {
      Daemon d({"--workers", "1"}, {}, {"KILND_CRASH_AT=" + at});
      d.keep();
      dir = d.dir();
      workload(d, trial, rng, accepted);
      // A bound on a hang only: it returns as soon as kilnd dies, and a loaded machine can take many seconds.
      if (d.wait_for_crash(120)) {
        ++tally.crashes;
        ++tally.by_point[point.name];
      } else {
        ADD_FAILURE() << "kilnd did not reach crash point " << at << "\n" << d.log();
        d.kill9();
      }
    }
    Daemon again({"--workers", "1"}, dir);
    check_after_restart(again, trial, accepted, tally);
  }
  EXPECT_EQ(tally.crashes, kTrials);
  EXPECT_EQ(tally.lost, 0);
  EXPECT_EQ(tally.duplicated, 0);
  EXPECT_EQ(tally.blobs_lost, 0);
  std::cout << "[ measured ] " << tally.crashes << " kill -9 crashes; jobs accepted " << tally.jobs_accepted
            << ", completed " << tally.completed << ", failed with reason " << tally.failed_with_reason << ", lost "
            << tally.lost << ", duplicated " << tally.duplicated << "; blobs accepted " << tally.blobs_accepted
            << ", lost " << tally.blobs_lost << "\n[ measured ] crashes by point:";
  for (const auto& [name, n] : tally.by_point) std::cout << " " << name << " " << n;
  std::cout << "\n";
}

}  // namespace
}  // namespace kiln
