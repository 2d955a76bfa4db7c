#include "daemon/config.h"

#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "daemon/auth.h"
#include "daemon/kilnd_config.pb.h"
#include "proto/byte_size.h"

namespace kiln::daemon {
namespace {

// --workers 0 is a node that only accepts jobs: alone, nothing would ever run them.
void check_accept_only(const Config& c) {
  if (c.workers == 0 && c.cluster.empty()) {
    throw std::invalid_argument(
        "--workers 0 (a node that only accepts jobs) needs --cluster: alone, kilnd would never run its jobs");
  }
}

// The farm's settings: a URL the Redis client parses, a lease in range, a node name usable as a consumer's.
void check_cluster(const Config& c) {
  if (c.cluster.empty()) return;
  if (c.cluster.size() > 1024) throw std::invalid_argument("cluster: at most 1024 bytes");
  if (!(c.cluster_lease_seconds >= 1 && c.cluster_lease_seconds <= 3600)) {
    throw std::invalid_argument("cluster_lease_seconds: must be in [1, 3600]");
  }
  for (char ch : c.node_name) {
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-' && ch != '_' && ch != '.' && ch != ':') {
      throw std::invalid_argument("node_name: letters, digits and - _ . : only, got '" + c.node_name + "'");
    }
  }
  if (c.node_name.size() > 64) throw std::invalid_argument("node_name: at most 64 characters");
  if (!(c.cluster_job_retention_seconds >= 0 && c.cluster_job_retention_seconds <= 3650 * 86400.0)) {
    throw std::invalid_argument("cluster_job_retention_seconds: must be in [0, 3650 days] (0: keep every record)");
  }
  if (!(c.cluster_eviction_grace_seconds >= 0 && c.cluster_eviction_grace_seconds <= 365 * 86400.0)) {
    throw std::invalid_argument("cluster_eviction_grace_seconds: must be in [0, 365 days]");
  }
}

class CollectErrors : public google::protobuf::io::ErrorCollector {
 public:
  explicit CollectErrors(std::string file) : file_(std::move(file)) {}
  void AddError(int line, int column, const std::string& message) override {
    if (first_.empty()) {
      first_ = file_ + ":" + std::to_string(line + 1) + ":" + std::to_string(column + 1) + ": " + message;
    }
  }
  const std::string& first() const { return first_; }

 private:
  std::string file_, first_;
};

uint64_t parse_unsigned(const std::string& flag, const std::string& text, uint64_t lo, uint64_t hi) {
  std::size_t used = 0;
  unsigned long long v = 0;
  bool ok = !text.empty() && text[0] != '-';
  if (ok) {
    try {
      v = std::stoull(text, &used);
    } catch (const std::exception&) {
      ok = false;
    }
  }
  if (!ok || used != text.size() || v < lo || v > hi) {
    throw std::invalid_argument(flag + ": expected a whole number in [" + std::to_string(lo) + ", " +
                                std::to_string(hi) + "], got '" + text + "'");
  }
  return v;
}

double parse_seconds(const std::string& flag, const std::string& text) {
  std::size_t used = 0;
  double v = NAN;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
  }
  if (used != text.size() || !(v > 0) || !std::isfinite(v)) {
    throw std::invalid_argument(flag + ": expected a positive number of seconds, got '" + text + "'");
  }
  return v;
}

// As parse_seconds, where 0 means "none" (no expiry, no grace).
double parse_seconds_or_zero(const std::string& flag, const std::string& text) {
  return text == "0" ? 0.0 : parse_seconds(flag, text);
}

// A size in bytes, optionally with a binary suffix: "512M", "6G".
uint64_t parse_bytes(const std::string& flag, const std::string& text) {
  constexpr uint64_t kMax = uint64_t{1} << 50;
  const std::optional<uint64_t> v = proto::parse_byte_size(text);
  if (!v || *v > kMax) {
    throw std::invalid_argument(flag + ": expected a size in bytes in [0, 2^50], whole or with K, M, G or T " +
                                "(x1024), got '" + text + "'");
  }
  return *v;
}

