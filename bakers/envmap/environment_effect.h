// The effects of the environment bake's plan, by the stable names the report, the daemon's plan decisions and a job's
// force_effects use.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace kiln::envmap {

// In the order the plan decides them.
enum class EnvironmentEffect {
  source,     // where the environment came from and how it was resampled
  sun_light,  // the sun as an explicit light (sun.h)
  lobe,       // the prefilter's lobe
  samples,    // how many samples per texel
  preview,    // preview.png
};

// The name on the wire and in the report: "source", "sun_light", "lobe", "samples", "preview".
std::string_view effect_name(EnvironmentEffect effect);
// The effect of that name, if any.
std::optional<EnvironmentEffect> effect_from_name(std::string_view name);

// Whether a job may force the effect on or off (force_effects): only sun_light.
bool forcible(EnvironmentEffect effect);
// The names of the forcible effects, comma-separated, for messages: "sun_light".
std::string forcible_effect_names();

}  // namespace kiln::envmap
