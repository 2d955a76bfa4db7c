#include "bakers/envmap/environment_effect.h"

#include <array>
#include <utility>

namespace kiln::envmap {
namespace {

constexpr std::array<std::pair<EnvironmentEffect, std::string_view>, 5> kEffectNames = {{
    {EnvironmentEffect::source, "source"},
    {EnvironmentEffect::sun_light, "sun_light"},
    {EnvironmentEffect::lobe, "lobe"},
    {EnvironmentEffect::samples, "samples"},
    {EnvironmentEffect::preview, "preview"},
}};

}  // namespace

std::string_view effect_name(EnvironmentEffect effect) {
  for (const auto& [e, name] : kEffectNames) {
    if (e == effect) return name;
  }
  return "";
}

std::optional<EnvironmentEffect> effect_from_name(std::string_view name) {
  for (const auto& [e, n] : kEffectNames) {
    if (n == name) return e;
  }
  return std::nullopt;
}

bool forcible(EnvironmentEffect effect) { return effect == EnvironmentEffect::sun_light; }

std::string forcible_effect_names() {
  std::string names;
  for (const auto& [e, name] : kEffectNames) {
    if (forcible(e)) names += (names.empty() ? "" : ", ") + std::string(name);
  }
  return names;
}

}  // namespace kiln::envmap
