"""The errors the kiln client raises: ServerError when kilnd refuses a request, ConnectionError (TimeoutError) when the
connection cannot be made, breaks or times out; both derive from KilnError."""

import builtins

from . import kiln_pb2 as pb


class KilnError(Exception):
    """Base of every error this package raises on purpose."""


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


class TlsError(ConnectionError):
    """TLS failed: the server does not speak it, its certificate is not trusted or not for this host, or it refused
    this client's certificate. The message says which and what to do."""


class TimeoutError(ConnectionError, builtins.TimeoutError):  # noqa: A001 (mirrors the C++ client's name)
    """Connecting, sending or receiving took longer than its timeout."""
