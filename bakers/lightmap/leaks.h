// Leaks: a texel's sample point that lies inside or behind geometry (a floor texel under a wall, a point of a mesh
// where another mesh intersects it) gathers light from where it cannot be, so light and shadow leak through walls
// and into corners. Following Bakery, such points are found by the back faces their rays see, then pushed out to
// the front side of the nearest one, or dropped.
//
// ## The rule (per sample point p, geometric normal n, texel world size s)
// Probe: shoot rings × sectors rays stratified over the hemisphere above n (cell centres of uniform-in-cos θ rings and
// azimuth sectors, alternate rings turned by half a sector), from p + ε n, of length probe_distance_texels · s (∞ by
// default: a point deep inside a thick wall sees nothing within a few texels, but it sees only back faces farther
// on). The back-face fraction is the share of the rays whose first hit is a back face. (Only the hemisphere above n:
// rays below go through the point's own surface, and a closed mesh's far side seen from inside is a back face that
// says nothing about the point.)
//   - fraction ≤ max_backface_fraction: the point is clear and stays.
//   - else it is inside: the back faces hit within move_distance_texels · s, nearest first (at most
//     max_move_attempts of them), are candidates: the point just in front of that face, hit + push_texels · s · n_f
//     (n_f the face's front normal, on the side the ray came out). The first candidate whose own probe is clear is
//     the new position (moved); if none is, the sample is invalid, and a texel left without samples is invalid.
// The origin p + ε n is lifted by ε = max(the sample's ray_offset, origin_offset_texels · s) and rounded to float
// without giving any of it back (scene::offset_ray_origin): the first bounds the float tracer's error at this triangle,
// the second keeps a margin of a texel's fraction; both scale with the scene. Unity's progressive lightmapper applies
// the same test (its "backface tolerance", default 90 % front faces) to all of a texel's rays; max_backface_fraction =
// 0.1 matches it.
//
// The moved point keeps its normals, barycentrics and weight: it still stands for the same part of the texel.
//
// ## Ending a probe early (the same verdicts and candidates, fewer rays)
// A probe's verdict is decided once so many back faces are seen that it cannot be clear (4 of the 32 default rays),
// or so few rays are left that it cannot stop being clear (3 left without a back face seen). A candidate's probe, or
// a clear one, then stops. An inside point's own probe goes on, since its candidates are the nearest back faces over
// all its rays, but each ray left needs to reach only as far as a back face that would still be one of them: the
// move distance, or the farthest of max_move_attempts candidates once that many are held. Most probed points of a
// level are inside (props sunk into terrain), and short rays are cheap. backface_fraction is over the rays traced
// while the verdict was open.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "bakers/bake/stop.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/vec3.h"

namespace kiln::lightmap {

struct HitInfo {
  double t = 0;            // distance along the unit direction
  bool front_face = true;  // the ray met the side the front normal points to; two-sided surfaces: always true
  Vec3 geometric_normal;   // unit, the front side's normal of the surface hit (whichever side the ray met); only
                           // back-face hits need it (front-face hits may leave it zero)
};

// The one thing leak handling needs from a ray tracer (the Embree tracer adapts to it).
class RayQuery {
 public:
  virtual ~RayQuery() = default;
  // The nearest surface at origin + t·dir for t in (0, tmax] (tmax may be +∞), dir a unit vector; nullopt if none.
  // Called from several threads at once.
  virtual std::optional<HitInfo> intersect(const Vec3& origin, const Vec3& dir, double tmax) const = 0;
};

struct LeakOptions {
  int rings = 4;                       // polar strata; rings × sectors rays per probe, [1, 64] each
  int sectors = 8;                     // azimuthal strata
  double max_backface_fraction = 0.1;  // [0, 1)
  double probe_distance_texels = std::numeric_limits<double>::infinity();  // > 0
  double move_distance_texels = 2.0;                                       // ≥ 0; 0 never moves, only invalidates
  double push_texels = 0.01;                                               // > 0
  double origin_offset_texels = 1e-4;                                      // ≥ 0
  int max_move_attempts = 4;                                               // ≥ 0
  // false traces every ray of every probe in full: the rule as written, a baseline for benchmarks (same verdicts).
  bool end_probes_early = true;
};

enum class LeakVerdict : uint8_t { clear, moved, invalid };

struct LeakResult {
  LeakVerdict verdict = LeakVerdict::clear;
  Vec3 position;                 // where the sample is now (unchanged when clear; meaningless when invalid)
  double backface_fraction = 0;  // of the probe at the original position, over its rays before the verdict
  uint32_t rays = 0;             // traced for this sample (probes of the candidates included)
};

// The rule above for one sample. Throws std::invalid_argument for options out of range (naming the field).
LeakResult resolve_leak(const TexelSample& sample, const RayQuery& rays, const LeakOptions& options);

struct LeakReport {
  size_t samples = 0;  // checked
  size_t pruned = 0;   // of them, clear without a probe: nothing near could hide them (leak_scope.h)
  size_t moved = 0;
  size_t invalidated = 0;         // samples dropped
  size_t texels_invalidated = 0;  // valid texels left without samples
  uint64_t rays = 0;              // traced
};

// Applies resolve_leak to every sample (in parallel), moves the moved ones and drops the invalid ones
// (LightmapTexels::retain). `probe`, if given, has one entry per sample: samples with 0 are clear without a probe
// (LeakScope::probe_mask says which cannot leak). Deterministic. Polls `stop` every few hundred samples and throws
// what its check() throws (the texels are then left as they were).
LeakReport fix_leaks(LightmapTexels& texels, const RayQuery& rays, const LeakOptions& options,
                     const bake::StopCheck& stop = {}, const std::vector<uint8_t>* probe = nullptr);

}  // namespace kiln::lightmap
