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
import tempfile
import time

from google.protobuf import descriptor as _descriptor
from google.protobuf import text_format

from . import kiln_pb2 as pb

PROTOCOL_VERSION = 1
DEFAULT_ADDRESS = "127.0.0.1:7878"
DEFAULT_MAX_FRAME_BYTES = 4 << 20
DEFAULT_MAX_CHUNK_BYTES = 1 << 20

# The largest response frame accepted whatever the server advertises, so a broken server cannot make us buffer
# without bound.
_MAX_RESPONSE_FRAME_BYTES = 64 << 20
# Room in a frame for the fields around a chunk's data.
_FRAME_OVERHEAD_BYTES = 1024
# sockaddr_un.sun_path holds 108 bytes on Linux, including the terminating zero.
_MAX_UNIX_PATH_BYTES = 107
# Re-queries of an upload whose offset moved under it (another client uploading the same blob) before giving up.
_MAX_UPLOAD_RESTARTS = 3
_READ_BYTES = 256 << 10
_CLIENT_NAME = "kiln-python 0.1.0"


# ---- Errors ------------------------------------------------------------------------------------------------------

class KilnError(Exception):
    """Base of every error this module raises on purpose."""


def _code_name(code):
    try:
        return pb.Error.Code.Name(code)
    except ValueError:
        return "CODE_%d" % code


class ServerError(KilnError):
    """The server answered a request with an error; also DATA_LOSS when fetched bytes fail verification.

    code: a kiln.pb.Error.Code value (e.g. kiln.pb.Error.INVALID_ARGUMENT); code_name: its name; message: for people;
    field: the path of the offending field ("job.material.ggx.alpha"), empty if no single field is at fault.
    """

    def __init__(self, code, message, field=""):
        self.code = int(code)
        self.message = message
        self.field = field
        super().__init__("%s%s (%s)" % (field + ": " if field else "", message, _code_name(self.code)))

    @property
    def code_name(self):
        return _code_name(self.code)


class ConnectionError(KilnError, builtins.ConnectionError):
    """No connection, a broken one, or a server that does not speak the protocol. The connection is closed.

    When the server closed it with a connection-level error (bad frame, deadline exceeded, shutting down), `code`,
    `message` and `field` say what it was; otherwise `code` is None.
    """

    def __init__(self, message, code=None, field=""):
        super().__init__(message)
        self.message = message
        self.code = code
        self.field = field


class TimeoutError(ConnectionError, builtins.TimeoutError):  # noqa: A001 (mirrors the C++ client's name)
    """Connecting, sending or receiving took longer than its timeout."""


# ---- Digests and job specs ---------------------------------------------------------------------------------------

def digest_of(data):
    """The protocol's name of some bytes: kiln.pb.Digest(sha256=lowercase hex, size)."""
    return pb.Digest(sha256=hashlib.sha256(data).hexdigest(), size=len(data))


def _as_digest(value):
    if isinstance(value, pb.Digest):
        return value
    if isinstance(value, pb.Output):
        return value.digest
    if isinstance(value, (tuple, list)) and len(value) == 2:
        return pb.Digest(sha256=value[0], size=int(value[1]))
    raise TypeError("expected a kiln.pb.Digest, a kiln.pb.Output or (sha256, size), got %r" % (value,))


def _valid_sha256(text):
    return len(text) == 64 and all(c in "0123456789abcdef" for c in text)


def state_name(state):
    """"SUCCEEDED" for kiln.pb.JOB_STATE_SUCCEEDED, and so on."""
    try:
        return pb.JobState.Name(state).replace("JOB_STATE_", "")
    except ValueError:
        return "STATE_%d" % state


def parse_job(text):
    """A kiln.pb.JobSpec from protobuf text format (the job files of `kiln submit`). ValueError if malformed."""
    try:
        return text_format.Parse(text, pb.JobSpec())
    except text_format.ParseError as e:
        raise ValueError("job spec: %s" % e) from e


def load_job(path):
    """A kiln.pb.JobSpec from a text-format job file. ValueError names the file and the line if malformed."""
    with open(path, "r", encoding="utf-8") as f:
        text = f.read()
    try:
        return text_format.Parse(text, pb.JobSpec())
    except text_format.ParseError as e:
        raise ValueError("%s: %s" % (path, e)) from e


