// Hard cases stay numerically stable (no NaN ever reaches a texel; degenerate and sliver triangles and a mesh
// touching itself do not produce NaN, black speckles or acne; a scene scaled by 1e-3 or 1e4 bakes the same):
// self-intersecting meshes, slivers, degenerate triangles, extreme scales and offsets, bad environment texels, NaN
// inputs, a grazing sun, chart edges, the shadow terminator of a sphere, and the honesty of the error estimate on a
// second analytic scene.
//
// Bounds used below, each exact:
// - Under a sky of radiance 1 and nothing else, a point outside a convex occluder sees at least the half of its
//   hemisphere on its side of the occluder's separating face plane: E ≥ π/2 (the cosine-weighted measure of half a
//   hemisphere cut by a plane through the normal is ½; a plane not through the point leaves more).
// - A point on a convex surface under any distant light sees nothing of the surface above its tangent plane, so E is
//   the light's unoccluded value there (no acne, no terminator artefact).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/math/constants.h"
#include "bakers/scene/polygon_irradiance.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using test::exr_output;
using test::lambert_material;
using test::lightmap_input;
using test::texel_means;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The number after "dropped_samples": in report.json (samples whose contribution was not finite and was discarded:
// a NaN that arose anywhere in the transport).
long dropped_samples(const LightmapBakeResult& r) {
  const std::string& json = test::find_output(r, "report.json").bytes;
  const auto at = json.find("\"dropped_samples\": ");
  if (at == std::string::npos) return -1;
  return std::stol(json.substr(at + 19));
}

// Every pixel of every EXR output of lightmap `map` is finite, and non-negative except in the SH (whose order-1
// coefficients are signed).
void expect_outputs_finite(const LightmapBakeResult& r, const std::string& map) {
  for (const bake::BakeOutput& o : r.outputs) {
    if (o.name.rfind(map + "_", 0) != 0 || o.media_type != "image/x-exr") continue;
    const image::FloatImage img = image::decode_exr(o.bytes);
    const bool signed_values = o.name == map + "_sh.exr";
    for (size_t i = 0; i < img.pixels.size(); ++i) {
      ASSERT_TRUE(std::isfinite(img.pixels[i]) && (signed_values || img.pixels[i] >= 0))
          << o.name << " value " << img.pixels[i];
    }
  }
}

double component(const Vec3& v, int axis) { return axis == 0 ? v.x : axis == 1 ? v.y : v.z; }

bool outside_box(const Vec3& p, Vec3 lo, Vec3 hi, double margin) {
  return p.x < lo.x - margin || p.x > hi.x + margin || p.y < lo.y - margin || p.y > hi.y + margin ||
         p.z < lo.z - margin || p.z > hi.z + margin;
}

struct Box {
  std::string name;
  Vec3 lo, hi;
};

// The projected solid angle ∫ max(0, n·ω) dω of an axis-aligned box seen from p (outside it): the sum over the faces
// p is in front of (for a convex box they do not overlap as seen from p), each by Lambert's formula clipped to p's
// horizon.
double box_projected_solid_angle(const Box& b, const Vec3& p, const Vec3& n) {
  double sum = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (bool high : {false, true}) {
      const double c = component(high ? b.hi : b.lo, axis);
      const double pa = component(p, axis);
      if (high ? !(pa > c) : !(pa < c)) continue;  // p behind or in this face's plane: the face is hidden
      std::vector<Vec3> face;
      for (int k = 0; k < 4; ++k) {
        double q[3];
        q[axis] = c;
        q[u] = component((k == 1 || k == 2) ? b.hi : b.lo, u);
        q[v] = component(k >= 2 ? b.hi : b.lo, v);
        face.push_back({q[0], q[1], q[2]});
      }
      sum += scene::polygon_projected_solid_angle(face, p, n);
    }
  }
  return sum;
}

