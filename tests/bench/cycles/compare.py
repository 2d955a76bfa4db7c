#!/usr/bin/python3
"""kiln against Cycles on the bundled Cornell box, baked into one 256^2 lightmap atlas: a benchmark run by hand.

See README.md beside this file for what it measures and how to read it. Run from the repository's top:
  tests/bench/cycles/setup.sh            # once: Blender, numpy, OpenImageIO's Python module
  /usr/bin/python3 tests/bench/cycles/compare.py --build build --table-out out/bench_cycles/table.md
"""
import argparse
import os
import platform
import shlex
import subprocess
import sys
import time

try:
    import numpy
    import OpenImageIO  # noqa: F401  (kiln_side reads EXRs with it)
except ImportError as missing:
    sys.exit(f"compare.py: Python module {missing.name} is missing: install the benchmark's packages with "
             "tests/bench/cycles/setup.sh and run it with /usr/bin/python3 (Debian's Python, which they serve)")

import cycles_side  # noqa: E402  (after the check above)
import error_metrics as em  # noqa: E402
import kiln_side  # noqa: E402

TOP = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../.."))
LIGHTMAP = "cornell_box"  # the atlas's name: the glTF meshes' (cornell_box.py --atlas)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--build", default="build", help="kiln's build folder (bin/kilnd, bin/kiln); default build")
    p.add_argument("--work", default=os.path.join(TOP, "out/bench_cycles"),
                   help="scene, reference cache and runs; default out/bench_cycles")
    p.add_argument("--blender", default="blender")
    p.add_argument("--resolution", type=int, default=256)
    p.add_argument("--max-bounces", type=int, default=8)
    p.add_argument("--threads", type=int, default=2, help="kilnd's baking threads and Cycles' threads; default 2")
    p.add_argument("--kiln-targets", type=float, nargs="+", default=[0.08, 0.04, 0.02])
    p.add_argument("--kiln-flags", default="", help='more flags for `kiln bake lightmap`, e.g. "--max-samples 8192"')
    p.add_argument("--cycles-samples", type=int, nargs="+", default=[64, 256, 1024])
    p.add_argument("--reference-samples", type=int, default=8192, help="per half of the reference; default 8192")
    p.add_argument("--seed", type=int, default=1, help="first seed of the runs (each run its own)")
    p.add_argument("--table-out", help="also write the table and ratios as markdown into this file")
    args = p.parse_args()
    args.build = os.path.abspath(args.build)
    if not os.access(os.path.join(args.build, "bin/kilnd"), os.X_OK):
        p.error(f"no kilnd in {args.build}/bin: build kiln first or name its build folder with --build")
    if max(args.cycles_samples) >= args.reference_samples:
        p.error("--reference-samples must exceed every --cycles-samples")
    return args


def source_commit(build):
    """The commit of the source tree the build folder was configured from, with -dirty if it has changes."""
    source = TOP
    cache = os.path.join(build, "CMakeCache.txt")
    if os.path.exists(cache):
        for line in open(cache):
            if line.startswith("CMAKE_HOME_DIRECTORY:INTERNAL="):
                source = line.split("=", 1)[1].strip()
    run = subprocess.run(["git", "-C", source, "describe", "--always", "--dirty", "--abbrev=12"],
                         capture_output=True, text=True)
    return f"{run.stdout.strip() or 'unknown'} ({source})"


def machine():
    model = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")),
                 platform.processor())
    return f"{os.cpu_count()} CPUs ({model}), {platform.system()} {platform.release()}"


