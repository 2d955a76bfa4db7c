#include "daemon/cluster/redis_client.h"

#include <hiredis/hiredis.h>
#include <poll.h>

#include <cerrno>
#include <charconv>

namespace kiln::cluster {

namespace {

constexpr size_t kMaxUrlBytes = 1024;
constexpr int kMaxDb = 65535;

[[noreturn]] void bad_url(std::string_view url, const std::string& problem) {
  throw std::invalid_argument("farm URL '" + std::string(url.substr(0, 200)) + "': " + problem +
                              "; expected redis://HOST:PORT[/DB] or unix:PATH[?db=DB]");
}

int parse_whole(std::string_view url, std::string_view text, int lo, int hi, const char* what) {
  int value = -1;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || value < lo || value > hi) {
    bad_url(url, std::string(what) + " must be a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                     "], got '" + std::string(text.substr(0, 20)) + "'");
  }
  return value;
}

RedisAddress parse_unix(std::string_view url, std::string_view rest) {
  RedisAddress a;
  const size_t query = rest.find('?');
  a.unix_path = std::string(rest.substr(0, query));
  if (a.unix_path.empty()) bad_url(url, "the socket's path is empty");
  if (query != std::string_view::npos) {
    const std::string_view q = rest.substr(query + 1);
    if (q.rfind("db=", 0) != 0) bad_url(url, "the only query a socket takes is db=N");
    a.db = parse_whole(url, q.substr(3), 0, kMaxDb, "the database");
  }
  return a;
}

RedisAddress parse_tcp(std::string_view url, std::string_view rest) {
  RedisAddress a;
  if (rest.find('@') != std::string_view::npos) {
    bad_url(url, "a password in the URL would show in logs and process lists: put it in cluster_password_file");
  }
  const size_t slash = rest.find('/');
  std::string_view hostport = rest.substr(0, slash);
  if (slash != std::string_view::npos) a.db = parse_whole(url, rest.substr(slash + 1), 0, kMaxDb, "the database");
  size_t colon = hostport.rfind(':');
  if (!hostport.empty() && hostport.front() == '[') {  // an IPv6 literal, [::1]:6379
    const size_t close = hostport.find(']');
    if (close == std::string_view::npos) bad_url(url, "an IPv6 address needs its closing ']'");
    a.host = std::string(hostport.substr(1, close - 1));
    colon = close + 1 < hostport.size() && hostport[close + 1] == ':' ? close + 1 : std::string_view::npos;
  } else {
    a.host = std::string(hostport.substr(0, colon));
  }
  if (a.host.empty()) bad_url(url, "the host is empty");
  if (colon != std::string_view::npos) a.port = parse_whole(url, hostport.substr(colon + 1), 1, 65535, "the port");
  return a;
}

// The command's name for messages (its first argument, bounded: it could be anything a caller passed).
std::string name_of(const std::vector<std::string>& args) {
  return args.empty() ? std::string("(empty command)") : args.front().substr(0, 32);
}

// Error replies that say the server cannot answer yet, rather than that the command is wrong: loading its data after
// a restart, a script still running, a replica that lost its master, a cluster slot moving. The caller treats them as
// an unreachable server (and tries again later), not as a refusal.
bool transient_error(const std::string& error) {
  for (const char* prefix : {"LOADING", "BUSY", "MASTERDOWN", "TRYAGAIN"}) {
    if (error.rfind(prefix, 0) == 0) return true;
  }
  return false;
}

RedisReply copy_reply(const redisReply& r) {
  RedisReply out;
  switch (r.type) {
    case REDIS_REPLY_STATUS:
      out.type = RedisReply::Type::status;
      out.str.assign(r.str, r.len);
      break;
    case REDIS_REPLY_ERROR:
      out.type = RedisReply::Type::error;
      out.str.assign(r.str, r.len);
      break;
    case REDIS_REPLY_STRING:
      out.type = RedisReply::Type::string;
      out.str.assign(r.str, r.len);
      break;
    case REDIS_REPLY_INTEGER:
      out.type = RedisReply::Type::integer;
      out.integer = r.integer;
      break;
    case REDIS_REPLY_ARRAY:
      out.type = RedisReply::Type::array;
      out.elements.reserve(r.elements);
      for (size_t i = 0; i < r.elements; ++i) out.elements.push_back(copy_reply(*r.element[i]));
      break;
    default:
      out.type = RedisReply::Type::nil;
  }
  return out;
}

// Takes ownership of a reply hiredis allocated, copies it out and frees it.
RedisReply adopt(void* raw) {
  std::unique_ptr<redisReply, decltype(&freeReplyObject)> owned(static_cast<redisReply*>(raw), freeReplyObject);
  return copy_reply(*owned);
}

timeval to_timeval(std::chrono::milliseconds ms) {
  return timeval{static_cast<time_t>(ms.count() / 1000), static_cast<suseconds_t>((ms.count() % 1000) * 1000)};
}

}  // namespace

