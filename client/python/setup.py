"""Builds the kiln package with its protocol module, kiln/kiln_pb2.py.

The module is generated while the package is built, so that an installed kiln never points into a source or build
tree: if kiln/kiln_pb2.py is already in the package folder (the staged copy the CMake build turns into a wheel), it is
used as it is; otherwise protoc ($PROTOC, else `protoc` on PATH) generates it from kiln.proto ($KILN_PROTO, else
proto/kiln.proto of the repository this folder belongs to). Everything else is in pyproject.toml.
"""

import os
import shutil
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
PB2 = "kiln_pb2.py"


def _fail(message):
    sys.stderr.write("kiln-client: %s\n" % message)
    raise SystemExit(1)


def _proto_path():
    path = os.environ.get("KILN_PROTO") or os.path.join(HERE, "..", "..", "proto", "kiln.proto")
    if not os.path.isfile(path):
        _fail("cannot generate kiln/%s: %s does not exist. Build the package from a kiln checkout "
              "(client/python), set KILN_PROTO to kiln.proto, or install the wheel kiln's build makes "
              "(<build>/python/dist/)" % (PB2, path))
    return os.path.abspath(path)


def _protoc():
    protoc = os.environ.get("PROTOC") or shutil.which("protoc")
    if not protoc:
        _fail("cannot generate kiln/%s: protoc is not installed (Debian: apt-get install protobuf-compiler) and "
              "$PROTOC is not set; or install the wheel kiln's build makes (<build>/python/dist/), which carries "
              "the module" % PB2)
    return protoc


class BuildWithProto(build_py):
    """build_py that also puts kiln_pb2.py into the built package."""

    def run(self):
        super().run()
        target = os.path.join(self.build_lib, "kiln")
        if os.path.isfile(os.path.join(HERE, "kiln", PB2)):
            return  # copied by build_py with the other modules
        proto = _proto_path()
        os.makedirs(target, exist_ok=True)
        command = [_protoc(), "--proto_path=" + os.path.dirname(proto), "--python_out=" + target, proto]
        result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
        if result.returncode != 0:
            _fail("%s failed (exit %d):\n%s" % (" ".join(command), result.returncode, result.stdout))
        if not os.path.isfile(os.path.join(target, PB2)):
            _fail("%s made no %s in %s" % (" ".join(command), PB2, target))


setup(cmdclass={"build_py": BuildWithProto})
