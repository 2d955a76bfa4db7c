// JobDb: records survive reopening and kill -9, unfinished jobs come back queued, idempotency keys are unique, the
// result cache finds succeeded jobs by spec key, and retention never evicts what a queued job needs.
#include "daemon/store/job_db.h"
#include "daemon/store/retention.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <fstream>
#include <functional>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "daemon/store/sha256.h"
#include "tests/support/temp_dir.h"

namespace fs = std::filesystem;
using namespace kiln::store;

namespace {

class TempDir : public kiln::test::TempDir {
 public:
  TempDir() : kiln::test::TempDir("kiln-jobdb-test") {}
  fs::path db() const { return path() / "jobs.db"; }
};

NewJob job(std::string name, int32_t priority = 0, std::string spec_key = "key-default") {
  NewJob j;
  j.name = std::move(name);
  j.type = "material";
  j.spec = std::string("spec\0with\0nuls", 14);
  j.spec_key = std::move(spec_key);
  j.priority = priority;
  return j;
}

std::string digest(int i) { return sha256_hex("blob " + std::to_string(i)); }

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

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

}  // namespace

TEST(JobDb, InsertAndGetRoundTripEveryField) {
  TempDir tmp;
  JobDb db(tmp.db());
  EXPECT_EQ(db.schema_version(), JobDb::kSchemaVersion);
  NewJob j = job("brass", 7, "k1");
  j.idempotency_key = "ci-build-42";
  j.input_digests = {digest(1), digest(2)};
  InsertOutcome out = db.insert(j);
  EXPECT_TRUE(out.created);
  const JobRecord& r = out.job;
  EXPECT_EQ(r.id.size(), 32u);
  EXPECT_TRUE(std::all_of(r.id.begin(), r.id.end(), [](char c) { return std::isxdigit(c) && !std::isupper(c); }));
  auto got = db.get(r.id);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->name, "brass");
  EXPECT_EQ(got->type, "material");
  EXPECT_EQ(got->spec, j.spec);  // opaque bytes, NULs included
  EXPECT_EQ(got->spec_key, "k1");
  EXPECT_EQ(got->priority, 7);
  EXPECT_EQ(got->state, JobState::queued);
  EXPECT_GT(got->submitted, 1.6e9);
  EXPECT_FALSE(got->started);
  EXPECT_FALSE(got->finished);
  EXPECT_EQ(got->idempotency_key, std::optional<std::string>("ci-build-42"));
  EXPECT_EQ(got->input_digests, j.input_digests);
  EXPECT_TRUE(got->output_digests.empty());
  EXPECT_FALSE(got->cache_source);
  EXPECT_FALSE(db.get("no-such-id"));
}

TEST(JobDb, IdsAreUniqueAndSeqIncreases) {
  TempDir tmp;
  JobDb db(tmp.db());
  std::set<std::string> ids;
  int64_t last_seq = 0;
  for (int i = 0; i < 300; ++i) {
    JobRecord r = db.insert(job("j" + std::to_string(i))).job;
    EXPECT_TRUE(ids.insert(r.id).second);
    EXPECT_GT(r.seq, last_seq);
    last_seq = r.seq;
  }
}

