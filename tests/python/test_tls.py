"""TLS in the Python client (client/python/kiln) against the real kilnd, with a CA and certificates the test makes
itself (tests/tools/make_test_certs.sh, with the openssl command): a job's round trip, the refusals, each with a
message saying what to do, client certificates, the environment variables, and the token never on the wire in clear.

Run by CTest (tests/CMakeLists.txt, test "python_tls") like test_client.py.
"""

import os
import shutil
import socket
import subprocess
import tempfile
import threading
import time
import unittest
from unittest import mock

import kiln
from test_client import REPO, TOKEN, Daemon, ggx_job

CERTS = None


def setUpModule():
    global CERTS
    CERTS = tempfile.mkdtemp(prefix="kiln_py_tls_")
    subprocess.run([os.path.join(REPO, "tests", "tools", "make_test_certs.sh"), CERTS], check=True,
                   stdout=subprocess.DEVNULL)


def tearDownModule():
    if CERTS:
        shutil.rmtree(CERTS, ignore_errors=True)


def cert(name):
    return os.path.join(CERTS, name)


def tls_flags(server="server", client_ca=False):
    flags = ["--tls-cert", cert(server + ".pem"), "--tls-key", cert(server + ".key")]
    if client_ca:
        flags += ["--tls-client-ca", cert("ca.pem")]
    return flags


class DaemonCase(unittest.TestCase):
    """One kilnd for the class, started with flags()."""

    @classmethod
    def flags(cls):
        return tls_flags()

    @classmethod
    def setUpClass(cls):
        cls.daemon = Daemon(cls.flags())

    @classmethod
    def tearDownClass(cls):
        cls.daemon.stop()

    def client(self, address=None, **kw):
        c = kiln.Client(address or self.daemon.tcp, token=TOKEN, timeout=30, connect_timeout=5, **kw)
        self.addCleanup(c.close)
        return c

    def failure(self, error_class, attempt):
        """The message of the error_class that attempt() raises, and how many seconds it took."""
        start = time.monotonic()
        with self.assertRaises(error_class) as caught:
            attempt()
        return str(caught.exception), time.monotonic() - start


class TlsServer(DaemonCase):
    def test_a_job_makes_the_round_trip_over_tls(self):
        c = self.client(tls_ca=cert("ca.pem"))
        reply = c.submit(ggx_job(0.35, samples=256))
        self.assertEqual(c.watch(reply.job_id).state, kiln.pb.JOB_STATE_SUCCEEDED)
        out = tempfile.mkdtemp(prefix="kiln_py_tls_out_")
        self.addCleanup(shutil.rmtree, out, True)
        self.assertTrue(c.fetch_outputs(reply.job_id, out))  # each output's SHA-256 verified
        # The host name works as well as the address: the certificate names both. The Unix socket stays plain.
        self.client("localhost:%d" % self.daemon.port, tls_ca=cert("ca.pem")).hello()
        self.client(self.daemon.unix, tls_ca=cert("ca.pem")).hello()

    def test_the_ca_comes_from_the_environment_too(self):
        with mock.patch.dict(os.environ, {"KILN_TLS_CA": cert("ca.pem")}):
            self.assertEqual(self.client().status().server_version.split()[0], "kilnd")

    def test_a_plain_client_is_told_to_use_tls(self):
        c = self.client()
        message, seconds = self.failure(kiln.ConnectionError, c.hello)
        self.assertIn("accepts only TLS on TCP", message)
        self.assertIn("FAILED_PRECONDITION", message)
        self.assertLess(seconds, 2.0)  # at once, not at the 2 s hello deadline

    def test_a_certificate_from_another_ca_is_refused(self):
        message, _ = self.failure(kiln.TlsError, lambda: self.client(tls_ca=cert("other-ca.pem")))
        self.assertIn("the server's certificate is refused", message)
        self.assertIn("other-ca.pem", message)

    def test_an_unreadable_ca_file_is_named(self):
        missing = cert("missing.pem")
        message, _ = self.failure(kiln.KilnError, lambda: self.client(tls_ca=missing))
        self.assertIn("tls_ca %s: cannot read it" % missing, message)

    def test_the_token_never_crosses_the_network_in_clear(self):
        captured = captured_session(self.daemon, self.client, tls_ca=cert("ca.pem"))
        self.assertGreater(len(captured), 1000)
        self.assertNotIn(TOKEN.encode(), captured)
        self.assertNotIn(TOKEN[:12].encode(), captured)


class PlainServer(DaemonCase):
    @classmethod
    def flags(cls):
        return []

    def test_a_tls_client_is_told_the_server_does_not_speak_tls(self):
        message, seconds = self.failure(kiln.TlsError, lambda: self.client(tls_ca=cert("ca.pem")).hello())
        self.assertIn("does not speak TLS", message)
        self.assertLess(seconds, 2.0)

    def test_the_tap_sees_the_token_without_tls(self):
        # The control of the test above: the tap would see the token if it crossed in clear.
        self.assertIn(TOKEN.encode(), captured_session(self.daemon, self.client))


class WrongNameServer(DaemonCase):
    @classmethod
    def flags(cls):
        return tls_flags("wrong-name")

    def test_a_certificate_for_another_host_is_refused(self):
        message, _ = self.failure(kiln.TlsError, lambda: self.client(tls_ca=cert("ca.pem")))
        self.assertIn("does not name the host", message)


class ClientCertificates(DaemonCase):
    @classmethod
    def flags(cls):
        return tls_flags(client_ca=True)

    def test_a_client_without_a_certificate_is_refused(self):
        message, _ = self.failure(kiln.TlsError, lambda: self.client(tls_ca=cert("ca.pem")).hello())
        self.assertIn("client certificate", message)

    def test_a_certificate_from_another_ca_is_refused(self):
        message, _ = self.failure(kiln.TlsError, lambda: self.client(
            tls_ca=cert("ca.pem"), tls_cert=cert("other-client.pem"), tls_key=cert("other-client.key")).hello())
        self.assertIn("does not accept the client certificate", message)

    def test_the_right_certificate_is_accepted(self):
        c = self.client(tls_ca=cert("ca.pem"), tls_cert=cert("client.pem"), tls_key=cert("client.key"))
        self.assertTrue(c.status().server_version)


def captured_session(daemon, make_client, **kw):
    """Says hello and submits a job through a proxy that keeps every byte it relays, both ways; those bytes."""
    listener = socket.create_server(("127.0.0.1", 0))
    captured = bytearray()

    def relay():
        downstream, _ = listener.accept()
        upstream = socket.create_connection(("127.0.0.1", daemon.port))

        def pump(a, b):
            try:
                while True:
                    data = a.recv(65536)
                    if not data:
                        break
                    captured.extend(data)
                    b.sendall(data)
            except OSError:
                pass
            for s in (a, b):
                try:
                    s.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

        other = threading.Thread(target=pump, args=(upstream, downstream))
        other.start()
        pump(downstream, upstream)
        other.join()
        downstream.close()
        upstream.close()

    thread = threading.Thread(target=relay)
    thread.start()
    with listener:
        c = make_client("127.0.0.1:%d" % listener.getsockname()[1], **kw)
        reply = c.submit(ggx_job(0.45, samples=256))
        c.watch(reply.job_id)
        c.close()
        thread.join(timeout=20)
    return bytes(captured)


if __name__ == "__main__":
    unittest.main()
