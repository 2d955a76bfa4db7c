"""Tests of the Python lightmap helpers (client/python/kiln/lightmap.py): kiln.mesh packs the kiln mesh layout
byte for byte as kiln.proto documents it, kiln.lightmap_job maps its keywords onto LightmapJob's fields, and a job
built with them bakes, on the real kilnd, the irradiance worked out by hand (read back with an EXR reader written
for these tests, exr_reader.py, independent of the OpenImageIO that kilnd writes with).

Run by CTest with test_client (tests/CMakeLists.txt, test "python_client"), or alone from tests/python:
    KILND=<build>/bin/kilnd KILN_PYTHON_PROTO=<build>/python/kiln PYTHONPATH=../../client/python \\
        /usr/bin/python3 -m unittest -v test_lightmap
"""

import json
import math
import os
import shutil
import struct
import tempfile
import unittest

import kiln
from kiln import pb

import test_client
from exr_reader import read_exr

# One real kilnd for this module, started and stopped as test_client does for its own (unittest calls these).
setUpModule, tearDownModule = test_client.setUpModule, test_client.tearDownModule

# The unit floor quad in the XZ plane, facing +Y, with lightmap UV (u, v) at world (u, 0, −v): v = 0 is the top row
# of the lightmap (glTF's convention, kiln.proto).
FLOOR_POSITIONS = [(0, 0, 0), (1, 0, 0), (1, 0, -1), (0, 0, -1)]
FLOOR_INDICES = [0, 1, 2, 0, 2, 3]  # counter-clockwise seen from +Y
FLOOR_UV = [(0, 0), (1, 0), (1, 1), (0, 1)]


def floor_mesh(name="floor"):
    return kiln.mesh(name, FLOOR_POSITIONS, FLOOR_INDICES, lightmap_uv=FLOOR_UV, normals=[(0, 1, 0)] * 4)


class MeshLayout(unittest.TestCase):
    """kiln.mesh against the layout of kiln.proto, unpacked here field by field with struct."""

    def test_header_arrays_and_flags_are_the_documented_layout(self):
        m = kiln.mesh("quad", positions=[0, 0, 0, 1, 0, 0, 1, 0, -1, 0.1, 0, -1], indices=[(0, 1, 2), (0, 2, 3)],
                      normals=[(0, 1, 0)] * 4, uv=[(0, 0), (1, 0), (1, 1), (0, 1)],
                      lightmap_uv=[(0.25, 0.25), (0.75, 0.25), (0.75, 0.75), (0.25, 0.75)], materials=[0, 7])
        d = m.data
        self.assertEqual(d[:8], b"KILNMSH1")
        self.assertEqual(struct.unpack_from("<3I", d, 8), (4, 2, 1 | 2 | 4 | 8))
        at = 20
        positions = struct.unpack_from("<12f", d, at)
        at += 48
        self.assertEqual(positions[9], struct.unpack("<f", struct.pack("<f", 0.1))[0])  # stored as float32
        self.assertEqual(struct.unpack_from("<12f", d, at), (0.0, 1.0, 0.0) * 4)  # normals
        at += 48
        self.assertEqual(struct.unpack_from("<8f", d, at), (0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0))  # uv
        at += 32
        self.assertEqual(struct.unpack_from("<2f", d, at + 16), (0.75, 0.75))  # lightmap_uv of vertex 2
        at += 32
        self.assertEqual(struct.unpack_from("<6I", d, at), (0, 1, 2, 0, 2, 3))
        at += 24
        self.assertEqual(struct.unpack_from("<2I", d, at), (0, 7))
        self.assertEqual(len(d), at + 8, "nothing after the material indices")
        self.assertEqual((m.vertex_count, m.triangle_count), (4, 2))
        self.assertEqual(m.digest, kiln.digest_of(d))

        # Optional arrays left out: their flags clear and their bytes absent.
        bare = kiln.mesh("bare", FLOOR_POSITIONS, FLOOR_INDICES)
        self.assertEqual(struct.unpack_from("<3I", bare.data, 8), (4, 2, 0))
        self.assertEqual(len(bare.data), 20 + 48 + 24)

    def test_inconsistent_arrays_are_errors_naming_the_mesh(self):
        with self.assertRaisesRegex(ValueError, "mesh quad normals: 1 entries for 4 vertices"):
            kiln.mesh("quad", FLOOR_POSITIONS, FLOOR_INDICES, normals=[(0, 1, 0)])
        with self.assertRaisesRegex(ValueError, "mesh quad indices: 5 numbers"):
            kiln.mesh("quad", FLOOR_POSITIONS, FLOOR_INDICES[:5])
        with self.assertRaisesRegex(ValueError, r"mesh quad positions\[1\]: 2 components"):
            kiln.mesh("quad", [(0, 0, 0), (1, 0)], [])
        with self.assertRaisesRegex(ValueError, "mesh quad materials: 1 entries for 2 triangles"):
            kiln.mesh("quad", FLOOR_POSITIONS, FLOOR_INDICES, materials=[0])
        with self.assertRaisesRegex(ValueError, "mesh quad indices"):
            kiln.mesh("quad", FLOOR_POSITIONS, [0, 1, -2])
        with self.assertRaisesRegex(ValueError, "mesh name"):
            kiln.mesh("", FLOOR_POSITIONS, FLOOR_INDICES)


