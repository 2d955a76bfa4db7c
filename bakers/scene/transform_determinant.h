// The determinant of an instance transform's 3×3 part: negative for a mirroring transform, which turns the normal of
// a triangle's winding inwards (the tracer turns it back; emissive triangles and the leak scope must agree with it).
#pragma once

#include "bakers/scene/scene.h"

namespace kiln::scene {

inline double determinant(const Transform& t) {
  const auto& m = t.m;
  return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
         m[2] * (m[4] * m[9] - m[5] * m[8]);
}

}  // namespace kiln::scene
