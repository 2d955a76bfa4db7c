// Every light, queried at hostile points and with extreme random numbers, returns finite values: points on the
// lights, on their planes, at their vertices, very near and very far; u at 0 and just below 1; tiny and huge
// scales. (Correctness is tested per light elsewhere; this sweep only asserts "never NaN or Inf, never negative".)
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bakers/scene/area_lights.h"
#include "bakers/scene/emissive_triangles.h"
#include "bakers/scene/environment_light.h"
#include "bakers/scene/punctual_lights.h"
#include "tests/scene/light_test_util.h"

namespace kiln::scene {
namespace {

std::vector<std::unique_ptr<LightSource>> hostile_lights(double scale) {
  std::vector<std::unique_ptr<LightSource>> out;
  const Vec3 c = Vec3{1, 2, 3} * scale;
  out.push_back(std::make_unique<PointLight>(c, Rgb{1e6}));
  // Colours that are not emission (NaN, ±Inf, negative channels): black or clamped, never propagated.
  out.push_back(std::make_unique<PointLight>(c, Rgb{std::nan(""), 1, 1}));
  out.push_back(std::make_unique<SpotLight>(c, Vec3{0, -1, 0}, Rgb{-1, 2, 0}, 0.1, 0.5));
  out.push_back(std::make_unique<DirectionalLight>(Vec3{0, -1, 0}, Rgb{std::numeric_limits<double>::infinity()}, 0.1));
  out.push_back(std::make_unique<RectLight>(c, Vec3{1, 0, 0}, Vec3{0, 0, 1}, Vec3{0, -1, 0}, Rgb{-1, 1, 1}, false));
  out.push_back(std::make_unique<SpotLight>(c, Vec3{0, -1, 0}, Rgb{5}, 0.3, 0.3));
  out.push_back(std::make_unique<DirectionalLight>(Vec3{0, -1, 0}, Rgb{1e5}, 0.5 * kPi / 180));
  out.push_back(std::make_unique<DirectionalLight>(Vec3{1e-300, -1e-300, 0}, Rgb{1}, 1e-9));
  out.push_back(
      std::make_unique<RectLight>(c, Vec3{1, 0, 0} * scale, Vec3{0, 0, 1e-9} * scale, Vec3{0, -1, 0}, Rgb{1}, true));
  out.push_back(
      std::make_unique<RectLight>(c, Vec3{1, 0, 0} * scale, Vec3{0, 0, 1} * scale, Vec3{0, -1, 0}, Rgb{1e30}, false));
  out.push_back(std::make_unique<DiskLight>(c, Vec3{0, -1, 0}, 1e-12 * scale, Rgb{1}, true));
  out.push_back(std::make_unique<DiskLight>(c, Vec3{0, 1, 1}, 1.0 * scale, Rgb{1}, false));
  out.push_back(std::make_unique<EmissiveTriangles>(std::vector<EmissiveTriangle>{
      {c, c + Vec3{1, 0, 0} * scale, c + Vec3{0, 0, 1} * scale, Rgb{2}, false, -1, -1},
      {c, c + Vec3{1e-8, 0, 0} * scale, c + Vec3{0, 1e-8, 1} * scale, Rgb{1e6}, true, -1, -1}}));
  Environment env;
  env.width = 32;
  env.height = 16;
  env.equirect.assign(32 * 16, Rgb{0});
  env.equirect[0] = Rgb{1e30};             // at the pole row
  env.equirect[5 * 32 + 7] = Rgb{1e-300};  // denormal-adjacent
  env.rotation_degrees = 1e9;
  out.push_back(std::make_unique<EnvironmentLight>(env));
  return out;
}

TEST(LightStability, HostileQueriesStayFinite) {
  for (double scale : {1e-4, 1.0, 1e4}) {
    const auto lights = hostile_lights(scale);
    const Vec3 c = Vec3{1, 2, 3} * scale;
    const std::vector<Vec3> points = {c,
                                      c + Vec3{0.5, 0, 0.5} * scale,  // on the rect / triangle planes
                                      c + Vec3{1, 0, 0} * scale,      // a vertex
                                      c + Vec3{0.5, -1e-15, 0.5} * scale,
                                      c - Vec3{0, 1e-300, 0},
                                      Vec3{0, 0, 0},
                                      Vec3{1e12, -1e12, 1e12} * scale};
    const std::vector<Vec3> normals = {{0, 1, 0}, {0, -1, 0}, {1, 0, 0}, {0, 0, 0}};
    const double one_minus = std::nextafter(1.0, 0.0);
    Pcg32 rng(3);
    for (const auto& light : lights) {
      for (const Vec3& p : points) {
        for (const Vec3& n : normals) {
          for (int k = 0; k < 60; ++k) {
            const Point2 u = k < 4 ? Point2{(k & 1) ? one_minus : 0.0, (k & 2) ? one_minus : 0.0}
                                   : Point2{rng.uniform(), rng.uniform()};
            const auto s = light->sample_li(p, n, u);
            if (!s) continue;
            ASSERT_TRUE(is_finite(s->wi) && std::fabs(length(s->wi) - 1) < 1e-9) << static_cast<int>(light->kind());
            ASSERT_TRUE(s->Li.is_finite() && s->Li.min() >= 0) << static_cast<int>(light->kind());
            ASSERT_TRUE(std::isfinite(s->pdf) && s->pdf >= 0 && (s->delta || s->pdf > 0));
            ASSERT_FALSE(std::isnan(s->distance));
            ASSERT_TRUE(s->irradiance(dot(s->wi, n)).is_finite());
            LightHit hit;
            hit.point = s->point;
            hit.distance = s->distance;
            hit.triangle = 0;
            const double pdf = light->pdf_li(p, n, s->wi, hit);
            ASSERT_TRUE(std::isfinite(pdf) && pdf >= 0);
            ASSERT_TRUE(light->Le(p, s->wi, hit).is_finite());
          }
          // Arbitrary directions, including axis-aligned ones through the lights.
          for (const Vec3& w : {Vec3{0, 1, 0}, Vec3{0, -1, 0}, Vec3{1, 0, 0}, normalize(Vec3{1, 1, 1})}) {
            LightHit hit;
            if (const auto h = light->intersect(p, w, kInfinity)) {
              ASSERT_TRUE(std::isfinite(h->distance) && is_finite(h->point));
              hit = *h;
            }
            ASSERT_TRUE(std::isfinite(light->pdf_li(p, n, w, hit)));
            ASSERT_TRUE(light->Le(p, w, hit).is_finite());
          }
        }
      }
      ASSERT_TRUE(light->power(scale).is_finite());
    }
  }
}

}  // namespace
}  // namespace kiln::scene
