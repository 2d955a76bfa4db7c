#include "bakers/bake/number_format.h"

#include <cstdio>
#include <cstdlib>

namespace kiln::bake {

std::string format_number(double v) {
  char buf[32];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

std::string format_rgb(const Rgb& c) {
  if (c.r == c.g && c.g == c.b) return format_number(c.r);
  return format_number(c.r) + "," + format_number(c.g) + "," + format_number(c.b);
}

}  // namespace kiln::bake
