// Seams: one 3D edge on two chart borders of a lightmap (a cube unwrapped into six charts has twelve). A bilinear
// lookup on either side reads different texels, so the two sides show different values along the edge and a line
// appears. find_seams finds them; SeamStitcher adjusts the texels the lookups read, after the image is baked and
// dilated, so that the lookups on both sides agree — the least-squares seam fixing of "seamless" lightmaps (Castaño's
// stitching for The Witness, Bakery's seam fixer).
//
// ## The least-squares problem
// Along each seam, at points p_k (parameter t_k along the edge, spaced at most half a texel on either side), the
// bilinear lookup on side A, Σ α_ki x_i, should equal that on side B, Σ β_kj x_j; every texel should stay near its
// baked value x⁰_i. Per channel, the change d = x − x⁰ minimises
//
//     Σ_k w_seam (r_k · (x⁰ + d))² + Σ_i c_i d_i²,      r_k = α_k − β_k (the lookups' weights, A minus B),
//
// with c_i = valid_weight for a texel with samples and dilated_weight for one without (a dilated or padding texel
// holds a copy of its neighbours, not a measurement, so it gives way first). The normal equations
//
//     (Σ_k w_seam r_k r_kᵀ + C) d = −Σ_k w_seam r_k (r_k · x⁰)
//
// are sparse, symmetric and positive definite (C > 0), over the texels some lookup reads and nothing else. They fall
// apart into independent components (charts that share no seam: one instance's charts at most), each a few hundred
// to a few thousand unknowns strung along its seams. Each component is solved directly, in double, by its Cholesky
// factor (bakers/math/envelope_cholesky.h), computed once per lightmap (by the first image that needs a change) and
// used for every channel of every image. The weights span 10⁵ (a seam against a dilated texel), which leaves a
// Jacobi-preconditioned conjugate gradient thousands of iterations short of a tight residual; CG remains the fallback
// for a component whose factor would exceed its budget, to a relative residual of `tolerance` within `max_iterations`.
// Texels no lookup reads are not unknowns: they keep their exact bytes.
//
// A channel with no negative value (irradiance, radiance, AO) also needs x ≥ 0. Where a seam's sides see very
// different light the fit takes a texel the lookup weighs least below 0; such values are held at 0 and the
// component solved again without them (an active set that only grows; SeamStitcher::solve_component).
//
// ## Lookups
// A bilinear lookup at texel-space point (s, t) (texels.h: (u·W, v·H)) reads the four texels around (s − ½, t − ½),
// clamped to the image's edge, as a GPU does with clamp-to-edge addressing.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bakers/image/exr.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/envelope_cholesky.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/scene.h"
#include "bakers/scene/scene_check.h"

