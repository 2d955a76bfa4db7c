#include "bakers/lightmap/atlas_pack.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <tuple>

#include "bakers/bake/invalid_input.h"
#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"
#include "bakers/math/skyline.h"

namespace kiln::lightmap {
namespace {

// Two charts closer than this could share a bilinear footprint.
constexpr int kMinPadding = 2;
// The bisection over the density factor stops at 2⁻²⁰ of it: far below what a texel of rounding changes.
constexpr int kFitSteps = 20;
// A page shrunk to its content keeps a side of a multiple of 4 texels: block-compressed formats (BC6H, ASTC 4×4) code
// 4 × 4 blocks.
constexpr int kPageMultiple = 4;

// The lightmap-UV rectangle and area of a mesh's baked triangles.
struct MeshChart {
  bool any = false;
  double u0 = 0, v0 = 0, u1 = 0, v1 = 0;
  double uv_area = 0;
};

bool finite(const Point2& p) { return std::isfinite(p.x) && std::isfinite(p.y); }

// The triangle's three indices when they are in range for both arrays it reads; false otherwise.
bool triangle_indices(const scene::Mesh& mesh, size_t t, std::array<uint32_t, 3>& idx) {
  if (3 * t + 2 >= mesh.indices.size()) return false;
  for (int c = 0; c < 3; ++c) {
    idx[c] = mesh.indices[3 * t + c];
    if (idx[c] >= mesh.positions.size() || idx[c] >= mesh.lightmap_uv.size()) return false;
  }
  return true;
}

bool baked(const scene::CheckedScene::MeshTriangles& info, size_t t) { return t < info.bake.size() && info.bake[t]; }

MeshChart mesh_chart(const scene::Mesh& mesh, const scene::CheckedScene::MeshTriangles& info) {
  MeshChart c;
  const size_t triangles = mesh.indices.size() / 3;
  for (size_t t = 0; t < triangles; ++t) {
    std::array<uint32_t, 3> idx;
    if (!baked(info, t) || !triangle_indices(mesh, t, idx)) continue;
    const Point2 &a = mesh.lightmap_uv[idx[0]], &b = mesh.lightmap_uv[idx[1]], &d = mesh.lightmap_uv[idx[2]];
    if (!finite(a) || !finite(b) || !finite(d)) continue;
    const double area = 0.5 * std::abs((b.x - a.x) * (d.y - a.y) - (b.y - a.y) * (d.x - a.x));
    if (!std::isfinite(area)) continue;
    c.uv_area += area;
    for (const Point2* p : {&a, &b, &d}) {
      if (!c.any) {
        c.u0 = c.u1 = p->x;
        c.v0 = c.v1 = p->y;
        c.any = true;
      }
      c.u0 = std::min(c.u0, p->x), c.u1 = std::max(c.u1, p->x);
      c.v0 = std::min(c.v0, p->y), c.v1 = std::max(c.v1, p->y);
    }
  }
  return c;
}

double world_area(const scene::Mesh& mesh, const scene::CheckedScene::MeshTriangles& info,
                  const scene::Transform& to_world) {
  double sum = 0;
  const size_t triangles = mesh.indices.size() / 3;
  for (size_t t = 0; t < triangles; ++t) {
    std::array<uint32_t, 3> idx;
    if (!baked(info, t) || !triangle_indices(mesh, t, idx)) continue;
    const Vec3 a = to_world.point(mesh.positions[idx[0]]);
    const Vec3 e1 = to_world.point(mesh.positions[idx[1]]) - a, e2 = to_world.point(mesh.positions[idx[2]]) - a;
    const double area = 0.5 * length(cross(e1, e2));
    if (std::isfinite(area)) sum += area;
  }
  return sum;
}

// An instance with a chart to place.
struct Chart {
  uint32_t region = 0;
  double u0 = 0, v0 = 0, du = 0, dv = 0;  // its UV rectangle
  double k_asked = 0;                     // texels per UV unit at the density asked for
  bool own_page = false;
};

// A chart's texels per UV unit and size at the density factor f: never above what fits a page (limit texels on its
// longer side), never below one texel on its longer side.
struct ChartSize {
  double k = 0;
  int w = 1, h = 1;
};

ChartSize chart_size(const Chart& c, double f, int limit) {
  const double longer = std::max(c.du, c.dv);
  ChartSize s;
  s.k = std::max(c.k_asked * f, 1.0 / longer);
  if (s.k * longer > limit) s.k = static_cast<double>(limit) / longer;
  // Rounding can put k·longer a hair above a whole number: step k down until the chart is inside its texels.
  for (;;) {
    s.w = std::max(1, static_cast<int>(std::ceil(s.k * c.du)));
    s.h = std::max(1, static_cast<int>(std::ceil(s.k * c.dv)));
    if (s.w <= limit && s.h <= limit) break;
    s.k = std::nextafter(s.k, 0.0);
  }
  return s;
}

struct Placement {
  int page = -1, x = 0, y = 0;  // of the chart's allocation (padding included)
  ChartSize size;
};

// Tallest first, then widest, then by instance: a full order, so the packing is deterministic.
std::vector<size_t> packing_order(const std::vector<Chart>& charts, const std::vector<Placement>& placed) {
  std::vector<size_t> order(charts.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return std::make_tuple(-placed[a].size.h, -placed[a].size.w, charts[a].region) <
           std::make_tuple(-placed[b].size.h, -placed[b].size.w, charts[b].region);
  });
  return order;
}

// Places every chart at density factor f; false as soon as more than max_pages pages would be needed.
bool place_all(const std::vector<Chart>& charts, double f, const AtlasOptions& o, int padding,
               std::vector<Placement>& out, int& pages, const bake::StopCheck& stop) {
  const int limit = o.page_size - padding;
  out.assign(charts.size(), {});
  for (size_t i = 0; i < charts.size(); ++i) out[i].size = chart_size(charts[i], f, limit);
  pages = 0;
  for (size_t i = 0; i < charts.size(); ++i) {
    if (!charts[i].own_page) continue;
    if (++pages > o.max_pages) return false;
    out[i].page = pages - 1;
  }
  const std::vector<size_t> order = packing_order(charts, out);
  std::vector<std::pair<int, Skyline>> shared;  // page index, skyline
  for (size_t n = 0; n < order.size(); ++n) {
    if (n % 1024 == 0) stop.check();
    if (charts[order[n]].own_page) continue;
    Placement& p = out[order[n]];
    const int w = p.size.w + padding, h = p.size.h + padding;
    bool placed = false;
    for (auto& [page, sky] : shared) {
      if (sky.find(w, h, p.x, p.y)) {
        sky.place(p.x, p.y, w, h);
        p.page = page;
        placed = true;
        break;
      }
    }
    if (placed) continue;
    if (++pages > o.max_pages) return false;
    Skyline& sky = shared.emplace_back(pages - 1, Skyline(o.page_size)).second;
    sky.find(w, h, p.x, p.y);  // always at (0, 0): w, h ≤ the page size
    sky.place(p.x, p.y, w, h);
    p.page = pages - 1;
  }
  return true;
}

// The allocations' positions in a square of `side` texels, packed in this order; false if one does not fit.
bool skyline_pack(const std::vector<Placement*>& items, int padding, int side, std::vector<std::array<int, 2>>& xy) {
  Skyline sky(side);
  xy.resize(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    const int w = items[i]->size.w + padding, h = items[i]->size.h + padding;
    if (w > side || h > side || !sky.find(w, h, xy[i][0], xy[i][1])) return false;
    sky.place(xy[i][0], xy[i][1], w, h);
  }
  return true;
}

// Moves a page's allocations (in their packing order) into the smallest square, a multiple of kPageMultiple texels on
// a side and below `size`, that the skyline packer fits them in; returns its side (`size` when none is smaller).
// Packing is not monotone in the side, so the bisection keeps the smallest side it saw fit, and only sides it tried.
int shrink_page(const std::vector<Placement*>& items, int padding, int size) {
  double area = 0;
  int largest = 0;
  for (const Placement* p : items) {
    area += static_cast<double>(p->size.w + padding) * (p->size.h + padding);
    largest = std::max({largest, p->size.w + padding, p->size.h + padding});
  }
  const int lower = std::max(largest, static_cast<int>(std::ceil(std::sqrt(area))));
  int lo = (lower + kPageMultiple - 1) / kPageMultiple, hi = (size - 1) / kPageMultiple;
  int best = size;
  std::vector<std::array<int, 2>> xy, best_xy;
  while (lo <= hi) {
    const int mid = (lo + hi) / 2;
    if (skyline_pack(items, padding, mid * kPageMultiple, xy)) {
      best = mid * kPageMultiple;
      best_xy = xy;
      hi = mid - 1;
    } else {
      lo = mid + 1;
    }
  }
  for (size_t i = 0; i < best_xy.size(); ++i) items[i]->x = best_xy[i][0], items[i]->y = best_xy[i][1];
  return best;
}

// Every page shrunk to its content (shrink_page), its allocations taken in the order place_all packed them.
void shrink_pages(std::vector<Placement>& placed, const std::vector<Chart>& charts, int padding,
                  std::vector<AtlasPage>& pages) {
  std::vector<std::vector<Placement*>> by_page(pages.size());
  for (size_t i : packing_order(charts, placed)) by_page[static_cast<size_t>(placed[i].page)].push_back(&placed[i]);
  for (size_t p = 0; p < pages.size(); ++p) pages[p].size = shrink_page(by_page[p], padding, pages[p].size);
}

}  // namespace

