// The effects the lightmap planner decides on. Their names are stable: reports, the wire protocol and a job's
// force_effects (`kiln --force EFFECT=on|off`) carry them.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace kiln::plan {

// In the order of LightmapPlan::decisions.
enum class LightmapEffect {
  point_lights,
  spot_lights,
  directional_lights,
  area_lights,
  emissive_triangles,
  environment_sampling,
  environment_importance_map,
  multiple_importance_sampling,
  indirect_bounces,
  specular_interreflection,
  anisotropy,
  textures,
  russian_roulette,
  light_tracing,
  participating_media,
  media_scattering,
};
inline constexpr int kLightmapEffectCount = static_cast<int>(LightmapEffect::media_scattering) + 1;

// Every effect, in declaration order.
const std::array<LightmapEffect, kLightmapEffectCount>& lightmap_effects();

// The stable name: "point_lights" for LightmapEffect::point_lights, and so on.
const char* effect_name(LightmapEffect effect);

// The effect of that name; nullopt for a name no effect has.
std::optional<LightmapEffect> parse_lightmap_effect(std::string_view name);

// The names of lightmap_effects(), in order.
std::vector<std::string> lightmap_effect_names();

}  // namespace kiln::plan
