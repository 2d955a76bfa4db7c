// Embree instancing in the tracer (TracerOptions::instancing): a mesh shared by instances traced as instances of one
// BVH gives the same hits as the flattened copies (instance, triangle, place, normals, UVs, sides), its ray offsets
// keep rays spawned off it from finding it again under rotations, non-uniform scales, mirrors and far translations,
// and it holds the mesh once.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "tests/bench/ray_workload.h"
#include "tests/scene/tracer_geometry.h"

namespace kiln::scene {
namespace {

using test::box_room;
using test::compose;
using test::scale_translate;

Vec3 random_unit(Pcg32& rng) { return sample_uniform_sphere({rng.uniform(), rng.uniform()}); }

Vec3 at_angle(const Vec3& n, double cos_theta, Pcg32& rng) {
  const Frame f = Frame::from_normal(n);
  const double phi = 2 * kPi * rng.uniform(), sin_theta = std::sqrt(1 - cos_theta * cos_theta);
  return f.from_local({sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta});
}

Tracer traced(const Scene& s, Instancing instancing) {
  TracerOptions o;
  o.instancing = instancing;
  return Tracer(check_scene(s).scene, o);
}

// A rotation by `angle` about the unit axis a (Rodrigues).
Transform rotation(const Vec3& a, double angle) {
  const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  Transform r;
  r.m = {t * a.x * a.x + c,       t * a.x * a.y - s * a.z, t * a.x * a.z + s * a.y, 0,
         t * a.x * a.y + s * a.z, t * a.y * a.y + c,       t * a.y * a.z - s * a.x, 0,
         t * a.x * a.z - s * a.y, t * a.y * a.z + s * a.x, t * a.z * a.z + c,       0};
  return r;
}

TEST(TracerInstancing, OnlySharedMeshesAreInstancedByDefault) {
  // The block mesh (2) has two instances, the room and the sphere one each. Small copies stay flattened: the blocks
  // of 6·2·4² = 192 triangles are instanced only from 4096 / 192 + 1 = 23 instances on.
  const Scene small = box_room(8, 4, 12, 24);
  EXPECT_EQ(traced(small, Instancing::shared).instanced_instance_count(), 0u);
  const Scene room = box_room(8, 27, 12, 24);  // blocks of 6·2·27² = 8748 triangles: one copy is enough
  const Tracer shared = traced(room, Instancing::shared);
  EXPECT_FALSE(shared.instanced(0));
  EXPECT_FALSE(shared.instanced(1));
  EXPECT_TRUE(shared.instanced(2));
  EXPECT_TRUE(shared.instanced(3));
  EXPECT_EQ(shared.instanced_mesh_count(), 1u);
  EXPECT_EQ(shared.instanced_instance_count(), 2u);
  const Tracer flat = traced(room, Instancing::none);
  EXPECT_EQ(flat.instanced_instance_count(), 0u);
  EXPECT_EQ(shared.triangle_count(), flat.triangle_count());
  EXPECT_EQ(shared.stored_triangle_count() + room.meshes[2].indices.size() / 3, flat.stored_triangle_count());
  const Tracer all = traced(room, Instancing::all);
  EXPECT_EQ(all.instanced_instance_count(), 4u);
  EXPECT_EQ(all.instanced_mesh_count(), 3u);
}

// The same incoherent rays through the flattened and the instanced tracer. Instanced geometry is the float object
// vertices under the float transform, flattened the double transform rounded to float: they differ by a few float
// roundings of the coordinates (~1e-6 of the room's size 10), so a ray may pick the neighbour of a triangle at an
// edge. Tolerances: the same triangle for all but 0.1 % of the rays; where it is the same, p within 1e-4 (the room is
// 10 across: 1e-5 relative, ten times the roundings), ng and ns within 1e-5, t within 1e-4, UVs within 1e-5.
TEST(TracerInstancing, SameHitsAsFlattenedCopies) {
  const Scene room = box_room();
  const Tracer flat = traced(room, Instancing::none);
  const Tracer inst = traced(room, Instancing::all);
  EXPECT_EQ(flat.bounds_lower().x, inst.bounds_lower().x);
  const std::vector<Ray> rays = bench::incoherent_rays(flat.bounds_lower(), flat.bounds_upper(), 100000, false, 7);
  size_t hits = 0, different = 0;
  for (const Ray& r : rays) {
    const auto a = flat.intersect(r);
    const auto b = inst.intersect(r);
    ASSERT_EQ(a.has_value(), b.has_value());
    if (!a) continue;
    ++hits;
    if (a->instance != b->instance || a->triangle != b->triangle) {
      ++different;
      continue;
    }
    EXPECT_EQ(a->mesh, b->mesh);
    EXPECT_EQ(a->material, b->material);
    EXPECT_NEAR(a->t, b->t, 1e-4);
    EXPECT_LT(length(a->p - b->p), 1e-4);
    EXPECT_LT(length(a->ng - b->ng), 1e-5);
    EXPECT_LT(length(a->ns - b->ns), 1e-5);
    EXPECT_NEAR(a->lightmap_uv.x, b->lightmap_uv.x, 1e-5);
    EXPECT_NEAR(a->lightmap_uv.y, b->lightmap_uv.y, 1e-5);
    EXPECT_EQ(a->front_face, b->front_face);
    // The offset clears more than the flattened one (the float ray transform) but stays within a small factor.
    EXPECT_GE(b->offset, 0.5 * a->offset);
    EXPECT_LT(b->offset, 1e-4);
    EXPECT_EQ(b->offset, inst.ray_offset(b->instance, b->triangle));
    EXPECT_EQ(a->offset, flat.ray_offset(a->instance, a->triangle));
    // The id query and the full one agree.
    const auto id = inst.intersect_id(r);
    ASSERT_TRUE(id);
    EXPECT_EQ(id->instance, b->instance);
    EXPECT_EQ(id->triangle, b->triangle);
    EXPECT_EQ(id->front_face, b->front_face);
    const Hit c = inst.complete(r, *id);
    EXPECT_EQ(c.p.x, b->p.x);
    EXPECT_EQ(c.offset, b->offset);
  }
  EXPECT_GT(hits, rays.size() * 9 / 10);
  EXPECT_LE(different, hits / 1000);
  // Streams agree with single rays.
  std::vector<std::optional<HitId>> out(2000);
  inst.intersect(std::span<const Ray>(rays.data(), out.size()), out);
  for (size_t i = 0; i < out.size(); ++i) {
    const auto one = inst.intersect_id(rays[i]);
    ASSERT_EQ(one.has_value(), out[i].has_value());
    if (one) {
      EXPECT_EQ(one->triangle, out[i]->triangle);
    }
  }
}

// Many instances of a closed sphere under rotations, non-uniform scales, a mirror, and at scales 1e-3 to 1e4 and far
// from the origin: no ray spawned off a hit at grazing angles (cos θ = ±1e-3) finds its own triangle, an outward one
// hits nothing of its own sphere, and an inward one hits the sphere's inside.
TEST(TracerInstancing, NoSelfIntersectionOnTransformedInstancesAtAnyScale) {
  const Mesh sphere = test::uv_sphere(12, 24);
  struct Config {
    double scale, shift;
  };
  const Config configs[] = {{1, 0}, {1e-3, 0}, {1e4, 0}, {1, 1e3}, {1e4, 1e4}};
  for (const Config& cfg : configs) {
    Scene s;
    s.materials.resize(1);
    s.meshes.push_back(sphere);
    std::vector<Vec3> centres;
    Pcg32 place(3);
    for (int k = 0; k < 8; ++k) {
      const Vec3 centre = (Vec3{1, 0.5, -0.7} * cfg.shift + Vec3{4.0 * k, 0, 0}) * cfg.scale;
      Transform squash;
      squash.m = {1, 0, 0, 0, 0, 0.5 + 0.2 * k, 0, 0, 0, 0, k % 2 ? -1.0 : 1.0, 0};  // odd ones mirrored
      const Transform t =
          compose(scale_translate(cfg.scale, centre), compose(rotation(normalize(random_unit(place)), k), squash));
      s.instances.push_back(test::instance(0, t));
      centres.push_back(centre);
    }
    const Tracer tracer = traced(s, Instancing::all);
    ASSERT_EQ(tracer.instanced_instance_count(), 8u);
    Pcg32 rng(11);
    int64_t primaries = 0, out_own = 0, in_self = 0, in_missed = 0;
    for (int i = 0; i < 40000; ++i) {
      const size_t k = i % centres.size();
      const Vec3 from = centres[k] + Vec3{0, 3, 0} * cfg.scale + random_unit(rng) * (0.5 * cfg.scale);
      const Vec3 to = centres[k] + random_unit(rng) * (0.3 * cfg.scale);
      const auto hit = tracer.intersect({from, to - from});
      if (!hit || hit->instance != static_cast<int>(k)) continue;
      ++primaries;
      const auto out = tracer.intersect(spawn_ray(hit->surface(), at_angle(hit->ng, 1e-3, rng)));
      if (out && out->instance == hit->instance) ++out_own;
      const auto in = tracer.intersect(spawn_ray(hit->surface(), at_angle(hit->ng, -1e-3, rng)));
      if (!in)
        ++in_missed;
      else if (in->instance == hit->instance && in->triangle == hit->triangle)
        ++in_self;
    }
    SCOPED_TRACE(testing::Message() << "scale " << cfg.scale << ", shift " << cfg.shift);
    EXPECT_GT(primaries, 10000);
    EXPECT_EQ(out_own, 0);  // a convex instance: leaving it outwards cannot meet it again
    EXPECT_EQ(in_self, 0);
    EXPECT_EQ(in_missed, 0);
  }
}

// 200 instances of one 4,608-triangle sphere: instanced, the tracer holds the mesh once.
TEST(TracerInstancing, HoldsASharedMeshOnce) {
  Scene s;
  s.materials.resize(1);
  s.meshes.push_back(test::uv_sphere(48, 48));
  for (int k = 0; k < 200; ++k) s.instances.push_back(test::instance(0, scale_translate(1, {3.0 * k, 0, 0})));
  const Tracer flat = traced(s, Instancing::none);
  const Tracer inst = traced(s, Instancing::shared);
  EXPECT_EQ(flat.triangle_count(), inst.triangle_count());
  EXPECT_EQ(inst.stored_triangle_count(), s.meshes[0].indices.size() / 3);
  // Flattened, each copy costs a BVH and its records; instanced, an instance is a few hundred bytes.
  EXPECT_LT(inst.memory_bytes() * 20, flat.memory_bytes());
}

}  // namespace
}  // namespace kiln::scene