class LightmapJobKeywords(unittest.TestCase):
    def test_keywords_mirror_the_proto(self):
        floor, wall = floor_mesh(), kiln.mesh("wall", FLOOR_POSITIONS, FLOOR_INDICES)
        sky = kiln.digest_of(b"an equirectangular image")
        wood = kiln.digest_of(b"a texture")
        job = kiln.lightmap_job(
            [floor, ("wall", wall.digest)],
            instances=[{"mesh": "floor"},
                       {"mesh": 1, "transform": [(1, 0, 0, 2), (0, 1, 0, 0), (0, 0, 1, 0)], "bake": False,
                        "lightmap_scale_offset": (0.5, 0.5, 0, 0.5), "lightmap": "atlas"}],
            textures=[{"name": "wood", "image": wood, "color_space": "srgb_texture"}],
            materials=[{"name": "oak", "base_color": (0.5, 0.4, 0.3), "base_color_texture": "wood",
                        "bsdf": {"diffuse": {"model": "oren_nayar", "albedo": 0.9, "sigma": 0.2},
                                 "specular": {"model": "ggx", "alpha": 0.2, "fresnel": "schlick", "f0": 0.04},
                                 "combine": "layered"},
                        "emission": 0, "two_sided": True}],
            lights=[{"name": "lamp", "color": (10, 9, 8), "point": {"position": (0.5, 2, -0.5)}},
                    {"name": "sun", "color": 3, "directional": {"direction": (0, -1, -1), "angular_diameter": 0.01}},
                    {"name": "panel", "rect": {"center": (0, 3, 0), "u": (1, 0, 0), "v": (0, 0, 1)}}],
            environment={"image": sky, "rotation_degrees": 90, "intensity": 2},
            material_overrides=[{"name": "oak", "base_color": 0.25}],
            lightmaps={"floor": 64}, resolution=32, padding=2, max_bounces=4, ao=True, preview=False, denoise=True,
            stitch_seams=False, error_metric="texel", generate_uvs="never", name="keywords", samples=256, target_error=0.05, seed=9, force_effects={"textures": False})
        j = job.lightmap
        self.assertEqual([m.name for m in j.meshes], ["floor", "wall"])
        self.assertEqual(j.meshes[0].geometry, floor.digest)
        self.assertEqual(j.meshes[1].geometry, wall.digest)
        self.assertEqual(j.instances[0].mesh, 0)
        self.assertEqual(list(j.instances[1].transform), [1, 0, 0, 2, 0, 1, 0, 0, 0, 0, 1, 0])
        self.assertEqual(list(j.instances[1].lightmap_scale_offset), [0.5, 0.5, 0, 0.5])
        self.assertTrue(j.instances[1].HasField("bake") and not j.instances[1].bake)
        self.assertEqual(j.textures[0].image, wood)
        oak = j.materials[0]
        self.assertEqual(oak.base_color_texture, 0)
        self.assertAlmostEqual(oak.bsdf.diffuse.oren_nayar.sigma, 0.2)
        self.assertEqual(oak.bsdf.specular.ggx.fresnel, pb.FRESNEL_SCHLICK)
        self.assertEqual(oak.bsdf.combine, pb.COMBINE_LAYERED)
        self.assertEqual((j.lights[0].point.position.y, j.lights[0].color.b), (2.0, 8.0))
        self.assertEqual(j.lights[1].WhichOneof("type"), "directional")
        self.assertEqual(j.lights[1].directional.direction.z, -1.0)
        self.assertEqual(j.lights[2].rect.u.x, 1.0)
        self.assertEqual((j.environment.image, j.environment.rotation_degrees, j.environment.intensity),
                         (sky, 90.0, 2.0))
        self.assertEqual(j.material_overrides[0].base_color.g, 0.25)
        self.assertEqual((j.lightmaps[0].name, j.lightmaps[0].resolution), ("floor", 64))
        self.assertEqual((j.resolution, j.padding, j.max_bounces, j.ao), (32, 2, 4, True))
        self.assertTrue(j.HasField("preview") and not j.preview)
        self.assertTrue(j.denoise)
        self.assertTrue(j.HasField("stitch_seams") and not j.stitch_seams)
        self.assertEqual(j.error_metric, kiln.pb.LIGHTMAP_ERROR_METRIC_TEXEL)
        self.assertEqual(j.generate_uvs, kiln.pb.GENERATE_UVS_NEVER)
        self.assertEqual((job.quality.samples, job.quality.seed), (256, 9))
        self.assertEqual(dict(job.force_effects), {"textures": False})

        # The same as the protobuf text format says it, for a small job.
        small = kiln.lightmap_job([("floor", floor.digest)], environment=(0.25, 0.5, 1), resolution=8)
        text = ('lightmap { meshes { name: "floor" geometry { sha256: "%s" size: %d } } '
                'environment { constant { r: 0.25 g: 0.5 b: 1 } } resolution: 8 }'
                % (floor.digest.sha256, floor.digest.size))
        self.assertEqual(small, kiln.parse_job(text))

    def test_atlas_keywords(self):
        floor = floor_mesh()
        job = kiln.lightmap_job([floor], instances=[{"mesh": "floor", "name": "left", "texel_density": 40},
                                                    {"mesh": 0, "name": "right", "own_page": True}],
                                texel_density=20, page_size=2048, max_pages=3, uniform_pages=True)
        j = job.lightmap
        self.assertEqual((j.texel_density, j.page_size, j.max_pages, j.uniform_pages), (20.0, 2048, 3, True))
        self.assertEqual((j.instances[0].name, j.instances[0].texel_density), ("left", 40.0))
        self.assertTrue(j.instances[1].own_page)
        self.assertFalse(j.instances[1].HasField("texel_density"))

    def test_media_keywords(self):
        floor = floor_mesh()
        smoke = kiln.pb.Digest(sha256="c" * 64, size=4000)
        job = kiln.lightmap_job([floor], media=[
            {"name": "haze", "fog": True, "sigma_a": 0.01, "sigma_s": (0.1, 0.2, 0.3), "g": 0.5},
            {"box": {"lo": (-1, 0, -1), "hi": (1, 2, 1)}, "emission": 2},
            {"vdb": {"file": smoke, "emission_grid": "heat", "transform": [[2, 0, 0, 1], [0, 2, 0, 0], [0, 0, 2, 0]]},
             "sigma_s": 1}])
        m = job.lightmap.media
        self.assertEqual(len(m), 3)
        self.assertTrue(m[0].fog)
        self.assertEqual((m[0].sigma_a.g, m[0].sigma_s.b, m[0].g), (0.01, 0.3, 0.5))
        self.assertEqual((m[1].box.lo.x, m[1].box.hi.y, m[1].emission.r), (-1, 2, 2))
        self.assertEqual(m[2].vdb.file, smoke)
        self.assertEqual(list(m[2].vdb.transform), [2, 0, 0, 1, 0, 2, 0, 0, 0, 0, 2, 0])
        self.assertEqual(m[2].vdb.emission_grid, "heat")
        with self.assertRaisesRegex(TypeError, r"job.lightmap.media\[0\]: Medium has no field 'fgo'"):
            kiln.lightmap_job([floor], media=[{"fgo": True}])

    def test_mistakes_name_their_field(self):
        floor = floor_mesh()
        with self.assertRaisesRegex(ValueError, r"job.lightmap.instances\[0\].mesh: no mesh named 'flor'"):
            kiln.lightmap_job([floor], instances=[{"mesh": "flor"}])
        with self.assertRaisesRegex(ValueError, r"job.lightmap.lights\[0\]: give one of .*point and spot"):
            kiln.lightmap_job([floor], lights=[{"point": {}, "spot": {}}])
        with self.assertRaisesRegex(TypeError, r"job.lightmap.lights\[0\].point.position: expected \(x, y, z\)"):
            kiln.lightmap_job([floor], lights=[{"point": {"position": (1, 2)}}])
        with self.assertRaisesRegex(TypeError, "job.lightmap: LightmapJob has no field 'resolutoin'"):
            kiln.lightmap_job([floor], resolutoin=8)
        with self.assertRaisesRegex(ValueError, "at least one mesh"):
            kiln.lightmap_job([])
        with self.assertRaisesRegex(TypeError, r"job.lightmap.meshes\[0\]"):
            kiln.lightmap_job(["floor"])


