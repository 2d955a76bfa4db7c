"""The kiln client: one blocking connection to kilnd speaking kiln.v1 (proto/kiln.proto), for pipelines.

It mirrors the C++ client library (client/lib/client.h): the same framing (each message preceded by its length as a
varint), nonzero request ids, Hello first, chunked resumable uploads, chunked fetches verified against their SHA-256,
watches that outlive heartbeats. A Client is not thread-safe: use one per thread.

Errors: an answer of the server with an error is a ServerError (code, message, field). A connection that cannot be
made, breaks, times out (TimeoutError) or is closed by the server (a connection-level error, request id 0: its code
is in ConnectionError.code) is a ConnectionError. The Client is closed afterwards; its next call connects again and
says hello again, so a watch can simply be repeated (it re-attaches) and an upload resumes where it broke.
"""

import builtins
import hashlib
import os
import socket
import ssl
import tempfile
import time

from . import kiln_pb2 as pb
from .digests import _as_digest, _valid_sha256, digest_of
from . import tls as _tls
from .errors import ConnectionError, KilnError, ServerError, TimeoutError, TlsError, _code_name
from .jobs import parse_job, state_name
from .wire import _decode_varint, _encode_varint, _parse_address, _read_token_file

PROTOCOL_VERSION = 1
DEFAULT_ADDRESS = "127.0.0.1:7878"
DEFAULT_MAX_FRAME_BYTES = 4 << 20
DEFAULT_MAX_CHUNK_BYTES = 1 << 20

# The largest response frame accepted whatever the server advertises, so a broken server cannot make us buffer
# without bound.
_MAX_RESPONSE_FRAME_BYTES = 64 << 20
# Room in a frame for the fields around a chunk's data.
_FRAME_OVERHEAD_BYTES = 1024
# Re-queries of an upload whose offset moved under it (another client uploading the same blob) in a row without the
# server's count growing, before giving up; while it grows, whoever sends the chunks (all send the same bytes), the
# upload goes on.
_MAX_UPLOAD_RESTARTS = 3
_READ_BYTES = 256 << 10
_CLIENT_NAME = "kiln-python 0.1.0"
# A connection older than this is replaced before saying hello: well inside any server's hello deadline (5 s by
# default), so a Client constructed long before its first request is not refused.
_FRESH_CONNECTION_SECONDS = 1.0


def _safe_output_name(name):
    return (bool(name) and name not in (".", "..") and "/" not in name and "\\" not in name and "\0" not in name)


