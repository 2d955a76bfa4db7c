#include "bakers/uvgen/chart_pack.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>

#include "bakers/math/skyline.h"

namespace kiln::uvgen {
namespace {

constexpr int kMinPadding = 2;
// The bisection over the density stops at 2⁻²⁰ of it, far below a texel's rounding.
constexpr int kFitSteps = 20;
// A chart's sides are at least this many surface units (a chart of one sliver triangle still has a width).
constexpr double kMinSide = 1e-12;

double cross(const Point2& o, const Point2& a, const Point2& b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Andrew's monotone chain.
std::vector<Point2> convex_hull(std::vector<Point2> pts) {
  std::sort(pts.begin(), pts.end(),
            [](const Point2& a, const Point2& b) { return std::tie(a.x, a.y) < std::tie(b.x, b.y); });
  if (pts.size() < 3) return pts;
  std::vector<Point2> hull(2 * pts.size());
  size_t k = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0) --k;
    hull[k++] = pts[i];
  }
  for (size_t i = pts.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i - 1]) <= 0) --k;
    hull[k++] = pts[i - 1];
  }
  hull.resize(k - 1);
  return hull;
}

// Rotates the chart to its smallest bounding rectangle, longer side along u, its corner at (0, 0); returns the size.
Point2 orient(FlatChart& chart) {
  std::vector<Point2> pts;
  for (const auto& q : chart.uv) pts.insert(pts.end(), q.begin(), q.end());
  const std::vector<Point2> hull = convex_hull(pts);
  double best_area = INFINITY, best_c = 1, best_s = 0;
  for (size_t i = 0; i < hull.size(); ++i) {
    const Point2 &a = hull[i], &b = hull[(i + 1) % hull.size()];
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    if (!(len > 0)) continue;
    const double c = (b.x - a.x) / len, s = (b.y - a.y) / len;
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (const Point2& p : hull) {
      const double x = c * p.x + s * p.y, y = -s * p.x + c * p.y;
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
    if ((x1 - x0) * (y1 - y0) < best_area) best_area = (x1 - x0) * (y1 - y0), best_c = c, best_s = s;
  }
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (auto& q : chart.uv) {
    for (Point2& p : q) {
      p = {best_c * p.x + best_s * p.y, -best_s * p.x + best_c * p.y};
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
  }
  const bool turn = (y1 - y0) > (x1 - x0);  // a quarter turn (counter-clockwise stays counter-clockwise)
  for (auto& q : chart.uv) {
    for (Point2& p : q) p = turn ? Point2{y1 - p.y, p.x - x0} : Point2{p.x - x0, p.y - y0};
  }
  const double w = turn ? y1 - y0 : x1 - x0, h = turn ? x1 - x0 : y1 - y0;
  return {std::max(w, kMinSide), std::max(h, kMinSide)};
}

struct Place {
  int x = 0, y = 0, w = 1, h = 1;  // the chart's texels (padding not included)
};

// Places every chart at density s in a square of `size`; false when one does not fit.
bool place_all(const std::vector<Point2>& sides, double s, int size, int padding, std::vector<Place>& out,
               const bake::StopCheck& stop) {
  out.assign(sides.size(), {});
  for (size_t i = 0; i < sides.size(); ++i) {
    out[i].w = std::max(1, static_cast<int>(std::ceil(s * sides[i].x)));
    out[i].h = std::max(1, static_cast<int>(std::ceil(s * sides[i].y)));
    if (out[i].w + padding > size || out[i].h + padding > size) return false;
  }
  std::vector<size_t> order(sides.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return std::make_tuple(-out[a].h, -out[a].w, a) < std::make_tuple(-out[b].h, -out[b].w, b);
  });
  Skyline sky(size);
  const int margin = padding / 2;
  for (size_t n = 0; n < order.size(); ++n) {
    if (n % 1024 == 0) stop.check();
    Place& p = out[order[n]];
    int x = 0, y = 0;
    if (!sky.find(p.w + padding, p.h + padding, x, y)) return false;
    sky.place(x, y, p.w + padding, p.h + padding);
    p.x = x + margin;
    p.y = y + margin;
  }
  return true;
}

// The smallest square (from the charts' area, grown 1/32 at a time) that holds the charts at density s.
int fit_size(const std::vector<Point2>& sides, double s, int padding, std::vector<Place>& out,
             const bake::StopCheck& stop) {
  double area = 0;
  for (const Point2& d : sides) area += (std::ceil(s * d.x) + padding) * (std::ceil(s * d.y) + padding);
  int size = std::max(padding + 1, static_cast<int>(std::ceil(std::sqrt(area))));
  while (!place_all(sides, s, size, padding, out, stop)) size += std::max(1, size / 32);
  return size;
}

}  // namespace

PackedCharts pack_charts(std::vector<FlatChart>& charts, const PackOptions& options, const bake::StopCheck& stop) {
  PackedCharts packed;
  packed.padding = std::max(kMinPadding, options.padding);
  if (charts.empty()) return packed;
  std::vector<Point2> sides;
  for (FlatChart& c : charts) sides.push_back(orient(c));
  std::vector<Place> places;
  if (options.texels_per_unit > 0) {
    packed.texels_per_unit = options.texels_per_unit;
    packed.size = fit_size(sides, packed.texels_per_unit, packed.padding, places, stop);
  } else {
    packed.size = std::max(options.size, packed.padding + 1);
    double area = 0, longest = 0;
    for (const Point2& d : sides) area += d.x * d.y, longest = std::max(longest, d.x);
    // Above hi the charts' own area (or the longest chart) exceeds the square; at lo each is one texel.
    double hi = std::min(packed.size / std::sqrt(area), (packed.size - packed.padding) / longest);
    double lo = 0;
    if (place_all(sides, hi, packed.size, packed.padding, places, stop)) {
      lo = hi;
    } else if (!place_all(sides, 0, packed.size, packed.padding, places, stop)) {
      packed.size = fit_size(sides, 0, packed.padding, places, stop);
    } else {
      for (int i = 0; i < kFitSteps; ++i) {
        const double mid = 0.5 * (lo + hi);
        (place_all(sides, mid, packed.size, packed.padding, places, stop) ? lo : hi) = mid;
      }
    }
    packed.texels_per_unit = lo;
    place_all(sides, lo, packed.size, packed.padding, places, stop);
  }
  // At density 0 (charts of one texel) the chart is squeezed into its texel.
  const double inv = 1.0 / packed.size;
  for (size_t i = 0; i < charts.size(); ++i) {
    const Place& p = places[i];
    const double sx = packed.texels_per_unit > 0 ? packed.texels_per_unit : p.w / sides[i].x;
    const double sy = packed.texels_per_unit > 0 ? packed.texels_per_unit : p.h / sides[i].y;
    for (auto& q : charts[i].uv)
      for (Point2& pt : q)
        pt = {(p.x + std::min(pt.x * sx, double(p.w))) * inv, (p.y + std::min(pt.y * sy, double(p.h))) * inv};
  }
  return packed;
}

}  // namespace kiln::uvgen