def print_setup(args, blender, commit, help_text):
    print("kiln against Cycles: the bundled Cornell box baked into one lightmap atlas")
    print(f"  machine: {machine()}")
    print(f"  kiln: {args.build}, source {commit}")
    print(f"  Cycles: {blender}, CPU, {args.threads} threads, PMJ sampling, adaptive sampling off, denoising off, "
          f"clamps 0, light threshold 0, max/diffuse bounces {args.max_bounces}; time of the bake operator")
    flags = f"--resolution {args.resolution} --max-bounces {args.max_bounces} --target-error E --seed S --job " \
            f"lambert.textproto {args.kiln_flags}".rstrip()
    print(f"  kiln: kilnd --threads {args.threads}, `kiln bake lightmap {flags}`; time of the client command")
    print(f"  atlas {args.resolution}^2; kiln targets {args.kiln_targets}; Cycles samples {args.cycles_samples}; "
          f"reference: Cycles, 2 x {args.reference_samples} samples (seeds {cycles_side.REFERENCE_SEEDS})")
    print(f"  kiln's --denoise: {'yes, rows for it' if '--denoise' in help_text else 'not offered; no rows for it'}")


def make_scene(work):
    scene = os.path.join(work, "cornell_box_atlas.gltf")
    subprocess.run(["/usr/bin/python3", os.path.join(TOP, "client/examples/scenes/cornell_box.py"), "--atlas", scene],
                   check=True)
    return scene


def triple(v):
    return "(" + ", ".join(f"{x:.4g}" for x in v) + ")" if v else "missing"


def print_materials(kiln_materials, cycles_materials):
    print("materials (base colour; emitted radiance):")
    by_name = {m["name"]: m for m in cycles_materials}
    for m in kiln_materials:
        c = by_name.get(m["name"], {})
        print(f"  {m['name']:6s} kiln {triple(m['base_color'])} {triple(m['emission'])}; "
              f"Cycles {triple(c.get('base_color'))} {triple(c.get('emission'))}")


def kiln_bake(daemon, args, scene, job, run_dir, target, seed, denoise):
    """One timed kiln bake and its row of the table."""
    out = os.path.join(run_dir, f"kiln{'_denoised' if denoise else ''}_{target}")
    flags = kiln_side.bake_flags(args.resolution, args.max_bounces, target, seed, job, shlex.split(args.kiln_flags),
                                 denoise)
    print(f"  kiln, target {target}, seed {seed}{', denoised' if denoise else ''} ...", end="", flush=True)
    wall, cpu, others, report = daemon.bake(scene, out, flags)
    suffix = "_irradiance_denoised.exr" if denoise else "_irradiance.exr"
    lightmap = next(m for m in report["lightmaps"] if m["name"] == LIGHTMAP)
    print(f" {wall:.1f} s wall ({report['seconds']:.1f} s of it baking), {cpu:.1f} s CPU, {report['bounces']} bounces "
          f"planned; other processes {others:.1f} CPU s")
    return {"baker": "kiln, denoised" if denoise else "kiln", "setting": f"target {target}", "target": target,
            "wall": wall, "cpu": cpu, "others": others, "spt": report["samples"] / lightmap["valid_texels"],
            "image": kiln_side.read_exr(os.path.join(out, LIGHTMAP + suffix))[..., :3],
            "valid": kiln_side.read_exr(os.path.join(out, LIGHTMAP + "_validity.exr"))[..., 0] > 0.5,
            "estimate": None if denoise else report["error_estimate"]}  # the report's is the raw lightmap's


def kiln_runs(args, scene, job, run_dir, help_text):
    """Every kiln bake, each with a seed of its own: raw, and denoised where the client offers it."""
    rows = []
    daemon = kiln_side.Kilnd(args.build, os.path.join(run_dir, "kilnd"), args.threads)
    try:
        for v, denoise in enumerate([False] + ([True] if "--denoise" in help_text else [])):
            for i, target in enumerate(args.kiln_targets):
                rows.append(kiln_bake(daemon, args, scene, job, run_dir, target, args.seed + 100 * v + i, denoise))
    finally:
        daemon.stop()
    return rows


