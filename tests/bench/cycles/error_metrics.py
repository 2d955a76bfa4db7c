"""The benchmark's measures: interior texels, relative RMSE against a noisy reference, equal-RMSE time ratios."""
import math

import numpy


def interior(mask):
    """Texels of `mask` whose eight neighbours are in it too: leaves out chart borders (partly covered texels, which
    the two bakers treat differently) and the texels next to those kiln invalidates (where its leak handling moves
    sample points)."""
    m = numpy.pad(mask, 1, constant_values=False)
    out = numpy.ones_like(mask)
    h, w = mask.shape
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            out &= m[dy:dy + h, dx:dx + w]
    return out


def relative_rmse(x, ref, mask):
    """sqrt(mean over the masked texels and RGB of (x - ref)^2) / mean(ref) over the same."""
    d = (x[mask] - ref[mask]).astype(numpy.float64)
    return math.sqrt(float(numpy.mean(d * d))) / float(numpy.mean(ref[mask], dtype=numpy.float64))


def reference_noise(half0, half1, mask):
    """The relative RMS noise of the mean of two independent halves: Var(mean) = Var(h0 - h1) / 4."""
    d = (half0[mask] - half1[mask]).astype(numpy.float64)
    mean_ref = float(numpy.mean((half0[mask] + half1[mask]) / 2, dtype=numpy.float64))
    return math.sqrt(float(numpy.mean(d * d))) / 2 / mean_ref


def without_noise(rmse, noise):
    """The RMSE against the truth: the reference's own independent noise adds in quadrature."""
    return math.sqrt(max(0.0, rmse * rmse - noise * noise))


def fitted_constant(points):
    """Monte Carlo's error^2 x time = K: the geometric mean of err^2 t over a curve's (error, time) points."""
    logs = [math.log(e * e * t) for e, t in points if e > 0 and t > 0]
    return math.exp(sum(logs) / len(logs)) if logs else float("nan")


def time_at(points, error):
    """A curve's time at `error`, interpolated linearly in log-log between its points (sorted by error)."""
    pts = sorted(points)
    for (e0, t0), (e1, t1) in zip(pts, pts[1:]):
        if e0 <= error <= e1:
            if e1 == e0:
                return t0
            a = (math.log(error) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0)))
    return None


def interpolated_ratios(a, b):
    """time_a / time_b at the same error, at every measured error of either curve inside the range both cover.
    Returns [(error, ratio)], empty if the ranges do not overlap."""
    a = [p for p in a if p[0] > 0 and p[1] > 0]
    b = [p for p in b if p[0] > 0 and p[1] > 0]
    if len(a) < 2 or len(b) < 2:
        return []
    low = max(min(e for e, _ in a), min(e for e, _ in b))
    high = min(max(e for e, _ in a), max(e for e, _ in b))
    errors = sorted({e for e, _ in a + b if low <= e <= high})
    return [(e, time_at(a, e) / time_at(b, e)) for e in errors]