class ProbesKeywords(unittest.TestCase):
    """kiln.probes_job: the scene as lightmap_job builds it, the probe settings in a ProbesJob's volume."""

    def test_scene_and_volume(self):
        floor = floor_mesh()
        job = kiln.probes_job([floor], spacing=0.5, max_distance=1.5, regions=[((0, 0, -1), (1, 1, 0))],
                              environment=1, lights=[{"point": {"position": (0, 2, 0)}}], target_error=0.1)
        self.assertEqual(job.WhichOneof("job"), "probes")
        self.assertEqual(job.probes.scene.meshes[0].name, "floor")
        self.assertEqual(len(job.probes.scene.lights), 1)
        v = job.probes.volume
        self.assertEqual((v.spacing, v.max_distance), (0.5, 1.5))
        self.assertFalse(v.HasField("max_probes"))
        self.assertEqual((v.regions[0].lo.z, v.regions[0].hi.y), (-1, 1))
        self.assertEqual(job.quality.target_error, 0.1)
        with self.assertRaisesRegex(TypeError, r"job.probes.volume.regions\[0\]: expected \(lo, hi\)"):
            kiln.probes_job([floor], spacing=0.5, regions=[(0, 0, 0)])
        both = kiln.lightmap_job([floor], probes={"spacing": 0.25, "regions": [{"lo": (0, 0, -1), "hi": (1, 1, 0)}]})
        self.assertEqual(both.lightmap.probes.spacing, 0.25)