std::optional<bake::InvalidInput> check_atlas_options(const AtlasOptions& o) {
  if (auto e = bake::check_range("texel_density", o.texel_density, bounds::kTexelDensity)) return e;
  if (auto e = bake::check_range("page_size", o.page_size, bounds::kAtlasPageSize.real())) return e;
  if (auto e = bake::check_range("padding", o.padding, bounds::kLightmapPadding.real())) return e;
  if (auto e = bake::check_range("max_pages", o.max_pages, bounds::kAtlasMaxPages.real())) return e;
  for (const auto& [i, io] : o.instances) {
    if (io.texel_density == 0) continue;
    const std::string field = "instances[" + std::to_string(i) + "].texel_density";
    if (auto e = bake::check_range(field, io.texel_density, bounds::kTexelDensity)) return e;
  }
  return std::nullopt;
}

std::string atlas_page_name(int page) { return "page" + std::to_string(page); }

double page_texels(const AtlasPack& pack) {
  double texels = 0;
  for (const AtlasPage& p : pack.pages) texels += static_cast<double>(p.size) * static_cast<double>(p.size);
  return texels;
}

double chart_area_fraction(const AtlasPack& pack) {
  double charts = 0;
  for (const AtlasPage& p : pack.pages) charts += p.chart_texels;
  const double texels = page_texels(pack);
  return texels > 0 ? charts / texels : 0.0;
}

