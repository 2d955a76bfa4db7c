// kilnd's TLS on the TCP listener: the OpenSSL context built from the configured files (TLS 1.2 or newer, optional
// client certificates), and telling a TLS client from a plain one by its first bytes.
#pragma once

#include <memory>
#include <string>
#include <string_view>

namespace boost::asio::ssl {
class context;
}

namespace kiln::daemon {

struct Config;

// The context for config.tls_cert and tls_key (and tls_client_ca, if set), or nullptr without TLS. Throws
// std::runtime_error naming the flag, the file and what to do: unreadable, not PEM, a key that does not belong to
// the certificate, a key others may read, a certificate that has expired.
std::unique_ptr<boost::asio::ssl::context> make_tls_context(const Config& config);

// One line for the start log: the certificate's subject and expiry, and whether client certificates are required.
std::string describe_tls(const Config& config, boost::asio::ssl::context& context);

// Whether the first bytes a client sent begin a TLS record (a handshake record: type 22, major version 3). A kiln
// frame never does: its length byte 22 would be followed by protobuf's tag byte, never 3. With one byte, only the
// type is checked.
bool starts_tls_handshake(std::string_view first_bytes);

}  // namespace kiln::daemon