// Two boxes interpenetrating, and a box sunk halfway into the floor, under a sky of radiance 1 (albedo 0.5, so light
// bounces between them): nothing non-finite anywhere, no sample dropped, and every texel whose points lie outside
// every other box (by a floor texel) has E between the union bound π − Σ Ω_occluder (the sky the floor and the other
// boxes could hide, each by its exact projected solid angle; overlaps only make the bound looser) and the furnace
// bound π/(1 − ρ), each widened by 6 of the texel's estimated standard errors. Texels of "a" buried inside "b" must
// not be lit as if open (a leak): invalid, or under the bound for what b leaves of the sky.
TEST(LightmapRobustness, MeshesTouchingThemselvesStayFinite) {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  const double half = 2.0;
  test::add_floor(s, 2 * half, 0);
  const std::vector<Box> boxes{{"sunk", {-1.5, -0.5, -1.5}, {-0.9, 0.5, -0.9}},
                               {"a", {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}},
                               {"b", {0.5, 0.3, 0.5}, {1.5, 1.3, 1.5}}};
  for (const Box& b : boxes) test::add_box(s, b.name, b.lo, b.hi, 0);
  s.environment.constant = Rgb{1.0};
  const int W = 32;
  LightmapBakeInput in = lightmap_input(s, W, 0.03);
  in.padding = 2;
  const LightmapBakeResult r = bake_lightmaps(in);
  EXPECT_EQ(dropped_samples(r), 0);
  const double margin = 2 * half / W;
  const std::vector<Vec3> floor_polygon{{-half, 0, -half}, {half, 0, -half}, {half, 0, half}, {-half, 0, half}};
  for (const std::string map : {"floor", "sunk", "a", "b"}) {
    expect_outputs_finite(r, map);
    auto exposed = [&](const Vec3& p) {
      for (const Box& b : boxes) {
        if (b.name != map && !outside_box(p, b.lo, b.hi, margin)) return false;
      }
      return map == "floor" || p.y > margin;  // box faces: above the floor
    };
    const auto checked = texel_means(s, map, W, [&](const Vec3& p, const Vec3&) { return exposed(p) ? 1.0 : 0.0; });
    const auto lower = texel_means(s, map, W, [&](const Vec3& p, const Vec3& n) {
      double hidden = map == "floor" ? 0.0 : scene::polygon_projected_solid_angle(floor_polygon, p, n);
      for (const Box& b : boxes) {
        if (b.name != map) hidden += box_projected_solid_angle(b, p, n);
      }
      return std::max(0.0, kPi - hidden);
    });
    const image::FloatImage E = exr_output(r, map + "_irradiance.exr"), err = exr_output(r, map + "_error.exr"),
                            valid = exr_output(r, map + "_validity.exr");
    int n = 0;
    for (int y = 0; y < W; ++y) {
      for (int x = 0; x < W; ++x) {
        const size_t t = static_cast<size_t>(y) * W + x;
        if (checked[t] != 1.0 || valid.at(x, y, 0) != 1.0f) continue;
        ++n;
        const double e = E.at(x, y, 0), noise = test::kEstimatedSigmas * err.at(x, y, 0) * e;
        EXPECT_GE(e, lower[t] - noise) << map << " texel " << x << "," << y;
        EXPECT_LE(e, kPi / (1 - 0.5) + noise) << map << " texel " << x << "," << y;
      }
    }
    EXPECT_GT(n, map == "floor" ? 500 : 100) << map;
  }
  // a's top buried inside b (by 0.1): b's faces leave it at most what a point just outside b's face would see.
  const auto buried = texel_means(s, "a", W, [&](const Vec3& p, const Vec3& n) {
    return n.y > 0.99 && !outside_box(p, boxes[2].lo, boxes[2].hi, -0.1) ? 1.0 : 0.0;
  });
  const image::FloatImage Ea = exr_output(r, "a_irradiance.exr"), Va = exr_output(r, "a_validity.exr");
  int buried_texels = 0;
  for (int y = 0; y < W; ++y) {
    for (int x = 0; x < W; ++x) {
      if (buried[static_cast<size_t>(y) * W + x] != 1.0) continue;
      ++buried_texels;
      if (Va.at(x, y, 0) == 1.0f) {
        EXPECT_LT(Ea.at(x, y, 0), 0.9 * kPi) << "buried texel of a lit: " << x << "," << y;
      }
    }
  }
  EXPECT_GT(buried_texels, 4);
}

