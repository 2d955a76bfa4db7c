// What every `kiln` command works with: the server and token it was given, the streams it prints on, and the
// connection to kilnd, made on first use; and the messages that say why a request failed.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

#include "client/cli/args.h"
#include "client/cli/commands.h"
#include "client/lib/client.h"

namespace kiln::cli {

struct Context {
  std::string server;
  std::string token;
  client::TlsOptions tls;   // TLS on TCP when tls.ca_file is set
  std::string tls_sources;  // where the TLS settings came from, for errors ("--tls-ca", "KILN_TLS_CA")
  Terminal terminal;
  std::ostream& out;
  std::ostream& err;
  std::optional<client::Client> client;
  v1::HelloReply hello;
};

// The server from --server, else $KILN_SERVER, else the default; the token from --token-file, else $KILN_TOKEN,
// else the file named by $KILN_TOKEN_FILE (none: no token); TLS's files from --tls-ca, --tls-cert and --tls-key,
// else $KILN_TLS_CA, $KILN_TLS_CERT and $KILN_TLS_KEY (no CA: no TLS).
void set_server_and_token(Context& ctx, const Flags& flags);

// The token in the first line of the file that is not blank or a # comment; `source` names where the path came
// from in errors ("--token-file"). Throws UsageError.
std::string read_token_file(const std::string& path, const std::string& source);

// A server's error for people: "field: message (CODE)", the field only once (kilnd's messages may start with it).
std::string describe_server_error(const client::ServerError& e);

// Connects and says hello; a ConnectionError is left to the caller (who may retry), everything else becomes a
// message for people.
void connect_and_greet(Context& ctx);

// The open connection, made now if there is none; a connection that cannot be made is a Failure.
client::Client& connected_client(Context& ctx);

// A server error on a request about job `id` ("cancel job", `what`), as the Failure that says so.
[[noreturn]] void throw_job_request_error(const Context& ctx, const client::ServerError& e, const std::string& id,
                                          const std::string& what);

// A connection broken while doing `what`, as the Failure that says so.
[[noreturn]] void throw_connection_lost(const Context& ctx, const client::ConnectionError& e, const std::string& what);

// Seconds on the steady clock, for progress lines.
double steady_seconds();

}  // namespace kiln::cli
