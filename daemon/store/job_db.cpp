#include "daemon/store/job_db.h"

#include <fcntl.h>
#include <openssl/rand.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <random>

#include "daemon/store/crash_point.h"
#include "daemon/store/sqlite.h"

namespace fs = std::filesystem;

namespace kiln::store {

using sqlite::exec;
using sqlite::Stmt;
using sqlite::Transaction;

std::string_view to_string(JobState s) {
  switch (s) {
    case JobState::queued:
      return "queued";
    case JobState::running:
      return "running";
    case JobState::succeeded:
      return "succeeded";
    case JobState::failed:
      return "failed";
    case JobState::cancelled:
      return "cancelled";
  }
  return "unknown";
}

std::optional<JobState> parse_job_state(std::string_view s) {
  for (JobState st : {JobState::queued, JobState::running, JobState::succeeded, JobState::failed, JobState::cancelled})
    if (s == to_string(st)) return st;
  return std::nullopt;
}

double unix_now() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::string new_job_id() {
  unsigned char bytes[16];
  if (RAND_bytes(bytes, sizeof bytes) != 1) {
    // OpenSSL's generator is seeded from the kernel; should it ever fail, the kernel's source via random_device.
    std::random_device rd;
    for (auto& b : bytes) b = static_cast<unsigned char>(rd());
  }
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out(32, '0');
  for (int i = 0; i < 16; ++i) {
    out[2 * i] = kHex[bytes[i] >> 4];
    out[2 * i + 1] = kHex[bytes[i] & 15];
  }
  return out;
}

std::string join_digests(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& d : v) {
    if (!out.empty()) out += ',';
    out += d;
  }
  return out;
}

std::vector<std::string> split_digests(const std::string& s) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start < s.size()) {
    size_t comma = s.find(',', start);
    if (comma == std::string::npos) comma = s.size();
    if (comma > start) out.push_back(s.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

namespace {

constexpr size_t kMaxIdempotencyKey = 256;

void check_digests(const std::vector<std::string>& v, const char* field) {
  for (size_t i = 0; i < v.size(); ++i) {
    const std::string& d = v[i];
    bool ok = d.size() == 64 &&
              std::all_of(d.begin(), d.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
    if (!ok)
      throw StoreError(StoreErrc::invalid_argument, std::string(field) + "[" + std::to_string(i) + "]: '" +
                                                        d.substr(0, 80) +
                                                        "' is not a SHA-256 digest (64 lowercase hex digits)");
  }
}

// Column order of every full SELECT; row_to_record reads by these positions.
constexpr const char* kColumns =
    "id, seq, name, type, spec, spec_key, priority, state, submitted, started, finished, error, result, "
    "idempotency_key, input_digests, output_digests, last_used, attempts, cache_source, evicted";
// The same, with the two payloads replaced by empty blobs (list views need neither).
constexpr const char* kColumnsNoPayload =
    "id, seq, name, type, X'', spec_key, priority, state, submitted, started, finished, error, X'', "
    "idempotency_key, input_digests, output_digests, last_used, attempts, cache_source, evicted";

JobRecord row_to_record(const Stmt& s, const fs::path& file) {
  JobRecord r;
  r.id = s.str(0);
  r.seq = s.i64(1);
  r.name = s.str(2);
  r.type = s.str(3);
  r.spec = s.str(4);
  r.spec_key = s.str(5);
  r.priority = static_cast<int32_t>(s.i64(6));
  std::string state = s.str(7);
  auto st = parse_job_state(state);
  if (!st)
    throw StoreError(StoreErrc::data_loss, "job database " + file.string() + ": job " + r.id +
                                               " has an unknown state '" + state + "'; the file was edited or damaged");
  r.state = *st;
  r.submitted = s.dbl(8);
  r.started = s.opt_dbl(9);
  r.finished = s.opt_dbl(10);
  r.error = s.str(11);
  r.result = s.str(12);
  r.idempotency_key = s.opt_str(13);
  r.input_digests = split_digests(s.str(14));
  r.output_digests = split_digests(s.str(15));
  r.last_used = s.dbl(16);
  r.attempts = static_cast<int32_t>(s.i64(17));
  r.cache_source = s.opt_str(18);
  r.evicted = s.opt_dbl(19);
  return r;
}

constexpr const char* kSchemaV1 = R"sql(
CREATE TABLE jobs (
  id              TEXT PRIMARY KEY NOT NULL,
  seq             INTEGER NOT NULL UNIQUE,
  name            TEXT NOT NULL DEFAULT '',
  type            TEXT NOT NULL,
  spec            BLOB NOT NULL,
  spec_key        TEXT NOT NULL,
  priority        INTEGER NOT NULL DEFAULT 0,
  state           TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  submitted       REAL NOT NULL,
  started         REAL,
  finished        REAL,
  error           TEXT NOT NULL DEFAULT '',
  result          BLOB,
  idempotency_key TEXT,
  input_digests   TEXT NOT NULL DEFAULT '',
  output_digests  TEXT NOT NULL DEFAULT '',
  last_used       REAL NOT NULL,
  attempts        INTEGER NOT NULL DEFAULT 0,
  cache_source    TEXT,
  evicted         REAL
);
CREATE INDEX jobs_state ON jobs (state);
CREATE INDEX jobs_spec_key ON jobs (spec_key, state);
CREATE UNIQUE INDEX jobs_idempotency_key ON jobs (idempotency_key);
CREATE INDEX jobs_last_used ON jobs (state, last_used);
PRAGMA user_version = 1;
)sql";

// One process per database: two daemons would both "recover" and run the same jobs. Returns the lock file's
// descriptor, holding the lock until it is closed.
int lock_database(const fs::path& file) {
  fs::path lock_path = file;
  lock_path += ".lock";
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0)
    throw StoreError(StoreErrc::io, "cannot create lock file " + lock_path.string() + ": " + std::strerror(errno) +
                                        "; check that the store directory exists and is writable");
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    char buf[32] = {};
    ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
    ::close(fd);
    std::string holder = n > 0 ? " (pid " + std::string(buf, static_cast<size_t>(n)) + ")" : "";
    while (!holder.empty() && (holder.back() == '\n')) holder.pop_back();
    throw StoreError(StoreErrc::failed_precondition,
                     "job database " + file.string() + " is in use by another kilnd process" + holder +
                         "; stop that daemon or give this one another --store directory");
  }
  std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd, 0) == 0) {
    [[maybe_unused]] ssize_t w = ::pwrite(fd, pid.data(), pid.size(), 0);  // a hint for people only
  }
  return fd;
}

