// kilnd's configuration: defaults, file, flags on top, and clear errors.
#include "daemon/config.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace kiln::daemon {
namespace {

std::string write_file(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / ("kiln_config_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

TEST(Config, DefaultsListenOnLoopbackOnly) {
  const CommandLine cl = parse_command_line({});
  EXPECT_EQ(cl.config.listen.rfind("127.0.0.1:", 0), 0u);
  EXPECT_FALSE(cl.help);
}

TEST(Config, FlagsOverrideTheFileWhereverConfigStands) {
  const std::string f = write_file("a.conf", "# comment\nworkers: 3\nstore: \"/srv/kiln\"\nthreads: 2\n");
  const CommandLine cl = parse_command_line({"--workers", "5", "--config", f, "--listen", "127.0.0.1:0"});
  EXPECT_EQ(cl.config.workers, 5u);         // the flag wins although it came first
  EXPECT_EQ(cl.config.store, "/srv/kiln");  // from the file
  EXPECT_EQ(cl.config.threads, 2u);
  EXPECT_EQ(cl.config.listen, "127.0.0.1:0");
}

TEST(Config, FileFieldsLeftOutKeepDefaults) {
  const std::string f = write_file("b.conf", "workers: 2\n");
  Config c;
  const double idle = c.idle_timeout_seconds;
  load_config_file(f, c);
  EXPECT_EQ(c.workers, 2u);
  EXPECT_EQ(c.idle_timeout_seconds, idle);
}

TEST(Config, SyntaxErrorsNameFileAndLine) {
  const std::string f = write_file("bad.conf", "workers: 2\nwrokers: 3\n");
  try {
    parse_command_line({"--config", f});
    FAIL();
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("bad.conf:2"), std::string::npos) << m;
    EXPECT_NE(m.find("wrokers"), std::string::npos) << m;
  }
}

TEST(Config, BadFlagsAreRefusedWithTheFlagNamed) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--workers", "0"}, "--workers"},
      {{"--workers", "x"}, "--workers"},
      {{"--workers", "-1"}, "--workers"},
      {{"--threads", "99999"}, "--threads"},
      {{"--idle-timeout", "0"}, "--idle-timeout"},
      {{"--heartbeat", "0"}, "--heartbeat"},
      {{"--heartbeat", "1.5"}, "--heartbeat"},
      {{"--frame-deadline", "nan"}, "--frame-deadline"},
      {{"--bogus", "1"}, "unknown argument '--bogus'"},
      {{"--listen"}, "--listen: missing value"},
      {{"--config"}, "--config: missing"},
  };
  for (const auto& [args, fragment] : cases) {
    try {
      parse_command_line(args);
      ADD_FAILURE() << "accepted " << args[0];
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  }
}

TEST(Config, ValidationRequiresATokenForTcpAndSomeListener) {
  Config c;
  c.token_file.clear();
  EXPECT_THROW(validate(c), std::invalid_argument);  // TCP without a token
  c.listen.clear();
  EXPECT_THROW(validate(c), std::invalid_argument);  // nothing to listen on
  c.socket = "/tmp/kiln.sock";
  EXPECT_NO_THROW(validate(c));  // the Unix socket alone needs no token
  c.listen = "localhost";
  c.token_file = "/x";
  EXPECT_THROW(validate(c), std::invalid_argument);  // no port
}

// deploy/kilnd.conf documents the defaults: loading it changes none of the settings it shows, except where the
// deployment differs on purpose (paths).
TEST(Config, ShippedConfigStatesTheDefaults) {
  Config shipped;
  load_config_file(std::string(KILN_SOURCE_DIR) + "/deploy/kilnd.conf", shipped);
  const Config defaults;
  EXPECT_EQ(shipped.heartbeat_seconds, defaults.heartbeat_seconds);
  EXPECT_EQ(shipped.max_connections, defaults.max_connections);
  EXPECT_EQ(shipped.max_pre_hello_connections, defaults.max_pre_hello_connections);
  EXPECT_EQ(shipped.hello_deadline_seconds, defaults.hello_deadline_seconds);
  EXPECT_EQ(shipped.idle_timeout_seconds, defaults.idle_timeout_seconds);
  EXPECT_EQ(shipped.frame_deadline_seconds, defaults.frame_deadline_seconds);
  EXPECT_EQ(shipped.max_crash_restarts, defaults.max_crash_restarts);
  EXPECT_EQ(shipped.partial_upload_max_age_seconds, defaults.partial_upload_max_age_seconds);
  EXPECT_EQ(shipped.memory_limit_bytes, defaults.memory_limit_bytes);
}

TEST(Config, HeartbeatFromFileAndFlag) {
  const std::string f = write_file("hb.conf", "heartbeat_seconds: 4\n");
  EXPECT_EQ(parse_command_line({"--config", f}).config.heartbeat_seconds, 4u);
  EXPECT_EQ(parse_command_line({"--config", f, "--heartbeat", "2"}).config.heartbeat_seconds, 2u);
}

TEST(Config, CrashLoopGuardFromFileAndFlag) {
  const std::string f = write_file("crash.conf", "max_crash_restarts: 5\n");
  EXPECT_EQ(parse_command_line({"--config", f}).config.max_crash_restarts, 5u);
  EXPECT_EQ(parse_command_line({"--config", f, "--max-crash-restarts", "0"}).config.max_crash_restarts, 0u);
  EXPECT_THROW(parse_command_line({"--max-crash-restarts", "-1"}), std::invalid_argument);
}

TEST(Config, MemoryLimitFromFileAndFlagWithBinarySuffixes) {
  const std::string f = write_file("mem.conf", "memory_limit_bytes: 1048576\n");
  EXPECT_EQ(parse_command_line({"--config", f}).config.memory_limit_bytes, uint64_t{1} << 20);
  EXPECT_EQ(parse_command_line({"--config", f, "--memory-limit", "6G"}).config.memory_limit_bytes, uint64_t{6} << 30);
  EXPECT_EQ(parse_command_line({"--memory-limit", "512m"}).config.memory_limit_bytes, uint64_t{512} << 20);
  EXPECT_EQ(parse_command_line({"--memory-limit", "1000"}).config.memory_limit_bytes, 1000u);
  EXPECT_THROW(parse_command_line({"--memory-limit", "6X"}), std::invalid_argument);
  EXPECT_THROW(parse_command_line({"--memory-limit", "G"}), std::invalid_argument);
  // Limits HelloReply promises are never 0, from a file either.
  Config zero;
  zero.token_file = "t";
  EXPECT_NO_THROW(validate(zero));
  zero.max_blob_bytes = 0;
  EXPECT_THROW(validate(zero), std::invalid_argument);
  zero.max_blob_bytes = 1;
  zero.max_queued_jobs = 0;
  EXPECT_THROW(validate(zero), std::invalid_argument);
  // The default is a share of this machine's memory, and some memory.
  EXPECT_GT(default_memory_limit(), uint64_t{1} << 20);
}

TEST(Config, ConnectionBoundsFromFileAndFlag) {
  const std::string f = write_file("conn.conf", "max_pre_hello_connections: 300\nhello_deadline_seconds: 2.5\n");
  const Config c = parse_command_line({"--config", f, "--max-connections", "8"}).config;
  EXPECT_EQ(c.max_pre_hello_connections, 300u);
  EXPECT_EQ(c.hello_deadline_seconds, 2.5);
  EXPECT_EQ(c.max_connections, 8u);
  EXPECT_THROW(parse_command_line({"--hello-deadline", "0"}), std::invalid_argument);
  EXPECT_THROW(parse_command_line({"--max-pre-hello-connections", "0"}), std::invalid_argument);
}

TEST(Config, TlsFromFileAndFlags) {
  const std::string f =
      write_file("tls.conf", "tls_cert: \"/etc/kiln/cert.pem\"\ntls_key: \"/etc/kiln/key.pem\"\ninsecure_tcp: false\n");
  // --insecure-tcp takes no value: the flag after it is still a flag.
  const Config c =
      parse_command_line({"--config", f, "--insecure-tcp", "--tls-client-ca", "/etc/kiln/clients.pem"}).config;
  EXPECT_EQ(c.tls_cert, "/etc/kiln/cert.pem");
  EXPECT_EQ(c.tls_key, "/etc/kiln/key.pem");
  EXPECT_EQ(c.tls_client_ca, "/etc/kiln/clients.pem");
  EXPECT_TRUE(c.insecure_tcp);
  EXPECT_FALSE(parse_command_line({}).config.insecure_tcp);
}

TEST(Config, TlsFilesGoTogether) {
  const auto message = [](std::vector<std::string> args) {
    args.insert(args.end(), {"--token-file", "t"});
    try {
      validate(parse_command_line(args).config);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(message({"--tls-cert", "c.pem", "--tls-key", "k.pem"}), "");
  EXPECT_NE(message({"--tls-cert", "c.pem"}).find("--tls-cert needs --tls-key"), std::string::npos);
  EXPECT_NE(message({"--tls-key", "k.pem"}).find("--tls-key needs --tls-cert"), std::string::npos);
  EXPECT_NE(message({"--tls-client-ca", "ca.pem"}).find("--tls-client-ca needs --tls-cert"), std::string::npos);
  EXPECT_NE(message({"--listen", "", "--socket", "s", "--tls-cert", "c", "--tls-key", "k"}).find("Unix socket stays"),
            std::string::npos);
}

TEST(Config, FarmSettingsComeFromFlagsOrTheFile) {
  const std::string f = write_file("farm.conf",
                                   "cluster: \"redis://10.0.0.5:6379/2\"\nnode_name: \"bake-07\"\n"
                                   "cluster_lease_seconds: 20\nworkers: 0\n");
  Config c = parse_command_line({"--config", f, "--socket", "s", "--listen", ""}).config;
  EXPECT_EQ(c.cluster, "redis://10.0.0.5:6379/2");
  EXPECT_EQ(c.node_name, "bake-07");
  EXPECT_EQ(c.cluster_lease_seconds, 20);
  EXPECT_EQ(c.workers, 0u);  // an accept-only node: allowed in a farm
  EXPECT_NO_THROW(validate(c));
  c = parse_command_line({"--cluster", "unix:/run/redis.sock", "--workers", "0", "--node-name", "a"}).config;
  EXPECT_EQ(c.cluster, "unix:/run/redis.sock");
  auto refused = [](Config bad, const std::string& fragment) {
    bad.socket = "s";
    bad.listen.clear();
    try {
      validate(bad);
      ADD_FAILURE() << "accepted: " << fragment;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  Config lease = c;
  lease.cluster_lease_seconds = 0.5;
  refused(lease, "cluster_lease_seconds: must be in [1, 3600]");
  Config name = c;
  name.node_name = "a/b";
  refused(name, "node_name");
  // A farm enforces the store limit (docs/FARM.md, "Retention"), within its retention settings' ranges.
  Config retention = c;
  retention.socket = "s";
  retention.listen.clear();
  retention.store_limit_bytes = 1 << 30;
  EXPECT_NO_THROW(validate(retention));
  retention.cluster_job_retention_seconds = -1;
  refused(retention, "cluster_job_retention_seconds");
  retention.cluster_job_retention_seconds = 0;  // kept forever
  retention.cluster_eviction_grace_seconds = 400 * 86400.0;
  refused(retention, "cluster_eviction_grace_seconds");
  const Config kept = parse_command_line({"--cluster", "unix:/r.sock", "--cluster-job-retention", "0",
                                          "--cluster-eviction-grace", "600"})
                          .config;
  EXPECT_EQ(kept.cluster_job_retention_seconds, 0);
  EXPECT_EQ(kept.cluster_eviction_grace_seconds, 600);
  Config alone = c;
  alone.cluster.clear();
  refused(alone, "--workers 0");
}

TEST(Config, TheShippedFarmNodeConfigIsValid) {
  Config c;
  load_config_file(std::string(KILN_SOURCE_DIR) + "/deploy/kilnd-farm.conf", c);
  EXPECT_EQ(c.cluster, "redis://redis.farm.lan:6379/0");
  EXPECT_EQ(c.store, "/srv/kiln-store");  // the path deploy/kilnd-farm@.service waits for and may write
  EXPECT_FALSE(c.cluster_password_file.empty());
  EXPECT_NO_THROW(validate(c));
}

TEST(Config, TheRedisPasswordFileMustBeTheOwnersAlone) {
  Config c;
  EXPECT_EQ(read_cluster_password(c), "");  // no file, no password
  c.cluster_password_file = write_file("redis-password", "s3cret\n");
  std::filesystem::permissions(c.cluster_password_file, std::filesystem::perms::owner_read |
                                                            std::filesystem::perms::owner_write |
                                                            std::filesystem::perms::group_read);
  try {
    read_cluster_password(c);
    ADD_FAILURE() << "a group-readable password file was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("chmod 600"), std::string::npos) << e.what();
  }
  std::filesystem::permissions(c.cluster_password_file,
                               std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  EXPECT_EQ(read_cluster_password(c), "s3cret");
}

TEST(Config, HelpListsEveryFlag) {
  const std::string u = usage();
  for (const char* f : {"--config", "--listen", "--socket", "--store", "--token-file", "--workers", "--threads",
                        "--tls-cert", "--tls-key", "--tls-client-ca", "--insecure-tcp", "--cluster",
                        "--cluster-password-file", "--node-name", "--cluster-lease"}) {
    EXPECT_NE(u.find(f), std::string::npos) << f;
  }
  EXPECT_TRUE(parse_command_line({"--workers", "bad", "--help"}).help);  // --help wins over a bad flag
}

}  // namespace
}  // namespace kiln::daemon
