// Sampling the visible slopes of the Beckmann distribution (Heitz & d'Eon 2014, "Importance Sampling
// Microfacet-Based BSDFs using the Distribution of Visible Normals", section 4 and appendix C), in the configuration
// of unit roughness: the caller stretches wo by the widths before and the slopes after.
#pragma once

#include "bakers/math/sampling.h"

namespace kiln::brdf {

// The slope (x̃, ỹ) of a microfacet seen from a direction whose polar angle has cosine cos_theta ∈ (0, 1], in the
// frame where that direction's azimuth is 0, for unit roughness: P22(x̃, ỹ) = exp(−x̃² − ỹ²)/π weighted by the
// projected area max(0, 1 − x̃ tan θ) of each facet. The facet's normal is (−x̃, −ỹ, 1) normalised. u.x picks x̃ by
// inverting its marginal CDF, u.y picks ỹ (independent of x̃: the Gaussian is separable) by inverting erf. Both
// inversions are monotone and continuous in u, so stratification carries over.
Point2 sample_beckmann_visible_slope(double cos_theta, Point2 u);

// erfc⁻¹(q) for q ∈ (0, 2): the x with erfc(x) = q, to a few ulps. Exposed for its test.
double erfc_inverse(double q);

}  // namespace kiln::brdf
