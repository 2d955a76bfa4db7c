// The one range check behind every baker's validate(): "must be in [lo, hi], got v" for the field at fault.
#pragma once

#include <optional>
#include <string>

#include "bakers/bake/invalid_input.h"
#include "bakers/math/rgb.h"

namespace kiln::bake {

// v in [lo, hi], or in (lo, hi] with lo_open, and finite (NaN fails every comparison, so it is caught too).
std::optional<InvalidInput> check_range(const std::string& field, double v, double lo, double hi, bool lo_open = false);
// Each channel of c in [lo, hi].
std::optional<InvalidInput> check_rgb(const std::string& field, const Rgb& c, double lo, double hi);

}  // namespace kiln::bake