def cycles_runs(args, scene, run_dir):
    rows = []
    for i, samples in enumerate(args.cycles_samples):
        seed = args.seed + 1000 + i
        prefix = os.path.join(run_dir, f"cycles_{samples}")
        print(f"  Cycles, {samples} samples, seed {seed} ...", end="", flush=True)
        image, baked, info = cycles_side.bake(args.blender, scene, samples, seed, prefix, args.resolution, args.threads,
                                              args.max_bounces, prefix + ".log")
        rows.append({"baker": "Cycles", "setting": f"{samples} samples", "wall": info["wall_seconds"],
                     "cpu": info["cpu_seconds"], "others": info["others_cpu_seconds"], "spt": samples, "image": image,
                     "baked": baked, "estimate": None, "materials": info["materials"]})
        print(f" {info['wall_seconds']:.1f} s wall, {info['cpu_seconds']:.1f} s CPU; other processes "
              f"{info['others_cpu_seconds']:.1f} CPU s (over Blender's whole run)")
    return rows


def agreement(kiln_row, halves, mask, noise):
    """kiln's lowest-target bake against the Cycles reference: RMSE and the ratio of their means (1 within noise if
    the two simulate the same light), overall, per channel, and over the darker and brighter texels (chosen by one
    half of the reference, compared with the other: choosing by the values compared would favour their noise)."""
    ref = (halves[0][0] + halves[1][0]) / 2
    rmse = em.relative_rmse(kiln_row["image"], ref, mask)
    k, r = kiln_row["image"][mask].astype(numpy.float64), ref[mask].astype(numpy.float64)
    scatter = rmse / numpy.sqrt(mask.sum())  # of the ratio of means, if texels' errors are independent
    print(f"agreement: kiln {kiln_row['setting']} against the reference over {int(mask.sum())} interior texels:")
    print(f"  relative RMSE {100 * rmse:.2f} % ({100 * em.without_noise(rmse, noise):.2f} % with the reference's "
          f"{100 * noise:.2f} % removed)")
    print(f"  mean kiln / mean Cycles: {k.sum() / r.sum():.4f} (noise about +-{scatter:.4f}); per channel R G B: " +
          " ".join(f"{k[:, c].sum() / r[:, c].sum():.4f}" for c in range(3)))
    weights = numpy.array([0.2126, 0.7152, 0.0722])
    chooser, other = halves[0][0][mask] @ weights, halves[1][0][mask].astype(numpy.float64)
    for name, sel in (("darkest third", chooser <= numpy.quantile(chooser, 1 / 3)),
                      ("brightest third", chooser >= numpy.quantile(chooser, 2 / 3))):
        print(f"  {name} of the texels: mean kiln / mean Cycles {k[sel].sum() / other[sel].sum():.4f}")


def measure(rows, ref, mask, noise):
    for r in rows:
        r["rmse_raw"] = em.relative_rmse(r["image"], ref, mask)
        r["rmse"] = em.without_noise(r["rmse_raw"], noise)


def disturbed(row, threads):
    """Other processes took more than 5 % of the CPU time the run could have used: its times are not its own."""
    return row["others"] > 0.05 * row["wall"] * threads


