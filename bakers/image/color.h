// Colour management through OpenColorIO: converting pixels between named colour spaces of the active config.
// The active config is $OCIO when set, else the one kiln ships (deploy/ocio/config.ocio, compiled in). Baking happens
// in the config's scene_linear role (lin_rec709 in kiln's config). OpenColorIO's headers stay in color.cpp.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace kiln::image {

class ColorConfig {
 public:
  // $OCIO if set (throws std::runtime_error naming the file if it cannot be loaded), else the shipped config.
  static const ColorConfig& active();
  // A config from its text (for tests and for configs that arrive with a job).
  static ColorConfig from_text(const std::string& yaml);

  ~ColorConfig();
  ColorConfig(ColorConfig&&) noexcept;

  // Where the config came from: "$OCIO=/path" or "kiln's shipped config".
  const std::string& source() const { return source_; }
  // The name of the working space (the scene_linear role).
  std::string working_space() const;
  // Every colour space name (not aliases).
  std::vector<std::string> spaces() const;
  // True if `name` names a colour space or a role of the config.
  bool has_space(const std::string& name) const;

  // Converts `pixels` interleaved pixels of `channels` (3 or 4; alpha untouched) from one space to another, in
  // place. Throws std::invalid_argument naming an unknown space ("colour space 'foo' is not in kiln's shipped
  // config; known: ...").
  void convert(float* data, std::size_t pixels, int channels, const std::string& from, const std::string& to) const;

  // Converts `pixels` interleaved pixels of `channels` (3 or 4) from a colour space to what a display shows, through
  // the config's display/view transform (OpenColorIO's DisplayViewTransform), in place. An empty `display` is the
  // config's default display and an empty `view` that display's default view (kiln's config: display "sRGB", view
  // "Standard" = srgb_display: clamp to [0, 1], then the sRGB curve). Returns "display/view" as used; with
  // pixels = 0 it only checks the names (data may be null). Throws std::invalid_argument naming an unknown space,
  // display or view.
  std::string convert_to_display(float* data, std::size_t pixels, int channels, const std::string& from,
                                 const std::string& display = "", const std::string& view = "") const;

 private:
  struct Impl;
  explicit ColorConfig(std::unique_ptr<Impl> impl, std::string source);
  std::unique_ptr<Impl> impl_;
  std::string source_;
};

}  // namespace kiln::image