def _enum_value(enum_type, value, path):
    if isinstance(value, bool):
        raise TypeError("%s: expected a %s name or number, got %r" % (path, enum_type.name, value))
    if isinstance(value, int):
        if value not in enum_type.values_by_number:
            raise ValueError("%s: %d is not a %s value" % (path, value, enum_type.name))
        return value
    if isinstance(value, str):
        name = value.strip().upper().replace("-", "_")
        # Fresnel -> FRESNEL_SCHLICK, Masking -> MASKING_V_GROOVE, EnvironmentLobe -> ENVIRONMENT_LOBE_GGX
        prefix = "".join("_" + c if c.isupper() and i else c for i, c in enumerate(enum_type.name)).upper() + "_"
        for candidate in (name, prefix + name):
            if candidate in enum_type.values_by_name:
                return enum_type.values_by_name[candidate].number
        choices = ", ".join(v.name[len(prefix):].lower() if v.name.startswith(prefix) else v.name
                            for v in enum_type.values)
        raise ValueError("%s: %r is not a %s (one of: %s)" % (path, value, enum_type.name, choices))
    raise TypeError("%s: expected a %s name or number, got %r" % (path, enum_type.name, value))


def _set_color(color, value, path):
    if isinstance(value, pb.Color):
        color.CopyFrom(value)
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        color.r = color.g = color.b = float(value)
    elif isinstance(value, dict):
        _fill(color, value, path)
    elif isinstance(value, (tuple, list)) and len(value) == 3:
        color.r, color.g, color.b = (float(v) for v in value)
    else:
        raise TypeError("%s: expected a number (grey), (r, g, b) or a kiln.pb.Color, got %r" % (path, value))


def _set_model(message, model, params, path):
    oneof = message.DESCRIPTOR.oneofs_by_name["model"]
    names = [f.name for f in oneof.fields]
    if model not in names:
        raise ValueError("%s: unknown model %r (one of: %s)" % (path, model, ", ".join(names)))
    sub = getattr(message, model)
    sub.SetInParent()
    _fill(sub, params, path + "." + model)


def _set_message(target, value, path):
    """A message field from a kiln.pb message of its type, or the plain Python forms of the common ones."""
    full_name = target.DESCRIPTOR.full_name
    if isinstance(value, type(target)):
        target.CopyFrom(value)
    elif full_name == "kiln.v1.Color":
        _set_color(target, value, path)
    elif full_name == "kiln.v1.Digest":
        try:
            target.CopyFrom(_as_digest(value))
        except TypeError as e:
            raise TypeError("%s: %s" % (path, e)) from None
    elif full_name == "kiln.v1.Vector3" and isinstance(value, (tuple, list)):
        if len(value) != 3:
            raise TypeError("%s: expected (x, y, z), got %r" % (path, value))
        target.x, target.y, target.z = (float(v) for v in value)
    elif full_name == "kiln.v1.Brdf":
        if not isinstance(value, dict) or "model" not in value:
            raise TypeError("%s: expected a dict with a 'model' key, e.g. {'model': 'lambert', "
                            "'albedo': 0.5}, got %r" % (path, value))
        rest = dict(value)
        _set_model(target, rest.pop("model"), rest, path)
    elif isinstance(value, dict):
        target.SetInParent()
        _fill(target, value, path)
    else:
        raise TypeError("%s: expected a dict or a kiln.pb.%s, got %r" % (path, target.DESCRIPTOR.name, value))


def _scalar(field, value, path):
    if field.type == _descriptor.FieldDescriptor.TYPE_ENUM:
        return _enum_value(field.enum_type, value, path)
    if field.type in (_descriptor.FieldDescriptor.TYPE_DOUBLE, _descriptor.FieldDescriptor.TYPE_FLOAT):
        try:
            return float(value)
        except (TypeError, ValueError):
            raise TypeError("%s: expected a number, got %r" % (path, value)) from None
    return value


