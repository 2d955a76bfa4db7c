"""Digests, the protocol's names of bytes: kiln.pb.Digest(sha256=lowercase hex, size)."""

import hashlib

from . import kiln_pb2 as pb


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