// A sliver triangle (aspect 1e6 in space and in UV) floating above the floor, and a zero-area triangle (three
// collinear points) mixed into a valid mesh whose UVs give it texels, under a sky of radiance 1, everything black (no
// bounce): the degenerate one is reported and left out (its texels invalid, then filled by dilation: finite), the
// sliver bakes exactly π on its upper side (a zero-variance estimate: 1e-6), and the floor gets π less the
// projected solid angles of the strip's triangle and the sliver (Lambert's formula). Tolerance: kEstimatedSigmas of the
// texels' own estimated errors and 1e-5 relative.
TEST(LightmapRobustness, SliverAndDegenerateTrianglesBakeWithoutNaN) {
  scene::Scene s;
  s.materials.push_back(lambert_material("black", 0.0));
  test::add_floor(s, 2.0, 0);
  scene::Mesh sliver;
  sliver.name = "sliver";
  sliver.positions = {{-0.5, 0.3, 0}, {0.5, 0.3, 0}, {0, 0.3, -1e-6}};  // CCW from above
  sliver.lightmap_uv = {{0.05, 0.5}, {0.95, 0.5}, {0.5, 0.5 - 0.9e-6}};
  sliver.indices = {0, 1, 2};
  s.meshes.push_back(sliver);
  s.instances.push_back({});
  s.instances.back().mesh = static_cast<int>(s.meshes.size() - 1);
  scene::Mesh strip;
  strip.name = "strip";
  // A valid triangle on the left of the UV square and a collinear one (zero area in 3-D, not in UV) on the right.
  strip.positions = {{-0.9, 0.0, 0.95}, {-0.5, 0.0, 0.95}, {-0.9, 0.0, 0.55},
                     {0.5, 0.0, 0.9},   {0.7, 0.0, 0.9},   {0.9, 0.0, 0.9}};
  for (Vec3& p : strip.positions) p.y = 0.5;  // above the floor, facing up (CCW from above below)
  strip.lightmap_uv = {{0.05, 0.05}, {0.45, 0.05}, {0.05, 0.45}, {0.55, 0.5}, {0.95, 0.5}, {0.75, 0.95}};
  strip.indices = {0, 1, 2, 3, 4, 5};
  s.meshes.push_back(strip);
  s.instances.push_back({});
  s.instances.back().mesh = static_cast<int>(s.meshes.size() - 1);
  s.environment.constant = Rgb{1.0};
  const int W = 16;
  LightmapBakeInput in = lightmap_input(s, W, 0.02);
  in.padding = 8;
  // A floor texel that sees the strip in ~2 % of its directions meets it in none of 16 × 4 × 2 rays 5 % of the
  // time, estimates zero variance and stops (the default min_samples): 64 make that (0.98)^512 ≈ 3e-5.
  in.min_samples = 64;
  const LightmapBakeResult r = bake_lightmaps(in);
  EXPECT_EQ(dropped_samples(r), 0);
  for (const char* map : {"floor", "sliver", "strip"}) expect_outputs_finite(r, map);
  bool reported = false;
  for (const std::string& line : r.skipped) reported |= line.find("degenerate_triangle") != std::string::npos;
  EXPECT_TRUE(reported) << "the collinear triangle is reported";
  const image::FloatImage Es = exr_output(r, "sliver_irradiance.exr"), Vs = exr_output(r, "sliver_validity.exr");
  int sliver_texels = 0;
  for (int y = 0; y < W; ++y) {
    for (int x = 0; x < W; ++x) {
      if (Vs.at(x, y, 0) != 1.0f) continue;
      ++sliver_texels;
      EXPECT_NEAR(Es.at(x, y, 0), kPi, 1e-6 * kPi) << "sliver texel " << x << "," << y;  // zero-variance sky
    }
  }
  EXPECT_GE(sliver_texels, 12) << "the sliver crosses the lightmap";
  const image::FloatImage Vt = exr_output(r, "strip_validity.exr");
  for (int y = 0; y < W; ++y) {
    for (int x = W / 2 + 1; x < W; ++x) EXPECT_EQ(Vt.at(x, y, 0), 0.0f) << "the degenerate triangle bakes nothing";
  }
  // The floor sees the sky less what the strip's valid triangle and the sliver hide: π − their projected solid
  // angles (they do not overlap as seen from the floor but in grazing directions of ~1e-6 sr).
  const std::vector<Vec3> tri{strip.positions[0], strip.positions[1], strip.positions[2]};
  const std::vector<Vec3> thin{sliver.positions[0], sliver.positions[1], sliver.positions[2]};
  const auto expected = texel_means(s, "floor", W, [&](const Vec3& p, const Vec3& n) {
    return kPi - scene::polygon_projected_solid_angle(tri, p, n) - scene::polygon_projected_solid_angle(thin, p, n);
  });
  const image::FloatImage Ef = exr_output(r, "floor_irradiance.exr"), ef = exr_output(r, "floor_error.exr");
  for (int y = 0; y < W; ++y) {
    for (int x = 0; x < W; ++x) {
      const double want = expected[static_cast<size_t>(y) * W + x];
      // The target error (0.02) on top of the estimate's own: a texel that sees the strip in only ~1e-3 of its
      // directions may still meet it in none of its samples, estimate zero variance and stop, off by < 1e-3.
      EXPECT_NEAR(Ef.at(x, y, 0), want, want * (test::kEstimatedSigmas * ef.at(x, y, 0) + 0.02))
          << "floor texel " << x << "," << y;
    }
  }
}