// The first read of the file: a file that is not a database fails here, before anything is written to it.
int schema_version_of(sqlite3* db, const fs::path& file) {
  Stmt s(db, file, "PRAGMA user_version");
  s.step();
  const int version = static_cast<int>(s.i64(0));
  if (version > JobDb::kSchemaVersion)
    throw StoreError(StoreErrc::failed_precondition,
                     "job database " + file.string() + " has schema version " + std::to_string(version) +
                         ", written by a newer kilnd; this one knows up to version " +
                         std::to_string(JobDb::kSchemaVersion) +
                         ". Run the newer kilnd, or point --store at another directory");
  return version;
}

void set_durability(sqlite3* db, const fs::path& file) {
  {
    Stmt s(db, file, "PRAGMA journal_mode = WAL");
    s.step();
    if (s.str(0) != "wal")
      throw StoreError(StoreErrc::io, "job database " + file.string() +
                                          ": cannot switch to write-ahead logging (journal mode stays '" + s.str(0) +
                                          "'); the store must be on a local file system");
  }
  // FULL rather than NORMAL: in WAL mode NORMAL survives a process crash but may lose the last commits on power
  // loss, and a lost commit here is a submit the client was told succeeded. Commits are a handful per job, so the
  // fsync per commit costs nothing next to a bake.
  exec(db, file, "PRAGMA synchronous = FULL", "setting synchronous mode");
}

// SQLite opens a file it may not write read-only without a word, and writes then fail one by one (every submit
// INTERNAL). The database is checked at open instead: the file must be writable, and taking the write lock must
// work (it needs the directory's -wal and -shm files too).
void check_writable(sqlite3* db, const fs::path& file) {
  const std::string advice =
      "; kilnd must write its job records there: make the file and its directory writable by the user kilnd runs "
      "as (and the file system read-write), or point --store at another directory";
  if (sqlite::read_only(db)) {
    throw StoreError(StoreErrc::failed_precondition, "job database " + file.string() + " is read-only" + advice);
  }
  try {
    exec(db, file, "BEGIN IMMEDIATE", "taking the write lock");
  } catch (const StoreError& e) {
    throw StoreError(StoreErrc::failed_precondition,
                     std::string(e.what()) + " (the database is read-only to kilnd)" + advice);
  }
  exec(db, file, "ROLLBACK", "releasing the write lock");
}