AtlasPack pack_atlas(const scene::CheckedScene& checked, const AtlasOptions& o, const bake::StopCheck& stop) {
  if (auto e = check_atlas_options(o)) throw *e;
  const auto t0 = std::chrono::steady_clock::now();
  const scene::Scene& sc = checked.scene;
  AtlasPack pack;
  pack.padding = std::max(kMinPadding, o.padding);
  // Per mesh once: instances share their mesh's UV rectangle and area.
  std::vector<MeshChart> mesh_charts(sc.meshes.size());
  for (size_t m = 0; m < sc.meshes.size(); ++m) {
    if (m < checked.triangles.size()) mesh_charts[m] = mesh_chart(sc.meshes[m], checked.triangles[m]);
  }
  std::vector<Chart> charts;
  for (size_t i = 0; i < sc.instances.size(); ++i) {
    if (i % 1024 == 0) stop.check();
    const scene::Instance& inst = sc.instances[i];
    if (!inst.bake) continue;
    AtlasRegion& r = pack.regions.emplace_back();
    r.instance = static_cast<uint32_t>(i);
    r.source_instance = i < checked.source_instance.size() ? checked.source_instance[i] : static_cast<uint32_t>(i);
    const auto opt = o.instances.find(r.source_instance);
    const AtlasInstanceOptions io = opt == o.instances.end() ? AtlasInstanceOptions{} : opt->second;
    r.density_asked = io.texel_density > 0 ? io.texel_density : o.texel_density;
    if (inst.mesh < 0 || static_cast<size_t>(inst.mesh) >= sc.meshes.size() ||
        static_cast<size_t>(inst.mesh) >= checked.triangles.size()) {
      r.note = "its mesh does not exist: not baked";
      continue;
    }
    const MeshChart& mc = mesh_charts[inst.mesh];
    r.uv_area = mc.uv_area;
    r.world_area = world_area(sc.meshes[inst.mesh], checked.triangles[inst.mesh], inst.to_world);
    if (!mc.any) {
      r.note = "its mesh has no triangle to bake (no lightmap UVs, or every triangle dropped): not baked";
      continue;
    }
    if (!(mc.uv_area > 0) || !(r.world_area > 0) || !std::isfinite(r.world_area) || !(mc.u1 > mc.u0) ||
        !(mc.v1 > mc.v0)) {
      r.note = "zero or non-finite area (world " + bake::format_number(r.world_area) + " m^2, lightmap UV " +
               bake::format_number(mc.uv_area) + "): nothing to give texels to, not baked";
      continue;
    }
    Chart c;
    c.region = static_cast<uint32_t>(pack.regions.size() - 1);
    c.u0 = mc.u0, c.v0 = mc.v0, c.du = mc.u1 - mc.u0, c.dv = mc.v1 - mc.v0;
    c.k_asked = r.density_asked * std::sqrt(r.world_area / mc.uv_area);
    c.own_page = io.own_page;
    if (!std::isfinite(c.k_asked)) {
      r.note = "its density does not fit a double (world area " + bake::format_number(r.world_area) + ", UV area " +
               bake::format_number(mc.uv_area) + "): not baked";
      continue;
    }
    charts.push_back(c);
  }

  std::vector<Placement> placed;
  int pages = 0;
  if (!place_all(charts, 1.0, o, pack.padding, placed, pages, stop)) {
    std::vector<Placement> at_least;
    if (!place_all(charts, 0.0, o, pack.padding, at_least, pages, stop)) {
      throw bake::InvalidInput(
          "max_pages", std::to_string(charts.size()) + " instances do not fit in " + std::to_string(o.max_pages) +
                           " pages of " + std::to_string(o.page_size) + "^2 texels even at one texel each with " +
                           std::to_string(pack.padding) +
                           " texels of padding; raise max_pages or page_size, or bake the scene in several jobs");
    }
    double lo = 0, hi = 1;
    std::vector<Placement> trial;
    placed = at_least;
    for (int step = 0; step < kFitSteps; ++step) {
      const double mid = 0.5 * (lo + hi);
      if (place_all(charts, mid, o, pack.padding, trial, pages, stop)) {
        lo = mid;
        placed = trial;
      } else {
        hi = mid;
      }
    }
    pack.density_scale = lo;
  }

  int page_count = 0;
  for (const Placement& p : placed) page_count = std::max(page_count, p.page + 1);
  for (int p = 0; p < page_count; ++p) pack.pages.push_back({atlas_page_name(p), o.page_size, {}, 0, false});
  if (!o.uniform_pages) shrink_pages(placed, charts, pack.padding, pack.pages);
  const int margin = pack.padding / 2;
  for (size_t i = 0; i < charts.size(); ++i) {
    const Chart& c = charts[i];
    const Placement& p = placed[i];
    AtlasRegion& r = pack.regions[c.region];
    r.page = p.page;
    r.x = p.x + margin;
    r.y = p.y + margin;
    r.width = p.size.w;
    r.height = p.size.h;
    const double k = p.size.k;
    const double page = pack.pages[p.page].size;
    r.scale_offset = {k / page, k / page, (r.x - k * c.u0) / page, (r.y - k * c.v0) / page};
    r.density = k * std::sqrt(r.uv_area / r.world_area);
    r.chart_texels = r.uv_area * k * k;
    const double asked = r.density_asked * pack.density_scale;
    if (r.density < asked * (1 - 1e-9)) {
      r.note = "density reduced to " + bake::format_number(r.density) + " texels/m: its chart (" +
               std::to_string(r.width) + " x " + std::to_string(r.height) + " texels) fills a page";
    } else if (r.density > asked * (1 + 1e-9)) {
      r.note = "density raised to " + bake::format_number(r.density) + " texels/m: one texel at least";
    }
    AtlasPage& pg = pack.pages[p.page];
    pg.regions.push_back(c.region);
    pg.chart_texels += r.chart_texels;
    pg.own_page = c.own_page;
  }
  pack.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return pack;
}

void apply_atlas(const AtlasPack& pack, scene::Scene& scene) {
  for (const AtlasRegion& r : pack.regions) {
    if (r.instance >= scene.instances.size()) continue;
    scene::Instance& inst = scene.instances[r.instance];
    if (r.page < 0) {
      inst.bake = false;
      continue;
    }
    inst.lightmap = pack.pages[r.page].name;
    inst.lightmap_scale_offset = r.scale_offset;
  }
}

scene::CheckedScene check_and_pack_scene(scene::Scene scene, const AtlasOptions& options, const bake::StopCheck& stop,
                                         AtlasPack& pack) {
  // One safe placeholder name for every instance: the check then has no lightmap to rename (the packer names the
  // pages), and no placement to refuse.
  for (scene::Instance& inst : scene.instances) {
    inst.lightmap = "page";
    inst.lightmap_scale_offset = {1, 1, 0, 0};
  }
  scene::CheckOptions check;
  check.overlaps = false;
  scene::CheckedScene checked = scene::check_scene(scene, check);
  stop.check();
  pack = pack_atlas(checked, options, stop);
  apply_atlas(pack, checked.scene);
  scene::check_overlaps(checked);
  return checked;
}

}  // namespace kiln::lightmap
