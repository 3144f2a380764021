"""Progressive rendering: passes accumulated in float64, and the image's error estimated from two halves.

Each pass adds the per-pixel sums of its samples. The error estimate compares two halves of the samples:
A, the first 2^k samples (2^k the largest power of two below the count so far), and B, the rest. With
per-sample variance sigma^2 and independent halves, E[(A - B)^2] = sigma^2 (1/nA + 1/nB) for the half
means A and B, so the variance of the full mean (sigma^2 / N, N = nA + nB) is estimated per pixel by
(A - B)^2 nA nB / N^2, which is (A - B)^2 / 4 for equal halves (the two-buffer estimate of adaptive
samplers such as Cycles'). Halves by prefix, not alternate passes: the first 2^k points of a (0, 2)-sequence
are a net and so are the next 2^k, and the tables of the stratified patterns are in that order too, so
both halves cover the pixel alike; alternate passes of a few samples each would be interleaved subsets of one
net, each far worse than the whole, and the estimate would exceed the error many times over.
float64 sums keep 65536 passes exact to far below the float32 image they become; the prefix sums are kept
in float32, which rounds them once, by 2^-24 relative, far below the sampling noise of A - B."""
import math

import numpy as np

MIN_PASSES_FOR_TARGET = 4  # an error estimate from 2 passes has one degree of freedom per pixel


def _is_power_of_two(n):
    return n & (n - 1) == 0


class Accumulator:
    def __init__(self, shape):
        self.total = np.zeros(shape, np.float64)
        self.prefix = self.previous_prefix = None  # sums of the first 2^k and 2^(k-1) samples, float32
        self.n_prefix = self.n_previous = self.n_total = self.passes = 0

    def add(self, sums, n):
        """Add one pass: `sums` over its n samples per pixel."""
        self.total += sums
        self.n_total += n
        self.passes += 1
        if _is_power_of_two(self.n_total):
            self.previous_prefix, self.n_previous = self.prefix, self.n_prefix
            self.prefix, self.n_prefix = self.total.astype(np.float32), self.n_total

    def mean(self):
        return self.total / max(self.n_total, 1)

    def halves(self):
        """(sum of A, nA): the first half, the largest power-of-two prefix below the count; None if there
        is none (before the second pass)."""
        if self.n_prefix < self.n_total and self.prefix is not None:
            return self.prefix, self.n_prefix
        if self.previous_prefix is not None:
            return self.previous_prefix, self.n_previous
        return None

    def half_difference(self):
        """(A - B) sqrt(nA nB) / N per pixel, whose square estimates the variance of the mean; None
        before the second pass."""
        halves = self.halves()
        if halves is None:
            return None
        first, n_first = halves
        n_rest = self.n_total - n_first
        scale = math.sqrt(n_first * n_rest) / self.n_total
        rest = self.total - first
        rest *= -scale / n_rest
        rest += first * (scale / n_first)
        return rest

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
