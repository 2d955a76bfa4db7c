"""Tests of the Python client (client/python/kiln) against the real kilnd, and against a scripted fake server for
what a well-behaved kilnd never does (corrupt bytes, interleaved responses, connection-level errors).

Run by CTest (tests/CMakeLists.txt, test "python_client") as
    KILND=<build>/bin/kilnd KILN_PYTHON_PROTO=<build>/python/kiln PYTHONPATH=client/python \
        /usr/bin/python3 -m unittest -v test_client          (from tests/python)
python3-protobuf is imported unguarded: without it these tests fail, they are not skipped.
"""

import hashlib
import os
import random
import shutil
import signal
import socket
import subprocess
import tempfile
import threading
import time
import unittest

import google.protobuf  # noqa: F401  (python3-protobuf; fails loudly if missing)

import kiln
from kiln import pb

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
TOKEN = "python-client-test-token-0123456789"


def ggx_job(alpha, samples=512, table=8, name=None):
    return kiln.material_job("ggx", name=name or "ggx %g" % alpha, alpha=alpha, table_mu=table, table_roughness=table,
                             samples=samples)


class Daemon:
    """The real kilnd in a temporary folder: TCP on a free loopback port and a Unix socket; extra_flags appended."""

    def __init__(self, extra_flags=()):
        binary = os.environ.get("KILND")
        if not binary or not os.access(binary, os.X_OK):
            raise RuntimeError("set KILND to the kilnd binary (<build>/bin/kilnd); CTest does")
        self.dir = tempfile.mkdtemp(prefix="kiln_py_")
        self.socket = os.path.join(self.dir, "kilnd.sock")
        tokens = os.path.join(self.dir, "tokens")
        with open(os.open(tokens, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
            f.write(TOKEN + "\n")
        self.out = os.path.join(self.dir, "kilnd.out")
        self.log_path = os.path.join(self.dir, "kilnd.log")
        with open(self.out, "w") as out, open(self.log_path, "w") as err:
            self.proc = subprocess.Popen(
                [binary, "--listen", "127.0.0.1:0", "--socket", self.socket, "--store",
                 os.path.join(self.dir, "store"), "--token-file", tokens, "--workers", "2",
                 "--hello-deadline", "2", *extra_flags],
                stdout=out, stderr=err, stdin=subprocess.DEVNULL)
        self.port = None
        prefix = "kilnd: listening on 127.0.0.1:"
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            with open(self.out) as f:
                for line in f:
                    if line.startswith(prefix):
                        self.port = int(line[len(prefix):])
            if self.port and os.path.exists(self.socket):
                return
            if self.proc.poll() is not None:
                raise RuntimeError("kilnd exited at start:\n" + self.log())
            time.sleep(0.05)
        self.stop()
        raise RuntimeError("kilnd did not start within 30 s:\n" + self.log())

    @property
    def tcp(self):
        return "127.0.0.1:%d" % self.port

    @property
    def unix(self):
        return "unix:" + self.socket

    def log(self):
        with open(self.log_path) as f:
            return f.read()

    def client(self, **kw):
        return kiln.Client(self.tcp, token=TOKEN, timeout=30, **kw)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self.dir, ignore_errors=True)


DAEMON = None


def setUpModule():
    global DAEMON
    DAEMON = Daemon()


def tearDownModule():
    if DAEMON is not None:
        DAEMON.stop()


def sha256(data):
    return hashlib.sha256(data).hexdigest()


class AgainstKilnd(unittest.TestCase):
    def setUp(self):
        self.c = DAEMON.client()
        self.addCleanup(self.c.close)

    def submit_watch_fetch(self, client, job):
        sub = client.submit(job)
        self.assertFalse(sub.cache_hit)
        events = []
        final = client.watch(sub.job_id, on_event=events.append)
        self.assertTrue(final.final)
        self.assertEqual(final.state, pb.JOB_STATE_SUCCEEDED, final.message + DAEMON.log())
        self.assertGreaterEqual(len(events), 1)
        self.assertIs(events[-1], final)
        fractions = [e.fraction for e in events]
        self.assertEqual(fractions, sorted(fractions), "progress never goes backwards")
        result = client.result(sub.job_id)
        self.assertEqual(result.state, pb.JOB_STATE_SUCCEEDED)
        self.assertEqual({o.name for o in result.outputs}, {"albedo.exr", "split_sum.exr", "preview.png", "report.json"})
        for output in result.outputs:
            data = client.fetch(output.digest)  # the client verifies too; check independently
            self.assertEqual(len(data), output.digest.size)
            self.assertEqual(sha256(data), output.digest.sha256)
        self.assertGreater(result.report.samples, 0)
        self.assertGreater(result.report.seconds, 0)
        self.assertTrue(result.report.json)
        return sub, result

    def test_submit_watch_fetch_over_tcp(self):
        sub, result = self.submit_watch_fetch(self.c, ggx_job(0.3))
        out = tempfile.mkdtemp(prefix="kiln_py_out_")
        self.addCleanup(shutil.rmtree, out, True)
        paths = self.c.fetch_outputs(sub.job_id, out)
        self.assertEqual([os.path.basename(p) for p in paths], [o.name for o in result.outputs])
        for path, output in zip(paths, result.outputs):
            with open(path, "rb") as f:
                self.assertEqual(sha256(f.read()), output.digest.sha256)
        self.assertEqual(sorted(os.listdir(out)), sorted(o.name for o in result.outputs), "no temporary files left")

    def test_submit_watch_fetch_over_unix_socket_without_token(self):
        with kiln.Client(DAEMON.unix, token="", timeout=30) as c:
            self.submit_watch_fetch(c, ggx_job(0.4))

    def test_identical_job_is_a_cache_hit_with_the_same_digests(self):
        first = self.c.submit(ggx_job(0.5))
        self.assertEqual(self.c.watch(first.job_id).state, pb.JOB_STATE_SUCCEEDED)
        hits = self.c.status().cache_hits
        second = self.c.submit(ggx_job(0.5, name="another name, same bake"))
        self.assertTrue(second.cache_hit)
        self.assertEqual(second.state, pb.JOB_STATE_SUCCEEDED)
        self.assertNotEqual(second.job_id, first.job_id)
        r1, r2 = self.c.result(first.job_id), self.c.result(second.job_id)
        self.assertEqual([(o.name, o.digest.sha256) for o in r1.outputs],
                         [(o.name, o.digest.sha256) for o in r2.outputs])
        self.assertTrue(r2.report.cache_hit)
        self.assertEqual(self.c.status().cache_hits, hits + 1)
        # The outputs of the cache hit are the same bytes.
        for o in r2.outputs:
            self.assertEqual(sha256(self.c.fetch(o)), o.digest.sha256)

    def test_bad_field_is_named(self):
        with self.assertRaises(kiln.ServerError) as caught:
            self.c.submit(ggx_job(-0.2))
        e = caught.exception
        self.assertEqual(e.code, pb.Error.INVALID_ARGUMENT, str(e))
        self.assertEqual(e.code_name, "INVALID_ARGUMENT")
        self.assertEqual(e.field, "job.material.ggx.alpha")
        self.assertIn("job.material.ggx.alpha", str(e))
        # The connection goes on serving.
        self.assertGreaterEqual(self.c.status().workers, 1)

    def test_blob_of_2_5_mib_round_trips_in_chunks(self):
        data = random.Random(7).randbytes(5 << 19)  # 2.5 MiB: three chunks of at most 1 MiB
        puts, fetches = [], []
        put, call = self.c.put_blob_chunk, self.c._call

        def counting_put(digest, offset, chunk):
            puts.append((offset, len(chunk)))
            return put(digest, offset, chunk)

        def counting_call(request, expected):
            if expected == "fetch":
                fetches.append(request.fetch.offset)
            return call(request, expected)

        self.c.put_blob_chunk = counting_put
        self.c._call = counting_call
        digest = self.c.upload_blob(data)
        self.assertEqual(digest.sha256, sha256(data))
        self.assertEqual(digest.size, len(data))
        chunk = self.c.limits.max_chunk_bytes
        self.assertGreaterEqual(len(puts), 3)
        self.assertTrue(all(n <= chunk for _, n in puts), puts)
        self.assertEqual(puts[0][0], 0)
        self.assertEqual(list(self.c.query_blobs([digest]).missing), [])
        self.assertEqual(self.c.fetch(digest), data)
        self.assertGreaterEqual(len(fetches), 3)
        # Uploading it again sends nothing: the server has it.
        del puts[:]
        self.assertEqual(self.c.upload_blob(data), digest)
        self.assertEqual(puts, [])

    def test_broken_upload_resumes_from_the_servers_offset(self):
        data = random.Random(11).randbytes(3 << 19)  # 1.5 MiB
        digest = kiln.digest_of(data)
        head = 300 << 10
        self.assertTrue(self.c.put_blob_chunk(digest, 0, data[:head]).received == head)
        self.c.close()  # the "broken" connection
        missing = self.c.query_blobs([digest]).missing  # reconnects and says hello again
        self.assertEqual([m.received for m in missing], [head])
        offsets = []
        put = self.c.put_blob_chunk
        self.c.put_blob_chunk = lambda d, off, chunk: (offsets.append(off), put(d, off, chunk))[1]
        self.assertEqual(self.c.upload_blob(data), digest)
        self.assertEqual(offsets[0], head)
        self.assertEqual(self.c.fetch(digest), data)

    def test_concurrent_uploads_of_one_blob_all_succeed(self):
        # Four clients upload the same 8 MiB at once: chunks find the offset moved by another client, and each
        # upload still ends with the blob stored.
        data = random.Random(12).randbytes(8 << 20)
        digests, errors = [], []

        def upload():
            try:
                with kiln.Client(DAEMON.tcp, token=TOKEN, timeout=60) as c:
                    digests.append(c.upload_blob(data))
            except Exception as e:  # noqa: BLE001 (reported below)
                errors.append(e)

        threads = [threading.Thread(target=upload) for _ in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        self.assertEqual(errors, [])
        self.assertEqual([d.sha256 for d in digests], [hashlib.sha256(data).hexdigest()] * 4)
        self.assertEqual(self.c.fetch(digests[0]), data)

    def test_wrong_or_missing_token_is_refused(self):
        for token in ["wrong-token-0123456789", "", TOKEN + "x"]:
            with kiln.Client(DAEMON.tcp, token=token, timeout=30) as c:
                with self.assertRaises(kiln.ServerError) as caught:
                    c.hello()
                self.assertEqual(caught.exception.code, pb.Error.UNAUTHENTICATED, str(caught.exception))
                self.assertEqual(caught.exception.field, "token")
                # Any request says hello first, and is refused the same way.
                with self.assertRaises(kiln.ServerError) as caught:
                    c.status()
                self.assertEqual(caught.exception.code, pb.Error.UNAUTHENTICATED)

    def test_token_from_environment_and_file(self):
        saved = {k: os.environ.pop(k, None) for k in ("KILN_TOKEN", "KILN_TOKEN_FILE")}

        def restore():
            for k, v in saved.items():
                os.environ.pop(k, None)
                if v is not None:
                    os.environ[k] = v

        self.addCleanup(restore)
        os.environ["KILN_TOKEN"] = TOKEN
        with kiln.Client(DAEMON.tcp) as c:
            self.assertEqual(c.hello().protocol_version, kiln.PROTOCOL_VERSION)
        del os.environ["KILN_TOKEN"]
        token_file = os.path.join(DAEMON.dir, "client-token")
        with open(token_file, "w") as f:
            f.write("# the token\n\n  %s  \n" % TOKEN)
        with kiln.Client(DAEMON.tcp, token_file=token_file) as c:
            self.assertIn("material", c.hello().job_types)

    def test_a_client_made_long_before_its_first_request_is_served(self):
        # kilnd closes a connection that has not said hello within its hello deadline (2 s for this daemon); the
        # client says hello on a fresh connection instead of the constructor's stale one.
        with DAEMON.client() as c:
            time.sleep(2.5)
            self.assertEqual(c.status().server_version.split()[0], "kilnd")

    def test_watch_all_list_status_cancel(self):
        ids = [self.c.submit(ggx_job(a, samples=256, table=4)).job_id for a in (0.61, 0.62, 0.63)]
        seen = set()
        finals = self.c.watch_all(ids, on_event=lambda e: seen.add(e.job_id))
        self.assertEqual(set(finals), set(ids))
        self.assertEqual(seen, set(ids))
        self.assertTrue(all(e.state == pb.JOB_STATE_SUCCEEDED for e in finals.values()))
        listed = {j.job_id: j for j in self.c.list_jobs(limit=1000).jobs}
        for job_id in ids:
            self.assertEqual(listed[job_id].state, pb.JOB_STATE_SUCCEEDED)
            self.assertEqual(listed[job_id].type, "material")
        self.assertEqual(len(self.c.list_jobs(limit=2).jobs), 2)
        status = self.c.status()
        self.assertGreaterEqual(status.jobs_completed, 3)
        self.assertGreater(status.uptime_seconds, 0)
        # Cancelling a job that has ended reports how it ended.
        self.assertEqual(self.c.cancel(ids[0]), pb.JOB_STATE_SUCCEEDED)
        # A watch of an ended job answers with one final event.
        events = []
        self.assertEqual(self.c.watch(ids[1], events.append).state, pb.JOB_STATE_SUCCEEDED)
        self.assertEqual(len(events), 1)

    def test_run_and_errors_on_unknown_jobs(self):
        out = tempfile.mkdtemp(prefix="kiln_py_out_")
        self.addCleanup(shutil.rmtree, out, True)
        result = self.c.run(ggx_job(0.7, samples=256, table=4), out_dir=out)
        self.assertEqual(result.state, pb.JOB_STATE_SUCCEEDED)
        self.assertEqual(sorted(os.listdir(out)), sorted(o.name for o in result.outputs))
        for call in (self.c.result, self.c.watch, lambda i: self.c.fetch_outputs(i, out)):
            with self.assertRaises(kiln.ServerError) as caught:
                call("no-such-job")
            self.assertEqual(caught.exception.code, pb.Error.NOT_FOUND, str(caught.exception))

    def test_environment_job_bakes_and_a_bad_image_fails_naming_it(self):
        small = dict(size=16, irradiance_size=8, dfg_size=8, dfg_samples=64, preview=False, samples=16)
        sub = self.c.submit(kiln.environment_job(constant=(0.5, 1.0, 2.0), name="py env", **small))
        self.assertEqual(self.c.watch(sub.job_id).state, pb.JOB_STATE_SUCCEEDED, DAEMON.log())
        result = self.c.result(sub.job_id)
        names = {o.name for o in result.outputs}
        self.assertTrue({"specular.ktx2", "specular_L2_nz.exr", "irradiance_px.exr", "sh.txt", "dfg.exr",
                         "report.json"} <= names, names)
        self.assertNotIn("preview.png", names)
        for output in result.outputs:
            self.assertEqual(sha256(self.c.fetch(output.digest)), output.digest.sha256)
        # An upload that is not an image: the job fails with the decoder's message, naming the image's field.
        with tempfile.NamedTemporaryFile(suffix=".exr") as f:
            f.write(b"this is not an image at all")
            f.flush()
            digest = self.c.upload_file(f.name)
        bad = self.c.submit(kiln.environment_job(digest, **small))
        final = self.c.watch(bad.job_id)
        self.assertEqual(final.state, pb.JOB_STATE_FAILED)
        error = self.c.result(bad.job_id).error
        self.assertEqual(error.code, pb.Error.INVALID_ARGUMENT, error.message)
        self.assertEqual(error.field, "job.environment.image")
        self.assertIn("not an image", error.message)

    def test_unreachable_server_is_a_connection_error(self):
        listener = socket.socket()
        listener.bind(("127.0.0.1", 0))
        port = listener.getsockname()[1]
        listener.close()  # nothing listens there now
        with self.assertRaises(kiln.ConnectionError):
            kiln.Client("127.0.0.1:%d" % port, token=TOKEN)
        with self.assertRaises(kiln.ConnectionError):
            kiln.Client("unix:" + os.path.join(DAEMON.dir, "no-such.sock"))
        with self.assertRaises(ValueError):
            kiln.Client("no-port-here")


class FakeServer:
    """One connection, answered by `script(request, send)` for each request; Hello is answered for it."""

    def __init__(self, script):
        self.script = script
        self.listener = socket.socket()
        self.listener.bind(("127.0.0.1", 0))
        self.listener.listen(1)
        self.address = "127.0.0.1:%d" % self.listener.getsockname()[1]
        self.thread = threading.Thread(target=self.serve, daemon=True)
        self.thread.start()

    def serve(self):
        conn, _ = self.listener.accept()
        with conn:
            buf = b""
            while True:
                data = conn.recv(1 << 16)
                if not data:
                    return
                buf += data
                while True:
                    shift = size = pos = 0
                    while pos < len(buf):
                        size |= (buf[pos] & 0x7F) << shift
                        shift += 7
                        pos += 1
                        if not buf[pos - 1] & 0x80:
                            break
                    else:
                        break
                    if len(buf) < pos + size:
                        break
                    request = pb.Request.FromString(buf[pos:pos + size])
                    buf = buf[pos + size:]

                    def send(response):
                        payload = response.SerializeToString()
                        conn.sendall(kiln.client._encode_varint(len(payload)) + payload)

                    if request.HasField("hello"):
                        reply = pb.Response(id=request.id)
                        reply.hello.protocol_version = 1
                        reply.hello.limits.max_frame_bytes = 4 << 20
                        reply.hello.limits.max_chunk_bytes = 1000
                        reply.hello.limits.heartbeat_seconds = 1
                        send(reply)
                    elif self.script(request, send) == "close":
                        return

    def close(self):
        self.listener.close()
        self.thread.join(5)


class AgainstAFakeServer(unittest.TestCase):
    def fake(self, script):
        self.server = FakeServer(script)
        self.addCleanup(self.server.close)
        client = kiln.Client(self.server.address, token="t", timeout=5)
        self.addCleanup(client.close)
        return client

    def test_fetched_bytes_that_do_not_match_the_digest_raise(self):
        good = b"the real bytes " * 200
        bad = bytearray(good)
        bad[1234] ^= 1

        def script(request, send):
            reply = pb.Response(id=request.id)
            start = request.fetch.offset
            reply.fetch.offset = start
            reply.fetch.data = bytes(bad[start:start + request.fetch.length])
            reply.fetch.eof = start + request.fetch.length >= len(bad)
            send(reply)

        c = self.fake(script)
        with self.assertRaises(kiln.ServerError) as caught:
            c.fetch(kiln.digest_of(good))
        self.assertEqual(caught.exception.code, pb.Error.DATA_LOSS)
        self.assertEqual(caught.exception.field, "digest.sha256")
        # A short blob is caught too.
        with self.assertRaises(kiln.ServerError) as caught:
            c.fetch(pb.Digest(sha256=sha256(good), size=len(good) + 5))
        self.assertEqual(caught.exception.code, pb.Error.DATA_LOSS)
        self.assertEqual(caught.exception.field, "digest.size")

    def test_watch_skips_heartbeats_and_other_requests_responses(self):
        def event(request_id, state, sequence, fraction, final=False):
            r = pb.Response(id=request_id)
            r.event.job_id = "job-1"
            r.event.state = state
            r.event.sequence = sequence
            r.event.fraction = fraction
            r.event.final = final
            return r

        def script(request, send):
            if request.HasField("watch"):
                send(event(request.id, pb.JOB_STATE_QUEUED, 1, 0.0))
                send(event(request.id + 1000, pb.JOB_STATE_RUNNING, 9, 0.9))  # an abandoned watch's event
                send(event(request.id, pb.JOB_STATE_RUNNING, 2, 0.5))
                send(event(request.id, pb.JOB_STATE_RUNNING, 2, 0.5))  # a heartbeat
                send(event(request.id, pb.JOB_STATE_SUCCEEDED, 3, 1.0, final=True))

        c = self.fake(script)
        events = []
        final = c.watch("job-1", events.append)
        self.assertEqual(final.state, pb.JOB_STATE_SUCCEEDED)
        self.assertEqual([e.sequence for e in events], [1, 2, 3])
        events = []
        c.watch("job-1", events.append, heartbeats=True)
        self.assertEqual([e.sequence for e in events], [1, 2, 2, 3])

    def test_connection_level_error_closes_and_the_next_call_reconnects(self):
        def script(request, send):
            reply = pb.Response(id=0)
            reply.error.code = pb.Error.UNAVAILABLE
            reply.error.message = "shutting down"
            send(reply)
            return "close"

        c = self.fake(script)
        with self.assertRaises(kiln.ConnectionError) as caught:
            c.status()
        self.assertEqual(caught.exception.code, pb.Error.UNAVAILABLE)
        self.assertFalse(c.is_open)
        # The fake server is gone: the reconnect fails as a ConnectionError too.
        self.server.close()
        with self.assertRaises(kiln.ConnectionError):
            c.status()

    def test_a_silent_server_times_out(self):
        c = self.fake(lambda request, send: None)
        c.timeout = 0.3
        with self.assertRaises(kiln.TimeoutError):
            c.status()
        self.assertFalse(c.is_open)


class JobSpecs(unittest.TestCase):
    def test_material_job_from_keywords(self):
        job = kiln.material_job("ggx", name="n", alpha=0.3, fresnel="schlick", f0=0.04, masking="height-correlated",
                                table_mu=32, table_roughness=16, samples=4096, seed=3,
                                force_effects={"specular_interreflection": False})
        g = job.material.ggx
        self.assertAlmostEqual(g.alpha, 0.3)
        self.assertEqual(g.fresnel, pb.FRESNEL_SCHLICK)
        self.assertEqual((g.f0.r, g.f0.g, g.f0.b), (0.04, 0.04, 0.04))
        self.assertEqual(g.masking, pb.MASKING_HEIGHT_CORRELATED)
        self.assertEqual((job.material.table_mu, job.material.table_roughness), (32, 16))
        self.assertEqual((job.quality.samples, job.quality.seed), (4096, 3))
        self.assertFalse(job.quality.HasField("target_error"))
        self.assertEqual(dict(job.force_effects), {"specular_interreflection": False})

        layered = kiln.material_job("layered", diffuse={"model": "oren_nayar", "albedo": (0.8, 0.5, 0.2),
                                                        "sigma": 0.3},
                                    specular={"model": "ggx", "alpha": 0.2, "fresnel": "FRESNEL_EXACT", "eta": 1.5},
                                    combine="weights", specular_weight=0.25)
        self.assertAlmostEqual(layered.material.layered.diffuse.oren_nayar.sigma, 0.3)
        self.assertEqual(layered.material.layered.specular.ggx.fresnel, pb.FRESNEL_EXACT)
        self.assertEqual(layered.material.layered.combine, pb.COMBINE_WEIGHTS)
        two = kiln.material_job("schlick_double", top={"c": 0.9, "r": 0.1}, bottom={"r": 1.0})
        self.assertAlmostEqual(two.material.schlick_double.top.c.g, 0.9)
        self.assertTrue(two.material.schlick_double.bottom.HasField("r"))

        with self.assertRaises(ValueError):
            kiln.material_job("gxx")
        with self.assertRaisesRegex(TypeError, "alhpa"):
            kiln.material_job("ggx", alhpa=0.3)
        with self.assertRaisesRegex(ValueError, "job.material.ggx.fresnel"):
            kiln.material_job("ggx", fresnel="shlick")

    def test_environment_job_from_keywords(self):
        digest = kiln.digest_of(b"an image")
        job = kiln.environment_job(digest, name="sky", lobe="cook_torrance", size=64, levels=3, rotation_degrees=90,
                                   intensity=2, color_space="lin_rec709", preview=False, samples=64, seed=2,
                                   force_effects={"sun_light": False})
        env = job.environment
        self.assertEqual(env.image, digest)
        self.assertEqual(env.lobe, pb.ENVIRONMENT_LOBE_COOK_TORRANCE)
        self.assertEqual((env.size, env.levels, env.rotation_degrees, env.intensity), (64, 3, 90.0, 2.0))
        self.assertTrue(env.HasField("preview") and not env.preview)
        self.assertFalse(env.HasField("dfg_size"))  # unset: the server's default
        self.assertEqual((job.quality.samples, job.quality.seed), (64, 2))
        self.assertEqual(dict(job.force_effects), {"sun_light": False})
        faces = kiln.environment_job(faces=[(digest.sha256, digest.size)] * 6)
        self.assertEqual(len(faces.environment.faces.digests), 6)
        grey = kiln.environment_job(constant=0.25)
        self.assertEqual((grey.environment.constant.r, grey.environment.constant.b), (0.25, 0.25))
        self.assertEqual(kiln.parse_job("environment { constant { r: 0.25 g: 0.25 b: 0.25 } }"), grey)
        with self.assertRaisesRegex(ValueError, "exactly one"):
            kiln.environment_job(digest, constant=1.0)
        with self.assertRaisesRegex(ValueError, "exactly one"):
            kiln.environment_job()
        with self.assertRaisesRegex(ValueError, "six faces"):
            kiln.environment_job(faces=[digest] * 5)
        with self.assertRaisesRegex(ValueError, "job.environment.lobe"):
            kiln.environment_job(digest, lobe="phong")

    def test_job_files_in_text_format(self):
        path = os.path.join(REPO, "client", "examples", "ggx_dielectric.textproto")
        if os.path.exists(path):
            job = kiln.load_job(path)
            self.assertTrue(job.material.HasField("ggx"))
        text = """
            name: "from text"
            material { ggx { alpha: 0.3 fresnel: FRESNEL_SCHLICK f0 { r: 0.04 g: 0.04 b: 0.04 } }
                       table_mu: 32 table_roughness: 16 }
            quality { samples: 4096 seed: 3 }
        """
        job = kiln.parse_job(text)
        made = kiln.material_job("ggx", name="from text", alpha=0.3, fresnel="schlick", f0=0.04, table_mu=32,
                                 table_roughness=16, samples=4096, seed=3)
        self.assertEqual(job, made)
        with self.assertRaises(ValueError):
            kiln.parse_job("material { ggx { alpha: oops } }")
        with self.assertRaises(ValueError):
            kiln.parse_job("no_such_field: 1")


if __name__ == "__main__":
    unittest.main()
