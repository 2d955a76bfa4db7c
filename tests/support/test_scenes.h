// Scenes with known answers for the lightmap tests: each built in code, with lightmap UVs, in the units given.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "bakers/image/exr.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/scene/scene.h"

namespace kiln::test {

// A Lambertian material (no specular lobe) of albedo `rho`.
scene::SceneMaterial lambert_material(const std::string& name, double rho, Rgb emission = Rgb{0.0});

// Appends a quad p0 p1 p2 p3 (counter-clockwise seen from its front) as a mesh of its own named `name`, subdivided
// n × n, lightmap UVs spanning [0, 1]² (p0 at (0, 1), p1 at (1, 1), p2 at (1, 0)), with one instance. Returns the
// mesh index.
int add_quad(scene::Scene& s, const std::string& name, Vec3 p0, Vec3 p1, Vec3 p2, Vec3 p3, uint32_t material,
             int n = 1);

// Appends an axis-aligned box (all six faces outward, or inward for a room) as one mesh with a lightmap atlas (the
// faces in a 3 × 2 grid with margins). Returns the mesh index.
int add_box(scene::Scene& s, const std::string& name, Vec3 lo, Vec3 hi, uint32_t material, bool inward = false);

// Appends a UV sphere (lat-long lightmap UVs, `rings` × 2·`rings` quads), facing outward or inward, with the
// sphere's vertex normals (smooth) or none (each facet its geometric normal).
int add_sphere(scene::Scene& s, const std::string& name, Vec3 centre, double radius, int rings, uint32_t material,
               bool inward = false, bool smooth = true);

// Multiplies every position of every mesh and every light position, size and distance by `scale` and then adds
// `offset` (directions, radiances and intensities unchanged; point and spot intensities scaled by scale² so that
// irradiance at scaled distances is unchanged).
void scale_scene(scene::Scene& s, double scale, Vec3 offset = {});

// x' = s·x + t.
scene::Transform translate_scale(Vec3 t, double s);

// ---- Lightmap test helpers (appended for the outputs, lights and robustness tests) ----

// The floor quad of side `size` centred at the origin facing +Y, subdivided n × n, as its own mesh "floor"
// (add_quad's UV layout: u grows towards +X, v = 0 at z = −size/2). Returns the mesh index.
int add_floor(scene::Scene& s, double size, uint32_t material, int n = 4);

// A 2 m floor (add_floor, n = 2) of one Lambertian material of albedo `rho` under a point light of intensity I at
// `position`, and nothing else.
scene::Scene floor_under_point_light(double rho, const Vec3& position, Rgb I);

// A 2 m black floor (add_floor, albedo 0: all light is direct) under a one-sided 1 m square light of radiance 10,
// 1 m above it and off centre (0.1, 1, −0.1), facing down.
scene::Scene floor_under_square_light();

// The irradiance from rectangle light `l` (one-sided, radiance l.color.r) at p with normal n, by Lambert's polygon
// formula (scene::polygon_projected_solid_angle), occlusion aside.
double rect_light_irradiance(const scene::Light& l, const Vec3& p, const Vec3& n);

// Per texel of lightmap `name` at `resolution`², the weighted mean of f(position, normal) over the sample points the
// baker's rasterizer (bakers/lightmap/texels.h) puts in the texel, with the weights the baker averages its estimates
// with; NaN for texels no triangle covers. An analytic field evaluated this way is exactly what a noise-free bake
// of it would store (texels.h is tested on its own), so a test's tolerance is the bake's noise and float storage.
std::vector<double> texel_means(const scene::Scene& s, const std::string& name, int resolution,
                                const std::function<double(const Vec3& p, const Vec3& n)>& f);

// An equirectangular W × H OpenEXR (RGB float) whose pixel centres hold radiance(direction) (bakers/envmap/cubemap.h
// conventions: row 0 the zenith, u = ½ looking along −Z).
std::string equirect_exr(int width, int height, const std::function<Rgb(const Vec3& dir)>& radiance);

// A bake input for tests: no padding and no seam stitching (texels are compared as baked: stitching moves the texels
// along a seam towards agreement with the other side, which at a hard edge is not what was measured there), no
// preview, and the texel error metric, so that
// NAME_error.exr holds each texel's standard error relative to its own mean (the tests that compare texels with
// exact values multiply it back by the texel's value).
lightmap::LightmapBakeInput lightmap_input(scene::Scene s, int resolution, double target_error);

// How many estimated standard errors a texel may be off in those comparisons. A texel's standard error comes from the
// spread of its kReplicas = 8 replica means (bakers/lightmap/replica_sums.h): 7 degrees of freedom, so the ratio of
// its error to the estimate follows Student's t with 7 degrees of freedom, which exceeds 8 in magnitude with
// probability 9·10⁻⁵ (6 would be exceeded at 5·10⁻⁴ per texel: about one texel in a few hundred-texel test).
inline constexpr double kEstimatedSigmas = 8;

// The output named `name` (throws std::runtime_error naming it when absent), and the same decoded as an EXR.
const bake::BakeOutput& find_output(const lightmap::LightmapBakeResult& result, const std::string& name);
image::FloatImage exr_output(const lightmap::LightmapBakeResult& result, const std::string& name);

// The bundled Cornell-box-like scene exactly as client/examples/scenes/cornell_box.py writes it (keep the two in step):
// a 2 m box (x in [−1, 1], y in [0, 2], z in [−1, 1]) open towards +z, white floor, ceiling and back wall, red left
// and green right walls, a short and a tall block (five faces each, rotated −17° and 18°), and a 0.5 m square
// emissive patch facing down at y = 1.99 emitting 17·(1, 0.71, 0.24). One mesh per object, each with one instance,
// per-face normals, texture UVs and its own lightmap atlas (each face a chart, margin 1/16); positions and UVs rounded
// to float as the glTF stores them. Materials are purely Lambertian with the script's base colours (diffuse albedo 1
// tinted by base_color; the glTF import would add the dielectric specular lobe of metallic-roughness): "white" 0.73,
// "red" (0.63, 0.065, 0.05), "green" (0.14, 0.45, 0.091), "light" 0.78 with the emission.
scene::Scene cornell_box();

}  // namespace kiln::test