TEST(JobDb, StateChangesAndTheirRefusals) {
  TempDir tmp;
  JobDb db(tmp.db());
  std::string id = db.insert(job("a")).job.id;
  expect_store_error([&] { db.mark_succeeded(id, "r", {}); }, StoreErrc::failed_precondition);
  JobRecord r = db.mark_running(id);
  EXPECT_EQ(r.state, JobState::running);
  EXPECT_TRUE(r.started);
  EXPECT_EQ(r.attempts, 1);
  r = db.mark_succeeded(id, std::string("res\0ult", 7), {digest(9)});
  EXPECT_EQ(r.state, JobState::succeeded);
  EXPECT_EQ(r.result, std::string("res\0ult", 7));
  EXPECT_EQ(r.output_digests, std::vector<std::string>{digest(9)});
  EXPECT_TRUE(r.finished);
  StoreError e = expect_store_error([&] { db.mark_cancelled(id); }, StoreErrc::failed_precondition);
  EXPECT_TRUE(contains(e.what(), "it is succeeded")) << e.what();
  EXPECT_TRUE(contains(e.what(), id)) << e.what();
  expect_store_error([&] { db.mark_running("nope"); }, StoreErrc::not_found);

  std::string q = db.insert(job("b")).job.id;
  EXPECT_EQ(db.mark_cancelled(q).state, JobState::cancelled);                       // a queued job can be cancelled
  expect_store_error([&] { db.mark_running(q); }, StoreErrc::failed_precondition);  // and then never runs
  std::string f = db.insert(job("c")).job.id;
  db.mark_running(f);
  JobRecord failed = db.mark_failed(f, "job.material.ggx.alpha: must be in (0, 1], got -0.2");
  EXPECT_EQ(failed.state, JobState::failed);
  EXPECT_EQ(failed.error, "job.material.ggx.alpha: must be in (0, 1], got -0.2");
}

TEST(JobDb, BadInputIsRefusedAndNothingIsStored) {
  TempDir tmp;
  JobDb db(tmp.db());
  NewJob no_type = job("x");
  no_type.type.clear();
  expect_store_error([&] { db.insert(no_type); }, StoreErrc::invalid_argument);
  NewJob no_key = job("x");
  no_key.spec_key.clear();
  expect_store_error([&] { db.insert(no_key); }, StoreErrc::invalid_argument);
  NewJob bad_digest = job("x");
  bad_digest.input_digests = {digest(1), "../../etc/passwd"};
  StoreError e = expect_store_error([&] { db.insert(bad_digest); }, StoreErrc::invalid_argument);
  EXPECT_TRUE(contains(e.what(), "input_digests[1]")) << e.what();
  NewJob empty_key = job("x");
  empty_key.idempotency_key = "";
  expect_store_error([&] { db.insert(empty_key); }, StoreErrc::invalid_argument);
  NewJob long_key = job("x");
  long_key.idempotency_key = std::string(1000, 'k');
  expect_store_error([&] { db.insert(long_key); }, StoreErrc::invalid_argument);
  std::string id = db.insert(job("ok")).job.id;
  db.mark_running(id);
  expect_store_error([&] { db.mark_succeeded(id, "r", {"zz"}); }, StoreErrc::invalid_argument);
  EXPECT_EQ(db.get(id)->state, JobState::running);
  JobCounts c = db.counts();
  EXPECT_EQ(c.queued + c.running + c.succeeded + c.failed + c.cancelled, 1u);
}

TEST(JobDb, SurvivesReopen) {
  TempDir tmp;
  std::string id;
  {
    JobDb db(tmp.db());
    id = db.insert(job("persist", 3, "kp")).job.id;
    db.mark_running(id);
    db.mark_succeeded(id, "the result", {digest(1), digest(2)});
  }
  JobDb db(tmp.db());
  auto r = db.get(id);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->state, JobState::succeeded);
  EXPECT_EQ(r->result, "the result");
  EXPECT_EQ(r->output_digests, (std::vector<std::string>{digest(1), digest(2)}));
  EXPECT_EQ(r->priority, 3);
  // The journal mode is part of the file: WAL stays on.
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open_v2(tmp.db().c_str(), &raw, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(raw, "PRAGMA journal_mode", -1, &st, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), "wal");
  sqlite3_finalize(st);
  sqlite3_close(raw);
}

