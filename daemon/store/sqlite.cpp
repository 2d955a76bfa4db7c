#include "daemon/store/sqlite.h"

#include <sqlite3.h>

namespace fs = std::filesystem;

namespace kiln::store::sqlite {
namespace {

StoreErrc errc_for(int rc) {
  if (rc == SQLITE_CONSTRAINT_UNIQUE || rc == SQLITE_CONSTRAINT_PRIMARYKEY) return StoreErrc::already_exists;
  switch (rc & 0xff) {
    case SQLITE_FULL:
      return StoreErrc::resource_exhausted;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return StoreErrc::data_loss;
    case SQLITE_CONSTRAINT:
      return StoreErrc::invalid_argument;
    default:
      return StoreErrc::io;
  }
}

}  // namespace

void throw_error(sqlite3* db, int rc, const fs::path& file, const std::string& doing) {
  std::string msg =
      "job database " + file.string() + ": " + doing + " failed: " + (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
  switch (rc & 0xff) {
    case SQLITE_FULL:
      msg += kDiskFullAdvice;
      break;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      msg +=
          "; the file is damaged or is not a kiln job database. Move it aside (kilnd will create a new one) "
          "or point --store at another directory";
      break;
    case SQLITE_READONLY:
    case SQLITE_CANTOPEN:
    case SQLITE_PERM:
      msg += "; check the permissions of the store directory";
      break;
    default:
      break;
  }
  throw StoreError(errc_for(rc), msg);
}

sqlite3* open(const fs::path& file) {
  sqlite3* db = nullptr;
  const int rc =
      sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    // SQLite allocates a handle even when opening fails; it holds the message, so it is closed after the throw.
    struct Closer {
      sqlite3* db;
      ~Closer() { sqlite3_close_v2(db); }
    } closer{db};
    throw_error(db, rc, file, "opening");
  }
  sqlite3_extended_result_codes(db, 1);
  sqlite3_busy_timeout(db, 5000);
  return db;
}

void close(sqlite3* db) { sqlite3_close_v2(db); }

int changes(sqlite3* db) { return sqlite3_changes(db); }

bool read_only(sqlite3* db) { return sqlite3_db_readonly(db, "main") != 0; }

void exec(sqlite3* db, const fs::path& file, const char* sql, const char* doing) {
  char* err = nullptr;
  int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    sqlite3_free(err);
    throw_error(db, rc, file, doing);
  }
}

Stmt::Stmt(sqlite3* db, const fs::path& file, const char* sql) : db_(db), file_(file) {
  int rc = sqlite3_prepare_v2(db, sql, -1, &st_, nullptr);
  if (rc != SQLITE_OK) throw_error(db, rc, file, "preparing a query");
}

Stmt::~Stmt() { sqlite3_finalize(st_); }

Stmt& Stmt::bind(int i, std::string_view v) {
  // A null pointer would bind NULL; an empty string is a value.
  check(sqlite3_bind_text(st_, i, v.empty() ? "" : v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  return *this;
}

Stmt& Stmt::bind_blob(int i, std::string_view v) {
  // A zero-length blob must still be a blob, not NULL: an empty spec or result is a value.
  check(sqlite3_bind_blob(st_, i, v.empty() ? "" : v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  return *this;
}

Stmt& Stmt::bind(int i, int64_t v) {
  check(sqlite3_bind_int64(st_, i, v));
  return *this;
}

Stmt& Stmt::bind(int i, double v) {
  check(sqlite3_bind_double(st_, i, v));
  return *this;
}

Stmt& Stmt::bind_null(int i) {
  check(sqlite3_bind_null(st_, i));
  return *this;
}

bool Stmt::step() {
  int rc = sqlite3_step(st_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throw_error(db_, rc, file_, "a query");
}

void Stmt::run() {
  while (step()) {
  }
}

bool Stmt::is_null(int c) const { return sqlite3_column_type(st_, c) == SQLITE_NULL; }
int64_t Stmt::i64(int c) const { return sqlite3_column_int64(st_, c); }
double Stmt::dbl(int c) const { return sqlite3_column_double(st_, c); }

std::string Stmt::str(int c) const {
  const void* p = sqlite3_column_blob(st_, c);
  int n = sqlite3_column_bytes(st_, c);
  return p ? std::string(static_cast<const char*>(p), static_cast<size_t>(n)) : std::string();
}

void Stmt::check(int rc) {
  if (rc != SQLITE_OK) throw_error(db_, rc, file_, "binding a query parameter");
}

Transaction::Transaction(sqlite3* db, const fs::path& file) : db_(db), file_(file) {
  exec(db, file, "BEGIN IMMEDIATE", "starting a transaction");
}

Transaction::~Transaction() {
  if (!done_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
}

void Transaction::commit() {
  exec(db_, file_, "COMMIT", "committing a transaction");
  done_ = true;
}

}  // namespace kiln::store::sqlite
