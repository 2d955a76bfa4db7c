#include "bakers/material/number_text.h"

#include <charconv>
#include <cmath>

namespace kiln::material {

std::string shortest_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest text that reads back as v
  return std::string(buf, r.ptr);
}

std::string rgb_list(const Rgb& c) {
  return "[" + shortest_number(c.r) + ", " + shortest_number(c.g) + ", " + shortest_number(c.b) + "]";
}

}  // namespace kiln::material