TEST(JobDb, UnfinishedJobsComeBackQueuedInQueueOrderAfterACrash) {
  TempDir tmp;
  std::string low, high, running, done;
  {
    JobDb db(tmp.db());
    low = db.insert(job("low", 0)).job.id;
    running = db.insert(job("running", 1)).job.id;
    high = db.insert(job("high", 5)).job.id;
    done = db.insert(job("done", 9)).job.id;
    db.mark_running(running);
    db.mark_running(done);
    db.mark_succeeded(done, "r", {});
  }  // "crash": closed without marking the running job finished
  JobDb db(tmp.db());
  Recovery rec = db.recover_unfinished();
  ASSERT_EQ(rec.queued.size(), 3u);
  EXPECT_EQ(rec.queued[0].id, high);
  EXPECT_EQ(rec.queued[1].id, running);
  EXPECT_EQ(rec.queued[2].id, low);
  EXPECT_TRUE(rec.gave_up.empty());
  auto r = db.get(running);
  EXPECT_EQ(r->state, JobState::queued);
  EXPECT_FALSE(r->started);
  EXPECT_EQ(r->attempts, 1);
  EXPECT_EQ(db.get(done)->state, JobState::succeeded);
}

TEST(JobDb, KillNineMidRunLosesNothingCommitted) {
  TempDir tmp;
  // A child process plays the daemon and is killed with SIGKILL while one job runs: no destructors, no checkpoint,
  // and its lock must not outlive it.
  pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    try {
      JobDb db(tmp.db());
      for (int i = 0; i < 20; ++i) db.insert(job("j" + std::to_string(i), i % 3));
      db.mark_running(db.list(100).back().id);  // the oldest
    } catch (...) {
      ::_exit(3);
    }
    // Keep the database open while dying (leaked on purpose).
    auto* leaked = new JobDb(tmp.path() / "other.db");
    (void)leaked;
    ::raise(SIGKILL);
    ::_exit(4);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status)) << "child exited with " << WEXITSTATUS(status);
  JobDb db(tmp.db());
  JobCounts before = db.counts();
  EXPECT_EQ(before.queued, 19u);
  EXPECT_EQ(before.running, 1u);
  Recovery rec = db.recover_unfinished();
  EXPECT_EQ(rec.queued.size(), 20u);
  EXPECT_EQ(db.counts().queued, 20u);
  for (size_t i = 1; i < rec.queued.size(); ++i) {
    const auto& a = rec.queued[i - 1];
    const auto& b = rec.queued[i];
    EXPECT_TRUE(a.priority > b.priority || (a.priority == b.priority && a.seq < b.seq));
  }
  JobDb other(tmp.path() / "other.db");  // the dead process's lock went with it
}

TEST(JobDb, AJobThatKeepsCrashingTheDaemonIsEventuallyFailed) {
  TempDir tmp;
  std::string id;
  {
    JobDb db(tmp.db(), {.max_crash_restarts = 2});
    id = db.insert(job("poison")).job.id;
    db.mark_running(id);
  }
  {
    JobDb db(tmp.db(), {.max_crash_restarts = 2});
    EXPECT_EQ(db.recover_unfinished().queued.size(), 1u);
    db.mark_running(id);
  }
  JobDb db(tmp.db(), {.max_crash_restarts = 2});
  Recovery rec = db.recover_unfinished();
  EXPECT_TRUE(rec.queued.empty());
  ASSERT_EQ(rec.gave_up.size(), 1u);
  EXPECT_EQ(rec.gave_up[0].state, JobState::failed);
  EXPECT_TRUE(contains(rec.gave_up[0].error, "2 times")) << rec.gave_up[0].error;
  // The reason names the guard and how to change it.
  EXPECT_TRUE(contains(rec.gave_up[0].error, "max_crash_restarts = 2")) << rec.gave_up[0].error;
  EXPECT_TRUE(contains(rec.gave_up[0].error, "--max-crash-restarts")) << rec.gave_up[0].error;
}

TEST(JobDb, AGracefulRequeueIsNotACrash) {
  TempDir tmp;
  JobDb db(tmp.db(), {.max_crash_restarts = 1});
  std::string id = db.insert(job("long")).job.id;
  for (int i = 0; i < 3; ++i) {
    db.mark_running(id);
    JobRecord r = db.mark_queued(id);  // shutdown grace period ran out
    EXPECT_EQ(r.state, JobState::queued);
    EXPECT_EQ(r.attempts, 0);
  }
  EXPECT_EQ(db.recover_unfinished().queued.size(), 1u);
}