struct Flag {
  const char* name;
  const char* field;  // the config file's field
  const char* help;
  std::function<void(Config&, const std::string&)> set;
  bool takes_value = true;  // false: a switch, set with ""
};

const std::vector<Flag>& flags() {
  static const std::vector<Flag> all = {
      {"--listen", "listen", "TCP address HOST:PORT (port 0: any free port, printed at start); '' for none",
       [](Config& c, const std::string& v) { c.listen = v; }},
      {"--socket", "socket", "Unix socket path; its permissions decide who connects; '' for none",
       [](Config& c, const std::string& v) { c.socket = v; }},
      {"--store", "store", "folder of the job records, blobs and results",
       [](Config& c, const std::string& v) { c.store = v; }},
      {"--token-file", "token_file", "file of accepted tokens (mode 0600), required with TCP",
       [](Config& c, const std::string& v) { c.token_file = v; }},
      {"--tls-cert", "tls_cert", "TLS on TCP: the server's certificate chain (PEM); needs --tls-key",
       [](Config& c, const std::string& v) { c.tls_cert = v; }},
      {"--tls-key", "tls_key", "TLS on TCP: the certificate's private key (PEM, not readable by others)",
       [](Config& c, const std::string& v) { c.tls_key = v; }},
      {"--tls-client-ca", "tls_client_ca", "TLS: require client certificates that chain to these CAs (PEM)",
       [](Config& c, const std::string& v) { c.tls_client_ca = v; }},
      {"--insecure-tcp", "insecure_tcp", "allow a non-loopback --listen without TLS (tokens in clear)",
       [](Config& c, const std::string&) { c.insecure_tcp = true; }, false},
      {"--workers", "workers", "jobs that run at once [1, 256]; 0: a farm node that only accepts (--cluster)",
       [](Config& c, const std::string& v) { c.workers = parse_unsigned("--workers", v, 0, 256); }},
      {"--cluster", "cluster", "farm mode: the nodes' Redis, redis://HOST:PORT[/DB] or unix:PATH (docs/SCALING.md)",
       [](Config& c, const std::string& v) { c.cluster = v; }},
      {"--cluster-password-file", "cluster_password_file", "farm mode: file with Redis's password (mode 0600)",
       [](Config& c, const std::string& v) { c.cluster_password_file = v; }},
      {"--node-name", "node_name", "farm mode: this node's name, unique in the farm (default HOSTNAME-PID)",
       [](Config& c, const std::string& v) { c.node_name = v; }},
      {"--cluster-lease", "cluster_lease_seconds", "farm mode: seconds before a silent node's jobs run elsewhere",
       [](Config& c, const std::string& v) { c.cluster_lease_seconds = parse_seconds("--cluster-lease", v); }},
      {"--cluster-job-retention", "cluster_job_retention_seconds",
       "farm mode: seconds a finished job's record stays in Redis after its last use, 0 = forever",
       [](Config& c, const std::string& v) {
         c.cluster_job_retention_seconds = parse_seconds_or_zero("--cluster-job-retention", v);
       }},
      {"--cluster-eviction-grace", "cluster_eviction_grace_seconds",
       "farm mode: seconds after its last use a blob is safe from the store limit",
       [](Config& c, const std::string& v) {
         c.cluster_eviction_grace_seconds = parse_seconds_or_zero("--cluster-eviction-grace", v);
       }},
      {"--threads", "threads", "baking threads in total, 0 = all cores [0, 1024]",
       [](Config& c, const std::string& v) { c.threads = parse_unsigned("--threads", v, 0, 1024); }},
      {"--store-limit-bytes", "store_limit_bytes", "evict least recently used results past this size, 0 = none",
       [](Config& c, const std::string& v) {
         c.store_limit_bytes = parse_unsigned("--store-limit-bytes", v, 0, uint64_t{1} << 50);
       }},
      {"--memory-limit", "memory_limit_bytes",
       "memory the running jobs' estimates may add up to, bytes or with K, M, G, T (x1024); 0 = 3/4 of the RAM",
       [](Config& c, const std::string& v) { c.memory_limit_bytes = parse_bytes("--memory-limit", v); }},
      {"--max-connections", "max_connections", "connections that said hello, at once [1, 10000]",
       [](Config& c, const std::string& v) { c.max_connections = parse_unsigned("--max-connections", v, 1, 10000); }},
      {"--max-pre-hello-connections", "max_pre_hello_connections",
       "connections not yet past hello [1, 100000]; when full the oldest is dropped",
       [](Config& c, const std::string& v) {
         c.max_pre_hello_connections = parse_unsigned("--max-pre-hello-connections", v, 1, 100000);
       }},
      {"--hello-deadline", "hello_deadline_seconds", "seconds from connecting to a successful hello",
       [](Config& c, const std::string& v) { c.hello_deadline_seconds = parse_seconds("--hello-deadline", v); }},
      {"--frame-deadline", "frame_deadline_seconds", "seconds a client may take to finish a frame it started",
       [](Config& c, const std::string& v) { c.frame_deadline_seconds = parse_seconds("--frame-deadline", v); }},
      {"--idle-timeout", "idle_timeout_seconds", "seconds before an idle connection is closed",
       [](Config& c, const std::string& v) { c.idle_timeout_seconds = parse_seconds("--idle-timeout", v); }},
      {"--heartbeat", "heartbeat_seconds", "seconds between a watch's events at most (repeats) [1, 3600]",
       [](Config& c, const std::string& v) { c.heartbeat_seconds = parse_unsigned("--heartbeat", v, 1, 3600); }},
      {"--max-queued-jobs", "max_queued_jobs", "jobs waiting at once [1, 1000000]",
       [](Config& c, const std::string& v) { c.max_queued_jobs = parse_unsigned("--max-queued-jobs", v, 1, 1000000); }},
      {"--shutdown-grace", "shutdown_grace_seconds", "seconds running jobs get to finish on SIGTERM/SIGINT",
       [](Config& c, const std::string& v) { c.shutdown_grace_seconds = parse_seconds("--shutdown-grace", v); }},
      {"--partial-upload-max-age", "partial_upload_max_age_seconds",
       "seconds before an untouched partial upload is deleted (at start and while running)",
       [](Config& c, const std::string& v) {
         c.partial_upload_max_age_seconds = parse_seconds("--partial-upload-max-age", v);
       }},
      {"--max-crash-restarts", "max_crash_restarts",
       "fail a job that was running at this many kilnd crashes in a row, 0 = never [0, 1000]",
       [](Config& c, const std::string& v) {
         c.max_crash_restarts = parse_unsigned("--max-crash-restarts", v, 0, 1000);
       }},
  };
  return all;
}

}  // namespace

