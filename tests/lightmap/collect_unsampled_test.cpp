// collect_unsampled against its definition: what collect_results copies from a state made of the same texels with no
// estimate added, channel by channel and bit for bit, without making that state.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "bakers/lightmap/lightmap_outputs.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/lightmap/texels.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), sizeof(T) * a.size()) == 0);
}

// A tile of a page: the right half of an 8×8 map of a floor whose UVs cover part of it, so that the tile has valid
// and invalid texels.
struct Tile {
  scene::Scene scene;
  std::string name;
  RasterOptions raster;
  LightmapTexels texels;
};

Tile floor_tile() {
  Tile t;
  t.scene.materials.push_back(test::lambert_material("floor", 0.5));
  test::add_floor(t.scene, 2.0, 0, 3);
  t.name = lightmap_names(t.scene).front();
  t.raster.width = t.raster.height = 8;
  t.raster.window = {4, 0, 4, 8};
  t.texels = rasterize_lightmap(t.scene, t.name, t.raster);
  return t;
}

std::vector<ShadingMaterial> lambertian_materials() {
  std::vector<ShadingMaterial> m(1);
  m[0].lambertian = brdf::LambertianForm{Rgb{0.5}, Rgb{0.0}};
  return m;
}

TEST(CollectUnsampled, IsWhatCollectResultsGivesForAStateWithoutEstimates) {
  const Tile tile = floor_tile();
  ASSERT_GT(tile.texels.valid_count(), 0u);
  const std::vector<ShadingMaterial> materials = lambertian_materials();
  const ResultChannels channels{true, true, true, true};  // AO, SH, radiance and guides: every channel
  ChartIds charts_state(tile.scene), charts_texels(tile.scene);
  LightmapResults from_state(tile.name, 8, 8, channels), from_texels(tile.name, 8, 8, channels);
  const LightmapState m = make_lightmap_state(tile.name, tile.texels, LeakReport{}, true, true);
  collect_results(m, 4, 0, {&tile.scene, &materials, &charts_state}, from_state);
  collect_unsampled(tile.texels, 4, 0, {&tile.scene, &materials, &charts_texels}, from_texels);

  size_t valid = 0;
  for (size_t p = 0; p < from_state.texel_count(); ++p) {
    SCOPED_TRACE(testing::Message() << "page texel " << p);
    ASSERT_EQ(from_texels.valid(p), from_state.valid(p));
    EXPECT_EQ(from_texels.count(p), 0u);
    EXPECT_EQ(from_state.count(p), 0u);
    // Bits, not values: an unknown error is +∞ in both, and a black mean 0, never −0 or NaN.
    const double se_state = from_state.standard_error(p), se_texels = from_texels.standard_error(p);
    EXPECT_EQ(std::memcmp(&se_state, &se_texels, sizeof(double)), 0) << se_state << " vs " << se_texels;
    if (from_state.valid(p)) {
      ++valid;
      EXPECT_EQ(se_texels, std::numeric_limits<double>::infinity()) << "no estimate: the error is unknown";
    }
    const Rgb a = from_state.mean(p), b = from_texels.mean(p);
    EXPECT_EQ(std::memcmp(&a, &b, sizeof(Rgb)), 0);
  }
  EXPECT_EQ(valid, tile.texels.valid_count());
  EXPECT_TRUE(same_bits(from_texels.ao, from_state.ao));
  EXPECT_TRUE(same_bits(from_texels.sh, from_state.sh));
  EXPECT_TRUE(same_bits(from_texels.sh_error, from_state.sh_error));
  EXPECT_TRUE(same_bits(from_texels.radiance, from_state.radiance));
  EXPECT_TRUE(same_bits(from_texels.guides.valid, from_state.guides.valid));
  EXPECT_TRUE(same_bits(from_texels.guides.position, from_state.guides.position));
  EXPECT_TRUE(same_bits(from_texels.guides.normal, from_state.guides.normal));
  EXPECT_TRUE(same_bits(from_texels.guides.texel_size, from_state.guides.texel_size));
  EXPECT_TRUE(same_bits(from_texels.guides.chart, from_state.guides.chart));
}

TEST(CollectUnsampled, RefusesATileOutsideThePage) {
  const Tile tile = floor_tile();
  ChartIds charts(tile.scene);
  LightmapResults page(tile.name, 8, 8, ResultChannels{});
  EXPECT_THROW(collect_unsampled(tile.texels, 5, 0, {&tile.scene, nullptr, &charts}, page), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::lightmap
