#include "bakers/bake/range_check.h"

#include <cmath>

#include "bakers/bake/number_format.h"

namespace kiln::bake {

std::optional<InvalidInput> check_range(const std::string& field, double v, double lo, double hi, bool lo_open) {
  const bool ok = std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi;
  if (ok) return std::nullopt;
  return InvalidInput(field, std::string("must be in ") + (lo_open ? "(" : "[") + format_number(lo) + ", " +
                                 format_number(hi) + "], got " + format_number(v));
}

std::optional<InvalidInput> check_rgb(const std::string& field, const Rgb& c, double lo, double hi) {
  for (int i = 0; i < 3; ++i) {
    if (auto e = check_range(field, c[i], lo, hi)) return e;
  }
  return std::nullopt;
}

}  // namespace kiln::bake