void load_config_file(const std::string& path, Config& config) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("config file " + path + ": cannot open it");
  std::stringstream text;
  text << in.rdbuf();
  kiln::daemon::v1::DaemonConfig file;
  google::protobuf::TextFormat::Parser parser;
  CollectErrors errors(path);
  parser.RecordErrorsTo(&errors);
  if (!parser.ParseFromString(text.str(), &file)) {
    throw std::runtime_error("config file " + errors.first() + " (fields are described in deploy/kilnd.conf)");
  }
  if (file.has_listen()) config.listen = file.listen();
  if (file.has_socket()) config.socket = file.socket();
  if (file.has_store()) config.store = file.store();
  if (file.has_token_file()) config.token_file = file.token_file();
  if (file.has_tls_cert()) config.tls_cert = file.tls_cert();
  if (file.has_tls_key()) config.tls_key = file.tls_key();
  if (file.has_tls_client_ca()) config.tls_client_ca = file.tls_client_ca();
  if (file.has_insecure_tcp()) config.insecure_tcp = file.insecure_tcp();
  if (file.has_workers()) config.workers = file.workers();
  if (file.has_threads()) config.threads = file.threads();
  if (file.has_store_limit_bytes()) config.store_limit_bytes = file.store_limit_bytes();
  if (file.has_memory_limit_bytes()) config.memory_limit_bytes = file.memory_limit_bytes();
  if (file.has_max_connections()) config.max_connections = file.max_connections();
  if (file.has_max_pre_hello_connections()) config.max_pre_hello_connections = file.max_pre_hello_connections();
  if (file.has_hello_deadline_seconds()) config.hello_deadline_seconds = file.hello_deadline_seconds();
  if (file.has_frame_deadline_seconds()) config.frame_deadline_seconds = file.frame_deadline_seconds();
  if (file.has_idle_timeout_seconds()) config.idle_timeout_seconds = file.idle_timeout_seconds();
  if (file.has_heartbeat_seconds()) config.heartbeat_seconds = file.heartbeat_seconds();
  if (file.has_max_frame_bytes()) config.max_frame_bytes = file.max_frame_bytes();
  if (file.has_max_chunk_bytes()) config.max_chunk_bytes = file.max_chunk_bytes();
  if (file.has_max_blob_bytes()) config.max_blob_bytes = file.max_blob_bytes();
  if (file.has_max_queued_jobs()) config.max_queued_jobs = file.max_queued_jobs();
  if (file.has_shutdown_grace_seconds()) config.shutdown_grace_seconds = file.shutdown_grace_seconds();
  if (file.has_partial_upload_max_age_seconds()) {
    config.partial_upload_max_age_seconds = file.partial_upload_max_age_seconds();
  }
  if (file.has_max_crash_restarts()) config.max_crash_restarts = file.max_crash_restarts();
  if (file.has_cluster()) config.cluster = file.cluster();
  if (file.has_cluster_password_file()) config.cluster_password_file = file.cluster_password_file();
  if (file.has_node_name()) config.node_name = file.node_name();
  if (file.has_cluster_lease_seconds()) config.cluster_lease_seconds = file.cluster_lease_seconds();
  if (file.has_cluster_job_retention_seconds()) {
    config.cluster_job_retention_seconds = file.cluster_job_retention_seconds();
  }
  if (file.has_cluster_eviction_grace_seconds()) {
    config.cluster_eviction_grace_seconds = file.cluster_eviction_grace_seconds();
  }
}

