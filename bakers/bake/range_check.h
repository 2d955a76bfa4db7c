// The one range check behind every baker's validate(): "must be in [lo, hi], got v" for the field at fault.
#pragma once

#include <optional>
#include <string>

#include "bakers/bake/invalid_input.h"
#include "bakers/math/rgb.h"
#include "proto/bounds.h"

namespace kiln::bake {

// v in the range, and finite (NaN fails every comparison, so it is caught too). The protocol's ranges are declared
// once in proto/bounds.h, which every layer reads.
std::optional<InvalidInput> check_range(const std::string& field, double v, const bounds::Range& range);
// Each channel of c in the range.
std::optional<InvalidInput> check_rgb(const std::string& field, const Rgb& c, const bounds::Range& range);

}  // namespace kiln::bake