class LightmapAgainstKilnd(unittest.TestCase):
    def setUp(self):
        self.c = test_client.DAEMON.client()
        self.addCleanup(self.c.close)
        self.out = tempfile.mkdtemp(prefix="kiln_py_lightmap_")
        self.addCleanup(shutil.rmtree, self.out, True)

    def bake(self, job, n, out):
        """Submits, watches and fetches `job` into `out`; returns the JobResult, the irradiance, validity and error
        images of the lightmap "floor" (n × n), and report.json."""
        reply = self.c.submit(job)
        self.assertFalse(reply.cache_hit)
        final = self.c.watch(reply.job_id)
        self.assertEqual(final.state, pb.JOB_STATE_SUCCEEDED, final.message + test_client.DAEMON.log())
        paths = self.c.fetch_outputs(reply.job_id, out)
        self.assertLessEqual({"floor_irradiance.exr", "floor_validity.exr", "floor_error.exr", "floor_preview.png",
                              "report.json"}, {os.path.basename(p) for p in paths})

        def read(name):
            with open(os.path.join(out, name), "rb") as f:
                return f.read()

        images = [read_exr(read("floor_%s.exr" % kind)) for kind in ("irradiance", "validity", "error")]
        for image in images:
            self.assertEqual((image.width, image.height), (n, n))
            self.assertEqual(image.string("kiln:lightmap"), "floor")
        report = json.loads(read("report.json"))
        self.assertEqual([m["name"] for m in report["lightmaps"]], ["floor"])
        self.assertEqual(report["lightmaps"][0]["resolution"], n)
        result = self.c.result(reply.job_id)
        self.assertGreater(result.report.samples, 0)
        self.assertGreater(result.report.rays, 0)
        return (result, *images, report)

    def check_every_texel(self, irradiance, validity, error, expected_at, tolerance_at):
        """Every texel valid (the quad covers the whole UV square), its error estimate finite, and its irradiance
        within 3 × that estimate of the expected value, plus tolerance_at(x, y, channel, expected)."""
        n = irradiance.width
        for y in range(n):
            for x in range(n):
                self.assertEqual(validity.at("Y", x, y), 1.0, (x, y))
                relative_error = error.at("Y", x, y)
                self.assertTrue(math.isfinite(relative_error) and relative_error >= 0, (x, y, relative_error))
                for c, channel in enumerate("RGB"):
                    expected = expected_at(x, y, c)
                    got = irradiance.at(channel, x, y)
                    tolerance = 3 * relative_error * expected + tolerance_at(x, y, c, expected)
                    self.assertLessEqual(abs(got - expected), tolerance, (x, y, channel, got, expected))

    def test_floor_under_a_constant_sky_has_irradiance_pi_times_its_radiance(self):
        # The furnace: an open upward floor under a sky of radiance L receives E = ∫ L cos θ dω = π L, at every texel.
        n, sky = 16, (0.25, 0.5, 1.0)
        floor = floor_mesh()
        self.c.upload_blob(floor.data)
        job = kiln.lightmap_job([floor], environment=sky, resolution=n, padding=0, target_error=0.01, seed=1,
                                name="python furnace")
        result, irradiance, validity, error, report = self.bake(job, n, os.path.join(self.out, "furnace"))
        # Tolerance: 3 × the texel's estimated relative error (the bound a lightmap bake is held to; cosine sampling
        # of a constant sky has no variance, so the baker reports about 0) plus 1e-6 relative for the float32 the EXR
        # stores.
        self.check_every_texel(irradiance, validity, error, lambda x, y, c: math.pi * sky[c],
                               lambda x, y, c, expected: 1e-6 * expected)
        plan = {d["effect"]: d["enabled"] for d in report["plan"]}
        self.assertTrue(plan["environment_sampling"])
        self.assertFalse(plan["point_lights"])
        self.assertLessEqual(report["error_estimate"], 0.01)  # the target was reached

        # The same job again is answered from the cache, with the same outputs.
        again = self.c.submit(job)
        self.assertTrue(again.cache_hit)
        self.assertEqual({o.name: o.digest.sha256 for o in self.c.result(again.job_id).outputs},
                         {o.name: o.digest.sha256 for o in result.outputs})

        # Asking for the denoised lightmap is another job, which adds it to the same outputs.
        denoised = kiln.lightmap_job([floor], environment=sky, resolution=n, padding=0, target_error=0.01, seed=1,
                                     denoise=True, name="python furnace, denoised")
        reply = self.c.submit(denoised)
        self.assertFalse(reply.cache_hit)
        self.assertEqual(self.c.watch(reply.job_id).state, pb.JOB_STATE_SUCCEEDED)
        outputs = {o.name: o.digest.sha256 for o in self.c.result(reply.job_id).outputs}
        self.assertEqual(set(outputs) - {o.name for o in result.outputs}, {"floor_irradiance_denoised.exr"})
        self.assertEqual(outputs["floor_irradiance.exr"],
                         {o.name: o.digest.sha256 for o in result.outputs}["floor_irradiance.exr"])

    def test_floor_under_a_point_light_has_i_cos_over_r_squared(self):
        # A point light of intensity I at height H over the floor's centre, nothing else: at distance ρ from its
        # foot, E = I cos θ / r² = I H / (ρ² + H²)^{3/2}; no other surface, so nothing bounces back.
        n, intensity, height = 16, (2.0, 1.0, 0.5), 1.0
        floor = floor_mesh()
        self.c.upload_blob(floor.data)
        job = kiln.lightmap_job([floor], resolution=n, padding=0, target_error=0.01, seed=1, name="python bulb",
                                lights=[{"name": "bulb", "color": intensity,
                                         "point": {"position": (0.5, height, -0.5)}}])
        _, irradiance, validity, error, report = self.bake(job, n, os.path.join(self.out, "bulb"))

        def falloff(x, y):  # the texel mean of H / (ρ² + H²)^{3/2}, over an 8 × 8 midpoint grid of the texel
            total = 0.0
            for i in range(8):
                for j in range(8):
                    u, v = (x + (i + 0.5) / 8) / n, (y + (j + 0.5) / 8) / n
                    rho2 = (u - 0.5) ** 2 + (v - 0.5) ** 2  # the light is over uv (0.5, 0.5)
                    total += height / (rho2 + height * height) ** 1.5
            return total / 64

        # Tolerance, beyond 3 × the estimated error (a delta light seen by next-event estimation: about 0): the
        # baker averages over its stratified points of the texel and we over an 8 × 8 grid, both midpoint rules of
        # a function whose relative second derivative is at most 3/H², so each is within (1/n)²/24 · 3 ≈ 5e-4 of
        # the true texel mean: 1e-3 relative covers both; float32 storage is far below it.
        self.check_every_texel(irradiance, validity, error, lambda x, y, c: intensity[c] * falloff(x, y),
                               lambda x, y, c, expected: 1e-3 * expected)
        # The centre gets 1/H² of I, the corners (ρ² = 1/2) 0.54 of it: the map is far from flat, so rows, columns
        # and the mesh's UVs have really been checked.
        self.assertGreater(irradiance.at("R", n // 2, n // 2) - irradiance.at("R", 0, 0), 0.8)
        plan = {d["effect"]: d["enabled"] for d in report["plan"]}
        self.assertTrue(plan["point_lights"])
        self.assertFalse(plan["environment_sampling"])

    def test_two_instances_of_one_mesh_share_an_atlas_page_with_a_manifest(self):
        # Two 1 m floors at 8 texels per metre in one 32-texel page: a region each, π under a sky of radiance 1.
        floor = floor_mesh()
        self.c.upload_blob(floor.data)
        job = kiln.lightmap_job([floor], instances=[{"mesh": 0, "name": "here"},
                                                    {"mesh": 0, "name": "there",
                                                     "transform": [(1, 0, 0, 3), (0, 1, 0, 0), (0, 0, 1, 0)]}],
                                environment=1.0, texel_density=8, page_size=32, max_pages=1, padding=0,
                                target_error=0.05, name="python atlas")
        reply = self.c.submit(job)
        final = self.c.watch(reply.job_id)
        self.assertEqual(final.state, pb.JOB_STATE_SUCCEEDED, final.message + test_client.DAEMON.log())
        out = os.path.join(self.out, "atlas")
        names = {os.path.basename(p) for p in self.c.fetch_outputs(reply.job_id, out)}
        self.assertLessEqual({"lightmaps.json", "page0_irradiance.exr", "page0_validity.exr", "report.json"}, names)
        with open(os.path.join(out, "lightmaps.json")) as f:
            manifest = json.load(f)
        self.assertEqual([i["name"] for i in manifest["instances"]], ["here", "there"])
        self.assertEqual({i["page"] for i in manifest["instances"]}, {"page0"})
        regions = [i["region"] for i in manifest["instances"]]
        self.assertEqual([(r["width"], r["height"]) for r in regions], [(8, 8), (8, 8)])
        self.assertNotEqual((regions[0]["x"], regions[0]["y"]), (regions[1]["x"], regions[1]["y"]))
        # The page shrinks to its two charts (8 texels and 2 of padding each, side by side): 20 texels a side.
        size = manifest["pages"][0]["size"]
        self.assertEqual(size, 20)
        with open(os.path.join(out, "page0_irradiance.exr"), "rb") as f:
            irradiance = read_exr(f.read())
        self.assertEqual((irradiance.width, irradiance.height), (size, size))
        for instance in manifest["instances"]:
            # The texel at the centre of each floor's UV square, by the manifest's scale and offset: E = π.
            u = 0.5 * instance["scale"][0] + instance["offset"][0]
            v = 0.5 * instance["scale"][1] + instance["offset"][1]
            x, y = int(u * size), int(v * size)
            self.assertAlmostEqual(irradiance.at("G", x, y), math.pi, delta=1e-5, msg=(instance["name"], x, y))

    def test_floor_under_the_sun_through_an_absorbing_box_follows_beers_law(self):
        # A sun of irradiance E at angle t from the vertical through a box of absorbing haze d deep: every texel gets
        # E cos t exp(-sigma_a d / cos t), through the service end to end (the medium in the job, the plan in the
        # report). Transmittance by ratio tracking through a homogeneous absorber is a yes/no per estimate, so the
        # texels are noisy: their mean is compared, within 4.5 standard errors of it taken from their spread
        # (64 texels: Student's t with 63 degrees of freedom exceeds 4.5 with probability 3e-5), plus 1e-5 relative.
        n, e_sun, t, depth, sigma_a = 8, 2.0, 0.5, 0.6, (0.2, 0.5, 1.0)
        floor = floor_mesh()
        self.c.upload_blob(floor.data)
        job = kiln.lightmap_job(
            [floor], resolution=n, padding=0, target_error=1e-4, samples=64, seed=3, name="python haze",
            lights=[{"name": "sun", "color": e_sun,
                     "directional": {"direction": (math.sin(t), -math.cos(t), 0), "angular_diameter": 0}}],
            media=[{"name": "haze", "box": {"lo": (-20, -1, -20), "hi": (20, depth, 20)}, "sigma_a": sigma_a}])
        _, irradiance, validity, _, report = self.bake(job, n, os.path.join(self.out, "haze"))
        for c, channel in enumerate("RGB"):
            values = [irradiance.at(channel, x, y) for y in range(n) for x in range(n) if validity.at("Y", x, y) == 1]
            self.assertEqual(len(values), n * n)
            mean = sum(values) / len(values)
            sd = math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1))
            expected = e_sun * math.cos(t) * math.exp(-sigma_a[c] * depth / math.cos(t))
            self.assertLessEqual(abs(mean - expected), 4.5 * sd / math.sqrt(len(values)) + 1e-5 * expected,
                                 (channel, mean, expected, sd))
        plan = {d["effect"]: d["enabled"] for d in report["plan"]}
        self.assertTrue(plan["participating_media"])
        self.assertFalse(plan["media_scattering"])  # it scatters nothing: attenuation only
        self.assertEqual(report["media"]["mode"], "attenuation")

    def test_a_corrupt_python_mesh_fails_naming_its_field(self):
        floor = floor_mesh()
        broken = floor.data[:-4]  # one index short
        digest = self.c.upload_blob(broken)
        job = kiln.lightmap_job([("floor", digest)], environment=1.0, resolution=8, target_error=0.2)
        reply = self.c.submit(job)
        final = self.c.watch(reply.job_id)
        self.assertEqual(final.state, pb.JOB_STATE_FAILED)
        result = self.c.result(reply.job_id)
        self.assertEqual(result.error.code, pb.Error.INVALID_ARGUMENT, result.error.message)
        self.assertEqual(result.error.field, "job.lightmap.meshes[0].geometry")



