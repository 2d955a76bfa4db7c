#!/usr/bin/env bash
# Makes the certificates the TLS tests use, in DIR (created): a CA of the test's own and, signed by it, a server
# certificate for localhost, 127.0.0.1 and ::1 (server.pem, server.key), a client certificate (client.pem,
# client.key) and a server certificate for another name (wrong-name.pem, wrong-name.key); and a second, unrelated CA
# (other-ca.pem) with a client certificate of its own (other-client.pem, other-client.key). P-256 keys (fast to
# make), valid for 2 days, keys mode 0600. Needs the openssl command (Debian's openssl package).
# Usage: tests/tools/make_test_certs.sh DIR
set -euo pipefail
dir="${1:?usage: make_test_certs.sh DIR}"
mkdir -p "$dir"
cd "$dir"
umask 077
key() { openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1" 2>/dev/null; }

# ca NAME SUBJECT
ca() {
  key "$1.key"
  openssl req -x509 -new -key "$1.key" -out "$1.pem" -days 2 -subj "$2" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign" 2>/dev/null
}

# leaf NAME CA SUBJECT EXTENSIONS
leaf() {
  key "$1.key"
  openssl req -new -key "$1.key" -out "$1.csr" -subj "$3" 2>/dev/null
  printf '%s\n' "$4" >"$1.ext"
  openssl x509 -req -in "$1.csr" -CA "$2.pem" -CAkey "$2.key" -CAcreateserial -out "$1.pem" -days 2 \
    -extfile "$1.ext" 2>/dev/null
  rm -f "$1.csr" "$1.ext"
}

server_ext="basicConstraints=CA:FALSE
keyUsage=critical,digitalSignature
extendedKeyUsage=serverAuth"
client_ext="basicConstraints=CA:FALSE
keyUsage=critical,digitalSignature
extendedKeyUsage=clientAuth"

ca ca "/CN=kiln test CA"
leaf server ca "/CN=localhost" "$server_ext
subjectAltName=DNS:localhost,IP:127.0.0.1,IP:::1"
leaf client ca "/CN=kiln test client" "$client_ext"
leaf wrong-name ca "/CN=elsewhere.example" "$server_ext
subjectAltName=DNS:elsewhere.example"
ca other-ca "/CN=kiln unrelated CA"
leaf other-client other-ca "/CN=kiln unrelated client" "$client_ext"
# Certificates are public; only the keys stay private.
chmod 644 ./*.pem
