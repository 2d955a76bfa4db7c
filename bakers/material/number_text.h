// Numbers as the material bake writes them in its plan lines and EXR attributes: std::to_chars's shortest text that
// reads back as the same double ("0.3", "1e-04"). It differs from bake::format_number's printf form in places
// (0.0001), so the material outputs keep their own.
#pragma once

#include <string>

#include "bakers/math/rgb.h"

namespace kiln::material {

// The shortest round-trip text of v; "null" for NaN and infinities.
std::string shortest_number(double v);
// "[r, g, b]", each channel as shortest_number.
std::string rgb_list(const Rgb& c);

}  // namespace kiln::material