namespace kiln::lightmap {

// One seam: the same world edge on two triangles whose lightmap UVs differ. Ends in texel space (instance scale and
// offset applied); a0 and b0 are the same world point, and so are a1 and b1.
struct Seam {
  Point2 a0, a1, b0, b1;
  TriangleRef a, b;
};

// UV ends closer than this (texels) are the same: the lookups on both sides then read the same texels.
inline constexpr double kSeamUvTolerance = 1e-4;
// Relative weld tolerance: world positions within kWeldTolerance · L (Chebyshev) are one point, where L is the
// larger of the lightmap's bounding-box extent and its largest absolute coordinate.
inline constexpr double kWeldTolerance = 1e-6;

struct SeamSearch {
  std::vector<Seam> seams;     // in scene order (by the first side's instance, triangle and edge)
  size_t edges = 0;            // distinct welded world edges of the lightmap's usable triangles
  size_t shared_edges = 0;     // of those, on exactly two triangles
  size_t non_manifold = 0;     // on more than two (each pair of them with different UVs is a seam, up to 4 sides)
  size_t degenerate = 0;       // seams left out: an end pair less than kSeamUvTolerance apart on a side
  size_t outside = 0;          // seams left out: an end outside the lightmap (UV outside [0, 1])
  size_t skipped_triangles = 0;  // triangles left out: no lightmap UVs, an index out of range, a non-finite value
};

// The seams of the lightmap `name` (scene::resolved_lightmap_name) at width × height texels: edges shared in world
// space by triangles of the baking instances (to_world applied, welded within kWeldTolerance) whose two sides'
// lightmap UVs (lightmap_scale_offset applied) differ by more than kSeamUvTolerance texels. Two instances sharing the
// lightmap meet at a seam only where they share the world edge. `bake_mask` as in RasterOptions. Deterministic;
// never throws for bad geometry (it is counted), only std::invalid_argument for a size below 1.
SeamSearch find_seams(const scene::Scene& scene, const std::string& name, int width, int height,
                      const std::vector<std::vector<uint8_t>>* bake_mask = nullptr);

// The same for the scene as the bake has it: the cleaned scene, and its triangles marked "traced, not baked" left out.
SeamSearch find_seams(const scene::CheckedScene& checked, const std::string& name, int width, int height);

// The most sides a world edge may have for its pairs to be seams; an edge on more is counted (non_manifold) and left
// out.
inline constexpr size_t kMostSidesOfASeamEdge = 4;

// The most bytes find_seams holds at once, the seams it returns included, for a lightmap of `triangles` triangles,
// whatever their geometry: every corner a point of its own in world space, every edge on four sides with six seams
// among them (seam_search_bytes_per_triangle a triangle, 636).
size_t seam_search_bytes_bound(uint64_t triangles);
double seam_search_bytes_per_triangle();
// The most seams find_seams finds per triangle: three sides a triangle, six seams among an edge's four sides.
inline constexpr double kMostSeamsPerTriangle = 3.0 * 6 / kMostSidesOfASeamEdge;

// The most a lookup point holds: its pair (8 bytes) and eight taps (four a side, 8 bytes each).
inline constexpr size_t kLookupPointBytes = 72;

struct StitchOptions {
  double seam_weight = 1000;    // w_seam, per lookup pair
  double valid_weight = 1;      // c_i of a texel with samples
  double dilated_weight = 0.01;  // c_i of a texel without (dilated or empty)
  // The most values a component's Cholesky factor may hold, per entry of its matrix; a component beyond it (or a
  // budget of 0) is solved by conjugate gradients. The level's components need 1.6 on average, 4.8 at most.
  double factor_budget = 8;
  // The most bytes a lightmap's factors, with what factoring them holds (a component's matrix and working space),
  // may hold, per texel of the lightmap: components are factored in order while they fit, the rest solved by
  // conjugate gradients, which keep no matrix. Refactors (values held at 0) run together while they fit it too. The
  // level's 2048² pages need 35 to 71 for their factors, its 696² page of small charts 80 and its factoring a little
  // more: all are factored within 96; past it CG takes several times as long.
  double factor_bytes_per_texel = 96;
  size_t min_factor_bytes = size_t{1} << 20;  // whatever the lightmap's size: a small one's factors are small anyway
  // The most bytes a lightmap's lookups may hold, per texel of it, counted at the most a lookup point can take (its
  // pair and eight taps, kLookupPointBytes): seams past it, in order, are not stitched (seams_over_budget). The
  // level's 2048² pages need 7 to 18, its 696² page of small charts 24; many tiny charts need most (at least two
  // points a seam).
  double lookup_bytes_per_texel = 48;
  size_t min_lookup_bytes = size_t{1} << 20;  // 14,563 lookup points
  int max_iterations = 2000;    // of conjugate gradients, per channel
  double tolerance = 1e-10;     // relative residual ‖b − A d‖ / ‖b‖ at which CG stops
};

// What one stitch did. Mismatches are |lookup A − lookup B|, the largest over channels, over the lightmap's
// brightness (the mean luminance of its valid texels, or of the one channel; 1 for a black lightmap): the relative
// units of the error image under the lightmap metric.
struct StitchStats {
  size_t unknowns = 0;          // texels some lookup reads
  size_t samples = 0;           // lookup pairs
  size_t texels_changed = 0;    // whose bytes changed
  double mismatch_before = 0;   // largest
  double mismatch_after = 0;
  double rms_before = 0;        // over the lookup pairs and channels
  double rms_after = 0;
  size_t components = 0;        // independent systems
  size_t factored = 0;          // of those, solved by their Cholesky factor; the others by CG
  int iterations = 0;           // the most CG iterations any channel took
  bool converged = true;        // every channel solved by CG reached the tolerance
  size_t channels_skipped = 0;  // channels left alone: a value the lookups read was not finite
  size_t held_at_zero = 0;      // texel values the fit would have taken below 0, held at 0 (over channels)
  double seconds = 0;
};

// The seams' lookup pairs and normal equations for one lightmap, built once and applied to each of its images (they
// share the texels and validity).
class SeamStitcher {
 public:
  // `validity`: width·height bytes (non-zero: valid), the map the images were dilated from. Seams with a NaN or
  // infinite end, an end outside [0, W] × [0, H], or no length on either side give no lookups. Throws
  // std::invalid_argument when the sizes disagree, the weights are not positive and finite, or factor_budget is
  // negative or not finite.
  SeamStitcher(const std::vector<Seam>& seams, int width, int height, const std::vector<uint8_t>& validity,
               const StitchOptions& options = {});