// A new file gets the schema; an SQLite file with tables but no version is someone else's and is left alone.
void create_schema(sqlite3* db, const fs::path& file) {
  bool has_tables;
  {
    Stmt s(db, file, "SELECT count(*) FROM sqlite_master");
    s.step();
    has_tables = s.i64(0) > 0;
  }
  if (has_tables)
    throw StoreError(StoreErrc::failed_precondition,
                     "job database " + file.string() +
                         " is an SQLite database, but not one kilnd created (it has tables and no schema version); "
                         "point --store at another directory");
  Transaction t(db, file);
  exec(db, file, kSchemaV1, "creating the schema");
  t.commit();
}

}  // namespace

struct JobDb::Impl {
  sqlite3* db = nullptr;
  int lock_fd = -1;
  ~Impl() {
    if (db) sqlite::close(db);
    if (lock_fd >= 0) ::close(lock_fd);  // releases the flock
  }
};

JobDb::JobDb(const fs::path& file, JobDbOptions options)
    : impl_(std::make_unique<Impl>()), file_(file), options_(options) {
  impl_->lock_fd = lock_database(file_);
  impl_->db = sqlite::open(file_);
  const int version = schema_version_of(impl_->db, file_);
  set_durability(impl_->db, file_);
  check_writable(impl_->db, file_);
  if (version == 0) create_schema(impl_->db, file_);
  // Future migrations: `if (version < 2) { … PRAGMA user_version = 2; }`, each in its own transaction.
}

JobDb::~JobDb() = default;

int JobDb::schema_version() {
  std::lock_guard lock(mu_);
  Stmt s(impl_->db, file_, "PRAGMA user_version");
  s.step();
  return static_cast<int>(s.i64(0));
}

namespace {

std::optional<JobRecord> get_locked(sqlite3* db, const fs::path& file, std::string_view id) {
  Stmt s(db, file, (std::string("SELECT ") + kColumns + " FROM jobs WHERE id = ?").c_str());
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return row_to_record(s, file);
}

std::optional<JobRecord> find_by_key_locked(sqlite3* db, const fs::path& file, std::string_view key) {
  Stmt s(db, file, (std::string("SELECT ") + kColumns + " FROM jobs WHERE idempotency_key = ?").c_str());
  s.bind(1, key);
  if (!s.step()) return std::nullopt;
  return row_to_record(s, file);
}

std::string shown_id(std::string_view id) { return "job " + std::string(id.substr(0, 80)); }

int64_t next_seq(sqlite3* db, const fs::path& file) {
  Stmt s(db, file, "SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs");
  s.step();
  return s.i64(0);
}

std::string unused_id(sqlite3* db, const fs::path& file) {
  // 128 random bits do not collide in practice; the primary key would catch it if they did, so try again.
  for (int attempt = 0;; ++attempt) {
    std::string id = new_job_id();
    if (!get_locked(db, file, id)) return id;
    if (attempt == 8) throw StoreError(StoreErrc::io, "cannot draw an unused job id; the random source is broken");
  }
}

}  // namespace

void check_new_job(const NewJob& job) {
  if (job.type.empty()) throw StoreError(StoreErrc::invalid_argument, "job type is empty; name the kind of bake");
  if (job.spec_key.empty())
    throw StoreError(StoreErrc::invalid_argument, "job spec_key is empty; it must identify the canonical spec");
  if (job.idempotency_key) {
    if (job.idempotency_key->empty())
      throw StoreError(StoreErrc::invalid_argument, "idempotency key is empty; leave it unset or give a value");
    if (job.idempotency_key->size() > kMaxIdempotencyKey)
      throw StoreError(StoreErrc::invalid_argument,
                       "idempotency key is " + std::to_string(job.idempotency_key->size()) + " bytes long; at most " +
                           std::to_string(kMaxIdempotencyKey) + " are allowed");
  }
  check_digests(job.input_digests, "input_digests");
  if (job.cached) check_digests(job.cached->output_digests, "cached.output_digests");
}