class Client:
    """One connection to kilnd.

    address: "HOST:PORT" (an IPv6 host in brackets) or "unix:PATH"; default $KILN_SERVER, else 127.0.0.1:7878.
    token: for TCP (the Unix socket's permissions decide there); default: the first line of token_file that is not
    blank or a # comment, else $KILN_TOKEN, else the file named by $KILN_TOKEN_FILE.
    timeout: seconds for each request to be sent and for each response to arrive; while watching, for each event
    (never less than twice the server's heartbeat period). connect_timeout: seconds for connecting (and TLS's
    handshake).
    tls_ca: TLS to a kilnd started with --tls-cert: the PEM file of the CA certificates to trust for the server's
    certificate, which must also name the host of the address; default $KILN_TLS_CA (neither: no TLS). TCP only: a
    Unix socket stays plain. tls_cert, tls_key: this client's certificate and key (PEM), for a kilnd that requires
    client certificates; default $KILN_TLS_CERT, $KILN_TLS_KEY. A TLS failure is a TlsError saying what to do.

    The constructor connects (ConnectionError if it cannot); the first request says hello with the token (hello()
    does it explicitly and returns the server's HelloReply). Use as a context manager or call close().
    """

    def __init__(self, address=None, token=None, timeout=60.0, *, token_file=None, connect_timeout=10.0,
                 client_name=_CLIENT_NAME, tls_ca=None, tls_cert=None, tls_key=None):
        self.address = address or os.environ.get("KILN_SERVER") or DEFAULT_ADDRESS
        self._kind, self._target = _parse_address(self.address)
        if token is None and token_file:
            token = _read_token_file(token_file)
        if token is None:
            token = os.environ.get("KILN_TOKEN") or None
        if token is None and os.environ.get("KILN_TOKEN_FILE"):
            token = _read_token_file(os.environ["KILN_TOKEN_FILE"])
        self.token = token or ""
        self.timeout = float(timeout)
        self.connect_timeout = float(connect_timeout)
        self.client_name = client_name
        self.tls_ca, self.tls_cert, self.tls_key = _tls.settings(tls_ca, tls_cert, tls_key)
        if self.tls_cert and not self.tls_ca:
            raise KilnError("tls_cert needs tls_ca (or $KILN_TLS_CA): a client certificate is only sent over TLS, "
                            "and TLS needs the CA that signed the server's certificate")
        # Files are checked now: a wrong path is the caller's mistake, not the network's.
        self._tls = (_tls.tls_context(self.tls_ca, self.tls_cert, self.tls_key)
                     if self.tls_ca and self._kind == "tcp" else None)
        self._sock = None
        self._buf = bytearray()
        self._next_id = 1
        self._hello = None
        self._reset_limits()
        self._connect()

    # -- connection --------------------------------------------------------------------------------------------

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001 (interpreter shutdown)
            pass

    @property
    def is_open(self):
        return self._sock is not None

    def close(self):
        sock, self._sock = self._sock, None
        self._hello = None
        self._buf = bytearray()
        if sock is not None:
            sock.close()

    def _reset_limits(self):
        self.limits = pb.Limits(max_frame_bytes=DEFAULT_MAX_FRAME_BYTES, max_chunk_bytes=DEFAULT_MAX_CHUNK_BYTES)
        self._max_response_bytes = DEFAULT_MAX_FRAME_BYTES + _FRAME_OVERHEAD_BYTES

    def _connect(self):
        self.close()
        self._reset_limits()
        try:
            if self._kind == "unix":
                sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                try:
                    sock.settimeout(self.connect_timeout)
                    sock.connect(self._target)
                except BaseException:
                    sock.close()
                    raise
            else:
                sock = socket.create_connection(self._target, timeout=self.connect_timeout)
                # Requests are single small frames answered before the next: Nagle's delay only adds latency.
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                if self._tls is not None:
                    sock = self._handshake(sock)
        except TlsError:
            raise
        except builtins.TimeoutError as e:
            raise TimeoutError("connecting to %s timed out after %g s" % (self.address, self.connect_timeout)) from e
        except OSError as e:
            raise ConnectionError("connecting to %s: %s" % (self.address, e.strerror or e)) from e
        self._sock = sock
        self._connected_at = time.monotonic()

    def _handshake(self, sock):
        """TLS over the connected socket, within connect_timeout (the server's hello deadline counts it too)."""
        try:
            return self._tls.wrap_socket(sock, server_hostname=self._target[0])
        except builtins.TimeoutError:
            sock.close()
            raise
        except (ssl.SSLError, builtins.ConnectionResetError) as e:
            sock.close()
            raise TlsError("TLS handshake with %s: %s" % (self.address, self._explain_tls(e))) from e

    def _explain_tls(self, error):
        if isinstance(error, builtins.ConnectionResetError):
            error = ssl.SSLEOFError("the connection was reset")
        return _tls.explain(error, self.address, self.tls_ca, self.tls_cert)

    def _fail(self, why, cls=ConnectionError, **kw):
        self.close()
        raise cls(why, **kw)

    def _ready(self):
        """Connected and greeted: reconnects after a broken connection and says hello if not yet said."""
        if self._sock is None:
            self._connect()
        if self._hello is None:
            self.hello()

    def _send(self, request):
        payload = request.SerializeToString()
        if len(payload) > self.limits.max_frame_bytes:
            raise KilnError("a request of %d bytes exceeds the server's frame limit of %d bytes"
                            % (len(payload), self.limits.max_frame_bytes))
        frame = _encode_varint(len(payload)) + payload
        try:
            self._sock.settimeout(self.timeout)
            self._sock.sendall(frame)
        except builtins.TimeoutError:
            self._fail("sending a request timed out after %g s" % self.timeout, TimeoutError)
        except ssl.SSLError as e:
            self._fail("sending a request: %s" % self._explain_tls(e), TlsError)
        except OSError as e:
            self._fail("sending a request: %s" % (e.strerror or e))

    def _read_frame(self, deadline, timeout):
        while True:
            try:
                head = _decode_varint(self._buf)
            except ValueError as e:
                self._fail("the server sent a malformed frame: %s" % e)
            if head is not None:
                size, skip = head
                if size > self._max_response_bytes:
                    self._fail("the server sent a frame of %d bytes, more than the %d allowed"
                               % (size, self._max_response_bytes))
                if len(self._buf) >= skip + size:
                    payload = bytes(self._buf[skip:skip + size])
                    del self._buf[:skip + size]
                    return payload
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self._fail("waiting for the server's answer timed out after %g s" % timeout, TimeoutError)
            try:
                self._sock.settimeout(remaining)
                data = self._sock.recv(_READ_BYTES)
            except builtins.TimeoutError:
                self._fail("waiting for the server's answer timed out after %g s" % timeout, TimeoutError)
            except ssl.SSLError as e:
                self._fail("waiting for the server's answer: %s" % self._explain_tls(e), TlsError)
            except OSError as e:
                self._fail("waiting for the server's answer: %s" % (e.strerror or e))
            if not data:
                self._fail("waiting for the server's answer: the server closed the connection")
            self._buf += data

    def _await(self, ids, expected, timeout=None):
        """The next response to one of the request ids in `ids`, with the body `expected`; skips responses to
        requests the caller abandoned (a watch left by an exception). A server error becomes ServerError."""
        timeout = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + timeout
        while True:
            payload = self._read_frame(deadline, timeout)
            response = pb.Response()
            try:
                response.ParseFromString(payload)
            except Exception:  # noqa: BLE001 (DecodeError, or a RuntimeWarning-ish error of the C implementation)
                self._fail("the server sent a frame that is not a kiln.v1.Response")
            if response.id == 0:
                # A connection-level error: the server is closing the connection.
                if response.HasField("error"):
                    e = response.error
                    self._fail("the server closed the connection: %s (%s)" % (e.message, _code_name(e.code)),
                               code=e.code, field=e.field)
                self._fail("the server sent a response without a request id")
            if response.id not in ids:
                continue
            if response.HasField("error"):
                e = response.error
                raise ServerError(e.code, e.message, e.field)
            body = response.WhichOneof("body")
            if body != expected:
                self._fail("the server answered request %d with a %s, expected a %s" % (response.id, body, expected))
            return response

    def _start(self, request):
        request.id = self._next_id
        self._next_id += 1
        self._send(request)
        return request.id

    def _call(self, request, expected):
        self._ready()
        request_id = self._start(request)
        return getattr(self._await({request_id}, expected), expected)

    def _chunk_bytes(self):
        """Data per BlobPut or FetchReply: the server's chunk limit, small enough for its frame limit."""
        chunk = self.limits.max_chunk_bytes
        if self.limits.max_frame_bytes > 2 * _FRAME_OVERHEAD_BYTES:
            chunk = min(chunk, self.limits.max_frame_bytes - _FRAME_OVERHEAD_BYTES)
        return max(1, min(chunk, _MAX_RESPONSE_FRAME_BYTES - _FRAME_OVERHEAD_BYTES))

    # -- session -----------------------------------------------------------------------------------------------

    def hello(self):
        """Says hello with the token (reconnecting if the connection broke); returns the server's HelloReply and
        remembers its limits, which size the chunks of uploads and fetches. ServerError UNAUTHENTICATED if the
        token is wrong or missing on TCP; the server then closes the connection (answering repeated failures ever
        more slowly), and the next call reconnects."""
        # The server closes a connection that has not said hello within a few seconds (its hello deadline); the
        # constructor's connection may have waited longer than that for the first request, so it is made afresh.
        if self._sock is None or time.monotonic() - self._connected_at > _FRESH_CONNECTION_SECONDS:
            self._connect()
        request = pb.Request()
        request.hello.protocol_version = PROTOCOL_VERSION
        request.hello.token = self.token
        request.hello.client = self.client_name
        try:
            reply = self._await({self._start(request)}, "hello").hello
        except ServerError:
            self.close()  # the server closes the connection after a failed hello; the next call reconnects
            raise
        if reply.protocol_version != PROTOCOL_VERSION:
            self._fail("the server speaks protocol version %d, this client %d"
                       % (reply.protocol_version, PROTOCOL_VERSION))
        limits = pb.Limits()
        limits.CopyFrom(reply.limits)
        # Zero means the server did not say: keep the protocol's defaults.
        if not limits.max_frame_bytes:
            limits.max_frame_bytes = DEFAULT_MAX_FRAME_BYTES
        if not limits.max_chunk_bytes:
            limits.max_chunk_bytes = DEFAULT_MAX_CHUNK_BYTES
        self.limits = limits
        self._max_response_bytes = min(max(limits.max_frame_bytes + _FRAME_OVERHEAD_BYTES, DEFAULT_MAX_FRAME_BYTES),
                                       _MAX_RESPONSE_FRAME_BYTES)
        self._hello = reply
        return reply

    # -- blobs -------------------------------------------------------------------------------------------------

    def query_blobs(self, digests):
        """The BlobQueryReply: which of `digests` the server does not hold whole, and how many bytes it holds."""
        request = pb.Request()
        request.blob_query.SetInParent()
        for d in digests:
            request.blob_query.digests.add().CopyFrom(_as_digest(d))
        return self._call(request, "blob_query")

    def put_blob_chunk(self, digest, offset, data):
        """One BlobPut: `data` at `offset` (which must be the server's `received`) of the blob `digest`. Returns
        the BlobPutReply. upload_blob() does this for a whole blob."""
        request = pb.Request()
        request.blob_put.digest.CopyFrom(_as_digest(digest))
        request.blob_put.offset = offset
        request.blob_put.data = bytes(data)
        return self._call(request, "blob_put")

    def upload_blob(self, data, progress=None):
        """Stores `data` (bytes-like) on the server unless it already holds it, in chunks of at most
        limits.max_chunk_bytes, resuming a broken upload from the offset the server reports. Returns its Digest, by
        which jobs refer to it. progress(done, total) is called as bytes go out."""
        view = memoryview(data).cast("B")
        digest = digest_of(view)
        total = len(view)
        stalled, furthest = 0, 0
        while True:
            self._ready()  # limits (chunk size) come from the hello
            chunk = self._chunk_bytes()
            missing = [m for m in self.query_blobs([digest]).missing
                       if m.digest.sha256 == digest.sha256 and m.digest.size == digest.size]
            if not missing:
                if progress:
                    progress(total, total)
                return digest
            offset = missing[0].received
            if offset > total:
                self._fail("the server holds %d bytes of a %d-byte blob" % (offset, total))
            if offset > furthest:
                stalled, furthest = 0, offset
            try:
                while True:
                    if progress:
                        progress(offset, total)
                    reply = self.put_blob_chunk(digest, offset, view[offset:offset + chunk])
                    if reply.complete:
                        if progress:
                            progress(total, total)
                        return digest
                    # The server's count is the truth, but it has to move forward and cannot end without storing.
                    if reply.received <= offset or reply.received >= total:
                        self._fail("the server's upload offset went from %d to %d of %d bytes without storing it"
                                   % (offset, reply.received, total))
                    offset = reply.received
            except ServerError as e:
                # Another upload of the same blob moved the server's offset: ask where it is now, go on from there.
                stalled += 1
                if e.code != pb.Error.FAILED_PRECONDITION or stalled > _MAX_UPLOAD_RESTARTS:
                    raise

    def upload_file(self, path, progress=None):
        """upload_blob() of a file's bytes; returns its Digest."""
        with open(path, "rb") as f:
            return self.upload_blob(f.read(), progress)

    # -- jobs --------------------------------------------------------------------------------------------------

    def submit(self, job_spec, priority=0, idempotency_key=""):
        """Submits a job (a kiln.pb.JobSpec, or its text format); returns the SubmitReply (job_id, cache_hit,
        state). ServerError INVALID_ARGUMENT names a bad field, e.g. "job.material.ggx.alpha"."""
        if isinstance(job_spec, str):
            job_spec = parse_job(job_spec)
        request = pb.Request()
        request.submit.job.CopyFrom(job_spec)
        request.submit.priority = priority
        request.submit.idempotency_key = idempotency_key
        return self._call(request, "submit")

    def _watch_timeout(self):
        heartbeat = self._hello.limits.heartbeat_seconds if self._hello is not None else 0
        return max(self.timeout, 2.0 * heartbeat)

    def watch(self, job_id, on_event=None, heartbeats=False):
        """Follows a job until it ends and returns the final JobEvent (its state says how it ended). on_event(event)
        is called for the job's current state and each change of it; the server's heartbeats (its latest event
        repeated while nothing changes) are passed on only with heartbeats=True. After a broken connection,
        watching again re-attaches."""
        return self.watch_all([job_id], on_event, heartbeats)[job_id]

    def watch_all(self, job_ids, on_event=None, heartbeats=False):
        """Follows several jobs at once on this connection (their events interleave) until every one has ended;
        returns {job_id: final JobEvent}. on_event and heartbeats as in watch()."""
        self._ready()
        pending = {}
        for job_id in dict.fromkeys(job_ids):
            request = pb.Request()
            request.watch.job_id = job_id
            pending[self._start(request)] = job_id
        last = {}
        finals = {}
        while pending:
            response = self._await(set(pending), "event", self._watch_timeout())
            event = response.event
            job_id = pending[response.id]
            key = (event.state, event.sequence, event.final)
            if on_event and (heartbeats or last.get(job_id) != key):
                on_event(event)
            last[job_id] = key
            if event.final:
                finals[job_id] = event
                del pending[response.id]
        return finals

    def cancel(self, job_id):
        """Cancels a job; returns the state it is in afterwards (CANCELLED, or how it had already ended)."""
        request = pb.Request()
        request.cancel.job_id = job_id
        return self._call(request, "cancel").state

    def result(self, job_id):
        """The JobResult: state, outputs (name, media type, color space, digest), the bake report, the error."""
        request = pb.Request()
        request.get_result.job_id = job_id
        return self._call(request, "result")

    def status(self):
        """The ServerStatus: queue, running jobs, workers, store use, cache hits, uptime."""
        request = pb.Request()
        request.status.SetInParent()
        return self._call(request, "status")

    def list_jobs(self, limit=0, state=pb.JOB_STATE_UNSPECIFIED):
        """A JobList, newest first; limit 0 means the server's default; a state lists only jobs in it."""
        request = pb.Request()
        request.list_jobs.limit = limit
        request.list_jobs.state = state
        return self._call(request, "jobs")

    # -- fetching ----------------------------------------------------------------------------------------------

    def fetch_into(self, digest, sink, progress=None):
        """Fetches a stored output (or blob) in chunks, handing each chunk to sink(bytes) as it arrives, and
        verifies size and SHA-256 at the end (ServerError DATA_LOSS if they do not match): the bytes are only known
        good when this returns. `digest` is a Digest, an Output or (sha256, size)."""
        digest = _as_digest(digest)
        if not _valid_sha256(digest.sha256):
            raise ValueError('fetch: digest "%s" is not 64 lowercase hex digits' % digest.sha256)
        self._ready()
        total = digest.size
        chunk = self._chunk_bytes()
        hasher = hashlib.sha256()
        offset = 0
        while True:
            if progress:
                progress(offset, total)
            request = pb.Request()
            request.fetch.digest.CopyFrom(digest)
            request.fetch.offset = offset
            request.fetch.length = chunk
            reply = self._call(request, "fetch")
            data = reply.data
            if reply.offset != offset:
                self._fail("the server answered a fetch at offset %d with offset %d" % (offset, reply.offset))
            if len(data) > chunk:
                self._fail("the server sent %d bytes for a fetch of %d" % (len(data), chunk))
            if len(data) > total - offset:
                raise ServerError(pb.Error.DATA_LOSS, "the server sent more than the %d bytes of blob %s"
                                  % (total, digest.sha256), "digest.size")
            if not data and not reply.eof:
                self._fail("the server sent no bytes of a fetch and no end either")
            hasher.update(data)
            sink(data)
            offset += len(data)
            if reply.eof:
                break
        if offset != total:
            raise ServerError(pb.Error.DATA_LOSS, "blob %s ended after %d of %d bytes" % (digest.sha256, offset, total),
                              "digest.size")
        got = hasher.hexdigest()
        if got != digest.sha256:
            raise ServerError(pb.Error.DATA_LOSS, "fetched bytes of blob %s have SHA-256 %s" % (digest.sha256, got),
                              "digest.sha256")
        if progress:
            progress(total, total)

    def fetch(self, digest, progress=None):
        """The bytes of a stored output (or blob), fetched in chunks and verified against the digest (ServerError
        DATA_LOSS if they do not match)."""
        parts = []
        self.fetch_into(digest, parts.append, progress)
        return b"".join(parts)

    def fetch_to_file(self, digest, path, progress=None):
        """Fetches into a file: written to a temporary file beside it and renamed over `path` only once verified.
        Returns path."""
        folder = os.path.dirname(os.path.abspath(path))
        fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".part", dir=folder)
        try:
            with os.fdopen(fd, "wb") as f:
                self.fetch_into(digest, f.write, progress)
                f.flush()
                os.fsync(f.fileno())
            os.chmod(tmp, 0o644)  # mkstemp makes it 0600; outputs are for the pipeline to read
            os.replace(tmp, path)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
        return path

    def fetch_outputs(self, job_id, out_dir, progress=None):
        """Fetches every output of a SUCCEEDED job into out_dir (created if needed), each verified, under its
        output name; returns the paths in the result's order. ServerError if the job did not succeed (its error, or
        FAILED_PRECONDITION while it has not ended). progress(name, done, total) per output."""
        result = self.result(job_id)
        if result.state != pb.JOB_STATE_SUCCEEDED:
            if result.HasField("error") and result.error.code:
                raise ServerError(result.error.code, "job %s %s: %s" % (job_id, state_name(result.state),
                                                                        result.error.message), result.error.field)
            raise ServerError(pb.Error.FAILED_PRECONDITION, "job %s is %s, not SUCCEEDED: it has no outputs%s"
                              % (job_id, state_name(result.state),
                                 "" if result.state in (pb.JOB_STATE_FAILED, pb.JOB_STATE_CANCELLED)
                                 else " yet (watch it to the end first)"), "job_id")
        for output in result.outputs:
            if not _safe_output_name(output.name):
                raise KilnError("job %s has an output named %r, which is not a plain file name" % (job_id, output.name))
        os.makedirs(out_dir, exist_ok=True)
        paths = []
        for output in result.outputs:
            path = os.path.join(out_dir, output.name)
            report = (lambda done, total, name=output.name: progress(name, done, total)) if progress else None
            paths.append(self.fetch_to_file(output.digest, path, report))
        return paths

    def run(self, job_spec, out_dir=None, on_event=None, priority=0, idempotency_key=""):
        """Submit, watch to the end and, with out_dir, fetch every output there. Returns the JobResult; ServerError
        if the job failed or was cancelled."""
        reply = self.submit(job_spec, priority, idempotency_key)
        final = self.watch(reply.job_id, on_event)
        if final.state != pb.JOB_STATE_SUCCEEDED:
            result = self.result(reply.job_id)
            code = result.error.code if result.HasField("error") and result.error.code else (
                pb.Error.CANCELLED if final.state == pb.JOB_STATE_CANCELLED else pb.Error.INTERNAL)
            raise ServerError(code, "job %s %s: %s" % (reply.job_id, state_name(final.state),
                                                       result.error.message or final.message), result.error.field)
        if out_dir is not None:
            self.fetch_outputs(reply.job_id, out_dir)
        return self.result(reply.job_id)
