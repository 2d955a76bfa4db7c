"""kiln: the Python client of the kiln baking service (kilnd).

    import kiln
    with kiln.Client("127.0.0.1:7878") as c:            # token from $KILN_TOKEN, or token=..., token_file=...
        job = kiln.material_job("ggx", alpha=0.3, fresnel="schlick", f0=0.04, table_mu=32, samples=4096)
        reply = c.submit(job)
        final = c.watch(reply.job_id, on_event=lambda e: print(e.fraction))
        paths = c.fetch_outputs(reply.job_id, "out/ggx")  # every output, its SHA-256 verified

The protocol's messages (kiln.v1, proto/kiln.proto) are `kiln.pb`: code protoc generates from kiln.proto. An
installed kiln (pip, the wheel of the build, the kiln-client package) carries it as kiln/kiln_pb2.py. Run from the
source tree or an installed one, this package finds it, in this order:
  1. in the folder named by $KILN_PYTHON_PROTO (<build>/python/kiln, made by the build target kiln_proto_python);
  2. in this package's own folder (how an installed kiln has it);
  3. in <repository>/build*/python/kiln/ (a build tree next to the sources; the newest if there are several);
  4. as a top-level module `kiln_pb2` on sys.path.
It needs the protobuf runtime, 3.20 or newer (Debian's python3-protobuf), and nothing else beyond the standard library.
"""

import glob as _glob
import importlib as _importlib
import os as _os
import sys as _sys

_PB2 = "kiln_pb2.py"


def _load_pb2():
    here = _os.path.dirname(_os.path.abspath(__file__))
    env = _os.environ.get("KILN_PYTHON_PROTO")
    if env:
        if not _os.path.isfile(_os.path.join(env, _PB2)):
            raise ImportError(
                "KILN_PYTHON_PROTO=%s holds no %s: build the target kiln_proto_python and point it at "
                "<build>/python/kiln" % (env, _PB2))
        candidates = [env]
    elif _os.path.isfile(_os.path.join(here, _PB2)):
        candidates = []  # a plain submodule import finds it
    else:
        repo = _os.path.dirname(_os.path.dirname(_os.path.dirname(here)))
        found = _glob.glob(_os.path.join(repo, "build*", "python", "kiln", _PB2))
        found.sort(key=_os.path.getmtime, reverse=True)
        candidates = [_os.path.dirname(found[0])] if found else []
    for folder in candidates:
        if folder not in __path__:
            __path__.append(folder)
    try:
        return _importlib.import_module(__name__ + ".kiln_pb2")
    except ModuleNotFoundError as e:
        if e.name != __name__ + ".kiln_pb2":
            raise  # e.g. google.protobuf itself is missing: say so, not something else
    try:
        module = _importlib.import_module("kiln_pb2")
    except ModuleNotFoundError as e:
        if e.name != "kiln_pb2":
            raise
        raise ImportError(
            "kiln: cannot find kiln_pb2.py (generated from proto/kiln.proto by the build target kiln_proto_python); "
            "set KILN_PYTHON_PROTO to <build>/python/kiln") from None
    _sys.modules[__name__ + ".kiln_pb2"] = module
    return module


pb = _load_pb2()

# The modules below need pb loaded first.
from .build import BuildResult, build  # noqa: E402
from .client import PROTOCOL_VERSION, Client  # noqa: E402
from .digests import digest_of  # noqa: E402
from .errors import ConnectionError, KilnError, ServerError, TimeoutError, TlsError  # noqa: E402
from .jobs import environment_job, load_job, material_job, parse_job, state_name  # noqa: E402
from .lightmap import Mesh, lightmap_job, mesh, probes_job  # noqa: E402

__all__ = [
    "PROTOCOL_VERSION",
    "BuildResult",
    "Client",
    "ConnectionError",
    "KilnError",
    "Mesh",
    "ServerError",
    "TimeoutError",
    "TlsError",
    "build",
    "digest_of",
    "environment_job",
    "lightmap_job",
    "load_job",
    "material_job",
    "mesh",
    "parse_job",
    "pb",
    "probes_job",
    "state_name",
]