InsertOutcome JobDb::insert(const NewJob& job) {
  check_new_job(job);
  std::lock_guard lock(mu_);
  sqlite3* db = impl_->db;
  Transaction t(db, file_);
  if (job.idempotency_key) {
    if (auto existing = find_by_key_locked(db, file_, *job.idempotency_key)) {
      if (existing->spec_key != job.spec_key)
        throw StoreError(StoreErrc::already_exists, "idempotency key '" + *job.idempotency_key +
                                                        "' was already used for job " + existing->id +
                                                        " with a different spec; use a new key for a different job");
      return {std::move(*existing), false};
    }
  }
  const int64_t seq = next_seq(db, file_);
  double now = unix_now();
  const std::string id = unused_id(db, file_);
  Stmt s(db, file_,
         "INSERT INTO jobs (id, seq, name, type, spec, spec_key, priority, state, submitted, started, finished, "
         "result, idempotency_key, input_digests, output_digests, last_used, cache_source) "
         "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?10, ?11, ?12, ?13, ?14, ?9, ?15)");
  s.bind(1, id).bind(2, seq).bind(3, job.name).bind(4, job.type).bind_blob(5, job.spec).bind(6, job.spec_key);
  s.bind(7, int64_t{job.priority}).bind(9, now).bind_opt(12, job.idempotency_key);
  s.bind(13, join_digests(job.input_digests));
  if (job.cached) {
    s.bind(8, to_string(JobState::succeeded)).bind(10, now).bind_blob(11, job.cached->result);
    s.bind(14, join_digests(job.cached->output_digests)).bind(15, job.cached->source_job_id);
  } else {
    s.bind(8, to_string(JobState::queued)).bind_null(10).bind_null(11).bind(14, std::string_view()).bind_null(15);
  }
  s.run();
  if (job.cached) {
    // The source's result was just used: keep it (and its blobs) from looking stale to eviction.
    Stmt u(db, file_, "UPDATE jobs SET last_used = ?2 WHERE id = ?1");
    u.bind(1, job.cached->source_job_id).bind(2, now).run();
  }
  auto rec = get_locked(db, file_, id);
  t.commit();
  crash_point("job.inserted");
  return {std::move(*rec), true};
}

std::optional<JobRecord> JobDb::get(std::string_view id) {
  std::lock_guard lock(mu_);
  return get_locked(impl_->db, file_, id);
}

std::optional<JobRecord> JobDb::find_by_idempotency_key(std::string_view key) {
  std::lock_guard lock(mu_);
  return find_by_key_locked(impl_->db, file_, key);
}

std::optional<JobRecord> JobDb::find_succeeded_by_spec_key(std::string_view spec_key) {
  std::lock_guard lock(mu_);
  Stmt s(impl_->db, file_,
         (std::string("SELECT ") + kColumns +
          " FROM jobs WHERE spec_key = ? AND state = 'succeeded' AND evicted IS NULL ORDER BY finished DESC, seq DESC "
          "LIMIT 1")
             .c_str());
  s.bind(1, spec_key);
  if (!s.step()) return std::nullopt;
  return row_to_record(s, file_);
}

namespace {

// The one place state changes are checked, so every illegal change is refused with the same kind of message.
template <class Update>
JobRecord transition(sqlite3* db, const fs::path& file, std::string_view id, std::initializer_list<JobState> from,
                     JobState to, Update&& update) {
  Transaction t(db, file);
  auto rec = get_locked(db, file, id);
  if (!rec) throw StoreError(StoreErrc::not_found, "no " + shown_id(id) + " in the job database");
  if (std::find(from.begin(), from.end(), rec->state) == from.end()) {
    std::string allowed;
    for (JobState s : from) allowed += (allowed.empty() ? "" : " or ") + std::string(to_string(s));
    throw StoreError(StoreErrc::failed_precondition, "cannot mark " + shown_id(id) + " " + std::string(to_string(to)) +
                                                         ": it is " + std::string(to_string(rec->state)) + ", not " +
                                                         allowed);
  }
  update();
  rec = get_locked(db, file, id);
  t.commit();
  return std::move(*rec);
}

}  // namespace

JobRecord JobDb::mark_running(std::string_view id) {
  std::lock_guard lock(mu_);
  JobRecord rec = transition(impl_->db, file_, id, {JobState::queued}, JobState::running, [&] {
    Stmt s(impl_->db, file_, "UPDATE jobs SET state = 'running', started = ?2, attempts = attempts + 1 WHERE id = ?1");
    s.bind(1, id).bind(2, unix_now()).run();
  });
  crash_point("job.running");
  return rec;
}

