// Light probes (irradiance_probes.h) against analytic answers: under a uniform sky with nothing around, every probe's
// SH is the projection of a constant, L·√(4π) in the DC term and 0 in the others; probes inside a closed box are
// invalid and those outside valid.
//
// Tolerance: the probes of the open scene are independent estimates of one SH, so each coefficient's mean over them
// is compared with the exact value within 4.5 standard errors of that mean, from the probes' spread (Student's t with
// 63 degrees of freedom exceeds 4.5 with probability 3·10⁻⁵), plus 10⁻⁹ for exact zeros.
#include "bakers/lightmap/irradiance_probes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "bakers/math/constants.h"
#include "bakers/plan/lightmap_plan.h"
#include "bakers/scene/light_sampler.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

// What the transport needs for a scene, built as the lightmap bake builds it.
struct Transport {
  scene::CheckedScene checked;
  std::unique_ptr<scene::Tracer> tracer;
  std::unique_ptr<scene::SceneLights> lights;
  plan::LightmapPlan plan;
  std::vector<ShadingMaterial> materials;
  TransportContext ctx;

  explicit Transport(const scene::Scene& s) : checked(scene::check_scene(s)) {
    tracer = std::make_unique<scene::Tracer>(checked.scene);
    lights = std::make_unique<scene::SceneLights>(checked.scene);
    plan = plan::plan_lightmap(checked.scene, plan::LightmapPlanOptions{});
    materials = shading_materials(checked.scene, plan);
    ctx.scene = &checked.scene;
    ctx.tracer = tracer.get();
    ctx.lights = lights.get();
    ctx.plan = &plan;
    ctx.materials = &materials;
    prepare_context(ctx);
  }
};

TEST(IrradianceProbes, UniformSkyProjectsToTheConstantsSh) {
  // A black 1 cm tile 100 m below: the tracer needs a scene; it hides 10⁻⁸ of the sky.
  scene::Scene s;
  s.materials.push_back(test::lambert_material("black", 0.0));
  test::add_quad(s, "tile", {0, -100, 0}, {0.01, -100, 0}, {0.01, -100, -0.01}, {0, -100, -0.01}, 0, 1);
  const Rgb sky{0.5, 1.0, 2.0};
  s.environment.constant = sky;
  const Transport t(s);
  ProbeGrid grid{{-1, 0, -1}, 0.5, 4, 4, 4};
  const std::vector<ProbeSummary> r = bake_probe_grid(t.ctx, grid, 1024);
  const size_t n = grid.count();
  for (int k = 0; k < 9; ++k) {
    for (int c = 0; c < 3; ++c) {
      double sum = 0, sum2 = 0;
      for (size_t p = 0; p < n; ++p) {
        sum += r[p].sh[k][c];
        sum2 += r[p].sh[k][c] * r[p].sh[k][c];
      }
      const double mean = sum / n, se = std::sqrt(std::max(0.0, (sum2 - n * mean * mean) / (n - 1)) / n);
      const double exact = k == 0 ? sky[c] * std::sqrt(4 * kPi) : 0.0;
      EXPECT_NEAR(mean, exact, 4.5 * se + 1e-9) << "coefficient " << k << " channel " << c;
      if (k < 2) std::printf("sh%d channel %d: %.5f +- %.2g (exact %.5f)\n", k, c, mean, se, exact);
    }
  }
  for (size_t p = 0; p < n; ++p) EXPECT_TRUE(r[p].valid) << p;
}

TEST(IrradianceProbes, ProbesInsideAClosedBoxAreInvalid) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_box(s, "box", {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}, 0);  // outward: from inside, back faces only
  s.environment.constant = Rgb{1.0};
  const Transport t(s);
  ProbeGrid grid{{-1.25, 0, 0}, 0.5, 6, 1, 1};  // x = −1.25 … 1.25: the middle two inside the box
  const std::vector<ProbeSummary> r = bake_probe_grid(t.ctx, grid, 64);
  for (int i = 0; i < 6; ++i) {
    const bool inside = std::abs(grid.position(i, 0, 0).x) < 0.5;
    EXPECT_EQ(r[i].valid, !inside) << "probe " << i;
    if (inside) {
      EXPECT_EQ(r[i].sh[0].r, 0.0);
    }
  }
}

}  // namespace
}  // namespace kiln::lightmap