def _fill(message, values, path):
    """Sets `message`'s fields from a dict of field names: scalars, enums by name, messages from dicts (or their
    plain forms: colors, digests, vectors, Brdfs), repeated fields from lists. TypeError/ValueError name the path."""
    fields = message.DESCRIPTOR.fields_by_name
    given = {}
    for key, value in values.items():
        if value is None:
            continue  # unset: the server's default
        field = fields.get(key)
        here = path + "." + key
        if field is None:
            raise TypeError("%s: %s has no field %r (fields: %s)"
                            % (path, message.DESCRIPTOR.name, key, ", ".join(fields)))
        if field.containing_oneof is not None:
            oneof = field.containing_oneof.name
            if oneof in given:
                raise ValueError("%s: give one of %s, not both %s and %s"
                                 % (path, ", ".join(f.name for f in field.containing_oneof.fields), given[oneof], key))
            given[oneof] = key
        if field.label == _descriptor.FieldDescriptor.LABEL_REPEATED:
            if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__iter__"):
                raise TypeError("%s: expected a list, got %r" % (here, value))
            target = getattr(message, key)
            del target[:]
            for i, item in enumerate(value):
                item_path = "%s[%d]" % (here, i)
                if field.type == _descriptor.FieldDescriptor.TYPE_MESSAGE:
                    _set_message(target.add(), item, item_path)
                else:
                    target.append(_scalar(field, item, item_path))
        elif field.type == _descriptor.FieldDescriptor.TYPE_MESSAGE:
            _set_message(getattr(message, key), value, here)
        else:
            setattr(message, key, _scalar(field, value, here))


def material_job(model, *, name="", table_mu=None, table_roughness=None, merl=None, samples=None,
                 target_error=None, time_limit_seconds=None, seed=None, force_effects=None, **params):
    """A kiln.pb.JobSpec for a material bake, from keyword arguments.

    `model` is a MaterialJob model ("lambert", "oren_nayar", "oren_nayar_simple", "cook_torrance", "ggx",
    "beckmann", "schlick", "schlick_double", "layered"); the other keywords not named here are that model's fields
    (kiln.proto): alpha, alpha_x, alpha_y, eta, fresnel, distribution, masking, normalization, f0, albedo, sigma,
    interreflection, c, r, p, top, bottom, diffuse, specular, combine, specular_weight. Colors take a number (grey),
    (r, g, b) or a kiln.pb.Color; enums a short name ("schlick", "height_correlated"), the full name or the number;
    nested messages a dict (a Brdf as {"model": "lambert", "albedo": 0.5}). None leaves a field to its default.

        material_job("ggx", alpha=0.3, fresnel="schlick", f0=0.04, table_mu=32, samples=4096)
        material_job("layered", diffuse={"model": "lambert", "albedo": (0.8, 0.2, 0.1)},
                     specular={"model": "ggx", "alpha": 0.2, "fresnel": "exact", "eta": 1.5})
    """
    spec = pb.JobSpec(name=name)
    _set_model(spec.material, model, params, "job.material")
    _fill(spec.material, {"table_mu": table_mu, "table_roughness": table_roughness, "merl": merl}, "job.material")
    _set_quality_and_effects(spec, {"samples": samples, "target_error": target_error,
                                    "time_limit_seconds": time_limit_seconds, "seed": seed}, force_effects)
    return spec


def _set_quality_and_effects(spec, quality, force_effects):
    if any(v is not None for v in quality.values()):
        spec.quality.SetInParent()
        _fill(spec.quality, quality, "job.quality")
    for effect, enabled in (force_effects or {}).items():
        spec.force_effects[effect] = bool(enabled)


def environment_job(image=None, *, faces=None, constant=None, name="", samples=None, target_error=None, seed=None,
                    force_effects=None, **settings):
    """A kiln.pb.JobSpec for an environment bake (image-based lighting), from keyword arguments.

    The environment is exactly one of: `image`, the Digest of an uploaded equirectangular image (what
    Client.upload_file returns, a kiln.pb.Digest or (sha256, size)); `faces`, six such digests in the order
    +X, -X, +Y, -Y, +Z, -Z; `constant`, a radiance (a number, (r, g, b) or a kiln.pb.Color). The other keywords are
    EnvironmentJob's fields (kiln.proto): color_space, rotation_degrees, intensity, lobe ("ggx", "beckmann",
    "cook_torrance", "schlick"), size, levels, irradiance_size, dfg_size, dfg_samples, preview. samples,
    target_error and seed go into the job's quality. None leaves a field to its default.

        with kiln.Client(...) as c:
            job = kiln.environment_job(c.upload_file("sky.exr"), size=128, lobe="ggx")
            c.run(job, out_dir="out/sky_env")
    """
    given = [k for k, v in (("image", image), ("faces", faces), ("constant", constant)) if v is not None]
    if len(given) != 1:
        raise ValueError("job.environment: give exactly one of image, faces or constant, got %s"
                         % (", ".join(given) or "none"))
    spec = pb.JobSpec(name=name)
    env = spec.environment
    if image is not None:
        env.image.CopyFrom(_as_digest(image))
    elif faces is not None:
        faces = list(faces)
        if len(faces) != 6:
            raise ValueError("job.environment.faces: exactly six faces (+X, -X, +Y, -Y, +Z, -Z), got %d" % len(faces))
        for face in faces:
            env.faces.digests.add().CopyFrom(_as_digest(face))
    else:
        _set_color(env.constant, constant, "job.environment.constant")
    _fill(env, settings, "job.environment")
    _set_quality_and_effects(spec, {"samples": samples, "target_error": target_error, "seed": seed}, force_effects)
    return spec