JobRecord JobDb::mark_succeeded(std::string_view id, std::string_view result,
                                const std::vector<std::string>& output_digests) {
  check_digests(output_digests, "output_digests");
  std::lock_guard lock(mu_);
  JobRecord rec = transition(impl_->db, file_, id, {JobState::running}, JobState::succeeded, [&] {
    Stmt s(impl_->db, file_,
           "UPDATE jobs SET state = 'succeeded', finished = ?2, last_used = ?2, result = ?3, output_digests = ?4, "
           "error = '' WHERE id = ?1");
    s.bind(1, id).bind(2, unix_now()).bind_blob(3, result).bind(4, join_digests(output_digests)).run();
  });
  crash_point("job.succeeded");
  return rec;
}

JobRecord JobDb::mark_failed(std::string_view id, std::string_view error) {
  std::lock_guard lock(mu_);
  return transition(impl_->db, file_, id, {JobState::queued, JobState::running}, JobState::failed, [&] {
    Stmt s(impl_->db, file_, "UPDATE jobs SET state = 'failed', finished = ?2, error = ?3 WHERE id = ?1");
    s.bind(1, id).bind(2, unix_now()).bind(3, error).run();
  });
}

JobRecord JobDb::mark_cancelled(std::string_view id) {
  std::lock_guard lock(mu_);
  return transition(impl_->db, file_, id, {JobState::queued, JobState::running}, JobState::cancelled, [&] {
    Stmt s(impl_->db, file_, "UPDATE jobs SET state = 'cancelled', finished = ?2 WHERE id = ?1");
    s.bind(1, id).bind(2, unix_now()).run();
  });
}

JobRecord JobDb::mark_queued(std::string_view id) {
  std::lock_guard lock(mu_);
  return transition(impl_->db, file_, id, {JobState::running}, JobState::queued, [&] {
    // Handed back by a graceful shutdown: that run was not a crash, so it does not count against the job.
    Stmt s(impl_->db, file_,
           "UPDATE jobs SET state = 'queued', started = NULL, attempts = MAX(attempts - 1, 0) WHERE id = ?1");
    s.bind(1, id).run();
  });
}

std::vector<JobRecord> JobDb::list(size_t limit, std::optional<JobState> state, std::optional<int64_t> before_seq) {
  std::lock_guard lock(mu_);
  std::string sql = std::string("SELECT ") + kColumnsNoPayload + " FROM jobs WHERE (?1 IS NULL OR state = ?1) " +
                    "AND (?2 IS NULL OR seq < ?2) ORDER BY seq DESC LIMIT ?3";
  Stmt s(impl_->db, file_, sql.c_str());
  if (state)
    s.bind(1, to_string(*state));
  else
    s.bind_null(1);
  s.bind_opt(2, before_seq);
  s.bind(3, static_cast<int64_t>(std::min<size_t>(limit, INT64_MAX)));
  std::vector<JobRecord> out;
  while (s.step()) out.push_back(row_to_record(s, file_));
  return out;
}

Recovery JobDb::recover_unfinished() {
  std::lock_guard lock(mu_);
  sqlite3* db = impl_->db;
  Recovery out;
  Transaction t(db, file_);
  std::vector<JobRecord> running;
  {
    Stmt s(db, file_, (std::string("SELECT ") + kColumns + " FROM jobs WHERE state = 'running'").c_str());
    while (s.step()) running.push_back(row_to_record(s, file_));
  }
  double now = unix_now();
  for (const auto& r : running) {
    if (options_.max_crash_restarts > 0 && r.attempts >= options_.max_crash_restarts) {
      std::string why = "kilnd stopped while this job was running, " + std::to_string(r.attempts) +
                        " times in a row, reaching the crash-loop limit (max_crash_restarts = " +
                        std::to_string(options_.max_crash_restarts) +
                        ", set in kilnd.conf or with --max-crash-restarts; 0 means no limit); it was not started "
                        "again, in case it is what stops the daemon. Check kilnd's log for the cause, then resubmit it";
      Stmt s(db, file_, "UPDATE jobs SET state = 'failed', finished = ?2, error = ?3 WHERE id = ?1");
      s.bind(1, r.id).bind(2, now).bind(3, why).run();
    } else {
      Stmt s(db, file_, "UPDATE jobs SET state = 'queued', started = NULL WHERE id = ?1");
      s.bind(1, r.id).run();
    }
  }
  {
    Stmt s(db, file_,
           (std::string("SELECT ") + kColumns + " FROM jobs WHERE state = 'queued' ORDER BY priority DESC, seq ASC")
               .c_str());
    while (s.step()) out.queued.push_back(row_to_record(s, file_));
  }
  for (const auto& r : running)
    if (auto rec = get_locked(db, file_, r.id); rec && rec->state == JobState::failed)
      out.gave_up.push_back(std::move(*rec));
  t.commit();
  return out;
}