std::string RedisAddress::describe() const {
  if (!unix_path.empty()) return "unix:" + unix_path + (db != 0 ? "?db=" + std::to_string(db) : "");
  const bool v6 = host.find(':') != std::string::npos;
  return "redis://" + (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port) + "/" + std::to_string(db);
}

RedisAddress parse_redis_url(std::string_view url) {
  if (url.size() > kMaxUrlBytes) bad_url(url, "longer than 1024 bytes");
  if (url.rfind("unix:", 0) == 0) return parse_unix(url, url.substr(5));
  if (url.rfind("redis://", 0) == 0) return parse_tcp(url, url.substr(8));
  if (url.rfind("rediss://", 0) == 0) {
    bad_url(url, "Debian 12's hiredis has no TLS: reach Redis through a TLS tunnel on loopback (docs/SCALING.md)");
  }
  bad_url(url, "unknown scheme");
}

std::string_view to_string(RedisReply::Type type) {
  switch (type) {
    case RedisReply::Type::nil:
      return "nil";
    case RedisReply::Type::status:
      return "status";
    case RedisReply::Type::error:
      return "error";
    case RedisReply::Type::integer:
      return "integer";
    case RedisReply::Type::string:
      return "string";
    case RedisReply::Type::array:
      return "array";
  }
  return "unknown";
}

namespace {
[[noreturn]] void wrong_type(const char* expected, const RedisReply& r) {
  throw RedisError(RedisErrc::protocol, std::string("expected a Redis ") + expected + " reply, got " +
                                            std::string(to_string(r.type)) +
                                            (r.type == RedisReply::Type::error ? " (" + r.str + ")" : ""));
}
}  // namespace

const std::string& RedisReply::as_string() const {
  if (type != Type::string && type != Type::status) wrong_type("string", *this);
  return str;
}

long long RedisReply::as_integer() const {
  if (type != Type::integer) wrong_type("integer", *this);
  return integer;
}

const std::vector<RedisReply>& RedisReply::as_array() const {
  if (type != Type::array) wrong_type("array", *this);
  return elements;
}

struct RedisClient::Connection {
  std::unique_ptr<redisContext, decltype(&redisFree)> context{nullptr, redisFree};
};

RedisClient::RedisClient(RedisOptions options) : options_(std::move(options)) { connect(); }
RedisClient::~RedisClient() = default;
RedisClient::RedisClient(RedisClient&&) noexcept = default;
RedisClient& RedisClient::operator=(RedisClient&&) noexcept = default;

bool RedisClient::connected() const { return connection_ != nullptr; }

void RedisClient::ensure_connected() {
  if (!connection_) connect();
}

void RedisClient::connect() {
  const RedisAddress& a = options_.address;
  const timeval tv = to_timeval(options_.connect_timeout);
  redisContext* c = a.unix_path.empty() ? redisConnectWithTimeout(a.host.c_str(), a.port, tv)
                                        : redisConnectUnixWithTimeout(a.unix_path.c_str(), tv);
  auto conn = std::make_unique<Connection>();
  conn->context.reset(c);
  if (c == nullptr || c->err) {
    const std::string why = c ? c->errstr : "out of memory";
    throw RedisError(RedisErrc::unavailable, "cannot connect to Redis at " + a.describe() + " (" + why +
                                                 "): check that redis-server runs there and the farm URL "
                                                 "(--cluster) names it");
  }
  redisSetTimeout(c, to_timeval(options_.command_timeout));
  connection_ = std::move(conn);
  // Each script is loaded again on demand: the server may be a new one.
  scripts_.clear();
  if (!options_.password.empty()) {
    const RedisReply r = pipeline({{"AUTH", options_.password}}).front();
    if (r.type == RedisReply::Type::error) {
      connection_.reset();
      throw RedisError(RedisErrc::refused, "Redis at " + a.describe() + " refused the password (" + r.str +
                                               "): check the file cluster_password_file names");
    }
  }
  if (a.db != 0) {
    const RedisReply r = pipeline({{"SELECT", std::to_string(a.db)}}).front();
    if (r.type == RedisReply::Type::error) {
      connection_.reset();
      throw RedisError(RedisErrc::refused, "Redis at " + a.describe() + " cannot select database " +
                                               std::to_string(a.db) + " (" + r.str +
                                               "): use a database below its 'databases' setting");
    }
  }
}

void RedisClient::lost(const std::string& doing) {
  const std::string why = connection_ && connection_->context->err ? connection_->context->errstr : "no reply";
  connection_.reset();
  throw RedisError(RedisErrc::unavailable, "lost the connection to Redis at " + options_.address.describe() +
                                               " while " + doing + " (" + why +
                                               "); it may or may not have run; the next command connects again");
}

void RedisClient::write_pending(const std::string& doing) {
  int done = 0;
  while (!done) {
    if (redisBufferWrite(connection_->context.get(), &done) != REDIS_OK) lost(doing);
  }
}