  // Stitches every channel of `image` (width × height, any channel count) in place. The first image with lookups
  // that disagree builds the normal equations and factors them, for this and every later image; images whose
  // lookups all agree (all black, as every image of a page a time limit left unsampled) never build them.
  StitchStats stitch(image::FloatImage& image);
  // The mismatches of `image` without changing it (mismatch_before and rms_before are filled).
  StitchStats measure(const image::FloatImage& image) const;

  size_t unknowns() const { return texels_.size(); }
  size_t components() const { return component_start_.size() - 1; }  // independent systems among the unknowns
  size_t samples() const { return pairs_.size(); }
  size_t seams_used() const { return seams_used_; }
  size_t seams_over_budget() const { return seams_over_budget_; }  // left out: their lookups would pass the budget
  size_t factored_components() const;  // 0 until a stitch builds the system
  size_t factor_bytes() const;         // held by the factors kept: at most max(min_factor_bytes, per texel × texels)
  // The most bytes the stitcher has held at once so far: its lookups, matrix and factors, and the transients of
  // building them and of a stitch.
  size_t peak_bytes() const { return peak_bytes_; }
  // The most peak_bytes() can reach for a lightmap of `texels` texels stitching images of at most `channels`
  // channels, whatever its seams (`seams` of them, held by the caller while the constructor reads them): every texel
  // an unknown, the lookups and factors at their caps.
  static size_t bytes_bound(uint64_t texels, int channels, uint64_t seams, const StitchOptions& options = {});

 private:
  struct Tap {
    uint32_t unknown;  // into texels_
    float weight;      // + on side A, − on side B: a bilinear weight, which float holds to 6·10⁻⁸
  };
  struct Pair {
    uint32_t first, count;  // taps_[first, first + count)
  };
  int width_ = 0, height_ = 0;
  std::vector<uint8_t> validity_;
  StitchOptions options_;
  size_t seams_used_ = 0, seams_over_budget_ = 0;
  std::vector<uint32_t> texels_;           // unknown → texel index, components contiguous (group_by_component)
  std::vector<uint32_t> component_start_;  // component k is the unknowns [start[k], start[k + 1])
  std::vector<Tap> taps_;
  std::vector<Pair> pairs_;
  std::vector<uint32_t> component_pairs_;  // component k's pairs are pairs_[component_pairs_[k], [k + 1])
  // A component's normal matrix in compressed rows, numbered within the component (row i is unknown lo + i).
  struct Block {
    std::vector<uint32_t> row_start, col;
    std::vector<double> value, diagonal;
    size_t bytes() const;
  };
  // Each unknown's taps in one component, in pair order: tap[begin[u] .. begin[u + 1]), each with its pair.
  struct TapIndex {
    std::vector<uint32_t> begin, tap, pair;
  };
  // Per component, its factor, or none for one solved by CG (from the lookups: no matrix is kept): built by the
  // first stitch with something to solve (build_system).
  bool system_built_ = false;
  std::vector<std::unique_ptr<EnvelopeCholesky>> factors_;
  size_t peak_bytes_ = 0;

  // What solving one component of one channel took.
  struct ComponentSolve {
    int iterations = 0;       // CG's, the most of any solve (0: factored)
    bool converged = true;    // every CG solve reached the tolerance
    size_t held_at_zero = 0;  // unknowns the fit would have taken below 0 (solve_component)
    size_t bytes = 0;         // the most it held beside the stitch's vectors, but for a refactor
    size_t refactor_bytes = 0;  // the most a refactor held: a matrix and a factor (RefactorGate)
  };
  // The solves of one channel on `threads` threads, summed (stitch).
  struct SolveSummary {
    explicit SolveSummary(size_t threads);
    void add(const ComponentSolve& one);
    void merge(const SolveSummary& other);
    // The `threads` largest solves' bytes, and the largest refactors' up to what the gate lets run together.
    size_t bytes_at_once(size_t refactor_capacity) const;

    int iterations = 0;
    bool converged = true;
    size_t held_at_zero = 0;
    std::vector<size_t> largest, largest_refactors;  // one per thread, largest first