JobCounts JobDb::counts() {
  std::lock_guard lock(mu_);
  JobCounts c;
  Stmt s(impl_->db, file_, "SELECT state, COUNT(*), COUNT(cache_source) FROM jobs GROUP BY state");
  while (s.step()) {
    auto st = parse_job_state(s.str(0));
    uint64_t n = static_cast<uint64_t>(s.i64(1));
    if (!st) continue;
    switch (*st) {
      case JobState::queued:
        c.queued = n;
        break;
      case JobState::running:
        c.running = n;
        break;
      case JobState::succeeded:
        c.succeeded = n;
        c.cache_hits = static_cast<uint64_t>(s.i64(2));
        break;
      case JobState::failed:
        c.failed = n;
        break;
      case JobState::cancelled:
        c.cancelled = n;
        break;
    }
  }
  return c;
}

bool JobDb::touch(std::string_view id, std::optional<double> when) {
  std::lock_guard lock(mu_);
  Stmt s(impl_->db, file_, "UPDATE jobs SET last_used = ?2 WHERE id = ?1");
  s.bind(1, id).bind(2, when.value_or(unix_now())).run();
  return sqlite::changes(impl_->db) > 0;
}

std::vector<JobRecord> JobDb::results_by_last_used(size_t limit) {
  std::lock_guard lock(mu_);
  Stmt s(impl_->db, file_,
         (std::string("SELECT ") + kColumnsNoPayload +
          " FROM jobs WHERE state = 'succeeded' AND evicted IS NULL ORDER BY last_used ASC, seq ASC LIMIT ?1")
             .c_str());
  s.bind(1, static_cast<int64_t>(std::min<size_t>(limit, INT64_MAX)));
  std::vector<JobRecord> out;
  while (s.step()) out.push_back(row_to_record(s, file_));
  return out;
}

std::unordered_set<std::string> JobDb::pinned_digests() {
  std::lock_guard lock(mu_);
  std::unordered_set<std::string> out;
  Stmt s(impl_->db, file_, "SELECT input_digests FROM jobs WHERE state IN ('queued', 'running')");
  while (s.step())
    for (auto& d : split_digests(s.str(0))) out.insert(std::move(d));
  return out;
}

std::unordered_map<std::string, double> JobDb::blob_last_used() {
  std::lock_guard lock(mu_);
  std::unordered_map<std::string, double> out;
  Stmt s(impl_->db, file_, "SELECT input_digests, output_digests, last_used FROM jobs");
  while (s.step()) {
    double t = s.dbl(2);
    for (int c : {0, 1})
      for (auto& d : split_digests(s.str(c))) {
        auto [it, inserted] = out.emplace(std::move(d), t);
        if (!inserted) it->second = std::max(it->second, t);
      }
  }
  return out;
}

size_t JobDb::mark_results_evicted(const std::unordered_set<std::string>& removed_digests) {
  if (removed_digests.empty()) return 0;
  std::lock_guard lock(mu_);
  sqlite3* db = impl_->db;
  Transaction t(db, file_);
  std::vector<std::string> hit;
  {
    Stmt s(db, file_, "SELECT id, output_digests FROM jobs WHERE state = 'succeeded' AND evicted IS NULL");
    while (s.step())
      for (const auto& d : split_digests(s.str(1)))
        if (removed_digests.count(d)) {
          hit.push_back(s.str(0));
          break;
        }
  }
  double now = unix_now();
  for (const auto& id : hit) {
    Stmt u(db, file_, "UPDATE jobs SET evicted = ?2 WHERE id = ?1");
    u.bind(1, id).bind(2, now).run();
  }
  t.commit();
  return hit.size();
}

}  // namespace kiln::store