class ProbesAgainstKilnd(unittest.TestCase):
    def test_probes_job_round_trip(self):
        """A probes job over a floor under a constant sky of 1: probes.vdb, its preview and a report with counts."""
        c = test_client.DAEMON.client()
        self.addCleanup(c.close)
        out = tempfile.mkdtemp(prefix="kiln_py_probes_")
        self.addCleanup(shutil.rmtree, out, True)
        floor = floor_mesh()
        c.upload_blob(floor.data)
        job = kiln.probes_job([floor], spacing=0.25, regions=[((0, 0, -1), (1, 0.5, 0))], environment=1,
                              target_error=0.2)
        reply = c.submit(job)
        final = c.watch(reply.job_id)
        self.assertEqual(final.state, pb.JOB_STATE_SUCCEEDED, final.message + test_client.DAEMON.log())
        names = {os.path.basename(p) for p in c.fetch_outputs(reply.job_id, out)}
        self.assertEqual(names, {"probes.vdb", "probes_preview.png", "report.json"})
        with open(os.path.join(out, "report.json")) as f:
            counts = json.load(f)["probes"]["counts"]
        # The region above the unit floor: 4 x 2 x 4 cells, each within max_distance (2 x 0.25) of the floor.
        self.assertEqual(counts["placed"], 4 * 2 * 4)
        self.assertEqual(counts["valid"], counts["placed"])

if __name__ == "__main__":
    unittest.main()
