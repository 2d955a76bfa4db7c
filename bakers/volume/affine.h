// Composition and inversion of 3×4 affine transforms (scene::Transform, row-major, last column the translation).
#pragma once

#include <optional>

#include "bakers/scene/scene.h"

namespace kiln::volume {

// a ∘ b: first b, then a.
scene::Transform compose(const scene::Transform& a, const scene::Transform& b);
// The inverse, or nothing for a transform scene::usable_transform rejects (singular, flattened or non-finite).
std::optional<scene::Transform> inverse(const scene::Transform& t);
// The transform whose columns are the images of the unit axes and the origin.
scene::Transform from_columns(const Vec3& x, const Vec3& y, const Vec3& z, const Vec3& origin);

}  // namespace kiln::volume
