// The lightmap planner's effects keep the names reports, the protocol and `--force EFFECT=on|off` use.
#include "bakers/plan/lightmap_effect.h"

#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace kiln::plan {
namespace {

TEST(LightmapEffect, NamesAreStableAndInOrder) {
  const std::vector<std::string> expected = {"point_lights",
                                             "spot_lights",
                                             "directional_lights",
                                             "area_lights",
                                             "emissive_triangles",
                                             "environment_sampling",
                                             "environment_importance_map",
                                             "multiple_importance_sampling",
                                             "indirect_bounces",
                                             "specular_interreflection",
                                             "anisotropy",
                                             "textures",
                                             "russian_roulette",
                                             "light_tracing",
                                             "participating_media",
                                             "media_scattering"};
  EXPECT_EQ(lightmap_effect_names(), expected);
  ASSERT_EQ(lightmap_effects().size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(effect_name(lightmap_effects()[i]), expected[i]);
}

TEST(LightmapEffect, EveryNameParsesBackToItsEffect) {
  for (LightmapEffect e : lightmap_effects()) {
    const std::optional<LightmapEffect> parsed = parse_lightmap_effect(effect_name(e));
    ASSERT_TRUE(parsed.has_value()) << effect_name(e);
    EXPECT_EQ(*parsed, e);
  }
}

TEST(LightmapEffect, UnknownNamesDoNotParse) {
  EXPECT_FALSE(parse_lightmap_effect("").has_value());
  EXPECT_FALSE(parse_lightmap_effect("sun_light").has_value());
  EXPECT_FALSE(parse_lightmap_effect("Point_Lights").has_value());
  EXPECT_FALSE(parse_lightmap_effect("point_lights ").has_value());
}

}  // namespace
}  // namespace kiln::plan