RedisReply RedisClient::read_reply(const std::string& doing) {
  void* raw = nullptr;
  if (redisGetReply(connection_->context.get(), &raw) != REDIS_OK || raw == nullptr) lost(doing);
  return adopt(raw);
}

std::vector<RedisReply> RedisClient::pipeline(const std::vector<std::vector<std::string>>& commands) {
  ensure_connected();
  const std::string doing = commands.size() == 1 ? "running " + name_of(commands.front())
                                                 : "running a pipeline of " + std::to_string(commands.size());
  for (const auto& args : commands) {
    std::vector<const char*> argv;
    std::vector<size_t> lens;
    for (const std::string& s : args) {
      argv.push_back(s.data());
      lens.push_back(s.size());
    }
    if (redisAppendCommandArgv(connection_->context.get(), static_cast<int>(argv.size()), argv.data(), lens.data()) !=
        REDIS_OK) {
      lost(doing);
    }
  }
  write_pending(doing);
  ++round_trips_;
  std::vector<RedisReply> replies;
  replies.reserve(commands.size());
  for (size_t i = 0; i < commands.size(); ++i) replies.push_back(read_reply(doing));
  return replies;
}

RedisReply RedisClient::command(const std::vector<std::string>& args) {
  RedisReply r = std::move(pipeline({args}).front());
  if (r.type != RedisReply::Type::error) return r;
  if (transient_error(r.str)) {
    throw RedisError(RedisErrc::unavailable, "Redis at " + options_.address.describe() + " cannot run " +
                                                 name_of(args) + " yet: " + r.str);
  }
  // A server that wants a password we were not given says NOAUTH: say where to put it.
  const bool noauth = r.str.rfind("NOAUTH", 0) == 0;
  throw RedisError(RedisErrc::refused, "Redis at " + options_.address.describe() + " refused " + name_of(args) + ": " +
                                           r.str +
                                           (noauth ? " (give kilnd the password in cluster_password_file)" : ""));
}

RedisReply RedisClient::read(const std::vector<std::string>& args) {
  try {
    return command(args);
  } catch (const RedisError& e) {
    // Only a dropped connection is worth an immediate retry; LOADING or BUSY would answer the same again.
    if (e.code() != RedisErrc::unavailable || connected()) throw;
  }
  return command(args);
}

RedisReply RedisClient::eval(const std::string& script, const std::vector<std::string>& keys,
                             const std::vector<std::string>& args) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    ensure_connected();
    auto found = scripts_.find(script);
    if (found == scripts_.end()) {
      found = scripts_.emplace(script, command({"SCRIPT", "LOAD", script}).as_string()).first;
    }
    std::vector<std::string> argv{"EVALSHA", found->second, std::to_string(keys.size())};
    argv.insert(argv.end(), keys.begin(), keys.end());
    argv.insert(argv.end(), args.begin(), args.end());
    RedisReply r = std::move(pipeline({argv}).front());
    if (r.type != RedisReply::Type::error) return r;
    // The server forgot the script (it restarted, or SCRIPT FLUSH): load it again, once.
    if (r.str.rfind("NOSCRIPT", 0) == 0) {
      scripts_.erase(found);
      continue;
    }
    if (transient_error(r.str)) {
      throw RedisError(RedisErrc::unavailable,
                       "Redis at " + options_.address.describe() + " cannot run a script yet: " + r.str);
    }
    throw RedisError(RedisErrc::refused, "Redis at " + options_.address.describe() + " failed a script: " + r.str);
  }
  throw RedisError(RedisErrc::refused,
                   "Redis at " + options_.address.describe() + " lost a script twice in a row while running it");
}

void RedisClient::send(const std::vector<std::string>& args) {
  ensure_connected();
  std::vector<const char*> argv;
  std::vector<size_t> lens;
  for (const std::string& s : args) {
    argv.push_back(s.data());
    lens.push_back(s.size());
  }
  const std::string doing = "sending " + name_of(args);
  if (redisAppendCommandArgv(connection_->context.get(), static_cast<int>(argv.size()), argv.data(), lens.data()) !=
      REDIS_OK) {
    lost(doing);
  }
  write_pending(doing);
  ++round_trips_;
}

std::optional<RedisReply> RedisClient::receive(std::chrono::milliseconds timeout) {
  if (!connection_) {
    throw RedisError(RedisErrc::unavailable, "not connected to Redis at " + options_.address.describe() +
                                                 ": send a command first (it connects)");
  }
  redisContext* c = connection_->context.get();
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    void* raw = nullptr;
    if (redisGetReplyFromReader(c, &raw) != REDIS_OK) lost("reading a message");
    if (raw != nullptr) return adopt(raw);
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    pollfd p{c->fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(left.count()));
    if (ready == 0) return std::nullopt;
    if (ready < 0) {
      if (errno == EINTR) continue;  // a signal, not a failure: poll again with the time left
      lost("waiting for a message");
    }
    if (redisBufferRead(c) != REDIS_OK) lost("reading a message");
  }
}

}  // namespace kiln::cluster
