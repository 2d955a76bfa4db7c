"""kiln.build: bake a build manifest (kiln.build.textproto) from Python, as `kiln build` does (docs/BUILD.md).

    import kiln
    result = kiln.build("assets/kiln.build.textproto", address="bake.example:7878", token_file="token",
                        jobs=4, report_junit="out/junit.xml")
    print(result.summary["baked"], result.summary["cached"])
    if not result.ok:
        for bake in result.failed():
            print(bake["name"], bake["failure"]["message"])

The build itself is the kiln program's (client/cli/build_*.cpp): the same planner of bakes (a manifest's commands
are `kiln bake` command lines, and lightmap scenes are imported with Assimp, both in C++), the same upload, checks,
folder writes and reports. This module runs it with the connection settings of kiln.Client and hands back its JSON
summary, so that a pipeline driving builds from Python gets exactly the command line's behaviour.
"""

import glob
import json
import os
import shutil
import subprocess
import tempfile

from .errors import ConnectionError, KilnError


class BuildResult:
    """How a build ended. ok: every bake succeeded and passed its checks. summary: the JSON report (docs/BUILD.md:
    totals, then each bake under "results"). exit_status: kiln build's (0 ok, 1 a bake failed). output: the
    one-screen summary it printed; log: its progress lines."""

    def __init__(self, exit_status, summary, output, log):
        self.exit_status = exit_status
        self.summary = summary
        self.output = output
        self.log = log

    @property
    def ok(self):
        return self.exit_status == 0

    def failed(self):
        """The bakes that failed, missed a check or could not be written."""
        return [b for b in self.summary["results"] if b["status"] in ("failed", "error")]

    def __repr__(self):
        s = self.summary
        return "<BuildResult %d bakes: %d baked, %d cached, %d failed>" % (
            s["bakes"], s["baked"], s["cached"], s["failed"] + s["errors"])


def _find_kiln(program):
    """The kiln program: `program`, else $KILN_CLI, else `kiln` on PATH, else <repository>/build*/bin/kiln."""
    if program:
        return program
    if os.environ.get("KILN_CLI"):
        return os.environ["KILN_CLI"]
    found = shutil.which("kiln")
    if found:
        return found
    repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    built = sorted(glob.glob(os.path.join(repo, "build*", "bin", "kiln")), key=os.path.getmtime, reverse=True)
    if built:
        return built[0]
    raise KilnError("kiln.build needs the kiln program (the C++ client, which plans and runs builds): install the "
                    "kiln-client package, put kiln on PATH, or pass kiln=PATH or set $KILN_CLI")


def build(manifest=".", *, address=None, token=None, token_file=None, tls_ca=None, tls_cert=None, tls_key=None,
          jobs=None, keep_going=False, only=(), report_junit=None, report_json=None, kiln=None, timeout=None):
    """Bakes the manifest (a file, or a folder holding kiln.build.textproto) and returns a BuildResult.

    address, token, token_file, tls_ca, tls_cert, tls_key: as kiln.Client takes them (defaults from $KILN_SERVER,
    $KILN_TOKEN, $KILN_TOKEN_FILE, $KILN_TLS_*); the token goes to the kiln program in its environment, never on its
    command line. jobs: at most this many bakes unfinished at a time (default all). keep_going: submit the rest after
    a failure. only: bake only these names (a glob's bakes by NAME or NAME/STEM). report_junit, report_json: also
    write those reports. kiln: the kiln program (default: see _find_kiln). timeout: seconds for the whole build.

    A failed bake is an outcome (result.ok is False), not an exception. Raises KilnError for a usage error (a bad
    manifest, a missing input; the message is kiln's, naming the file and line) and ConnectionError when kilnd
    cannot be reached or the connection was lost.
    """
    args = [_find_kiln(kiln)]
    env = dict(os.environ)
    if address:
        args += ["--server", address]
    if token is not None:
        env["KILN_TOKEN"] = token
        env.pop("KILN_TOKEN_FILE", None)
    elif token_file:
        args += ["--token-file", os.fspath(token_file)]
    for flag, value in (("--tls-ca", tls_ca), ("--tls-cert", tls_cert), ("--tls-key", tls_key)):
        if value:
            args += [flag, os.fspath(value)]
    args += ["build", os.fspath(manifest)]
    if jobs is not None:
        args += ["--jobs", str(int(jobs))]
    if keep_going:
        args.append("--keep-going")
    if isinstance(only, str):
        only = [only]
    for name in only:
        args += ["--only", name]
    if report_junit:
        args += ["--report-junit", os.fspath(report_junit)]
    with tempfile.TemporaryDirectory(prefix="kiln_build_") as tmp:
        json_path = os.fspath(report_json) if report_json else os.path.join(tmp, "build.json")
        args += ["--report-json", json_path]
        run = subprocess.run(args, env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True,
                             timeout=timeout)
        if run.returncode not in (0, 1):
            message = run.stderr.strip().splitlines()[-1] if run.stderr.strip() else "exit status %d" % run.returncode
            if message.startswith("kiln: "):
                message = message[len("kiln: "):]
            raise (ConnectionError if run.returncode == 3 else KilnError)("kiln build %s: %s" % (manifest, message))
        with open(json_path) as f:
            summary = json.load(f)
    return BuildResult(run.returncode, summary, run.stdout, run.stderr)