// The point-light floor and the sun-and-box shadow scenes at scale 1e-3, 1e4, and at scale 1 but 1e5 from the
// origin (where float geometry is resolved to 1e5 · 2⁻²⁴ ≈ 6e-3): the point light gives I cos θ/r² at every texel (a
// delta light, albedo 0: no noise; 1e-5 relative for float storage and the positions' rounding); the sun leaves
// E = 0 exactly at texels whose points all lie in the exact shadow and E cos θ exactly at those all clear of it, with a
// margin of 2e-2 (in scene units × scale) around the shadow's edges for the float geometry.
TEST(LightmapRobustness, PointAndSunScenesAtExtremeScalesMatchTheAnalyticAnswer) {
  struct Placement {
    double scale;
    Vec3 offset;
  };
  for (const Placement& at : {Placement{1e-3, {}}, Placement{1e4, {}}, Placement{1.0, {1e5, 3e4, -1e5}}}) {
    const std::string where = "scale " + std::to_string(at.scale) + " offset " + std::to_string(at.offset.x);
    {
      scene::Scene s;
      s.materials.push_back(lambert_material("black", 0.0));
      test::add_floor(s, 2.0, 0);
      scene::Light l;
      l.type = scene::LightShape::point;
      l.position = {0.3, 1.5, 0.2};
      l.color = Rgb{20.0};
      s.lights.push_back(l);
      test::scale_scene(s, at.scale, at.offset);
      const scene::Light& ls = s.lights[0];
      const auto expected = texel_means(s, "floor", 16, [&](const Vec3& p, const Vec3& n) {
        const Vec3 d = ls.position - p;
        const double r = length(d);
        return ls.color.r * std::max(0.0, dot(n, d / r)) / (r * r);
      });
      const LightmapBakeResult r = bake_lightmaps(lightmap_input(s, 16, 0.01));
      EXPECT_EQ(dropped_samples(r), 0) << where;
      const image::FloatImage E = exr_output(r, "floor_irradiance.exr");
      for (int y = 0; y < 16; ++y) {
        for (int x = 0; x < 16; ++x) {
          const double want = expected[static_cast<size_t>(y) * 16 + x];
          EXPECT_NEAR(E.at(x, y, 0), want, 1e-5 * want) << where << " point light texel " << x << "," << y;
        }
      }
    }
    {
      scene::Scene s;
      s.materials.push_back(lambert_material("black", 0.0));
      test::add_floor(s, 4.0, 0);
      test::add_box(s, "box", {-0.5, 0, -0.5}, {0.5, 1, 0.5}, 0);
      scene::Light sun;
      sun.type = scene::LightShape::directional;
      sun.direction = normalize(Vec3{1, -1, 0});  // the shadow: x ∈ [0.5, 1.5], |z| ≤ 0.5
      s.lights.push_back(sun);
      const scene::Scene unscaled = s;
      test::scale_scene(s, at.scale, at.offset);
      const int W = 32;
      const double m = 2e-2;
      // Classified on the unscaled scene (the same texels and points, up to the scaling).
      const auto shadowed = texel_means(unscaled, "floor", W, [&](const Vec3& p, const Vec3&) {
        return (p.x > 0.5 + m && p.x < 1.5 - m && std::abs(p.z) < 0.5 - m) ? 1.0 : 0.0;
      });
      const auto clear = texel_means(unscaled, "floor", W, [&](const Vec3& p, const Vec3&) {
        return (p.x > 1.5 + m || p.x < -0.5 - m || std::abs(p.z) > 0.5 + m) ? 1.0 : 0.0;
      });
      const LightmapBakeResult r = bake_lightmaps(lightmap_input(s, W, 0.01));
      EXPECT_EQ(dropped_samples(r), 0) << where;
      const image::FloatImage E = exr_output(r, "floor_irradiance.exr");
      int n_shadow = 0, n_clear = 0;
      for (int y = 0; y < W; ++y) {
        for (int x = 0; x < W; ++x) {
          const size_t t = static_cast<size_t>(y) * W + x;
          if (shadowed[t] == 1.0) {
            ++n_shadow;
            EXPECT_EQ(E.at(x, y, 0), 0.0f) << where << " shadowed texel " << x << "," << y;
          } else if (clear[t] == 1.0) {
            ++n_clear;
            EXPECT_NEAR(E.at(x, y, 0), std::sqrt(0.5), 1e-6) << where << " lit texel " << x << "," << y;
          }
        }
      }
      EXPECT_GT(n_shadow, 20);
      EXPECT_GT(n_clear, 500);
    }
  }
}

