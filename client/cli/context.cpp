#include "client/cli/context.h"

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace kiln::cli {

using client::Client;
using client::ConnectionError;
using client::ServerError;

namespace {

constexpr const char* kDefaultServer = "127.0.0.1:7878";

}  // namespace

void set_server_and_token(Context& ctx, const Flags& flags) {
  if (auto s = flags.get("--server")) {
    ctx.server = *s;
  } else if (const char* env = std::getenv("KILN_SERVER"); env && *env) {
    ctx.server = env;
  } else {
    ctx.server = kDefaultServer;
  }
  if (auto t = flags.get("--token-file")) {
    ctx.token = read_token_file(*t, "--token-file");
  } else if (const char* env = std::getenv("KILN_TOKEN"); env && *env) {
    ctx.token = env;
  } else if (const char* file = std::getenv("KILN_TOKEN_FILE"); file && *file) {
    ctx.token = read_token_file(file, "KILN_TOKEN_FILE");
  }
  const auto tls_setting = [&](const char* flag, const char* env, std::string& into) {
    std::string source;
    if (auto v = flags.get(flag)) {
      into = *v;
      source = flag;
    } else if (const char* e = std::getenv(env); e && *e) {
      into = e;
      source = env;
    }
    if (!source.empty()) ctx.tls_sources += (ctx.tls_sources.empty() ? "" : ", ") + source;
  };
  tls_setting("--tls-ca", "KILN_TLS_CA", ctx.tls.ca_file);
  tls_setting("--tls-cert", "KILN_TLS_CERT", ctx.tls.cert_file);
  tls_setting("--tls-key", "KILN_TLS_KEY", ctx.tls.key_file);
  if (ctx.tls.ca_file.empty() && !ctx.tls.cert_file.empty()) {
    throw UsageError(
        "--tls-cert needs --tls-ca (or KILN_TLS_CA): a client certificate is only sent over TLS, and "
        "TLS needs the CA that signed the server's certificate");
  }
}

std::string read_token_file(const std::string& path, const std::string& source) {
  std::ifstream in(path);
  if (!in) throw UsageError(source + " " + path + ": cannot read the token file: " + std::strerror(errno));
  for (std::string line; std::getline(in, line);) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t\r");
    return line.substr(first, last - first + 1);
  }
  throw UsageError(source + " " + path + ": the token file holds no token (blank lines and # comments are skipped)");
}

std::string describe_server_error(const ServerError& e) {
  const std::string& m = e.message();
  const bool named = e.field().empty() || m.rfind(e.field() + ":", 0) == 0;
  return (named ? "" : e.field() + ": ") + m + " (" + v1::Error::Code_Name(e.code()) + ")";
}

void connect_and_greet(Context& ctx) {
  ctx.client.reset();
  client::Options options;
  options.client_name = "kiln-cli 0.1.0";
  options.tls = ctx.tls;
  try {
    Client c(ctx.server, options);
    ctx.hello = c.hello(ctx.token);
    ctx.client.emplace(std::move(c));
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    if (what.rfind("TLS", 0) == 0) throw UsageError(what + " (from " + ctx.tls_sources + ")");
    throw UsageError("--server: " + what);
  } catch (const ServerError& e) {
    if (e.code() == v1::Error::UNAUTHENTICATED) {
      throw Failure(kExitServer,
                    "kilnd at " + ctx.server + " refused this client: " + e.message() +
                        (ctx.token.empty() ? "; no token was given: pass --token-file FILE or set KILN_TOKEN"
                                           : "; check the token (--token-file FILE or KILN_TOKEN) against the "
                                             "server's token file"));
    }
    throw Failure(kExitServer, "kilnd at " + ctx.server + " refused the connection: " + describe_server_error(e));
  }
}

Client& connected_client(Context& ctx) {
  if (ctx.client && ctx.client->is_open()) return *ctx.client;
  try {
    connect_and_greet(ctx);
  } catch (const client::TlsError& e) {
    throw Failure(kExitServer, "cannot talk to kilnd at " + ctx.server + ": " + e.what());
  } catch (const ConnectionError& e) {
    throw Failure(kExitServer, "cannot talk to kilnd at " + ctx.server + ": " + e.what() +
                                   ". Is kilnd running there? Choose the server with --server HOST:PORT, "
                                   "--server unix:PATH or KILN_SERVER");
  }
  return *ctx.client;
}

void throw_job_request_error(const Context& ctx, const ServerError& e, const std::string& id, const std::string& what) {
  if (e.code() == v1::Error::NOT_FOUND) {
    throw Failure(kExitUsage, "kilnd at " + ctx.server + " has no job '" + id + "' (" + e.message() +
                                  "); list the jobs it has with `kiln jobs`");
  }
  if (e.code() == v1::Error::INVALID_ARGUMENT) {
    throw Failure(kExitUsage,
                  "kilnd at " + ctx.server + " refused to " + what + " '" + id + "': " + describe_server_error(e));
  }
  throw Failure(kExitServer,
                "kilnd at " + ctx.server + " could not " + what + " '" + id + "': " + describe_server_error(e));
}

void throw_connection_lost(const Context& ctx, const ConnectionError& e, const std::string& what) {
  throw Failure(kExitServer, "lost the connection to kilnd at " + ctx.server + " while " + what + ": " + e.what());
}

double steady_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace kiln::cli
