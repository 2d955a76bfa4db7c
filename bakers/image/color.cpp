#include "bakers/image/color.h"

#include <OpenColorIO/OpenColorIO.h>

#include <cstdlib>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>

namespace OCIO = OCIO_NAMESPACE;

namespace kiln::image {

extern const char* const kShippedOcioConfig;  // generated from deploy/ocio/config.ocio

struct ColorConfig::Impl {
  OCIO::ConstConfigRcPtr config;
  // Processors are costly to build and cheap to reuse: one per (from, to) pair.
  mutable std::mutex mutex;
  mutable std::map<std::pair<std::string, std::string>, OCIO::ConstCPUProcessorRcPtr> processors;
};

ColorConfig::ColorConfig(std::unique_ptr<Impl> impl, std::string source)
    : impl_(std::move(impl)), source_(std::move(source)) {}
ColorConfig::~ColorConfig() = default;
ColorConfig::ColorConfig(ColorConfig&&) noexcept = default;

ColorConfig ColorConfig::from_text(const std::string& yaml) {
  auto impl = std::make_unique<Impl>();
  try {
    std::istringstream in(yaml);
    impl->config = OCIO::Config::CreateFromStream(in);
    impl->config->validate();
  } catch (const OCIO::Exception& e) {
    throw std::runtime_error(std::string("OpenColorIO config is invalid: ") + e.what());
  }
  return ColorConfig(std::move(impl), "an OpenColorIO config given as text");
}

const ColorConfig& ColorConfig::active() {
  static const ColorConfig config = [] {
    const char* env = std::getenv("OCIO");
    if (env && *env) {
      auto impl = std::make_unique<Impl>();
      try {
        impl->config = OCIO::Config::CreateFromFile(env);
        impl->config->validate();
      } catch (const OCIO::Exception& e) {
        throw std::runtime_error(std::string("$OCIO=") + env + ": cannot use this OpenColorIO config (" + e.what() +
                                 "); fix it or unset OCIO to use kiln's own");
      }
      return ColorConfig(std::move(impl), std::string("$OCIO=") + env);
    }
    ColorConfig c = from_text(kShippedOcioConfig);
    c.source_ = "kiln's shipped config";
    return c;
  }();
  return config;
}

std::string ColorConfig::working_space() const {
  const OCIO::ConstColorSpaceRcPtr cs = impl_->config->getColorSpace(OCIO::ROLE_SCENE_LINEAR);
  return cs ? cs->getName() : std::string();
}

std::vector<std::string> ColorConfig::spaces() const {
  std::vector<std::string> out;
  for (int i = 0; i < impl_->config->getNumColorSpaces(); ++i)
    out.emplace_back(impl_->config->getColorSpaceNameByIndex(i));
  return out;
}

bool ColorConfig::has_space(const std::string& name) const {
  return !name.empty() && impl_->config->getColorSpace(name.c_str()) != nullptr;
}

void ColorConfig::convert(float* data, std::size_t pixels, int channels, const std::string& from,
                          const std::string& to) const {
  if (channels != 3 && channels != 4) {
    throw std::invalid_argument("colour conversion needs 3 or 4 channels, got " + std::to_string(channels));
  }
  for (const std::string* name : {&from, &to}) {
    if (!has_space(*name)) {
      std::string known;
      for (const std::string& s : spaces()) known += (known.empty() ? "" : ", ") + s;
      throw std::invalid_argument("colour space '" + *name + "' is not in " + source_ + "; known: " + known);
    }
  }
  if (pixels == 0) return;
  OCIO::ConstCPUProcessorRcPtr cpu;
  {
    std::lock_guard lock(impl_->mutex);
    auto& slot = impl_->processors[{from, to}];
    if (!slot) {
      slot = impl_->config->getProcessor(from.c_str(), to.c_str())
                 ->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F32, OCIO::BIT_DEPTH_F32, OCIO::OPTIMIZATION_DEFAULT);
    }
    cpu = slot;
  }
  OCIO::PackedImageDesc image(data, static_cast<long>(pixels), 1, channels);
  cpu->apply(image);
}

std::string ColorConfig::convert_to_display(float* data, std::size_t pixels, int channels, const std::string& from,
                                            const std::string& display, const std::string& view) const {
  if (channels != 3 && channels != 4) {
    throw std::invalid_argument("display conversion needs 3 or 4 channels, got " + std::to_string(channels));
  }
  if (!has_space(from)) {
    std::string known;
    for (const std::string& s : spaces()) known += (known.empty() ? "" : ", ") + s;
    throw std::invalid_argument("colour space '" + from + "' is not in " + source_ + "; known: " + known);
  }
  const OCIO::ConstConfigRcPtr& config = impl_->config;
  const std::string d = display.empty() ? config->getDefaultDisplay() : display;
  bool display_known = false;
  for (int i = 0; i < config->getNumDisplays(); ++i) display_known |= d == config->getDisplay(i);
  if (!display_known) {
    throw std::invalid_argument("display '" + d + "' is not in " + source_ + "; use one of its displays");
  }
  const std::string v = view.empty() ? config->getDefaultView(d.c_str()) : view;
  bool view_known = false;
  for (int i = 0; i < config->getNumViews(d.c_str()); ++i) view_known |= v == config->getView(d.c_str(), i);
  if (!view_known) {
    throw std::invalid_argument("view '" + v + "' of display '" + d + "' is not in " + source_ +
                                "; use one of that display's views");
  }
  if (pixels == 0) return d + "/" + v;
  OCIO::ConstCPUProcessorRcPtr cpu;
  {
    std::lock_guard lock(impl_->mutex);
    // Keyed apart from convert()'s (from, to) pairs: a NUL cannot appear in a space name.
    auto& slot = impl_->processors[{from, std::string(1, '\0') + d + "/" + v}];
    if (!slot) {
      OCIO::DisplayViewTransformRcPtr transform = OCIO::DisplayViewTransform::Create();
      transform->setSrc(from.c_str());
      transform->setDisplay(d.c_str());
      transform->setView(v.c_str());
      slot = config->getProcessor(transform)->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F32, OCIO::BIT_DEPTH_F32,
                                                                       OCIO::OPTIMIZATION_DEFAULT);
    }
    cpu = slot;
  }
  OCIO::PackedImageDesc image(data, static_cast<long>(pixels), 1, channels);
  cpu->apply(image);
  return d + "/" + v;
}

}  // namespace kiln::image