TEST(JobDb, IdempotencyKeyNamesOneJob) {
  TempDir tmp;
  std::string first;
  {
    JobDb db(tmp.db());
    NewJob j = job("a", 0, "same-spec");
    j.idempotency_key = "upload-7";
    InsertOutcome a = db.insert(j);
    InsertOutcome b = db.insert(j);
    EXPECT_TRUE(a.created);
    EXPECT_FALSE(b.created);
    EXPECT_EQ(a.job.id, b.job.id);
    first = a.job.id;
    NewJob other = job("b", 0, "another-spec");
    other.idempotency_key = "upload-7";
    StoreError e = expect_store_error([&] { db.insert(other); }, StoreErrc::already_exists);
    EXPECT_TRUE(contains(e.what(), first)) << e.what();
    EXPECT_EQ(db.find_by_idempotency_key("upload-7")->id, first);
    EXPECT_FALSE(db.find_by_idempotency_key("upload-8"));
  }
  JobDb db(tmp.db());  // and still after a restart
  NewJob again = job("a", 0, "same-spec");
  again.idempotency_key = "upload-7";
  EXPECT_EQ(db.insert(again).job.id, first);
  EXPECT_EQ(db.counts().queued, 1u);
}

TEST(JobDb, ConcurrentInsertsWithOneKeyCreateOneJob) {
  TempDir tmp;
  JobDb db(tmp.db());
  std::atomic<int> created{0};
  std::vector<std::thread> threads;
  std::mutex mu;
  std::set<std::string> ids;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&] {
      NewJob j = job("racer", 0, "k");
      j.idempotency_key = "only-once";
      InsertOutcome o = db.insert(j);
      if (o.created) ++created;
      std::lock_guard lock(mu);
      ids.insert(o.job.id);
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(created.load(), 1);
  EXPECT_EQ(ids.size(), 1u);
}

TEST(JobDb, ResultCacheFindsTheNewestSucceededJobForASpecKey) {
  TempDir tmp;
  JobDb db(tmp.db());
  EXPECT_FALSE(db.find_succeeded_by_spec_key("spec-A"));
  std::string failed = db.insert(job("f", 0, "spec-A")).job.id;
  db.mark_running(failed);
  db.mark_failed(failed, "boom");
  std::string queued = db.insert(job("q", 0, "spec-A")).job.id;
  EXPECT_FALSE(db.find_succeeded_by_spec_key("spec-A"));  // neither failed nor unfinished jobs answer
  db.mark_running(queued);
  db.mark_succeeded(queued, "result-A", {digest(1)});
  auto hit = db.find_succeeded_by_spec_key("spec-A");
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->id, queued);
  EXPECT_FALSE(db.find_succeeded_by_spec_key("spec-B"));

  // A cache hit is a job of its own, succeeded at once, that says where its result came from.
  db.touch(queued, 100.0);
  NewJob again = job("again", 0, "spec-A");
  again.cached = CachedResult{hit->id, "result-A (cache hit)", hit->output_digests};
  JobRecord copy = db.insert(again).job;
  EXPECT_EQ(copy.state, JobState::succeeded);
  EXPECT_EQ(copy.result, "result-A (cache hit)");
  EXPECT_EQ(copy.cache_source, std::optional<std::string>(queued));
  EXPECT_EQ(copy.output_digests, hit->output_digests);
  EXPECT_GT(db.get(queued)->last_used, 100.0);  // the source was just used
  JobCounts c = db.counts();
  EXPECT_EQ(c.succeeded, 2u);
  EXPECT_EQ(c.cache_hits, 1u);
  EXPECT_EQ(c.failed, 1u);
}

