// The lightmap planner with participating media: from what the media take from typical light paths it skips them,
// simulates attenuation only, or simulates them in full with the bounces their albedo asks for, and says why; media
// outside the scene are skipped with the reason; forcing works; light tracing gives way to gathering (its rays from
// the lights are not tracked through media).
#include <gtest/gtest.h>

#include "bakers/plan/lightmap_plan.h"
#include "bakers/volume/medium_input.h"
#include "tests/support/test_scenes.h"

namespace kiln::plan {
namespace {

std::string reason_of(const LightmapPlan& plan, const std::string& effect) {
  for (const Decision& d : plan.decisions) {
    if (d.effect == effect) return d.reason;
  }
  return "";
}

// A homogeneous box medium (box: 4 m wide around the 2 m floor, 2 m high).
volume::MediumInput haze(const Rgb& sigma_a, const Rgb& sigma_s,
                         const volume::Bounds3& box = {{-2, 0, -2}, {2, 2, 2}}) {
  volume::HomogeneousMediumSpec spec;
  spec.sigma_a = sigma_a;
  spec.sigma_s = sigma_s;
  spec.box = box;
  return volume::MediumInput{"haze", spec};
}

// Plans scene `s` with `inputs` as its media (built here, as the bake builds them).
struct MediaPlanning {
  std::vector<volume::MediumInput> inputs;
  std::vector<std::unique_ptr<volume::Medium>> media;
  LightmapPlanOptions options;
  LightmapPlan plan(const scene::Scene& s) {
    media = volume::make_media(inputs);
    options.media_inputs = &inputs;
    options.media.clear();
    for (const auto& m : media) options.media.push_back(m.get());
    return plan_lightmap(s, options);
  }
};

scene::Scene floor_under_sun() {
  scene::Scene s = test::floor_under_point_light(0.0, {0, 1, 0}, Rgb{0.0});
  s.lights[0].type = scene::LightShape::directional;
  s.lights[0].direction = normalize(Vec3{0.3, -1, 0.1});
  s.lights[0].color = Rgb{1.0};
  return s;
}

TEST(MediaPlan, DecidesFromWhatTheMediaTakeAndScatter) {
  const scene::Scene s = floor_under_sun();
  MediaPlanning p;
  p.options.target_error = 0.04;  // budget 0.01
  EXPECT_EQ(p.plan(s).media_mode, MediaMode::none);
  EXPECT_NE(reason_of(p.plan(s), "participating_media").find("no participating media"), std::string::npos);

  // A haze taking about 1e-3 of the light (optical depths ~0.001 over paths of ~1 m): below the budget, skipped.
  p.inputs = {haze(Rgb{5e-4}, Rgb{5e-4})};
  LightmapPlan plan = p.plan(s);
  EXPECT_EQ(plan.media_mode, MediaMode::none) << reason_of(plan, "participating_media");
  EXPECT_NE(reason_of(plan, "participating_media").find("skipped"), std::string::npos);
  EXPECT_LT(plan.media_analysis.extinction, 0.01);

  // Absorbing smoke taking ~10 %, scattering 1 % of what it takes: attenuation only.
  p.inputs = {haze(Rgb{0.1}, Rgb{0.001})};
  plan = p.plan(s);
  EXPECT_EQ(plan.media_mode, MediaMode::attenuation) << reason_of(plan, "media_scattering");
  EXPECT_NE(reason_of(plan, "media_scattering").find("attenuation only"), std::string::npos);
  EXPECT_GT(plan.media_analysis.extinction, 0.01);
  EXPECT_EQ(plan.bounces, 0);  // a black floor, and nothing scattered
  EXPECT_FALSE(plan.light_tracing);

  // A white fog: in full, with the bounces its albedo asks for although the floor is black.
  p.inputs = {haze(Rgb{0.0}, Rgb{1.0})};
  plan = p.plan(s);
  EXPECT_EQ(plan.media_mode, MediaMode::scattering) << reason_of(plan, "media_scattering");
  EXPECT_EQ(plan.media_analysis.albedo, 1.0);
  EXPECT_GT(plan.bounces, 1) << reason_of(plan, "indirect_bounces");
  EXPECT_NE(reason_of(plan, "indirect_bounces").find("media"), std::string::npos);
  EXPECT_EQ(plan.media, std::vector<int>{0});

  // Forced: the fog as attenuation only, or not at all.
  p.options.force_effects = {{"media_scattering", false}};
  EXPECT_EQ(p.plan(s).media_mode, MediaMode::attenuation);
  p.options.force_effects = {{"participating_media", false}};
  EXPECT_EQ(p.plan(s).media_mode, MediaMode::none);
  EXPECT_TRUE(p.plan(s).media.empty());
}

TEST(MediaPlan, MediaOutsideTheSceneAreSkippedWithTheReason) {
  const scene::Scene s = floor_under_sun();
  MediaPlanning p;
  p.inputs = {haze(Rgb{1.0}, Rgb{1.0}, {{100, 100, 100}, {101, 101, 101}}), haze(Rgb{0.0}, Rgb{1.0})};
  p.inputs[0].name = "far away";
  LightmapPlan plan = p.plan(s);
  EXPECT_EQ(plan.media, std::vector<int>{1});  // the other is simulated
  EXPECT_NE(reason_of(plan, "participating_media").find("media[0] 'far away'"), std::string::npos)
      << reason_of(plan, "participating_media");
  p.inputs.pop_back();
  p.options.force_effects = {{"participating_media", true}};  // nothing to force on
  plan = p.plan(s);
  EXPECT_EQ(plan.media_mode, MediaMode::none);
  EXPECT_NE(reason_of(plan, "participating_media").find("do not overlap"), std::string::npos);
}

TEST(MediaPlan, LightTracingGivesWayToGatheringInMedia) {
  // A grey floor under a point light: light tracing serves its indirect light without media.
  const scene::Scene s = test::floor_under_point_light(0.5, {0, 1, 0}, Rgb{2.0});
  MediaPlanning p;
  p.options.target_error = 0.01;
  ASSERT_TRUE(p.plan(s).light_tracing) << reason_of(p.plan(s), "light_tracing");
  p.inputs = {haze(Rgb{0.0}, Rgb{0.5})};
  const LightmapPlan plan = p.plan(s);
  EXPECT_FALSE(plan.light_tracing);
  EXPECT_NE(reason_of(plan, "light_tracing").find("participating media"), std::string::npos)
      << reason_of(plan, "light_tracing");
  p.options.force_effects["light_tracing"] = true;
  EXPECT_THROW(p.plan(s), bake::InvalidInput);  // cannot be forced through media
}

}  // namespace
}  // namespace kiln::plan
