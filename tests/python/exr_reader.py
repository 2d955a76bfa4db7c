"""A small OpenEXR reader in plain Python (zlib and struct), so the Python tests can check kilnd's images without
OpenEXR or numpy bindings, and with a decoder independent of the one kilnd writes with (OpenImageIO).

It reads what kilnd writes and little more: one part, scanline (not tiled, not deep), compression NONE, ZIPS or ZIP,
channels of HALF, FLOAT or UINT. Layout and ZIP coding after "The OpenEXR File Layout" (openexr.com): a header of
attributes, a table of chunk offsets, then chunks of (y, size, data); ZIP data is zlib of bytes split into even and
odd halves with a delta predictor; within a scan line, channels in alphabetical order, each a whole row.
"""

import struct
import zlib

_MAGIC = 20000630
_LINES_PER_CHUNK = {0: 1, 2: 1, 3: 16}  # NONE, ZIPS, ZIP
_PIXEL_BYTES = {0: 4, 1: 2, 2: 4}       # UINT, HALF, FLOAT
_PIXEL_FORMAT = {0: "I", 1: "e", 2: "f"}


class ExrImage:
    """width, height, and channels: {name: [row 0 values..., row 1 values..., ...]} (row 0 is the top, stored
    first); attributes: {name: (type, raw bytes)}."""

    def __init__(self, width, height, channels, attributes):
        self.width = width
        self.height = height
        self.channels = channels
        self.attributes = attributes

    def at(self, channel, x, y):
        return self.channels[channel][y * self.width + x]

    def string(self, name):
        kind, raw = self.attributes[name]
        if kind != "string":
            raise ValueError("attribute %s is a %s" % (name, kind))
        return raw.decode("utf-8")


def _undo_zip(data, expected):
    t = bytearray(zlib.decompress(data))
    if len(t) != expected:
        raise ValueError("a ZIP chunk inflates to %d bytes, %d expected" % (len(t), expected))
    for i in range(1, len(t)):  # the predictor: each byte was stored as the difference to the previous one + 128
        t[i] = (t[i - 1] + t[i] - 128) & 0xFF
    half = (len(t) + 1) // 2
    out = bytearray(len(t))
    out[0::2] = t[:half]  # the first half holds the even bytes, the second the odd ones
    out[1::2] = t[half:]
    return bytes(out)


def read_exr(data):
    """An ExrImage from the bytes of an .exr file. ValueError for what this reader does not handle."""
    magic, version = struct.unpack_from("<iI", data, 0)
    if magic != _MAGIC:
        raise ValueError("not an OpenEXR file")
    if version & 0xFF != 2 or version & 0x1A00:  # version 2; not tiled (0x200), deep (0x800) or multi-part (0x1000)
        raise ValueError("an OpenEXR layout this reader does not handle (version field 0x%x)" % version)
    at = 8
    attributes = {}
    while data[at] != 0:
        end = data.index(b"\0", at)
        name = data[at:end].decode()
        at = end + 1
        end = data.index(b"\0", at)
        kind = data[at:end].decode()
        at = end + 1
        (size,) = struct.unpack_from("<i", data, at)
        at += 4
        attributes[name] = (kind, data[at:at + size])
        at += size
    at += 1
    compression = attributes["compression"][1][0]
    if compression not in _LINES_PER_CHUNK:
        raise ValueError("compression %d is not NONE, ZIPS or ZIP" % compression)
    x0, y0, x1, y1 = struct.unpack("<4i", attributes["dataWindow"][1])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    channels = []  # (name, pixel type), in the file's (alphabetical) order
    raw = attributes["channels"][1]
    i = 0
    while raw[i] != 0:
        end = raw.index(b"\0", i)
        name = raw[i:end].decode()
        pixel_type, _linear, x_sampling, y_sampling = struct.unpack_from("<iBxxxii", raw, end + 1)
        if (x_sampling, y_sampling) != (1, 1):
            raise ValueError("channel %s is subsampled" % name)
        channels.append((name, pixel_type))
        i = end + 1 + 16
    lines = _LINES_PER_CHUNK[compression]
    chunks = (height + lines - 1) // lines
    offsets = struct.unpack_from("<%dQ" % chunks, data, at)
    values = {name: [] for name, _ in channels}
    row_bytes = sum(_PIXEL_BYTES[t] for _, t in channels) * width
    for offset in offsets:
        y, size = struct.unpack_from("<ii", data, offset)
        count = min(lines, y0 + height - y)
        block = data[offset + 8:offset + 8 + size]
        if size < row_bytes * count:  # stored as it is when compressing would not have made it smaller
            block = _undo_zip(block, row_bytes * count)
        at = 0
        for _ in range(count):
            for name, pixel_type in channels:
                n = _PIXEL_BYTES[pixel_type] * width
                values[name].extend(struct.unpack_from("<%d%s" % (width, _PIXEL_FORMAT[pixel_type]), block, at))
                at += n
    return ExrImage(width, height, values, attributes)
