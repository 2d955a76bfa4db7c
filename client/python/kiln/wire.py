"""The wire under the Client: frames (each message preceded by its length as a varint), server addresses and token
files."""

import os

from .errors import KilnError

# sockaddr_un.sun_path holds 108 bytes on Linux, including the terminating zero.
_MAX_UNIX_PATH_BYTES = 107


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