// An environment image with NaN, +Inf, −Inf and negative texels below the horizon: they are sanitised by the
// documented rule (env_input.h), counted in report.json's scene problems, never seen in an output, and an upward
// plane still gets π (the sky above is 1; the bilinear horizon blur allows 1e-3, see lightmap_lights_test).
TEST(LightmapRobustness, BadEnvironmentTexelsAreCountedAndNeverReachAnOutput) {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  test::add_floor(s, 2.0, 0);
  int bad = 0;
  const std::string env = test::equirect_exr(64, 32, [&](const Vec3& d) {
    if (d.y > 0) return Rgb{1.0};
    if (d.y > -0.5) return Rgb{0.0};
    const double v[4] = {kNaN, kInf, -kInf, -3.0};
    ++bad;
    return Rgb{v[bad % 4], 0.0, 0.0};
  });
  LightmapBakeInput in = lightmap_input(s, 16, 0.01);
  in.environment_image = env;
  in.min_samples = 64;
  in.radiance = in.ao = in.directional = true;
  const LightmapBakeResult r = bake_lightmaps(in);
  expect_outputs_finite(r, "floor");
  EXPECT_EQ(dropped_samples(r), 0);
  const std::string counted = "environment: " + std::to_string(bad) + " texels";
  bool found = false;
  for (const std::string& line : r.skipped) found |= line.find(counted) != std::string::npos;
  EXPECT_TRUE(found) << "expected the report to say '" << counted << "'";
  EXPECT_NE(test::find_output(r, "report.json").bytes.find(counted), std::string::npos);
  const image::FloatImage E = exr_output(r, "floor_irradiance.exr"), err = exr_output(r, "floor_error.exr");
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x)
      EXPECT_NEAR(E.at(x, y, 0), kPi, kPi * (test::kEstimatedSigmas * err.at(x, y, 0) + 1e-3)) << x << "," << y;
  }
}

// NaN in light colours and in emission: lights.h's rule ("a colour with a non-finite channel emits nothing") applies
// to every emitter, so a NaN point light and a partly-NaN emissive quad add nothing: the floor under a rect light
// gets exactly the rect light's Lambert irradiance, the quad only shading it (the rect light is above the quad's
// reach: texels compared are those the quad does not shadow). No output is NaN.
// lights.h's rule for light colours ("a colour with a non-finite channel emits nothing, negative channels are 0"):
// a NaN point light, an infinite spot light, a rect light with a NaN channel and a NaN sun add nothing, so the floor
// gets exactly what the one good rect light gives (Lambert's formula), no sample is dropped and no output is NaN.
// Tolerance: kEstimatedSigmas of the texels' estimated errors (rect light sampling) and 1e-6 relative.
TEST(LightmapRobustness, NonFiniteLightColoursEmitNothing) {
  scene::Scene s;
  s.materials.push_back(lambert_material("black", 0.0));
  test::add_floor(s, 2.0, 0);
  scene::Light good;
  good.type = scene::LightShape::rect;
  good.position = {-0.3, 1.0, 0.3};
  good.u_axis = {0.6, 0, 0};
  good.v_axis = {0, 0, 0.4};
  good.color = Rgb{10.0};
  scene::Light point;
  point.type = scene::LightShape::point;
  point.position = {0, 1, 0};
  point.color = Rgb{kNaN};
  scene::Light spot = point;
  spot.type = scene::LightShape::spot;
  spot.color = Rgb{kInf};
  scene::Light bad_rect = good;
  bad_rect.position = {0.4, 0.8, -0.4};
  bad_rect.color = Rgb{1.0, kNaN, 1.0};
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.color = Rgb{kNaN, 1.0, 1.0};
  s.lights = {point, good, spot, bad_rect, sun};
  const std::vector<Vec3> polygon{
      good.position - good.u_axis * 0.5 - good.v_axis * 0.5, good.position + good.u_axis * 0.5 - good.v_axis * 0.5,
      good.position + good.u_axis * 0.5 + good.v_axis * 0.5, good.position - good.u_axis * 0.5 + good.v_axis * 0.5};
  const auto expected = texel_means(s, "floor", 16, [&](const Vec3& p, const Vec3& n) {
    return good.color.r * scene::polygon_projected_solid_angle(polygon, p, n);
  });
  LightmapBakeInput in = lightmap_input(s, 16, 0.02);
  in.min_samples = 32;
  const LightmapBakeResult r = bake_lightmaps(in);
  expect_outputs_finite(r, "floor");
  EXPECT_EQ(dropped_samples(r), 0);
  const image::FloatImage E = exr_output(r, "floor_irradiance.exr"), err = exr_output(r, "floor_error.exr");
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      const double want = expected[static_cast<size_t>(y) * 16 + x];
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(E.at(x, y, c), want, want * (test::kEstimatedSigmas * err.at(x, y, 0) + 1e-6) + 1e-9)
            << x << "," << y << " ch " << c;
      }
    }
  }
}

