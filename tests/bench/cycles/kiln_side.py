"""kiln's side of the Cycles benchmark: a private kilnd, Lambertian overrides, timed `kiln bake lightmap` runs."""
import json
import os
import re
import subprocess
import time

import OpenImageIO as oiio

import cpu_clock


def read_exr(path):
    """An EXR's pixels as float32, rows top first, shape (height, width, channels)."""
    buf = oiio.ImageBuf(str(path))
    if buf.has_error:
        raise SystemExit(f"compare.py: cannot read {path}: {buf.geterror()}")
    return buf.get_pixels(oiio.FLOAT)


def text_color(c):
    return f"{{ r: {c[0]!r} g: {c[1]!r} b: {c[2]!r} }}"


def lambertian_job(gltf_path, job_path):
    """Writes a kiln.v1.LightmapJob text file making every material of the glTF Lambertian with its base colour (the
    importer's GGX-over-Lambert otherwise adds a specular lobe Cycles' Diffuse BSDF lacks); emission stays as imported.
    Returns the materials as kiln sees them: name, base colour, emitted radiance (emissiveFactor x strength)."""
    with open(gltf_path) as f:
        materials = json.load(f)["materials"]
    lines, seen = [], []
    for m in materials:
        base = m.get("pbrMetallicRoughness", {}).get("baseColorFactor", [1, 1, 1, 1])[:3]
        strength = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
        emission = [c * strength for c in m.get("emissiveFactor", [0, 0, 0])]
        lines.append(f'material_overrides {{ name: "{m["name"]}" bsdf {{ diffuse {{ lambert {{ albedo '
                     f"{text_color([1, 1, 1])} }} }} }} base_color {text_color(base)} }}")
        seen.append({"name": m["name"], "base_color": base, "emission": emission})
    with open(job_path, "w") as f:
        f.write("# Every material Lambertian with its base colour; emission as imported.\n" + "\n".join(lines) + "\n")
    return seen


class Kilnd:
    """A kilnd of our own on a free loopback port, with a fresh store (so that no bake is answered from a cache)."""

    def __init__(self, build, state_dir, threads):
        self.build = build
        os.makedirs(state_dir, exist_ok=True)
        self.token = os.path.join(state_dir, "token")
        fd = os.open(self.token, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)  # kilnd refuses a readable token
        with os.fdopen(fd, "w") as f:
            f.write(os.urandom(32).hex() + "\n")
        self.out_path = os.path.join(state_dir, "kilnd.out")
        self.log_path = os.path.join(state_dir, "kilnd.log")
        with open(self.out_path, "w") as out, open(self.log_path, "w") as log:
            self.proc = subprocess.Popen(
                [os.path.join(build, "bin/kilnd"), "--listen", "127.0.0.1:0", "--store",
                 os.path.join(state_dir, "store"), "--token-file", self.token, "--threads", str(threads),
                 "--workers", "1"], stdout=out, stderr=log)
        self.address = self._wait_for_address()

    def _wait_for_address(self):
        for _ in range(300):
            with open(self.out_path) as f:
                m = re.search(r"^kilnd: listening on (127\.0\.0\.1:\d+)$", f.read(), re.M)
            if m:
                return m.group(1)
            if self.proc.poll() is not None:
                raise SystemExit(f"compare.py: kilnd did not start:\n{open(self.log_path).read()}")
            time.sleep(0.1)
        self.stop()
        raise SystemExit(f"compare.py: kilnd did not start within 30 s (log: {self.log_path})")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout=60)

    def bake(self, scene, out_dir, flags):
        """Runs `kiln bake lightmap` (a cache miss, checked); returns wall seconds of the client command, CPU seconds
        of kilnd plus the client, CPU seconds other processes took meanwhile, and the report."""
        cmd = [os.path.join(self.build, "bin/kiln"), "--server", self.address, "--token-file", self.token, "bake",
               "lightmap", scene, "--no-preview", "--out", out_dir] + flags
        cpu_daemon, cpu_client = cpu_clock.of_process(self.proc.pid), cpu_clock.of_children()
        others = cpu_clock.Others()
        wall = time.perf_counter()
        run = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - wall
        cpu = cpu_clock.of_process(self.proc.pid) - cpu_daemon + cpu_clock.of_children() - cpu_client
        others = others.stop(cpu)
        if run.returncode != 0:
            raise SystemExit(f"compare.py: {' '.join(cmd)} failed:\n{run.stdout}{run.stderr}")
        if "cache miss" not in run.stdout:
            raise SystemExit(f"compare.py: kiln answered from its cache; every run must bake:\n{run.stdout}")
        with open(os.path.join(out_dir, "report.json")) as f:
            report = json.load(f)
        return wall, cpu, others, report


def bake_flags(resolution, max_bounces, target, seed, job, extra, denoise):
    flags = ["--resolution", str(resolution), "--max-bounces", str(max_bounces), "--target-error", repr(target),
             "--seed", str(seed), "--job", job] + extra
    return flags + (["--denoise"] if denoise else [])


def lightmap_help(build):
    return subprocess.run([os.path.join(build, "bin/kiln"), "bake", "lightmap", "--help"], capture_output=True,
                          text=True).stdout
