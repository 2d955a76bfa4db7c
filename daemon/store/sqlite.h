// A minimal RAII layer over the SQLite C API for the job database: prepared statements, plain statements and
// transactions, every failure a StoreError naming the database file, what was being done and what to do about it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "daemon/store/blob_store.h"

struct sqlite3;
struct sqlite3_stmt;

namespace kiln::store::sqlite {

// Opens or creates the database file for reading and writing, with extended result codes and a 5 s busy timeout.
// The connection is the caller's to close; it serializes nothing itself (the caller guards it with a mutex).
sqlite3* open(const std::filesystem::path& file);
void close(sqlite3* db);
// Rows changed by the last statement.
int changes(sqlite3* db);
// True if the connection cannot write the main database (SQLite opens a file it may not write read-only, silently).
bool read_only(sqlite3* db);

// Throws the StoreError for SQLite result code `rc` (extended codes included) of `doing` on `file`.
[[noreturn]] void throw_error(sqlite3* db, int rc, const std::filesystem::path& file, const std::string& doing);

// Runs SQL that returns no rows.
void exec(sqlite3* db, const std::filesystem::path& file, const char* sql, const char* doing);

// A prepared statement: bind parameters (1-based), step through the rows, read columns (0-based).
class Stmt {
 public:
  Stmt(sqlite3* db, const std::filesystem::path& file, const char* sql);
  ~Stmt();
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  Stmt& bind(int i, std::string_view v);
  Stmt& bind_blob(int i, std::string_view v);
  Stmt& bind(int i, int64_t v);
  Stmt& bind(int i, double v);
  Stmt& bind_null(int i);
  template <class T>
  Stmt& bind_opt(int i, const std::optional<T>& v) {
    return v ? bind(i, *v) : bind_null(i);
  }

  // True while there is a row.
  bool step();
  void run();

  bool is_null(int c) const;
  int64_t i64(int c) const;
  double dbl(int c) const;
  std::string str(int c) const;
  std::optional<std::string> opt_str(int c) const { return is_null(c) ? std::nullopt : std::optional(str(c)); }
  std::optional<double> opt_dbl(int c) const { return is_null(c) ? std::nullopt : std::optional(dbl(c)); }

 private:
  void check(int rc);
  sqlite3* db_;
  const std::filesystem::path& file_;
  sqlite3_stmt* st_ = nullptr;
};

// BEGIN IMMEDIATE … COMMIT, rolled back if anything throws in between.
class Transaction {
 public:
  Transaction(sqlite3* db, const std::filesystem::path& file);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit();

 private:
  sqlite3* db_;
  const std::filesystem::path& file_;
  bool done_ = false;
};

}  // namespace kiln::store::sqlite
