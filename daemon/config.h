// kilnd's configuration: defaults, a protobuf text-format file, command-line flags on top, then validation.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace kiln::daemon {

struct Config {
  std::string listen = "127.0.0.1:7878";
  std::string socket;
  std::string store = "kiln-store";
  std::string token_file;
  // TLS on the TCP listener (the Unix socket stays plain: it is local and its permissions protect it). The
  // certificate chain and key in PEM; with client_ca, clients must present a certificate that chains to it.
  std::string tls_cert;
  std::string tls_key;
  std::string tls_client_ca;
  // Allows listening beyond loopback without TLS (tokens then cross the network in clear): for networks protected
  // otherwise, such as a VPN or an SSH tunnel's far end.
  bool insecure_tcp = false;
  uint32_t workers = 1;
  uint32_t threads = 0;
  uint64_t store_limit_bytes = 0;
  // Memory the running jobs' estimates may add up to; 0: default_memory_limit() (kilnd resolves it at start).
  uint64_t memory_limit_bytes = 0;
  uint32_t max_connections = 64;              // connections that said hello
  uint32_t max_pre_hello_connections = 1024;  // connections that have not yet; the oldest dropped when full
  double hello_deadline_seconds = 5;          // from connecting to a successful hello
  double frame_deadline_seconds = 30;
  double idle_timeout_seconds = 600;
  // A watch repeats its latest event when nothing was sent for it this long (HelloReply.limits.heartbeat_seconds).
  uint32_t heartbeat_seconds = 10;
  uint64_t max_frame_bytes = uint64_t{4} << 20;
  uint64_t max_chunk_bytes = uint64_t{1} << 20;
  uint64_t max_blob_bytes = uint64_t{1} << 30;
  uint32_t max_queued_jobs = 1000;
  double shutdown_grace_seconds = 30;
  // The crash-loop guard: a job that was running when kilnd died this many times in a row is failed, not run
  // again. 0: no limit.
  uint32_t max_crash_restarts = 3;
  // A partial upload untouched this long is deleted (its client gave up), at start and while running.
  double partial_upload_max_age_seconds = 86400;
  // Farm mode (docs/SCALING.md): the Redis that the farm's nodes share (redis://HOST:PORT[/DB] or unix:PATH[?db=N]);
  // empty: one kilnd alone, with SQLite. `store` is then the folder every node mounts.
  std::string cluster;
  std::string cluster_password_file;  // Redis's password (requirepass), in a file only its owner can read
  std::string node_name;              // this node's name in the farm; empty: HOSTNAME-PID
  double cluster_lease_seconds = 10;  // a job whose node stopped renewing this long runs again elsewhere
  // Finished jobs unused this long leave Redis (0: never); blobs used this recently are never evicted.
  double cluster_job_retention_seconds = 30 * 86400.0;
  double cluster_eviction_grace_seconds = 3600;
};

// What the command line asked for besides the configuration.
struct CommandLine {
  Config config;
  bool help = false;
};

// The password in cluster_password_file (its first line), refusing a file that others may read. Empty without one.
std::string read_cluster_password(const Config& config);

// Reads the text-format file into `config`, field by field (fields the file leaves out keep their value).
// Throws std::runtime_error naming the file and the line on a syntax error or an unknown field.
void load_config_file(const std::string& path, Config& config);

// Defaults, then --config FILE, then the other flags in any order. Throws std::invalid_argument with a message for
// people ("--workers: expected a whole number in [1, 256], got 'x'").
CommandLine parse_command_line(const std::vector<std::string>& args);

// Checks ranges and combinations (TCP needs a token file; at least one listener; the TLS files go together).
// Throws std::invalid_argument. Whether the TCP address is loopback is checked when it is resolved (server.cpp).
void validate(const Config& config);

// Three quarters of the machine's physical memory: room for the bakes and the daemon's own, under the kernel's.
uint64_t default_memory_limit();

// --help: every flag and its config-file field.
std::string usage();

}  // namespace kiln::daemon