std::string read_cluster_password(const Config& config) {
  if (config.cluster_password_file.empty()) return {};
  check_owner_only(config.cluster_password_file, "cluster_password_file",
                   "write Redis's password (its requirepass) on its first line, mode 0600");
  std::ifstream in(config.cluster_password_file);
  std::string line;
  std::getline(in, line);
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  if (line.empty()) {
    throw std::runtime_error("cluster_password_file " + config.cluster_password_file +
                             ": its first line is empty; write Redis's password there");
  }
  return line;
}

CommandLine parse_command_line(const std::vector<std::string>& args) {
  CommandLine cl;
  // --config first, wherever it stands, so that every other flag overrides the file.
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") cl.help = true;
    if (args[i] == "--config") {
      if (i + 1 >= args.size()) throw std::invalid_argument("--config: missing the file name");
      load_config_file(args[i + 1], cl.config);
    }
  }
  if (cl.help) return cl;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--config") {
      ++i;
      continue;
    }
    const Flag* flag = nullptr;
    for (const Flag& f : flags()) {
      if (a == f.name) flag = &f;
    }
    if (!flag) throw std::invalid_argument("unknown argument '" + a + "' (see --help)");
    if (!flag->takes_value) {
      flag->set(cl.config, "");
      continue;
    }
    if (i + 1 >= args.size()) throw std::invalid_argument(a + ": missing value");
    flag->set(cl.config, args[++i]);
  }
  check_accept_only(cl.config);
  return cl;
}

