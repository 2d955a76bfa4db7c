// Scene-linear RGB made into an 8-bit picture for a person (the environment preview, the lightmap preview): one
// automatic exposure rule, one display transform, one quantisation, so that every kiln preview is exposed and
// encoded alike.
//
// ## Automatic exposure (auto_exposure)
// The multiplier that maps the median of the key luminances (Rec.709 luma, bakers/math/rgb.h luminance, of the
// pixels the caller chooses) to mid-grey kMidGrey = 0.18. A median that is black (more than half the pixels are) or
// not finite falls back to the mean, which still says how bright the rest is; when that too is black or not finite
// (a black picture, or no pixels) the exposure is 1, as it is when the key is so small that 0.18 / key overflows.
// NaN luminances are left out. With an even count the median is the upper of the two middle values.
//
// ## Display and quantisation (display_png8)
// Every value is multiplied by the exposure; a value that is NaN or negative (not light) becomes 0 before the
// transform, since OpenColorIO does not define NaN input. Then the active OpenColorIO config's display/view transform
// from `color_space` (empty display and view: the config's defaults, kiln's "sRGB"/"Standard" = clamp to [0, 1] and
// the sRGB curve), and each value v becomes round(255 · clamp(v, 0, 1)); a NaN the transform might make becomes 0.
// No NaN reaches the PNG.
#pragma once

#include <string>
#include <vector>

#include "bakers/image/png.h"

namespace kiln::image {

inline constexpr double kMidGrey = 0.18;

struct AutoExposure {
  enum class Key { median, mean, black };  // which statistic set the exposure (black: none could, exposure 1)
  double multiplier = 1.0;                 // finite, > 0
  double key = 0.0;                        // the luminance mapped to kMidGrey (the median or the mean)
  Key from = Key::black;
};

// The automatic exposure of the rule above for these luminances (taken by value: the median reorders them).
AutoExposure auto_exposure(std::vector<double> luminances);

// What an automatic exposure did, for people (a preview's kiln:exposure_rule): "automatic: median <what> luminance
// K -> 0.18", the same with "mean" and "(the median is black)", or "automatic: <black>, exposure 1". `what` names the
// pixels the key came from ("background", "valid texel"); `black` says what a black key means ("a black environment").
std::string describe_exposure(const AutoExposure& exposure, const std::string& what, const std::string& black);

// `linear` holds width × height interleaved RGB pixels, top row first, scene-linear in `color_space` (a space or role
// of the active config); `exposure` is a finite multiplier > 0. Returns the 3-channel picture with the text chunk
// "kiln:display_view" ("display/view" as used) set; the caller adds the rest of its metadata. Throws
// std::invalid_argument when the size does not match or the exposure is not finite and positive, and (from the
// colour config) naming an unknown colour space, display or view.
Png8Image display_png8(std::vector<float> linear, int width, int height, double exposure,
                       const std::string& color_space, const std::string& display = {}, const std::string& view = {});

}  // namespace kiln::image
