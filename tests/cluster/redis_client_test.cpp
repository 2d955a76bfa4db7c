// The farm's Redis client against a real redis-server the test starts on a Unix socket (tests/cluster/redis_server.h).
#include "daemon/cluster/redis_client.h"

#include <gtest/gtest.h>

#include <memory>
#include <thread>

#include "tests/cluster/redis_server.h"
#include "tests/support/eventually.h"

namespace kiln::cluster {
namespace {

using test::eventually;
using test::RedisServer;

// Runs `f` and returns the RedisError it throws (failing the test if it throws none).
template <class F>
RedisError error_of(F&& f) {
  try {
    f();
  } catch (const RedisError& e) {
    return e;
  }
  ADD_FAILURE() << "expected a RedisError";
  return RedisError(RedisErrc::protocol, "none thrown");
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(RedisUrl, ParsesTcpAndUnixForms) {
  const RedisAddress plain = parse_redis_url("redis://farm-redis");
  EXPECT_EQ(plain.host, "farm-redis");
  EXPECT_EQ(plain.port, 6379);
  EXPECT_EQ(plain.db, 0);
  const RedisAddress full = parse_redis_url("redis://10.0.0.5:7000/3");
  EXPECT_EQ(full.host, "10.0.0.5");
  EXPECT_EQ(full.port, 7000);
  EXPECT_EQ(full.db, 3);
  EXPECT_EQ(full.describe(), "redis://10.0.0.5:7000/3");
  const RedisAddress v6 = parse_redis_url("redis://[::1]:6380");
  EXPECT_EQ(v6.host, "::1");
  EXPECT_EQ(v6.port, 6380);
  EXPECT_EQ(v6.describe(), "redis://[::1]:6380/0");
  const RedisAddress unix_socket = parse_redis_url("unix:/run/redis/redis.sock?db=2");
  EXPECT_EQ(unix_socket.unix_path, "/run/redis/redis.sock");
  EXPECT_TRUE(unix_socket.host.empty());
  EXPECT_EQ(unix_socket.db, 2);
  EXPECT_EQ(unix_socket.describe(), "unix:/run/redis/redis.sock?db=2");
}

TEST(RedisUrl, RefusesBadUrlsSayingWhy) {
  const std::pair<const char*, const char*> cases[] = {
      {"redis://", "the host is empty"},
      {"redis://host:0", "the port must be a whole number in [1, 65535], got '0'"},
      {"redis://host:70000", "the port"},
      {"redis://host:6379/x", "the database must be a whole number"},
      {"redis://host:6379/-1", "the database"},
      {"redis://user:secret@host", "cluster_password_file"},
      {"rediss://host", "no TLS"},
      {"http://host", "unknown scheme"},
      {"unix:", "the socket's path is empty"},
      {"unix:/tmp/r.sock?timeout=3", "db=N"},
      {"[::1", "unknown scheme"},
  };
  for (const auto& [url, problem] : cases) {
    try {
      parse_redis_url(url);
      ADD_FAILURE() << url << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_TRUE(contains(e.what(), problem)) << url << ": " << e.what();
      EXPECT_TRUE(contains(e.what(), "redis://HOST:PORT[/DB] or unix:PATH")) << e.what();
    }
  }
  EXPECT_THROW(parse_redis_url("redis://" + std::string(2000, 'h')), std::invalid_argument);
}

class RedisClientTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (RedisServer::binary().empty()) GTEST_SKIP() << RedisServer::kSkipMessage;
    server_ = std::make_unique<RedisServer>();
  }
  std::unique_ptr<RedisServer> server_;
};

TEST_F(RedisClientTest, CommandsCarryBinaryArgumentsAndEveryReplyType) {
  RedisClient c(server_->options());
  const std::string bytes("a\0b\r\nc", 6);  // NUL and CRLF: arguments must not be text
  EXPECT_EQ(c.command({"SET", "k", bytes}).as_string(), "OK");
  EXPECT_EQ(c.command({"GET", "k"}).as_string(), bytes);
  EXPECT_TRUE(c.command({"GET", "absent"}).is_nil());
  EXPECT_EQ(c.command({"INCRBY", "n", "41"}).as_integer(), 41);
  EXPECT_EQ(c.command({"INCR", "n"}).as_integer(), 42);
  c.command({"RPUSH", "l", "x", "y"});
  const RedisReply list = c.command({"LRANGE", "l", "0", "-1"});
  ASSERT_EQ(list.as_array().size(), 2u);
  EXPECT_EQ(list.as_array()[1].as_string(), "y");
  EXPECT_EQ(c.round_trips(), 7u);
}

TEST_F(RedisClientTest, ErrorRepliesThrowWithTheServersMessageAndTheCommand) {
  RedisClient c(server_->options());
  c.command({"SET", "text", "abc"});
  const RedisError e = error_of([&] { c.command({"INCR", "text"}); });
  EXPECT_EQ(e.code(), RedisErrc::refused);
  EXPECT_TRUE(contains(e.what(), "INCR")) << e.what();
  EXPECT_TRUE(contains(e.what(), "not an integer")) << e.what();
  EXPECT_TRUE(contains(e.what(), server_->url())) << e.what();
  // The connection stays usable after an error reply.
  EXPECT_EQ(c.command({"GET", "text"}).as_string(), "abc");
  const RedisError wrong = error_of([&] { c.command({"GET", "text"}).as_integer(); });
  EXPECT_EQ(wrong.code(), RedisErrc::protocol);
  EXPECT_TRUE(contains(wrong.what(), "expected a Redis integer reply, got string")) << wrong.what();
}

// A server that cannot answer yet (here BUSY: another client's script runs past the busy threshold; LOADING after a
// restart is the same kind of reply) is unavailable to the caller, who tries again, not a refusal of the command.
TEST_F(RedisClientTest, AServerThatCannotAnswerYetIsUnavailableNotARefusal) {
  RedisClient c(server_->options());
  c.command({"CONFIG", "SET", "busy-reply-threshold", "10"});
  std::thread busy([options = server_->options()] {
    RedisClient looping(options);
    try {
      looping.command({"EVAL", "while true do end", "0"});
    } catch (const RedisError&) {
      // SCRIPT KILL ends it with an error reply: expected.
    }
  });
  RedisError e(RedisErrc::protocol, "no reply yet");
  ASSERT_TRUE(eventually([&] {
    try {
      c.command({"GET", "k"});
      return false;  // the script has not started yet
    } catch (const RedisError& error) {
      e = error;
      return true;
    }
  }));
  EXPECT_EQ(e.code(), RedisErrc::unavailable) << e.what();
  EXPECT_TRUE(contains(e.what(), "BUSY")) << e.what();
  EXPECT_TRUE(contains(e.what(), "cannot run GET yet")) << e.what();
  c.command({"SCRIPT", "KILL"});
  busy.join();
  EXPECT_TRUE(c.command({"GET", "k"}).is_nil());
}

TEST_F(RedisClientTest, PipelineIsOneRoundTripAndReturnsErrorsInPlace) {
  RedisClient c(server_->options());
  c.command({"SET", "text", "abc"});
  const uint64_t before = c.round_trips();
  const auto replies = c.pipeline({{"SET", "a", "1"}, {"INCR", "text"}, {"INCR", "a"}});
  EXPECT_EQ(c.round_trips(), before + 1);
  ASSERT_EQ(replies.size(), 3u);
  EXPECT_EQ(replies[0].as_string(), "OK");
  EXPECT_EQ(replies[1].type, RedisReply::Type::error);
  EXPECT_EQ(replies[2].as_integer(), 2);  // the command after the error ran
}

TEST_F(RedisClientTest, ScriptsRunByDigestAndSurviveAFlushedScriptCache) {
  RedisClient c(server_->options());
  const std::string script = "return redis.call('INCRBY', KEYS[1], ARGV[1])";
  EXPECT_EQ(c.eval(script, {"sum"}, {"5"}).as_integer(), 5);
  EXPECT_EQ(c.eval(script, {"sum"}, {"7"}).as_integer(), 12);
  // What a Redis restart does to the script cache: the client loads the script again.
  RedisClient other(server_->options());
  other.command({"SCRIPT", "FLUSH"});
  EXPECT_EQ(c.eval(script, {"sum"}, {"1"}).as_integer(), 13);
  const RedisError e = error_of([&] { c.eval("return redis.call('NOSUCHCOMMAND')", {}, {}); });
  EXPECT_EQ(e.code(), RedisErrc::refused);
  EXPECT_TRUE(contains(e.what(), "failed a script")) << e.what();
}

TEST_F(RedisClientTest, SelectsTheDatabaseTheUrlNames) {
  RedisOptions three = server_->options();
  three.address = parse_redis_url(server_->url() + "?db=3");
  RedisClient in_three(three);
  in_three.command({"SET", "where", "three"});
  RedisClient in_zero(server_->options());
  EXPECT_TRUE(in_zero.command({"GET", "where"}).is_nil());
  EXPECT_EQ(in_three.command({"GET", "where"}).as_string(), "three");
  RedisOptions beyond = server_->options();
  beyond.address = parse_redis_url(server_->url() + "?db=999");  // Redis has 16 databases unless configured
  const RedisError e = error_of([&] { RedisClient c(beyond); });
  EXPECT_EQ(e.code(), RedisErrc::refused);
  EXPECT_TRUE(contains(e.what(), "cannot select database 999")) << e.what();
}

TEST_F(RedisClientTest, ReconnectsAtTheNextCommandAfterTheServerRestarts) {
  RedisClient c(server_->options());
  c.command({"SET", "kept", "yes"});
  server_->stop();
  // The broken connection, then the absent server: both unavailable, naming the server.
  const RedisError lost = error_of([&] { c.command({"GET", "kept"}); });
  EXPECT_EQ(lost.code(), RedisErrc::unavailable);
  EXPECT_TRUE(contains(lost.what(), server_->url())) << lost.what();
  EXPECT_FALSE(c.connected());
  const RedisError absent = error_of([&] { c.command({"GET", "kept"}); });
  EXPECT_EQ(absent.code(), RedisErrc::unavailable);
  EXPECT_TRUE(contains(absent.what(), "cannot connect to Redis at " + server_->url())) << absent.what();
  EXPECT_TRUE(contains(absent.what(), "redis-server")) << absent.what();
  server_->start();  // the same socket; the AOF brings the key back
  EXPECT_EQ(c.command({"GET", "kept"}).as_string(), "yes");
  EXPECT_TRUE(c.connected());
}

TEST_F(RedisClientTest, AReadRetriesOnceOnANewConnectionAfterARestart) {
  RedisClient writer(server_->options());
  RedisClient reader(server_->options());
  writer.command({"SET", "kept", "yes"});
  EXPECT_EQ(reader.read({"GET", "kept"}).as_string(), "yes");
  server_->stop();
  server_->start();  // both clients' connections are now dead, and neither knows it yet
  // A write may have run before the connection broke: it is never sent twice, and says so.
  const RedisError lost = error_of([&] { writer.command({"SET", "kept", "again"}); });
  EXPECT_EQ(lost.code(), RedisErrc::unavailable);
  EXPECT_TRUE(contains(lost.what(), "may or may not have run")) << lost.what();
  // A read is answered: the dead connection is found, dropped and the read sent again.
  EXPECT_EQ(reader.read({"GET", "kept"}).as_string(), "yes");
  EXPECT_TRUE(reader.connected());
  // Errors the server answers are not retried (the same command would get the same answer).
  const RedisError refused = error_of([&] { reader.read({"HGETALL", "kept"}); });
  EXPECT_EQ(refused.code(), RedisErrc::refused);
}

TEST_F(RedisClientTest, PubSubDeliversPublishedMessagesAndTimesOutQuietly) {
  RedisClient subscriber(server_->options());
  subscriber.send({"SUBSCRIBE", "kiln:test"});
  const auto confirmation = subscriber.receive(std::chrono::seconds(30));
  ASSERT_TRUE(confirmation);
  EXPECT_EQ(confirmation->as_array()[0].as_string(), "subscribe");
  EXPECT_FALSE(subscriber.receive(std::chrono::milliseconds(0)));  // nothing published yet
  RedisClient publisher(server_->options());
  EXPECT_EQ(publisher.command({"PUBLISH", "kiln:test", "hello"}).as_integer(), 1);
  const auto message = subscriber.receive(std::chrono::seconds(30));
  ASSERT_TRUE(message);
  ASSERT_EQ(message->as_array().size(), 3u);
  EXPECT_EQ(message->as_array()[0].as_string(), "message");
  EXPECT_EQ(message->as_array()[1].as_string(), "kiln:test");
  EXPECT_EQ(message->as_array()[2].as_string(), "hello");
}

TEST(RedisClientConnect, NamesTheServerItCannotReach) {
  RedisOptions o;
  o.address = parse_redis_url("unix:/nonexistent/kiln-test/redis.sock");
  const RedisError e = error_of([&] { RedisClient c(o); });
  EXPECT_EQ(e.code(), RedisErrc::unavailable);
  EXPECT_TRUE(contains(e.what(), "cannot connect to Redis at unix:/nonexistent/kiln-test/redis.sock")) << e.what();
}

TEST(ShippedRedisConfig, KeepsEveryWriteAndNeverEvicts) {
  if (RedisServer::binary().empty()) GTEST_SKIP() << RedisServer::kSkipMessage;
  // deploy/redis/kiln-redis.conf as redis-server reads it (the test's socket and directory on top).
  RedisServer server({}, std::string(KILN_SOURCE_DIR) + "/deploy/redis/kiln-redis.conf");
  RedisClient c(server.options());
  auto setting = [&](const std::string& name) { return c.command({"CONFIG", "GET", name}).as_array().at(1).str; };
  EXPECT_EQ(setting("appendonly"), "yes");
  EXPECT_EQ(setting("appendfsync"), "always");
  EXPECT_EQ(setting("maxmemory-policy"), "noeviction");
  EXPECT_EQ(setting("save"), "");
}

class RedisPasswordTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (RedisServer::binary().empty()) GTEST_SKIP() << RedisServer::kSkipMessage;
    server_ = std::make_unique<RedisServer>(std::vector<std::string>{"--requirepass", "s3cret"});
  }
  std::unique_ptr<RedisServer> server_;
};

TEST_F(RedisPasswordTest, AuthenticatesAndSaysWhereAMissingOrWrongPasswordGoes) {
  RedisOptions right = server_->options();
  right.password = "s3cret";
  RedisClient c(right);
  EXPECT_EQ(c.command({"PING"}).as_string(), "PONG");

  RedisClient anonymous(server_->options());
  const RedisError missing = error_of([&] { anonymous.command({"PING"}); });
  EXPECT_EQ(missing.code(), RedisErrc::refused);
  EXPECT_TRUE(contains(missing.what(), "NOAUTH")) << missing.what();
  EXPECT_TRUE(contains(missing.what(), "cluster_password_file")) << missing.what();

  RedisOptions wrong = server_->options();
  wrong.password = "guess";
  const RedisError refused = error_of([&] { RedisClient w(wrong); });
  EXPECT_EQ(refused.code(), RedisErrc::refused);
  EXPECT_TRUE(contains(refused.what(), "refused the password")) << refused.what();
  EXPECT_FALSE(contains(refused.what(), "guess")) << "the message must not repeat the password";
}

}  // namespace
}  // namespace kiln::cluster
