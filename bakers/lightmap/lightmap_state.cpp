#include "bakers/lightmap/lightmap_state.h"

#include <utility>

#include "bakers/lightmap/light_tracing.h"

namespace kiln::lightmap {
namespace {

// The element sizes are read off the members themselves, so the figures follow the struct.
template <class Vector>
constexpr size_t element_bytes() {
  return sizeof(typename Vector::value_type);
}

}  // namespace

Receiver receiver_of(const TexelSample& sample) {
  Receiver r;
  r.surface = sample.surface();
  r.ns = dot(sample.shading_normal, sample.geometric_normal) > 0 ? sample.shading_normal : sample.geometric_normal;
  return r;
}

LightmapState make_lightmap_state(std::string name, LightmapTexels texels, const LeakReport& leaks, bool ao,
                                  bool directional) {
  std::vector<uint8_t> validity = texels.validity();
  const int width = texels.width, height = texels.height;
  LightmapState m{name, std::move(texels), LightmapImage(name, width, height, std::move(validity)), leaks, {}, {}, {},
                  {},   {}};
  m.attempts.assign(m.texels.texel_count(), 0);
  if (ao) m.ao_sum.assign(m.texels.texel_count(), Rgb{});
  if (directional) {
    m.sh_sum.assign(m.texels.texel_count(), {});
    m.sh_y2.assign(m.texels.texel_count(), {});
  }
  return m;
}

BakeStateBytes lightmap_state_bytes(bool ao, bool directional, bool traced) {
  BakeStateBytes b;
  b.per_texel = element_bytes<decltype(LightmapState::attempts)>();
  if (traced) {
    b.per_texel += element_bytes<decltype(LightmapState::traced)>() + LightmapImage::kTracedBytesPerTexel +
                   LightTracer::kBytesPerTexel;
  }
  if (ao) b.per_texel += element_bytes<decltype(LightmapState::ao_sum)>();
  if (directional) {
    b.per_texel += element_bytes<decltype(LightmapState::sh_sum)>() + element_bytes<decltype(LightmapState::sh_y2)>();
  }
  return b;
}

}  // namespace kiln::lightmap