// A NaN in an emission makes the material emit nothing (scene_check repairs it, as lights.h's usable_emission
// does for lights), so no path carries it and no estimate is dropped.
TEST(LightmapRobustness, NaNEmissionEmitsNothing) {
  scene::Scene s;
  s.materials.push_back(lambert_material("black", 0.0));
  s.materials.push_back(lambert_material("bad glow", 0.0, Rgb{1.0, kNaN, 1.0}));
  test::add_floor(s, 2.0, 0);
  const Vec3 q[4] = {{0.6, 0.2, -0.9}, {0.9, 0.2, -0.9}, {0.9, 0.2, -0.6}, {0.6, 0.2, -0.6}};  // faces −Y
  const int lamp = test::add_quad(s, "bad_lamp", q[0], q[1], q[2], q[3], 1, 1);
  s.instances[lamp].bake = false;
  scene::Light nan_point;
  nan_point.type = scene::LightShape::point;
  nan_point.position = {0, 1, 0};
  nan_point.color = Rgb{kNaN};
  scene::Light rect;
  rect.type = scene::LightShape::rect;
  rect.position = {-0.3, 1.0, 0.3};
  rect.u_axis = {0.6, 0, 0};
  rect.v_axis = {0, 0, 0.4};
  rect.color = Rgb{10.0};
  s.lights = {nan_point, rect};
  const std::vector<Vec3> rect_polygon{
      rect.position - rect.u_axis * 0.5 - rect.v_axis * 0.5, rect.position + rect.u_axis * 0.5 - rect.v_axis * 0.5,
      rect.position + rect.u_axis * 0.5 + rect.v_axis * 0.5, rect.position - rect.u_axis * 0.5 + rect.v_axis * 0.5};
  const auto expected = texel_means(s, "floor", 16, [&](const Vec3& p, const Vec3& n) {
    // The quad shadows floor points near it from the rect light: leave those out (NaN: not compared).
    if (p.x > 0.2 && p.z < -0.2) return kNaN;
    return rect.color.r * scene::polygon_projected_solid_angle(rect_polygon, p, n);
  });
  LightmapBakeInput in = lightmap_input(s, 16, 0.02);
  in.min_samples = 32;
  const LightmapBakeResult r = bake_lightmaps(in);
  expect_outputs_finite(r, "floor");
  EXPECT_EQ(dropped_samples(r), 0) << "a NaN emission reached the transport";
  const image::FloatImage E = exr_output(r, "floor_irradiance.exr"), err = exr_output(r, "floor_error.exr");
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      const double want = expected[static_cast<size_t>(y) * 16 + x];
      if (std::isnan(want)) continue;
      EXPECT_NEAR(E.at(x, y, 0), want, want * (test::kEstimatedSigmas * err.at(x, y, 0) + 1e-6) + 1e-9)
          << x << "," << y;
    }
  }
}

// The worst case of the same rule: inside a closed sphere whose emission has a NaN channel, every path meets the
// emitter. By lights.h's rule nothing emits, so E = 0 exactly at every texel, and the bake ends by itself (no time
// limit needed: estimates tried, kept or dropped, bound every texel's work).
TEST(LightmapRobustness, NaNEmissionEverywhereStillBakesZero) {
  scene::Scene s;
  s.materials.push_back(lambert_material("bad glow", 0.5, Rgb{1.0, kNaN, 1.0}));
  test::add_sphere(s, "sphere", {0, 0, 0}, 1.0, 8, 0, /*inward=*/true, /*smooth=*/false);
  LightmapBakeInput in = lightmap_input(s, 8, 0.05);
  const LightmapBakeResult r = bake_lightmaps(in);
  expect_outputs_finite(r, "sphere");
  const image::FloatImage E = exr_output(r, "sphere_irradiance.exr"), err = exr_output(r, "sphere_error.exr"),
                          V = exr_output(r, "sphere_validity.exr");
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      if (V.at(x, y, 0) != 1.0f) continue;
      EXPECT_EQ(E.at(x, y, 0), 0.0f) << x << "," << y;
      EXPECT_EQ(err.at(x, y, 0), 0.0f) << "texel " << x << "," << y << " has no estimate (error 1 = none)";
    }
  }
  EXPECT_EQ(dropped_samples(r), 0);
}

