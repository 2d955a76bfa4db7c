#include "bakers/plan/lightmap_effect.h"

namespace kiln::plan {

const std::array<LightmapEffect, kLightmapEffectCount>& lightmap_effects() {
  static const std::array<LightmapEffect, kLightmapEffectCount> kAll = [] {
    std::array<LightmapEffect, kLightmapEffectCount> all{};
    for (int i = 0; i < kLightmapEffectCount; ++i) all[i] = static_cast<LightmapEffect>(i);
    return all;
  }();
  return kAll;
}

const char* effect_name(LightmapEffect effect) {
  switch (effect) {
    case LightmapEffect::point_lights:
      return "point_lights";
    case LightmapEffect::spot_lights:
      return "spot_lights";
    case LightmapEffect::directional_lights:
      return "directional_lights";
    case LightmapEffect::area_lights:
      return "area_lights";
    case LightmapEffect::emissive_triangles:
      return "emissive_triangles";
    case LightmapEffect::environment_sampling:
      return "environment_sampling";
    case LightmapEffect::environment_importance_map:
      return "environment_importance_map";
    case LightmapEffect::multiple_importance_sampling:
      return "multiple_importance_sampling";
    case LightmapEffect::indirect_bounces:
      return "indirect_bounces";
    case LightmapEffect::specular_interreflection:
      return "specular_interreflection";
    case LightmapEffect::anisotropy:
      return "anisotropy";
    case LightmapEffect::textures:
      return "textures";
    case LightmapEffect::russian_roulette:
      return "russian_roulette";
    case LightmapEffect::light_tracing:
      return "light_tracing";
    case LightmapEffect::participating_media:
      return "participating_media";
    case LightmapEffect::media_scattering:
      return "media_scattering";
  }
  return "unknown";
}

std::optional<LightmapEffect> parse_lightmap_effect(std::string_view name) {
  for (LightmapEffect e : lightmap_effects()) {
    if (name == effect_name(e)) return e;
  }
  return std::nullopt;
}

std::vector<std::string> lightmap_effect_names() {
  std::vector<std::string> names;
  for (LightmapEffect e : lightmap_effects()) names.emplace_back(effect_name(e));
  return names;
}

}  // namespace kiln::plan
