// What a lightmap's target error measures.
//
//   lightmap (the default): a texel's standard error over the lightmap's brightness (the mean luminance of its valid
//     texels): what a viewer sees under one exposure for the whole map, and what an RMSE over the map measures. Dark
//     texels need no more absolute precision than bright ones, so the samples go where the noise is.
//   texel: a texel's standard error over its own mean luminance: the same relative precision everywhere, dark
//     corners included (they cost the most samples).
// Both divide by max(that luminance, the error floor).
#pragma once

namespace kiln::lightmap {

enum class ErrorMetric { lightmap, texel };

inline const char* to_string(ErrorMetric m) { return m == ErrorMetric::lightmap ? "lightmap" : "texel"; }

}  // namespace kiln::lightmap
