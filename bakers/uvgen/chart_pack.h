// Packing a mesh's flattened charts (chart_flatten.h) into its lightmap-UV square, at a texel density, with padding
// in texels between charts, by the atlas packer's skyline (bakers/math/skyline.h, as bakers/lightmap/atlas_pack.h
// packs instances into pages).
//
// Each chart is first rotated to its smallest bounding rectangle (over the directions of its convex hull's edges),
// longer side along u; a rotation keeps it counter-clockwise. At s texels per surface unit a chart of w × h units
// takes ⌈s·w⌉ × ⌈s·h⌉ texels; with the padding, ⌈s·w⌉ + p × ⌈s·h⌉ + p, placed by the skyline (tallest first, then
// widest, then by chart index) with the chart ⌊p/2⌋ texels into its place. Two charts are then at least p texels
// apart, and the same rule as the atlas's holds: every texel of the gap is nearer one chart, so dilation fills it
// from that one and a bilinear lookup at a chart's border reads that chart's texels only (p ≥ 2).
//
// Two ways to size the square:
//   - texels_per_unit > 0: the charts at that density, in the smallest square (grown 1/32 at a time) that holds them;
//     what an atlas-packed bake asks (its texel density times the instance's scale);
//   - otherwise `size`: the largest density (by bisection) at which the charts fit a square of `size` texels; what a
//     bake into a lightmap of fixed resolution asks. When even one texel per chart does not fit, the square grows.
// The UVs are then divided by the square's side: every chart lies in [0, 1]², on whole texels of that square.
#pragma once

#include <vector>

#include "bakers/bake/stop.h"
#include "bakers/uvgen/chart_flatten.h"

namespace kiln::uvgen {

struct PackOptions {
  double texels_per_unit = 0;
  int size = 256;
  int padding = 4;  // at least 2 are used
};

struct PackedCharts {
  int size = 0;                // texels on a side of the square
  double texels_per_unit = 0;  // the density the charts were placed at
  int padding = 0;             // as used
};

// Rewrites the charts' UVs in place. Deterministic.
PackedCharts pack_charts(std::vector<FlatChart>& charts, const PackOptions& options, const bake::StopCheck& stop = {});

}  // namespace kiln::uvgen
