// A small synchronous Redis client for kilnd's farm mode (docs/SCALING.md): one connection, replies copied into
// plain C++ values, reconnection at the next command after the connection was lost, and errors that name the server
// and say what to do. hiredis stays inside redis_client.cpp.
//
// Not thread-safe: one client per thread (a worker, the subscriber), as hiredis's synchronous context requires.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace kiln::cluster {

// Where the farm's Redis is: redis://HOST:PORT[/DB] (PORT defaults to 6379) or unix:PATH[?db=DB].
struct RedisAddress {
  std::string host;  // empty for a Unix socket
  int port = 6379;
  std::string unix_path;  // empty for TCP
  int db = 0;             // the database SELECTed after connecting
  // The address as a URL, for messages: "redis://127.0.0.1:6379/0" or "unix:/run/redis/redis.sock?db=2".
  std::string describe() const;
};

// Parses a farm URL. Throws std::invalid_argument naming the URL and its problem.
RedisAddress parse_redis_url(std::string_view url);

struct RedisOptions {
  RedisAddress address;
  std::string password;  // empty: no AUTH
  std::chrono::milliseconds connect_timeout{2000};
  // How long one command may wait for its reply before the connection counts as lost.
  std::chrono::milliseconds command_timeout{5000};
};

enum class RedisErrc {
  unavailable,  // cannot connect, the connection broke (the command may or may not have run), or the server cannot
                // answer yet (LOADING after a restart, BUSY with a script): try again later
  refused,      // the server answered with an error (a wrong password, a script error, a wrong type)
  protocol,     // a reply of a shape the caller did not expect
};

class RedisError : public std::runtime_error {
 public:
  RedisError(RedisErrc code, const std::string& message) : std::runtime_error(message), code_(code) {}
  RedisErrc code() const { return code_; }

 private:
  RedisErrc code_;
};

// One reply, owned: hiredis's reply tree is copied into this and freed at once.
struct RedisReply {
  enum class Type { nil, status, error, integer, string, array };
  Type type = Type::nil;
  std::string str;  // status, error and string replies
  long long integer = 0;
  std::vector<RedisReply> elements;

  bool is_nil() const { return type == Type::nil; }
  // The checked accessors throw RedisError(protocol) naming the expected and the actual type.
  const std::string& as_string() const;  // a string or a status
  long long as_integer() const;
  const std::vector<RedisReply>& as_array() const;
};

std::string_view to_string(RedisReply::Type type);

class RedisClient {
 public:
  // Connects (and authenticates, and selects the database). Throws RedisError: unavailable when the server cannot be
  // reached, refused when it turns the password down.
  explicit RedisClient(RedisOptions options);
  ~RedisClient();
  RedisClient(RedisClient&&) noexcept;
  RedisClient& operator=(RedisClient&&) noexcept;
  RedisClient(const RedisClient&) = delete;
  RedisClient& operator=(const RedisClient&) = delete;

  // Runs one command (binary-safe arguments) and returns its reply. An error reply throws RedisError(refused) with
  // the server's message and the command's name. After a lost connection, the next command connects again first.
  RedisReply command(const std::vector<std::string>& args);
  // A read-only command (GET, HGETALL, ZRANGE…): as command(), but when the connection turns out to be lost (Redis
  // restarted while this client was idle) it is sent once more on a new connection, since running a read twice
  // changes nothing.
  RedisReply read(const std::vector<std::string>& args);
  // Sends several commands in one round trip and returns their replies in order; error replies are returned (type
  // error), not thrown, since the other commands ran.
  std::vector<RedisReply> pipeline(const std::vector<std::vector<std::string>>& commands);
  // Runs a Lua script by its digest (EVALSHA), loading it on first use and again after the server lost it (a Redis
  // restart empties the script cache).
  RedisReply eval(const std::string& script, const std::vector<std::string>& keys,
                  const std::vector<std::string>& args);

  // Pub/sub: send() writes a command without waiting for its reply (SUBSCRIBE, UNSUBSCRIBE), receive() waits up to
  // `timeout` for the next reply or pushed message and returns nothing if none came.
  void send(const std::vector<std::string>& args);
  std::optional<RedisReply> receive(std::chrono::milliseconds timeout);

  bool connected() const;
  const RedisAddress& address() const { return options_.address; }
  // Commands and pipelines sent since the client was made, one per round trip (the farm benchmark's figure).
  uint64_t round_trips() const { return round_trips_; }

 private:
  struct Connection;  // hiredis's context, in redis_client.cpp
  void ensure_connected();
  void connect();
  // Drops the connection after an I/O error and throws unavailable, saying what was being done.
  [[noreturn]] void lost(const std::string& doing);
  RedisReply read_reply(const std::string& doing);
  void write_pending(const std::string& doing);

  RedisOptions options_;
  std::unique_ptr<Connection> connection_;
  std::unordered_map<std::string, std::string> scripts_;  // script → its SHA1, as SCRIPT LOAD named it
  uint64_t round_trips_ = 0;
};

}  // namespace kiln::cluster
