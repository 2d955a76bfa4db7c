// The bundled Cornell box as the tests and benchmarks build it (tests/support/test_scenes.h, a port of
// client/examples/scenes/cornell_box.py): closed except for its open front, every face wound towards the inside of the
// room, lightmap UVs in [0, 1] without overlapping charts, and nothing the scene check would repair or drop.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "tests/support/test_scenes.h"

namespace kiln::test {
namespace {

TEST(CornellBox, HasTheScriptsMeshesAndMaterials) {
  const scene::Scene s = cornell_box();
  std::set<std::string> names;
  size_t triangles = 0;
  for (const scene::Mesh& m : s.meshes) {
    names.insert(m.name);
    triangles += m.indices.size() / 3;
  }
  EXPECT_EQ(names, (std::set<std::string>{"floor", "ceiling", "back_wall", "left_wall", "right_wall", "short_block",
                                          "tall_block", "light"}));
  // Six single quads and two five-faced blocks, two triangles a quad.
  EXPECT_EQ(triangles, 2u * (6 + 5 + 5));
  EXPECT_EQ(s.instances.size(), s.meshes.size());
  ASSERT_EQ(s.materials.size(), 4u);
  // The one emitter: the ceiling patch, 17·(1, 0.71, 0.24) (glTF emissiveFactor × emissive strength).
  EXPECT_DOUBLE_EQ(s.materials[3].emission.g, 17 * 0.71);
  for (size_t i = 0; i < 3; ++i) EXPECT_EQ(s.materials[i].emission.max(), 0.0) << s.materials[i].name;
}

// Values read back from the glTF the script writes (python3 cornell_box.py out.gltf, then its float32 accessors): the
// sixth vertex of each block (rotation and placement) and the lightmap UV of each block's last vertex (the atlas
// layout). The port stores floats as the glTF does, so they agree to float precision (relative 1e-7; UVs are exact
// binary fractions here).
TEST(CornellBox, MatchesTheScriptsOutput) {
  const scene::Scene s = cornell_box();
  auto mesh = [&](const std::string& name) -> const scene::Mesh& {
    for (const scene::Mesh& m : s.meshes) {
      if (m.name == name) return m;
    }
    throw std::runtime_error("no mesh " + name);
  };
  const scene::Mesh& short_block = mesh("short_block");
  const scene::Mesh& tall_block = mesh("tall_block");
  ASSERT_EQ(short_block.positions.size(), 20u);
  ASSERT_EQ(tall_block.positions.size(), 20u);
  constexpr double kFloat = 1e-7;
  EXPECT_NEAR(short_block.positions[5].x, 0.529179931, kFloat);
  EXPECT_NEAR(short_block.positions[5].y, 0.0, kFloat);
  EXPECT_NEAR(short_block.positions[5].z, 0.744602919, kFloat);
  EXPECT_NEAR(tall_block.positions[5].x, 0.0480220541, kFloat);
  EXPECT_NEAR(tall_block.positions[5].z, -0.107388146, kFloat);
  EXPECT_DOUBLE_EQ(short_block.lightmap_uv.back().x, 0.375);
  EXPECT_DOUBLE_EQ(short_block.lightmap_uv.back().y, 0.609375);
  EXPECT_DOUBLE_EQ(tall_block.lightmap_uv.back().x, 0.3984375);
  EXPECT_DOUBLE_EQ(tall_block.lightmap_uv.back().y, 0.53125);
  EXPECT_DOUBLE_EQ(mesh("floor").lightmap_uv.back().x, 0.0625);  // a single face: the chart inside the margin
  EXPECT_NEAR(mesh("light").positions[0].y, 1.99, kFloat);
}

TEST(CornellBox, CleanLightmapUvsWithoutOverlaps) {
  const scene::Scene s = cornell_box();
  const scene::CheckedScene checked = scene::check_scene(s);
  // Nothing to repair or drop: in particular no overlapping_lightmap_uv, no UV outside [0, 1], no degenerate triangle.
  EXPECT_TRUE(checked.report.clean()) << checked.report.summary();
  for (const scene::Mesh& m : s.meshes) {
    ASSERT_EQ(m.lightmap_uv.size(), m.positions.size()) << m.name;
    for (const Point2& uv : m.lightmap_uv) {
      EXPECT_TRUE(uv.x >= 0 && uv.x <= 1 && uv.y >= 0 && uv.y <= 1) << m.name << " (" << uv.x << ", " << uv.y << ")";
    }
    // Per-face normals agree with the winding (what the front-face test below relies on for shading).
    for (size_t t = 0; t < m.indices.size(); t += 3) {
      const Vec3 ng = normalize(cross(m.positions[m.indices[t + 1]] - m.positions[m.indices[t]],
                                      m.positions[m.indices[t + 2]] - m.positions[m.indices[t]]));
      // The vertex normals are the face normal rounded to float: agreement to float precision.
      for (int k = 0; k < 3; ++k) EXPECT_GT(dot(ng, m.normals[m.indices[t + k]]), 1 - 1e-6) << m.name;
    }
  }
}

// From points in the upper half of the room (above the tall block, below the light patch), rays in every direction
// hit a front face, or escape through the open front: crossing z = 1 within the opening x ∈ [−1, 1], y ∈ [0, 2].
TEST(CornellBox, ClosedExceptTheOpenFrontAndWoundInwards) {
  const scene::CheckedScene checked = scene::check_scene(cornell_box());
  const scene::Tracer tracer(checked.scene);
  Pcg32 rng(7);
  int escaped = 0, back_faces = 0, wrong_exit = 0;
  constexpr int kRays = 20000;
  for (int i = 0; i < kRays; ++i) {
    const Vec3 o{-0.95 + 1.9 * rng.uniform(), 1.25 + 0.7 * rng.uniform(), -0.95 + 1.9 * rng.uniform()};
    const Vec3 d = sample_uniform_sphere({rng.uniform(), rng.uniform()});
    const auto hit = tracer.intersect(scene::Ray{o, d});
    if (hit) {
      back_faces += !hit->front_face;
      continue;
    }
    ++escaped;
    // The exit must be the opening: the ray heads towards +z and crosses z = 1 inside the box's outline (a margin of
    // 1e-6 m: float vertices at ±1 and 2 are exact, the crossing is computed in double).
    const double t = d.z > 0 ? (1 - o.z) / d.z : -1;
    const Vec3 p = o + d * t;
    if (!(t > 0 && std::abs(p.x) <= 1 + 1e-6 && p.y >= -1e-6 && p.y <= 2 + 1e-6)) ++wrong_exit;
  }
  EXPECT_EQ(back_faces, 0);
  EXPECT_EQ(wrong_exit, 0);
  // The opening subtends a sizeable solid angle from these points: some rays must leave, or the front is closed.
  EXPECT_GT(escaped, kRays / 50);
  EXPECT_LT(escaped, kRays / 2);  // and most do not: the other five sides are closed
}

}  // namespace
}  // namespace kiln::test
