// Numbers as text for descriptions, plans and reports: the shortest text that reads back as the same double.
#pragma once

#include <string>

#include "bakers/math/rgb.h"

namespace kiln::bake {

// Shortest round-trip text for a number ("0.3", "1e-06").
std::string format_number(double v);
// "0.8" when the three channels agree, else "0.8,0.5,0.2".
std::string format_rgb(const Rgb& c);

}  // namespace kiln::bake
