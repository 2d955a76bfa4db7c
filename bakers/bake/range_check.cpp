#include "bakers/bake/range_check.h"

#include <cmath>

#include "bakers/bake/number_format.h"

namespace kiln::bake {

std::optional<InvalidInput> check_range(const std::string& field, double v, const bounds::Range& range) {
  if (std::isfinite(v) && range.contains(v)) return std::nullopt;
  return InvalidInput(field, std::string("must be in ") + (range.lo_open ? "(" : "[") + format_number(range.lo) + ", " +
                                 format_number(range.hi) + "], got " + format_number(v));
}

std::optional<InvalidInput> check_rgb(const std::string& field, const Rgb& c, const bounds::Range& range) {
  for (int i = 0; i < 3; ++i) {
    if (auto e = check_range(field, c[i], range)) return e;
  }
  return std::nullopt;
}

}  // namespace kiln::bake