def table(rows, threads):
    lines = ["| baker | setting | wall s | CPU s | samples per texel | relative RMSE (reference noise removed) | "
             "kiln's error estimate |", "| --- | --- | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        estimate = f"{100 * r['estimate']:.1f} %" if r["estimate"] is not None else ""
        mark = " (!)" if disturbed(r, threads) else ""
        lines.append(f"| {r['baker']} | {r['setting']}{mark} | {r['wall']:.1f} | {r['cpu']:.1f} | {r['spt']:.0f} | "
                     f"{100 * r['rmse']:.2f} % | {estimate} |")
    if any(disturbed(r, threads) for r in rows):
        lines += ["", "(!) other processes took over 5 % of the CPU time during this run: its times are not its own "
                  "(" + ", ".join(f"{r['baker']} {r['setting']}: {r['others']:.1f} CPU s" for r in rows
                                  if disturbed(r, threads)) + ")"]
    return lines


def ratio_lines(rows, baker):
    """kiln's time over Cycles' at equal RMSE, wall and CPU: fitted (err^2 t constant) and interpolated."""
    lines = []
    for clock in ("wall", "cpu"):
        ours = [(r["rmse"], r[clock]) for r in rows if r["baker"] == baker]
        theirs = [(r["rmse"], r[clock]) for r in rows if r["baker"] == "Cycles"]
        fitted = em.fitted_constant(ours) / em.fitted_constant(theirs)
        at = em.interpolated_ratios(ours, theirs)
        interpolated = (", ".join(f"{ratio:.2f}x at {100 * e:.2f} %" for e, ratio in at) if at else
                        "none: the two curves' RMSE ranges do not overlap")
        if at:
            geo = numpy.exp(numpy.mean([numpy.log(ratio) for _, ratio in at]))
            interpolated += f" (geometric mean {geo:.2f}x)"
        name = "wall" if clock == "wall" else "CPU"
        lines.append(f"- {baker} / Cycles, {name} time at equal RMSE: fitted **{fitted:.2f}x**; "
                     f"interpolated {interpolated}")
    return lines


def interior_texels(halves, enclosed, kiln, cycles):
    baked = halves[0][1] & halves[1][1] & numpy.logical_and.reduce([r["baked"] for r in cycles])
    valid = numpy.logical_and.reduce([r["valid"] for r in kiln])
    mask = em.interior(baked & valid & ~enclosed)
    print(f"texels: {int(baked.sum())} baked by Cycles, {int(valid.sum())} valid in every kiln bake, "
          f"{int(enclosed.sum())} seeing back faces; {int(mask.sum())} interior (baked, valid and clear, and their 8 "
          "neighbours too)")
    return mask


def results(args, rows, ref, mask, noise, blender, commit):
    """The table and the equal-RMSE ratios, as markdown lines."""
    measure(rows, ref, mask, noise)
    lines = table(rows, args.threads) + [""]
    for baker in dict.fromkeys(r["baker"] for r in rows if r["baker"] != "Cycles"):
        lines += ratio_lines(rows, baker)
    return lines + ["", f"Machine: {machine()}; {blender}; kiln {commit.split()[0]}; reference: Cycles, 2 x "
                    f"{args.reference_samples} samples, its noise ({100 * noise:.3f} %) removed in quadrature; "
                    f"{int(mask.sum())} interior texels of a {args.resolution}^2 atlas."]


def main():
    started = time.time()
    args = parse_args()
    os.makedirs(args.work, exist_ok=True)
    blender = cycles_side.blender_version(args.blender)
    commit = source_commit(args.build)
    help_text = kiln_side.lightmap_help(args.build)
    print_setup(args, blender, commit, help_text)
    scene = make_scene(args.work)
    run_dir = os.path.join(args.work, "runs", time.strftime("%Y%m%d-%H%M%S"))
    os.makedirs(run_dir)
    job = os.path.join(run_dir, "lambert.textproto")
    kiln_materials = kiln_side.lambertian_job(scene, job)
    print("reference:")
    halves, enclosed, ref_dir = cycles_side.reference(args.blender, scene, args.reference_samples, args.work,
                                                      args.resolution, args.threads, args.max_bounces, blender)
    print("kiln:")
    kiln = kiln_runs(args, scene, job, run_dir, help_text)
    print("Cycles:")
    cycles = cycles_runs(args, scene, run_dir)
    print_materials(kiln_materials, cycles[0]["materials"])

    mask = interior_texels(halves, enclosed, kiln, cycles)
    noise = em.reference_noise(halves[0][0], halves[1][0], mask)
    print(f"reference noise (relative RMS of the mean of the halves): {100 * noise:.3f} %")
    agreement(min((r for r in kiln if r["baker"] == "kiln"), key=lambda r: r["target"]), halves, mask, noise)
    lines = results(args, kiln + cycles, (halves[0][0] + halves[1][0]) / 2, mask, noise, blender, commit)
    print("\n" + "\n".join(lines))
    if args.table_out:
        os.makedirs(os.path.dirname(os.path.abspath(args.table_out)), exist_ok=True)
        with open(args.table_out, "w") as f:
            f.write("\n".join(lines) + "\n")
        print(f"\nwrote {args.table_out}")
    print(f"outputs in {run_dir}; reference in {ref_dir}; {time.time() - started:.0f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
