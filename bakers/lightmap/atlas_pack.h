// Atlas packing: every baking instance of a scene gets a rectangle of its own in one of a few square atlas pages, at
// a texel density (texels per metre of surface), and the scale and offset that map its mesh's lightmap UVs there, as
// the lightmappers of game engines do (Unity's lightmapScaleOffset, Bakery, Godot's LightmapGI).
//
// ## An instance's region
// Its chart is the bounding rectangle [u0, u1] × [v0, v1] of its mesh's baked triangles' lightmap UVs (the triangles
// the scene check marks as baked). With A_w the world area of those triangles under the instance's transform and
// A_uv their lightmap-UV area, k = d·√(A_w / A_uv) texels per UV unit gives d texels per metre on average over the
// instance; the chart takes ⌈k·(u1 − u0)⌉ × ⌈k·(v1 − v0)⌉ texels (at least 1 × 1). A chart that would not fit a page
// (with its padding) is shrunk to fit, and its reduced density reported. The scale is the same along u and v, so the
// mesh's own UV proportions (and their distortion, if any) are kept.
//
// The chart's corner (u0, v0) lands on a whole texel (x, y) of the page: uv_page = uv · s + o with
// s = k / P and o = (x − k·u0, y − k·v0) / P (P the page size), the same s along u and v. The offsets may be negative
// and uv · s + o may leave [0, 1] outside the chart's rectangle: only the chart's UVs are in the page.
//
// ## Padding
// Two charts are at least `padding` texels apart (and a chart ⌊padding/2⌋ texels from the page's edge): every texel of
// the gap is nearer one chart than the other, so dilation fills it from that one and a bilinear lookup at a chart's
// border reads that chart's texels only. At least 2 (a bilinear footprint); the bake passes its dilation padding.
//
// ## Pages
// Rectangles (chart plus padding) are sorted by height, then width (both descending), then instance index, and placed
// one by one in the first page where a skyline bottom-left packer finds room (the lowest position, then the leftmost);
// a new page opens when none has. An instance with `own_page` gets a page of its own (opened first, in instance
// order). Pages are named "page0", "page1", ... in the order they open: plain ASCII, no path separator, so the output
// files are PAGE_irradiance.exr and so on.
//
// ## Page sizes
// A page is then shrunk to the smallest square, a multiple of 4 texels on a side, that the same packer fits its
// charts in (in the same order): the last page of a level, partly filled, or a page of its own, takes the texels its
// charts need rather than page_size². The densities stay as packed; only the charts' positions and the page's side
// change. `uniform_pages` keeps every page at page_size (for an engine that stores the pages in one texture array).
//
// ## More than max_pages
// Every density is then multiplied by the largest factor (found by bisection, to 2⁻²⁰) at which the charts fit in
// max_pages, and the factor is reported: the bake delivers the highest density that fits rather than failing a job
// after its upload. Only when the charts cannot fit even at one texel each is it an InvalidInput naming "max_pages".
//
// Instances whose mesh has no baked triangle (no lightmap UVs, or every triangle dropped or degenerate) or whose
// world or UV area is zero or not finite get no region: they are not baked (still traced), and the region says why.
// Deterministic: the same scene and options give the same pages, bit for bit.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bakers/bake/invalid_input.h"
#include "bakers/bake/stop.h"
#include "bakers/scene/scene_check.h"

namespace kiln::lightmap {

struct AtlasInstanceOptions {
  double texel_density = 0;  // texels per metre for this instance; 0: AtlasOptions::texel_density
  bool own_page = false;     // a page of its own, shared with no other instance
};

struct AtlasOptions {
  double texel_density = 0;    // texels per metre of surface (per scene unit); > 0 packs, 0 does not
  int page_size = 1024;        // texels on a side of every page
  int padding = 4;             // texels between charts; at least 2 are used
  int max_pages = 16;          // most pages
  bool uniform_pages = false;  // every page page_size on a side; false: each shrunk to its content (## Page sizes)
  // By index into the input scene's instances (CheckedScene::source_instance maps the checked scene's to them).
  std::map<uint32_t, AtlasInstanceOptions> instances;
};

// One instance's place in the atlas.
struct AtlasRegion {
  uint32_t instance = 0;                           // into the checked scene's instances
  uint32_t source_instance = 0;                    // into the input scene's instances
  int page = -1;                                   // into AtlasPack::pages; -1: not packed (`note` says why), not baked
  int x = 0, y = 0;                                // the chart's top-left texel in the page (padding not included)
  int width = 0, height = 0;                       // the chart's texels
  std::array<double, 4> scale_offset{1, 1, 0, 0};  // {s_u, s_v, o_u, o_v}: uv_page = (s_u·u + o_u, s_v·v + o_v)
  double density_asked = 0;                        // texels per metre asked for (the instance's or the job's)
  double density = 0;                              // reached: k·√(A_uv / A_w)
  double world_area = 0;                           // A_w, square metres
  double uv_area = 0;                              // A_uv, in the mesh's lightmap-UV units
  double chart_texels = 0;                         // A_uv·k²: the texels its triangles cover, in texel² units
  std::string note;  // why it was not packed, or why its density is below the one asked for; else empty
};

struct AtlasPage {
  std::string name;
  int size = 0;                   // texels on a side: page_size, or less for a page shrunk to its content
  std::vector<uint32_t> regions;  // into AtlasPack::regions, in instance order
  double chart_texels = 0;        // Σ of its regions' chart_texels
  bool own_page = false;          // holds one own_page instance
};

struct AtlasPack {
  std::vector<AtlasPage> pages;
  std::vector<AtlasRegion> regions;  // one per baking instance of the checked scene, in its order
  double density_scale = 1;          // the factor every density was multiplied by to fit max_pages; 1: none
  int padding = 0;                   // texels between charts, as used
  double seconds = 0;
};

// nullopt if the options are in range, else the field ("texel_density", "page_size", "padding", "max_pages",
// "instances[I].texel_density") and the problem.
std::optional<bake::InvalidInput> check_atlas_options(const AtlasOptions& options);

// "page<N>".
std::string atlas_page_name(int page);

// The texels of all the pack's pages, and the fraction of them its charts cover by their UV area (its efficiency;
// 0 for a pack without pages).
double page_texels(const AtlasPack& pack);
double chart_area_fraction(const AtlasPack& pack);

// The regions and pages of the checked scene's baking instances. Throws bake::InvalidInput("max_pages", ...) when
// the charts cannot fit in max_pages pages even at one texel each, and for options out of range ("texel_density",
// "page_size", "padding", "max_pages", "instances[I].texel_density"); polls `stop` every block of instances.
AtlasPack pack_atlas(const scene::CheckedScene& checked, const AtlasOptions& options, const bake::StopCheck& stop = {});

// Puts the pack into the scene (the checked scene packed): each packed instance bakes into its page with its scale
// and offset; the others are not baked.
void apply_atlas(const AtlasPack& pack, scene::Scene& scene);

// The scene check of a bake that packs: the instances' own lightmap names and scales and offsets are dropped (the
// packer names and places them, so no lightmap is renamed for its file name), the scene is checked, packed and placed
// (apply_atlas), and only then checked for overlapping lightmap UVs, so the report has the overlaps of the pages as
// baked (a mesh whose own UVs overlap), not of the placement the packer replaced. `pack` receives the pack.
scene::CheckedScene check_and_pack_scene(scene::Scene scene, const AtlasOptions& options, const bake::StopCheck& stop,
                                         AtlasPack& pack);

}  // namespace kiln::lightmap
