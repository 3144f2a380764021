"""Progressive rendering: passes accumulated in float64, and the image's error estimated from two halves.

Each pass adds the per-pixel sums of its samples. Passes alternate between two half-buffers A (even
passes) and B (odd passes). When the samples are independent between passes with per-sample variance
sigma^2, E[(A - B)^2] = sigma^2 (1/nA + 1/nB) for the half means A and B, so the variance of the full mean
(sigma^2 / N, N = nA + nB) is estimated per pixel by (A - B)^2 nA nB / N^2, which is (A - B)^2 / 4 for
equal halves (the two-buffer estimate of adaptive samplers such as Cycles'). float64 sums keep 65536
passes exact to far below the float32 image they become."""
import math

import numpy as np

MIN_PASSES_FOR_TARGET = 4  # an error estimate from 2 passes has one degree of freedom per pixel


class Accumulator:
    def __init__(self, shape):
        self.total = np.zeros(shape, np.float64)
        self.even = np.zeros(shape, np.float64)
        self.n_total = self.n_even = self.passes = 0

    def add(self, sums, n):
        """Add one pass: `sums` over its n samples per pixel."""
        self.total += sums
        if self.passes % 2 == 0:
            self.even += sums
            self.n_even += n
        self.n_total += n
        self.passes += 1

    def mean(self):
        return self.total / max(self.n_total, 1)

    def half_difference(self):
        """(A - B) sqrt(nA nB) / N per pixel, whose square estimates the variance of the mean; None
        before the second pass."""
        n_odd = self.n_total - self.n_even
        if self.passes < 2:
            return None
        odd = self.total - self.even
        odd *= -math.sqrt(self.n_even * n_odd) / (n_odd * self.n_total)
        odd += self.even * (math.sqrt(self.n_even * n_odd) / (self.n_even * self.n_total))
        return odd

    def variance(self):
        """Per-pixel estimated variance of the mean, or None before the second pass."""
        d = self.half_difference()
        return None if d is None else d * d

    def estimated_rmse(self):
        """(estimated RMSE of the image over all pixels and channels, the same relative to the image's mean
        value), or (None, None) before the second pass."""
        d = self.half_difference()
        if d is None:
            return None, None
        d = d.ravel()
        rmse = math.sqrt(np.dot(d, d) / d.size)
        mean = float(np.mean(self.total)) / self.n_total
        return rmse, rmse / mean if mean > 0 else math.inf


def pass_size(spp, work_per_sample, budget=1 << 22):
    """Samples per pass: a power of two, at most spp / 2 (so that there are two halves to compare) and
    with at most `budget` work units (rays, roughly) per pass, so a pass takes a fraction of a second."""
    size = 1
    while size * 2 <= spp // 2 and size * 2 * work_per_sample <= budget:
        size *= 2
    return size