   private:
    static void keep(std::vector<size_t>& list, size_t bytes);
  };

  size_t held_bytes() const;
  // Raises the peak to what is held now and `transient` bytes more.
  void note_peak(size_t transient) { peak_bytes_ = std::max(peak_bytes_, held_bytes() + transient); }
  void group_by_component();
  TapIndex index_taps(size_t k) const;
  size_t taps_of(size_t k) const;
  size_t count_entries(size_t k, const TapIndex& index) const;
  static size_t factoring_bytes(size_t n, size_t taps, size_t entries);
  Block build_block(size_t k, const TapIndex& index, size_t entries) const;
  // Factors each component within its budget, in order while the factors and the factoring fit max_factor_bytes();
  // `beside`: the bytes the caller holds meanwhile.
  void build_system(size_t beside);
  size_t max_factor_bytes() const;
  bool factored(size_t k) const { return k < factors_.size() && factors_[k] != nullptr; }
  // c_i of unknown u: how firmly its texel keeps its baked value.
  double texel_weight(uint32_t u) const {
    return validity_[texels_[u]] ? options_.valid_weight : options_.dilated_weight;
  }
  // Component k's change d[lo, hi) for the right-hand side b[lo, hi) of one channel whose baked values are x0.
  // Refactoring a component with values held at 0 passes `gate` (seams.cpp), which bounds the refactors at once.
  class RefactorGate;
  size_t refactor_reservation(size_t k) const;
  ComponentSolve solve_component(size_t k, const std::vector<double>& x0, bool non_negative,
                                 const std::vector<double>& b, std::vector<double>& d, RefactorGate& gate) const;
  // q = A p over component k's unknowns (p[0] is unknown lo), summed from its lookup pairs: A's rows and columns of
  // `held` unknowns (when given) left out, their q set to 0.
  void multiply(size_t k, const uint8_t* held, const double* p, double* q) const;
  // Conjugate gradients on component k for the right-hand side b into d (both from unknown lo), over the unknowns not
  // `held`; d of held unknowns is left as it is.
  int conjugate_gradients(size_t k, const double* b, const uint8_t* held, double* d, bool& converged) const;
  // The largest and RMS |lookup A − lookup B| over `scale`, over the lookup pairs and channels.
  void mismatch(const image::FloatImage& image, double scale, double& largest, double& rms) const;
};

// One lightmap's seams in report.json: what was found, and what stitching did to NAME_irradiance.exr.
struct SeamReport {
  size_t seams = 0;           // seam edges stitched
  size_t non_manifold = 0;    // world edges on more than two triangles
  size_t left_out = 0;        // seams not stitched: no length in UV on a side, or an end outside the lightmap
  size_t over_budget = 0;     // seams not stitched: their lookups would pass lookup_bytes_per_texel
  size_t samples = 0;         // lookup pairs along them
  size_t components = 0;      // independent systems the texels along seams form
  size_t factored = 0;        // of those, solved directly; the others by CG (0: no image needed a change)
  size_t peak_bytes = 0;      // the most the stitcher held at once (SeamStitcher::peak_bytes)
  size_t texels_changed = 0;  // of NAME_irradiance.exr
  size_t held_at_zero = 0;    // of its texel values (over channels), which the fit would have taken below 0
  double mismatch_before = 0, mismatch_after = 0;  // largest, relative (StitchStats)
  double rms_before = 0, rms_after = 0;
  int iterations = 0;
  bool converged = true;
  double seconds = 0;  // finding the seams, building the system and stitching every image of the lightmap
};

// The seams of one lightmap of a bake, found once, stitching each of its images (irradiance, denoised, radiance, AO,
// preview) through finish() after their dilation.
class LightmapSeams {
 public:
  LightmapSeams(const scene::CheckedScene& checked, const std::string& name, int width, int height,
                const std::vector<uint8_t>& validity, const StitchOptions& options = {});
  // Stitches an image in place; `irradiance` says it is NAME_irradiance.exr, whose figures go in the report.
  void stitch(image::FloatImage& image, bool irradiance);
  ImageFinish finish(bool irradiance) {
    return [this, irradiance](image::FloatImage& image) { stitch(image, irradiance); };
  }
  const SeamReport& report() const { return report_; }

 private:
  SeamReport report_;  // before stitcher_: its construction fills the search's counts
  SeamStitcher stitcher_;
};

}  // namespace kiln::lightmap
