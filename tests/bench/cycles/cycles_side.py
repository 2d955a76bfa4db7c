"""Cycles' side of the benchmark: Blender runs of cycles_bake.py, and the converged reference they are compared with."""
import hashlib
import json
import os
import subprocess

import numpy

import cpu_clock

HERE = os.path.dirname(os.path.abspath(__file__))
REFERENCE_SEEDS = (1_000_001, 1_000_002)  # the two halves; the runs' seeds stay below them


def blender_version(blender):
    try:
        run = subprocess.run([blender, "--version"], capture_output=True, text=True)
    except FileNotFoundError:
        run = None
    if run is None or run.returncode != 0:
        raise SystemExit(f"compare.py: {blender} --version failed; install it with tests/bench/cycles/setup.sh")
    return run.stdout.splitlines()[0].strip()


def bake(blender, scene, samples, seed, prefix, resolution, threads, max_bounces, log, extra=()):
    """One Cycles bake in its own headless Blender; returns (E in W/m^2 as (h, w, 3), baked mask, info). Cycles stores
    E/pi: the pixels are multiplied by pi here."""
    cmd = [blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
           os.path.join(HERE, "cycles_bake.py"), "--", "--scene", scene, "--samples", str(samples), "--seed", str(seed),
           "--out", prefix, "--resolution", str(resolution), "--threads", str(threads), "--max-bounces",
           str(max_bounces), *extra]
    ours, others = cpu_clock.of_children(), cpu_clock.Others()
    with open(log, "w") as f:
        run = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    others = others.stop(cpu_clock.of_children() - ours)  # over Blender's whole run, start-up included
    if run.returncode != 0:
        raise SystemExit(f"compare.py: the Cycles bake failed ({' '.join(cmd)}); its output: {log}")
    image, baked, info = load(prefix)
    info["others_cpu_seconds"] = others
    return image, baked, info


def load(prefix):
    pixels = numpy.load(prefix + ".npy")
    with open(prefix + ".json") as f:
        info = json.load(f)
    return pixels[..., :3] * numpy.pi, pixels[..., 3] != -1.0, info


def cached_bake(folder, name, what, blender, scene, samples, seed, resolution, threads, max_bounces, extra=()):
    prefix = os.path.join(folder, name)
    if os.path.exists(prefix + ".json"):
        print(f"  {what}: cached in {folder}")
        return load(prefix)
    print(f"  {what}: baking {samples} samples per texel with Cycles (seed {seed}) ...", end="", flush=True)
    result = bake(blender, scene, samples, seed, prefix, resolution, threads, max_bounces, prefix + ".log", extra)
    print(f" {result[2]['wall_seconds']:.1f} s wall, {result[2]['cpu_seconds']:.1f} s CPU")
    return result


def enclosed(blender, scene, folder, resolution, threads):
    """Texels that see back faces (over 1 % of their cosine-weighted hemisphere): floor under the blocks, ceiling over
    the light. kiln moves their sample points out (its leak handling); Cycles bakes what is there, darkness."""
    fraction = cached_bake(folder, "backfaces", "back-face fraction", blender, scene, 64, 1, resolution, threads, 0,
                           ["--backfaces"])[0][..., 0] / numpy.pi
    return fraction > 0.01


def reference(blender, scene, samples, work, resolution, threads, max_bounces, version):
    """The converged reference: two independent halves of `samples` each (different seeds), cached under
    WORK/reference/ by the hash of the scene file and of cycles_bake.py, Blender's version, the sample count,
    resolution and bounces; and the texels that see back faces. Returns (halves, enclosed texels, the folder)."""
    digest = hashlib.sha256()
    for path in (scene, os.path.join(HERE, "cycles_bake.py")):  # what is baked, and how
        with open(path, "rb") as f:
            digest.update(f.read())
    digest = digest.hexdigest()[:16]
    tag = version.replace(" ", "_")
    folder = os.path.join(work, "reference", f"{digest}_{tag}_{samples}spp_{resolution}px_{max_bounces}b")
    os.makedirs(folder, exist_ok=True)
    halves = [cached_bake(folder, f"half{i}", f"reference half {i}", blender, scene, samples, seed, resolution,
                          threads, max_bounces) for i, seed in enumerate(REFERENCE_SEEDS)]
    return halves, enclosed(blender, scene, folder, resolution, threads), folder