// A NaN base colour: either refused before baking (std::invalid_argument naming the material) or sanitised; in no
// case a NaN in an output (NAME_radiance.exr multiplies E by the material's reflectance).
// scene_check repairs it (NaN channel → 0) and reports it.
TEST(LightmapRobustness, NaNBaseColourNeverReachesAnOutput) {
  scene::Scene s;
  scene::SceneMaterial m = lambert_material("nan colour", 0.5);
  m.base_color = Rgb{0.5, kNaN, 0.5};
  s.materials.push_back(m);
  test::add_floor(s, 2.0, 0);
  s.environment.constant = Rgb{1.0};
  LightmapBakeInput in = lightmap_input(s, 8, 0.05);
  in.radiance = true;
  try {
    const LightmapBakeResult r = bake_lightmaps(in);
    expect_outputs_finite(r, "floor");
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("nan colour"), std::string::npos) << e.what();
  }
}

// A sun grazing the floor (elevations 1e-2, 1e-4 and 1e-6 rad): E = E_n sin(elevation) at every texel, finite and
// positive: shadow rays that skim the floor must not find the floor itself (delta light, albedo 0: no noise; 1e-6
// relative for float storage).
TEST(LightmapRobustness, GrazingSunStaysFiniteAndLit) {
  for (double elevation : {1e-2, 1e-4, 1e-6}) {
    scene::Scene s;
    s.materials.push_back(lambert_material("black", 0.0));
    test::add_floor(s, 2.0, 0);
    scene::Light sun;
    sun.type = scene::LightShape::directional;
    sun.direction = Vec3{std::cos(elevation) * 0.8, -std::sin(elevation), std::cos(elevation) * 0.6};
    sun.color = Rgb{1.0};
    s.lights.push_back(sun);
    const LightmapBakeResult r = bake_lightmaps(lightmap_input(s, 16, 0.01));
    expect_outputs_finite(r, "floor");
    const image::FloatImage E = exr_output(r, "floor_irradiance.exr");
    const double want = std::sin(elevation);
    for (int y = 0; y < 16; ++y) {
      for (int x = 0; x < 16; ++x) {
        EXPECT_NEAR(E.at(x, y, 0), want, 1e-6 * want) << "elevation " << elevation << " texel " << x << "," << y;
      }
    }
  }
}

// Chart edges: an outward box and a faceted sphere (convex: every point sees exactly its hemisphere of sky) under a
// uniform sky of radiance 1, at a resolution (37) whose texels the charts' edges cut: every valid texel, partly
// covered ones included, is π (zero-variance estimator: 1e-6 for float storage). A black speckle is a texel whose
// points see their own surface.
TEST(LightmapRobustness, ChartEdgesHaveNoBlackSpeckles) {
  const int W = 37;
  for (const std::string map : {"box", "ball"}) {
    // Each alone: two convex objects would see each other.
    scene::Scene s;
    s.materials.push_back(lambert_material("grey", 0.5));
    if (map == "box") test::add_box(s, "box", {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}, 0);
    if (map == "ball") test::add_sphere(s, "ball", {0, 0, 0}, 0.6, 10, 0, /*inward=*/false, /*smooth=*/false);
    s.environment.constant = Rgb{1.0};
    const LightmapBakeResult r = bake_lightmaps(lightmap_input(s, W, 0.01));
    const image::FloatImage E = exr_output(r, map + "_irradiance.exr");
    const image::FloatImage V = exr_output(r, map + "_validity.exr");
    int valid = 0;
    for (int y = 0; y < W; ++y) {
      for (int x = 0; x < W; ++x) {
        if (V.at(x, y, 0) != 1.0f) continue;
        ++valid;
        EXPECT_NEAR(E.at(x, y, 0), kPi, 1e-6 * kPi) << map << " texel " << x << "," << y;
      }
    }
    EXPECT_GT(valid, 300) << map;
  }
}