TEST(JobDb, ListIsNewestFirstWithoutPayloads) {
  TempDir tmp;
  JobDb db(tmp.db());
  std::vector<std::string> ids;
  for (int i = 0; i < 5; ++i) ids.push_back(db.insert(job("j" + std::to_string(i))).job.id);
  db.mark_running(ids[1]);
  auto all = db.list(3);
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[0].id, ids[4]);
  EXPECT_EQ(all[2].id, ids[2]);
  EXPECT_TRUE(all[0].spec.empty());
  auto page2 = db.list(10, std::nullopt, all.back().seq);
  ASSERT_EQ(page2.size(), 2u);
  EXPECT_EQ(page2[0].id, ids[1]);
  auto running = db.list(10, JobState::running);
  ASSERT_EQ(running.size(), 1u);
  EXPECT_EQ(running[0].id, ids[1]);
  JobCounts c = db.counts();
  EXPECT_EQ(c.queued, 4u);
  EXPECT_EQ(c.running, 1u);
}

TEST(JobDb, SecondOpenOfTheSameDatabaseIsRefused) {
  TempDir tmp;
  JobDb db(tmp.db());
  StoreError e = expect_store_error([&] { JobDb again(tmp.db()); }, StoreErrc::failed_precondition);
  EXPECT_TRUE(contains(e.what(), "in use by another kilnd")) << e.what();
  EXPECT_TRUE(contains(e.what(), std::to_string(::getpid()))) << e.what();
}

