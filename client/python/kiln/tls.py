"""TLS for the Client, with Python's ssl module: the context for a kilnd started with --tls-cert (TCP only), and
TLS failures explained for people, as the C++ client explains them (client/lib/client.cpp)."""

import os
import ssl

from .errors import KilnError


def _check_readable(what, path, wanted):
    try:
        with open(path, "rb"):
            pass
    except OSError as e:
        raise KilnError("%s %s: cannot read it (%s); give %s" % (what, path, e.strerror or e, wanted)) from None


def tls_context(ca_file, cert_file=None, key_file=None):
    """An SSLContext trusting the CA certificates in ca_file (PEM) for the server's certificate, which must also name
    the host connected to; TLS 1.2 or newer; this client's certificate and key if given. KilnError naming a file
    that cannot be used."""
    _check_readable("tls_ca", ca_file, "the PEM certificate of the CA that signed the server's certificate")
    if bool(cert_file) != bool(key_file):
        raise KilnError("a TLS client certificate needs its key, and a key its certificate: give tls_cert and tls_key")
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)  # verifies the certificate and the host name
    ctx.minimum_version = ssl.TLSVersion.TLSv1_2
    try:
        ctx.load_verify_locations(cafile=ca_file)
    except ssl.SSLError as e:
        raise KilnError("tls_ca %s: holds no PEM certificate (%s); give the CA that signed the server's certificate"
                        % (ca_file, e.reason or e)) from None
    if cert_file:
        _check_readable("tls_cert", cert_file, "this client's certificate in PEM")
        _check_readable("tls_key", key_file, "the client certificate's private key in PEM")
        try:
            ctx.load_cert_chain(cert_file, key_file)
        except ssl.SSLError as e:
            raise KilnError("tls_cert %s, tls_key %s: not a PEM certificate and its unencrypted key (%s)"
                            % (cert_file, key_file, e.reason or e)) from None
    return ctx


def settings(tls_ca, tls_cert, tls_key):
    """The TLS files from the arguments, else $KILN_TLS_CA, $KILN_TLS_CERT and $KILN_TLS_KEY."""
    return (tls_ca or os.environ.get("KILN_TLS_CA") or None,
            tls_cert or os.environ.get("KILN_TLS_CERT") or None,
            tls_key or os.environ.get("KILN_TLS_KEY") or None)


_CLIENT_REFUSED = ("ALERT_CERTIFICATE_REQUIRED", "ALERT_BAD_CERTIFICATE", "ALERT_UNKNOWN_CA",
                   "ALERT_HANDSHAKE_FAILURE", "ALERT_CERTIFICATE_UNKNOWN")


def explain(error, address, ca_file, cert_file):
    """What an ssl.SSLError (or an end of stream in the handshake) means here, and what to do. Under TLS 1.3 a server
    refusing this client's certificate says so after the handshake, at the first read."""
    reason = getattr(error, "reason", None) or ""
    if isinstance(error, ssl.SSLCertVerificationError):
        message = error.verify_message or str(error)
        if "mismatch" in message.lower():
            return ("the server's certificate does not name the host of %s (%s): connect by a name or address it was "
                    "made for, or give the server a certificate for it" % (address, message))
        return ("the server's certificate is refused (%s): it must be signed by a CA in %s and name the host of %s"
                % (message, ca_file, address))
    if reason in ("WRONG_VERSION_NUMBER", "PACKET_LENGTH_TOO_LONG", "RECORD_LAYER_FAILURE") or isinstance(
            error, (ssl.SSLEOFError, ssl.SSLZeroReturnError)):
        return ("the server at %s does not speak TLS (%s): start kilnd with --tls-cert and --tls-key, or connect "
                "without tls_ca" % (address, reason or error))
    if any(reason.endswith(r) for r in _CLIENT_REFUSED):
        if cert_file:
            return ("the server refused the TLS connection (%s); it does not accept the client certificate %s: it "
                    "must be signed by a CA in the server's --tls-client-ca" % (reason, cert_file))
        return ("the server refused the TLS connection (%s); it may require a client certificate: give tls_cert and "
                "tls_key" % reason)
    return "TLS failed (%s)" % (reason or error)