// No acne, no terminator artefact: a sphere under a delta sun (albedo 0). Faceted: every texel is exactly
// E max(0, n·L) with the facet's normal, E = 0 exactly where n·L < 0 and lit where n·L > 0 (a convex polyhedron
// never shadows itself). Smooth normals: texels whose points all have n_s·L > 0.2 are lit to E n_s·L (20 rings:
// the facet normal is within 9° of n_s, so n_g·L > 0 there too), those with n_s·L < −0.2 are 0.
TEST(LightmapRobustness, SphereUnderASunHasNoAcne) {
  const Vec3 to_sun = normalize(Vec3{-0.3, 1, -0.5});
  for (bool smooth : {false, true}) {
    scene::Scene s;
    s.materials.push_back(lambert_material("black", 0.0));
    test::add_sphere(s, "ball", {0.2, 0.1, -0.3}, 0.8, 20, 0, /*inward=*/false, smooth);
    scene::Light sun;
    sun.type = scene::LightShape::directional;
    sun.direction = -to_sun;
    sun.color = Rgb{3.0};
    s.lights.push_back(sun);
    const int W = 32;
    const double cut = smooth ? 0.2 : 0.0;
    const auto lit =
        texel_means(s, "ball", W, [&](const Vec3&, const Vec3& n) { return dot(n, to_sun) > cut ? 1.0 : 0.0; });
    const auto dark =
        texel_means(s, "ball", W, [&](const Vec3&, const Vec3& n) { return dot(n, to_sun) < -cut ? 1.0 : 0.0; });
    const auto expected =
        texel_means(s, "ball", W, [&](const Vec3&, const Vec3& n) { return 3.0 * std::max(0.0, dot(n, to_sun)); });
    const LightmapBakeResult r = bake_lightmaps(lightmap_input(s, W, 0.01));
    const image::FloatImage E = exr_output(r, "ball_irradiance.exr");
    int n_lit = 0, n_dark = 0;
    for (int y = 0; y < W; ++y) {
      for (int x = 0; x < W; ++x) {
        const size_t t = static_cast<size_t>(y) * W + x;
        if (lit[t] == 1.0) {
          ++n_lit;
          EXPECT_NEAR(E.at(x, y, 0), expected[t], 1e-6 * expected[t])
              << (smooth ? "smooth" : "faceted") << " lit texel " << x << "," << y;
        } else if (dark[t] == 1.0) {
          ++n_dark;
          EXPECT_EQ(E.at(x, y, 0), 0.0f) << (smooth ? "smooth" : "faceted") << " dark texel " << x << "," << y;
        }
      }
    }
    EXPECT_GT(n_lit, 200);
    EXPECT_GT(n_dark, 200);
  }
}

// The estimated error is honest on a second analytic scene: the sun with a 0.5 rad disc (noise from cos θ across the
// disc) over a floor, E = E_n cos θ_c exactly. The measured RMS relative error over all texels is within a factor of
// 2 of the reported estimate, at two targets.
TEST(LightmapRobustness, TheEstimatedErrorIsHonestUnderASunDisc) {
  scene::Scene s;
  s.materials.push_back(lambert_material("black", 0.0));
  test::add_floor(s, 2.0, 0);
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.direction = normalize(Vec3{0.6, -1, 0.3});
  sun.angular_diameter = 0.5;
  sun.color = Rgb{1.0};
  s.lights.push_back(sun);
  const double want = dot(Vec3{0, 1, 0}, -sun.direction);
  for (double target : {0.02, 0.005}) {
    LightmapBakeInput in = lightmap_input(s, 16, target);
    in.min_samples = 8;
    const LightmapBakeResult r = bake_lightmaps(in);
    const image::FloatImage E = exr_output(r, "floor_irradiance.exr");
    double sum_sq = 0;
    for (int y = 0; y < 16; ++y) {
      for (int x = 0; x < 16; ++x) sum_sq += std::pow((E.at(x, y, 0) - want) / want, 2);
    }
    const double measured = std::sqrt(sum_sq / 256);
    std::printf("sun disc honesty: target %g measured %.4g estimated %.4g\n", target, measured, r.error_estimate);
    EXPECT_GT(r.error_estimate, 0.0);
    EXPECT_LE(measured, 2 * r.error_estimate) << "target " << target << " measured " << measured;
    EXPECT_GE(measured, r.error_estimate / 2) << "target " << target << " measured " << measured;
  }
}

}  // namespace
}  // namespace kiln::lightmap