TEST(JobDb, AFileThatIsNotADatabaseIsRefusedAndLeftAlone) {
  TempDir tmp;
  std::string garbage(4096, 'x');
  {
    std::ofstream f(tmp.db(), std::ios::binary);
    f << garbage;
  }
  StoreError e = expect_store_error([&] { JobDb db(tmp.db()); }, StoreErrc::data_loss);
  EXPECT_TRUE(contains(e.what(), tmp.db().string())) << e.what();
  std::ifstream f(tmp.db(), std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  EXPECT_EQ(ss.str(), garbage);
}

TEST(JobDb, ADatabaseFromANewerVersionIsRefused) {
  TempDir tmp;
  { JobDb db(tmp.db()); }
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(tmp.db().c_str(), &raw), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(raw, "PRAGMA user_version = 99", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(raw);
  StoreError e = expect_store_error([&] { JobDb db(tmp.db()); }, StoreErrc::failed_precondition);
  EXPECT_TRUE(contains(e.what(), "newer kilnd")) << e.what();
}

// Runs `check` in a child process as an unprivileged user when the test runs as root (CI does), since root writes
// through file permissions; `dir` is handed to that user. Returns the child's exit status: 0 when check() is true.
int run_unprivileged(const fs::path& dir, const std::function<bool()>& check) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (::geteuid() == 0) {
      constexpr uid_t kNobody = 65534;
      for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (::chown(e.path().c_str(), kNobody, kNobody) != 0) _exit(3);
      }
      if (::chown(dir.c_str(), kNobody, kNobody) != 0 || ::setgid(kNobody) != 0 || ::setuid(kNobody) != 0) _exit(3);
    }
    _exit(check() ? 0 : 1);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// A job database kilnd cannot write to (a read-only file, as after a restore with the wrong permissions) is refused
// when it is opened, saying so, instead of every submit failing INTERNAL later.
TEST(JobDb, AReadOnlyDatabaseIsRefusedWhenOpened) {
  TempDir tmp;
  { JobDb db(tmp.db()); }
  const int status = run_unprivileged(tmp.path(), [&] {
    fs::permissions(tmp.db(), fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
    try {
      JobDb db(tmp.db());
      std::fprintf(stderr, "a read-only job database was opened\n");
      return false;
    } catch (const StoreError& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return e.code() == StoreErrc::failed_precondition && contains(e.what(), "read-only") &&
             contains(e.what(), tmp.db().string());
    }
  });
  EXPECT_EQ(status, 0);
}

TEST(JobDb, ForeignSqliteDatabaseIsRefused) {
  TempDir tmp;
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(tmp.db().c_str(), &raw), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(raw, "CREATE TABLE photos (id INTEGER)", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(raw);
  expect_store_error([&] { JobDb db(tmp.db()); }, StoreErrc::failed_precondition);
}

TEST(JobDb, RetentionInputs) {
  TempDir tmp;
  JobDb db(tmp.db());
  NewJob a = job("a", 0, "ka");
  a.input_digests = {digest(1), digest(2)};
  std::string ida = db.insert(a).job.id;
  NewJob b = job("b", 0, "kb");
  b.input_digests = {digest(2), digest(3)};
  std::string idb = db.insert(b).job.id;
  db.mark_running(idb);
  db.mark_succeeded(idb, "r", {digest(4)});
  NewJob c = job("c", 0, "kc");
  std::string idc = db.insert(c).job.id;
  db.mark_running(idc);
  db.mark_succeeded(idc, "r", {digest(5)});
  db.touch(idb, 2000.0);
  db.touch(idc, 1000.0);
  db.touch(ida, 3000.0);

  EXPECT_EQ(db.pinned_digests(), (std::unordered_set<std::string>{digest(1), digest(2)}));
  auto lru = db.results_by_last_used(10);
  ASSERT_EQ(lru.size(), 2u);
  EXPECT_EQ(lru[0].id, idc);
  EXPECT_EQ(lru[1].id, idb);
  auto times = db.blob_last_used();
  EXPECT_DOUBLE_EQ(times[digest(2)], 3000.0);  // the latest of the jobs that refer to it
  EXPECT_DOUBLE_EQ(times[digest(3)], 2000.0);
  EXPECT_DOUBLE_EQ(times[digest(5)], 1000.0);
  EXPECT_EQ(db.mark_results_evicted({digest(5)}), 1u);
  EXPECT_FALSE(db.find_succeeded_by_spec_key("kc"));
  EXPECT_TRUE(db.get(idc)->evicted);
  EXPECT_EQ(db.results_by_last_used(10).size(), 1u);
}

TEST(JobDb, EnforceRetentionEvictsOldResultsNeverQueuedInputs) {
  TempDir tmp;
  BlobStore blobs(tmp.path());
  JobDb db(tmp.db());
  auto bytes = [](int i) { return std::string(1000, static_cast<char>('a' + i)); };
  BlobId in_old = blobs.put(bytes(0));     // input of a finished job
  BlobId out_old = blobs.put(bytes(1));    // its output, not used for long
  BlobId out_new = blobs.put(bytes(2));    // a recently fetched result
  BlobId in_queued = blobs.put(bytes(3));  // input of a queued job: pinned
  NewJob old_job = job("old", 0, "k-old");
  old_job.input_digests = {in_old.digest};
  std::string old_id = db.insert(old_job).job.id;
  db.mark_running(old_id);
  db.mark_succeeded(old_id, "r-old", {out_old.digest});
  std::string new_id = db.insert(job("new", 0, "k-new")).job.id;
  db.mark_running(new_id);
  db.mark_succeeded(new_id, "r-new", {out_new.digest});
  NewJob queued = job("queued", 0, "k-q");
  queued.input_digests = {in_queued.digest};
  std::string queued_id = db.insert(queued).job.id;
  db.touch(old_id, 1000.0);
  db.touch(queued_id, 500.0);  // oldest of all, and still kept: it is pinned

  RetentionReport r = enforce_retention(db, blobs, 2000);
  ASSERT_EQ(r.blobs.removed.size(), 2u);
  EXPECT_TRUE(blobs.contains(in_queued));
  EXPECT_TRUE(blobs.contains(out_new));
  EXPECT_FALSE(blobs.contains(in_old));
  EXPECT_FALSE(blobs.contains(out_old));
  EXPECT_EQ(r.results_evicted, 1u);
  EXPECT_FALSE(db.find_succeeded_by_spec_key("k-old"));  // the cache no longer offers a result it lost
  EXPECT_TRUE(db.find_succeeded_by_spec_key("k-new"));
  // Nothing left to evict without touching the pinned blob.
  RetentionReport r2 = enforce_retention(db, blobs, 0);
  EXPECT_TRUE(blobs.contains(in_queued));
  EXPECT_TRUE(r2.blobs.limit_unreachable);
}