# ---- Framing -----------------------------------------------------------------------------------------------------

def _encode_varint(n):
    out = bytearray()
    while True:
        bits = n & 0x7F
        n >>= 7
        if n:
            out.append(bits | 0x80)
        else:
            out.append(bits)
            return bytes(out)


def _decode_varint(buf):
    """(value, length of the varint) from the start of buf, or None if it is not all there yet."""
    value = 0
    for i in range(min(len(buf), 10)):
        byte = buf[i]
        value |= (byte & 0x7F) << (7 * i)
        if not byte & 0x80:
            return value, i + 1
    if len(buf) >= 10:
        raise ValueError("a frame length longer than 10 bytes")
    return None


def _parse_address(address):
    """("unix", path) or ("tcp", (host, port)); ValueError if malformed."""
    def bad(why):
        return ValueError('server address "%s": %s' % (address, why))

    if address.startswith("unix:"):
        path = address[5:]
        if not path:
            raise bad('no socket path after "unix:"')
        if len(os.fsencode(path)) > _MAX_UNIX_PATH_BYTES:
            raise bad("socket path longer than %d bytes" % _MAX_UNIX_PATH_BYTES)
        return "unix", path
    host, colon, port = address.rpartition(":")
    if not colon:
        raise bad("expected HOST:PORT or unix:PATH")
    if len(host) >= 2 and host[0] == "[" and host[-1] == "]":
        host = host[1:-1]
    elif ":" in host:
        raise bad("an IPv6 address goes in brackets, e.g. [::1]:7878")
    if not host:
        raise bad("no host before the port")
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise bad("port must be a number in [1, 65535]")
    return "tcp", (host, int(port))


def _read_token_file(path):
    with open(path, "r", encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#"):
                return line
    raise KilnError("%s: the token file holds no token (blank lines and # comments are skipped)" % path)


def _safe_output_name(name):
    return (bool(name) and name not in (".", "..") and "/" not in name and "\\" not in name and "\0" not in name)


# ---- The client --------------------------------------------------------------------------------------------------

class Client:
    """One connection to kilnd.

    address: "HOST:PORT" (an IPv6 host in brackets) or "unix:PATH"; default $KILN_SERVER, else 127.0.0.1:7878.
    token: for TCP (the Unix socket's permissions decide there); default: the first line of token_file that is not
    blank or a # comment, else $KILN_TOKEN, else the file named by $KILN_TOKEN_FILE.
    timeout: seconds for each request to be sent and for each response to arrive; while watching, for each event
    (never less than twice the server's heartbeat period). connect_timeout: seconds for connecting.

    The constructor connects (ConnectionError if it cannot); the first request says hello with the token (hello()
    does it explicitly and returns the server's HelloReply). Use as a context manager or call close().
    """

    def __init__(self, address=None, token=None, timeout=60.0, *, token_file=None, connect_timeout=10.0,
                 client_name=_CLIENT_NAME):
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
        except builtins.TimeoutError as e:
            raise TimeoutError("connecting to %s timed out after %g s" % (self.address, self.connect_timeout)) from e
        except OSError as e:
            raise ConnectionError("connecting to %s: %s" % (self.address, e.strerror or e)) from e
        self._sock = sock

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
        token is wrong or missing on TCP."""
        if self._sock is None:
            self._connect()
        request = pb.Request()
        request.hello.protocol_version = PROTOCOL_VERSION
        request.hello.token = self.token
        request.hello.client = self.client_name
        reply = self._await({self._start(request)}, "hello").hello
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
        restarts = 0
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
                if e.code != pb.Error.FAILED_PRECONDITION or restarts >= _MAX_UPLOAD_RESTARTS:
                    raise
                restarts += 1

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