void validate(const Config& c) {
  if (c.listen.empty() && c.socket.empty()) {
    throw std::invalid_argument("nothing to listen on: give --listen HOST:PORT or --socket PATH");
  }
  if (!c.listen.empty() && c.listen.rfind(':') == std::string::npos) {
    throw std::invalid_argument("--listen: expected HOST:PORT, got '" + c.listen + "'");
  }
  if (!c.listen.empty() && c.token_file.empty()) {
    throw std::invalid_argument("--listen needs --token-file: TCP clients must present a token");
  }
  if (c.tls_cert.empty() != c.tls_key.empty()) {
    throw std::invalid_argument(c.tls_cert.empty() ? "--tls-key needs --tls-cert: give the certificate it belongs to"
                                                   : "--tls-cert needs --tls-key: give the certificate's private key");
  }
  if (!c.tls_client_ca.empty() && c.tls_cert.empty()) {
    throw std::invalid_argument(
        "--tls-client-ca needs --tls-cert and --tls-key: client certificates are checked in a TLS handshake");
  }
  if (!c.tls_cert.empty() && c.listen.empty()) {
    throw std::invalid_argument(
        "--tls-cert applies to the TCP listener, and there is none: give --listen HOST:PORT "
        "(the Unix socket stays plain)");
  }
  if (c.store.empty()) throw std::invalid_argument("--store: a folder is required");
  if (c.workers > 256) throw std::invalid_argument("workers: must be in [1, 256] (0 with --cluster)");
  check_accept_only(c);
  check_cluster(c);
  if (c.max_connections < 1 || c.max_connections > 10000) {
    throw std::invalid_argument("max_connections: must be in [1, 10000]");
  }
  if (c.max_pre_hello_connections < 1 || c.max_pre_hello_connections > 100000) {
    throw std::invalid_argument("max_pre_hello_connections: must be in [1, 100000]");
  }
  for (const auto& [name, value] : {std::pair{"hello_deadline_seconds", c.hello_deadline_seconds},
                                    std::pair{"frame_deadline_seconds", c.frame_deadline_seconds},
                                    std::pair{"idle_timeout_seconds", c.idle_timeout_seconds},
                                    std::pair{"partial_upload_max_age_seconds", c.partial_upload_max_age_seconds}}) {
    if (!(value > 0) || !std::isfinite(value)) {
      throw std::invalid_argument(std::string(name) + ": must be a positive number of seconds");
    }
  }
  if (c.max_crash_restarts > 1000) throw std::invalid_argument("max_crash_restarts: must be in [0, 1000]");
  // HelloReply's limits are never 0 (kiln.proto): a file cannot set what the flags' ranges refuse.
  if (c.max_blob_bytes < 1) throw std::invalid_argument("max_blob_bytes: must be at least 1");
  if (c.max_queued_jobs < 1 || c.max_queued_jobs > 1000000) {
    throw std::invalid_argument("max_queued_jobs: must be in [1, 1000000]");
  }
  if (c.heartbeat_seconds < 1 || c.heartbeat_seconds > 3600) {
    throw std::invalid_argument("heartbeat_seconds: must be in [1, 3600]");
  }
  if (c.max_frame_bytes < 1024 || c.max_frame_bytes > (uint64_t{64} << 20)) {
    throw std::invalid_argument("max_frame_bytes: must be in [1 KiB, 64 MiB]");
  }
  // A chunk travels inside a frame with a little framing around it.
  if (c.max_chunk_bytes < 1024 || c.max_chunk_bytes + 1024 > c.max_frame_bytes) {
    throw std::invalid_argument("max_chunk_bytes: must be at least 1 KiB and 1 KiB below max_frame_bytes");
  }
}

std::string usage() {
  std::string u =
      "usage: kilnd [--config FILE] [flags]\n\n"
      "kilnd, the kiln baking daemon. Settings come from built-in defaults, then the protobuf text-format file\n"
      "given with --config (annotated example: deploy/kilnd.conf), then these flags:\n\n";
  for (const Flag& f : flags()) {
    char line[256];
    const std::string name = std::string(f.name) + (f.takes_value ? "" : " (no value)");
    std::snprintf(line, sizeof line, "  %-28s %-26s %s\n", name.c_str(), f.field, f.help);
    u += line;
  }
  u += "\nThe second column is the config file's field. Logs go to stderr. SIGTERM or SIGINT stops accepting,\n"
       "lets running jobs finish within shutdown_grace_seconds, re-queues the rest and exits.\n";
  return u;
}

}  // namespace kiln::daemon

namespace kiln::daemon {

uint64_t default_memory_limit() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return uint64_t{4} << 30;  // unknown: a size most build machines have
  return static_cast<uint64_t>(pages) * static_cast<uint64_t>(page) / 4 * 3;
}

}  // namespace kiln::daemon
