#include "daemon/tls_context.h"

// Boost 1.74's Asio uses std::exchange without including <utility> itself.
#include <utility>

#include <boost/asio/ssl/context.hpp>

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "daemon/config.h"

namespace kiln::daemon {
namespace ssl = boost::asio::ssl;

namespace {

// "Dec  3 07:00:00 2027 GMT"
std::string time_text(const ASN1_TIME* t) {
  BIO* bio = BIO_new(BIO_s_mem());
  if (!bio) return "?";
  ASN1_TIME_print(bio, t);
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio, &data);
  std::string text(data, n > 0 ? static_cast<std::size_t>(n) : 0);
  BIO_free(bio);
  return text;
}

std::string subject_text(X509* cert) {
  BIO* bio = BIO_new(BIO_s_mem());
  if (!bio) return "?";
  X509_NAME_print_ex(bio, X509_get_subject_name(cert), 0, XN_FLAG_RFC2253);
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio, &data);
  std::string text(data, n > 0 ? static_cast<std::size_t>(n) : 0);
  BIO_free(bio);
  return text;
}

// Opening the file first gives the system's reason (no such file, permission denied) rather than OpenSSL's.
void check_readable(const std::string& flag, const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) {
    throw std::runtime_error(flag + " " + path + ": cannot read it (" + std::strerror(errno) + "); give " + what +
                             " (docs/SECURITY.md shows how to make one)");
  }
}

// A private key others may read is as good as published. The group may read it (Debian's ssl-cert group holds keys
// that services share this way).
void check_key_private(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && (st.st_mode & S_IRWXO) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw std::runtime_error("--tls-key " + path + ": others can read it (mode " + mode +
                             "); refusing to use it. Run: chmod o-rwx " + path);
  }
}

}  // namespace

std::unique_ptr<ssl::context> make_tls_context(const Config& config) {
  if (config.tls_cert.empty()) return nullptr;
  const std::string& cert = config.tls_cert;
  const std::string& key = config.tls_key;
  check_readable("--tls-cert", cert, "the server's certificate chain in PEM");
  check_readable("--tls-key", key, "the certificate's private key in PEM");
  check_key_private(key);

  auto ctx = std::make_unique<ssl::context>(ssl::context::tls_server);
  SSL_CTX* native = ctx->native_handle();
  // TLS 1.2 and 1.3 only, with OpenSSL's default ciphers for them (Debian builds at security level 2); no
  // compression (CRIME) and no renegotiation (a client could make the server do handshakes at will).
  SSL_CTX_set_min_proto_version(native, TLS1_2_VERSION);
  ctx->set_options(ssl::context::default_workarounds | ssl::context::no_compression | SSL_OP_NO_RENEGOTIATION |
                   SSL_OP_CIPHER_SERVER_PREFERENCE);

  boost::system::error_code ec;
  ctx->use_certificate_chain_file(cert, ec);
  if (ec) {
    throw std::runtime_error("--tls-cert " + cert + ": not a PEM certificate chain (" + ec.message() +
                             "); give the server's certificate, then any intermediates, in PEM");
  }
  ctx->use_private_key_file(key, ssl::context::pem, ec);
  if (ec && ec.category() == boost::asio::error::get_ssl_category() &&
      ERR_GET_REASON(static_cast<unsigned long>(ec.value())) == X509_R_KEY_VALUES_MISMATCH) {
    throw std::runtime_error("--tls-key " + key + ": does not belong to the certificate in --tls-cert " + cert +
                             "; give the key the certificate was made for");
  }
  if (ec) {
    throw std::runtime_error("--tls-key " + key + ": not a PEM private key, or encrypted (" + ec.message() +
                             "); give the unencrypted PEM key of --tls-cert " + cert);
  }
  if (SSL_CTX_check_private_key(native) != 1) {
    throw std::runtime_error("--tls-key " + key + ": does not belong to the certificate in --tls-cert " + cert +
                             "; give the key the certificate was made for");
  }
  X509* leaf = SSL_CTX_get0_certificate(native);
  if (leaf && X509_cmp_current_time(X509_get0_notAfter(leaf)) < 0) {
    throw std::runtime_error("--tls-cert " + cert + ": the certificate expired on " +
                             time_text(X509_get0_notAfter(leaf)) + "; clients would refuse it. Renew it");
  }
  if (leaf && X509_cmp_current_time(X509_get0_notBefore(leaf)) > 0) {
    throw std::runtime_error("--tls-cert " + cert + ": the certificate is not valid before " +
                             time_text(X509_get0_notBefore(leaf)) + "; check this machine's clock");
  }

  if (!config.tls_client_ca.empty()) {
    const std::string& ca = config.tls_client_ca;
    check_readable("--tls-client-ca", ca, "the CA certificates that sign client certificates, in PEM");
    ctx->load_verify_file(ca, ec);
    STACK_OF(X509_NAME)* names = ec ? nullptr : SSL_load_client_CA_file(ca.c_str());
    if (!names) {
      throw std::runtime_error("--tls-client-ca " + ca + ": holds no PEM CA certificate" +
                               (ec ? " (" + ec.message() + ")" : std::string()) +
                               "; give the CA that signs the clients' certificates");
    }
    // The CAs are named to the client in the handshake, so it can pick the certificate to present.
    SSL_CTX_set_client_CA_list(native, names);
    ctx->set_verify_mode(ssl::verify_peer | ssl::verify_fail_if_no_peer_cert);
    // Resumed sessions must belong to this server's verification settings.
    static const unsigned char kSessionContext[] = "kilnd";
    SSL_CTX_set_session_id_context(native, kSessionContext, sizeof kSessionContext - 1);
  } else {
    ctx->set_verify_mode(ssl::verify_none);
  }
  return ctx;
}

std::string describe_tls(const Config& config, ssl::context& context) {
  std::string text = "TLS 1.2+ on TCP";
  if (X509* leaf = SSL_CTX_get0_certificate(context.native_handle())) {
    text += ", certificate " + subject_text(leaf) + " valid until " + time_text(X509_get0_notAfter(leaf));
  }
  text += config.tls_client_ca.empty() ? "; client certificates not asked for"
                                       : "; client certificates required, signed by a CA in " + config.tls_client_ca;
  return text;
}

bool starts_tls_handshake(std::string_view first_bytes) {
  if (first_bytes.empty() || static_cast<unsigned char>(first_bytes[0]) != 0x16) return false;
  return first_bytes.size() < 2 || static_cast<unsigned char>(first_bytes[1]) == 0x03;
}

}  // namespace kiln::daemon
