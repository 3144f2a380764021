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
float64 sums keep 65536 passes exact to far below the float32 image they become; the prefix sum is kept
in float32, which rounds it once, by 2^-24 relative, far below the sampling noise of A - B.

The first pass's kernel also sums its first half apart (first_half), so that even a render of one pass
has both halves. Memory, for images of any size: passes arrive in bands of rows, added in place. The prefix of
2^k samples is copied from the total, band by band, only when a pass goes past 2^k: until then the first half
is still the prefix of 2^(k-1), so one prefix buffer does instead of two. The images and the error estimate are
computed in chunks of rows, with no full-size temporaries. The host keeps at most BYTES_PER_PIXEL a pixel."""
import math

import numpy as np

MIN_PASSES_FOR_TARGET = 4  # an error estimate from 2 passes has one degree of freedom per pixel
CHANNELS = 3
# The peak per pixel, reached once the variance image is made (images(), or the last pass's estimated_rmse):
# the float64 total with the float32 prefix and the variance image, then the total with both float32 images
# (the prefix released before the mean image is made).
BYTES_PER_PIXEL = CHANNELS * (8 + 4 + 4)
CHUNK_BYTES = 16 << 20  # float64 temporaries of the chunked computations, per chunk
PASS_WORK = 1 << 27     # work units (rays, roughly) of a pass, at most: pass_size


def _is_power_of_two(n):
    return n & (n - 1) == 0


def row_chunks(height, row_bytes, budget=CHUNK_BYTES):
    """Slices of rows covering [0, height), each of at most `budget` bytes at `row_bytes` a row (at least
    one row)."""
    rows = max(1, budget // row_bytes)
    return [slice(r, min(r + rows, height)) for r in range(0, height, rows)]


class Halves:
    """The counts of a progressive render's sums and the rules of its error estimate's two halves, one place
    for the host's Accumulator and the device's (device_sums.py): which samples the prefix holds, when it is
    taken from the total, and the half difference's weights."""

    def __init__(self):
        self.n_prefix = self.n_total = self.passes = 0

    def prefix_from_total(self):
        """Whether the pass now being added starts by copying the total into the prefix (where it brings no
        first half of its own): the count is about to pass a power of two, the first half of every later
        estimate."""
        return self.n_total > 0 and _is_power_of_two(self.n_total)

    def end_pass(self, n, n_first=0):
        """The current pass, of n samples per pixel, has been added for every row, with the sums of its first
        n_first samples where n_first > 0."""
        if n_first > 0:
            self.n_prefix = n_first
        elif self.prefix_from_total():
            self.n_prefix = self.n_total
        self.n_total += n
        self.passes += 1

    def counts(self):
        """The counts a checkpoint keeps (restore_counts takes them back)."""
        return {"n_prefix": self.n_prefix, "n_total": self.n_total, "passes": self.passes}

    def restore_counts(self, counts):
        """counts() of a checkpoint, checked against its pass schedule already (checkpoint._checked_progress)."""
        for name in ("n_prefix", "n_total", "passes"):
            setattr(self, name, counts[name])

    def weights(self):
        """(prefix weight, total weight), float64: the half difference (A - B) sqrt(nA nB) / N, with A the mean
        of the first n_prefix samples and B of the rest, is prefix * (1/nA + 1/nB) - total / nB, scaled."""
        n_rest = self.n_total - self.n_prefix
        scale = math.sqrt(self.n_prefix * n_rest) / self.n_total
        return scale / self.n_prefix + scale / n_rest, -scale / n_rest


class Accumulator(Halves):
    """The per-pixel sums of a progressive render, planar (CHANNELS x H x W); with AOVs (raytrace/aovs.py), their
    sums too, aov_planes x H x W float64 in aov_total (None without), apart from the image's: the error estimate
    is the image's alone."""

    def __init__(self, shape, aov_planes=0):
        super().__init__()
        self.total = np.zeros(shape, np.float64)
        self.aov_total = np.zeros((aov_planes, *shape[1:]), np.float64) if aov_planes else None
        self.prefix = None  # float32 sum of the first n_prefix samples, n_prefix a power of two
        self.kept_variance = None  # variance() as estimated_rmse(keep_variance=True) made it, until more sums come
        self.rays = 0.0  # rays traced, over every band added

    def _chunks(self):
        return row_chunks(self.total.shape[1], self.total.shape[2] * self.total.shape[0] * 8)

    def add_rows(self, row0, sums, first=None, rays=0.0, aovs=None):
        """Add the current pass's sums for the rows [row0, row0 + len); end_pass() counts the pass. `first`:
        the sums over the first pass's first n_first samples (first_half), the first half of the estimate;
        `rays`: the rays those rows' samples traced; `aovs`: the AOVs' sums over the same samples."""
        rows = slice(row0, row0 + sums.shape[1])
        if aovs is not None:
            self.aov_total[:, rows] += aovs
        self.rays += rays
        self.kept_variance = None
        if first is None and self.prefix_from_total():
            first = self.total[:, rows]
        if first is not None:
            if self.prefix is None:
                self.prefix = np.empty(self.total.shape, np.float32)
            self.prefix[:, rows] = first
        self.total[:, rows] += sums

    def add(self, sums, n, first=None, n_first=0):
        """Add one pass over the whole image: `sums` over its n samples per pixel (and `first` over its first
        n_first)."""
        self.add_rows(0, sums, first)
        self.end_pass(n, n_first)

    def rays_traced(self):
        """The rays traced, over every band added so far."""
        return self.rays

    def state(self):
        """(counts, arrays): everything the sums are, for a checkpoint (checkpoint.py); restore() takes it back
        to the same bits."""
        arrays = {"total": self.total}
        if self.prefix is not None:
            arrays["prefix"] = self.prefix
        if self.aov_total is not None:
            arrays["aov_total"] = self.aov_total
        return {**self.counts(), "rays": self.rays}, arrays

    def restore(self, counts, arrays):
        """The state() of an Accumulator of the same shape; ValueError for one that is not."""
        self.restore_counts(counts)
        self.rays = float(counts.get("rays", 0.0))
        self.total[...] = checked_array(arrays, "total", self.total.shape, np.float64)
        self.prefix = None if "prefix" not in arrays else checked_array(arrays, "prefix", self.total.shape, np.float32)
        if self.aov_total is not None:
            self.aov_total[...] = checked_array(arrays, "aov_total", self.aov_total.shape, np.float64)
        self.kept_variance = None

    def _half_difference(self, rows):
        """(A - B) sqrt(nA nB) / N for `rows` (float64, planar), whose square estimates the variance of
        the mean: A the first n_prefix samples, B the rest. Only with a prefix. As one linear combination of
        the sums, A - B = prefix (1/nA + 1/nB) - total / nB: one temporary, where forming the rest's sum
        first took two more (the estimate's host time for a 512 x 512 render is not small beside a GPU's
        kernel time for scene 0: measured in commit 77b202d)."""
        prefix_weight, total_weight = self.weights()
        d = self.total[:, rows] * total_weight
        d += self.prefix[:, rows] * prefix_weight
        return d

    def _interleaved(self, planar_rows):
        """H x W x CHANNELS float32 from a function of a chunk of rows returning planar values."""
        shape = self.total.shape
        out = np.empty((shape[1], shape[2], shape[0]), np.float32)
        for rows in self._chunks():
            out[rows] = np.moveaxis(planar_rows(rows), 0, -1)
        return out

    def mean(self):
        """The image: H x W x CHANNELS float32 mean of the samples."""
        return self._interleaved(lambda rows: self.total[:, rows] / max(self.n_total, 1))

    def aov_means(self):
        """The AOVs' means, aov_planes x H x W float32 (planar, as the kernel's planes), or None without AOVs."""
        if self.aov_total is None:
            return None
        out = np.empty(self.aov_total.shape, np.float32)
        row_bytes = self.aov_total.shape[0] * self.aov_total.shape[2] * 8
        for rows in row_chunks(self.aov_total.shape[1], row_bytes):  # no full-size float64 temporary
            out[:, rows] = self.aov_total[:, rows] / max(self.n_total, 1)
        return out

    def variance(self):
        """H x W x CHANNELS float32 estimated variance of each pixel's mean, or None before the second
        pass."""
        if self.prefix is None:
            return None
        return self._interleaved(lambda rows: np.square(self._half_difference(rows)))

    def images(self):
        """(mean(), variance()) at the least memory, releasing the sums: this accumulator is spent."""
        variance = self.variance() if self.kept_variance is None else self.kept_variance
        self.prefix = self.kept_variance = None
        image = self.mean()
        self.total = None
        return image, variance

    def estimated_rmse(self, keep_variance=False):
        """(estimated RMSE of the image over all pixels and channels, the same relative to the image's mean
        value), or (None, None) before the second pass. With keep_variance (after the last pass) it is the mean
        of the variance image, kept for images(): the sums are differenced once, not twice (a 512 x 512 image's
        difference takes more host time than scene 0's kernels take on a GPU: measured in commits a8eb2ae and
        77b202d)."""
        if self.prefix is None:
            return None, None
        if keep_variance:
            self.kept_variance = self.variance()
            squares = float(np.sum(self.kept_variance, dtype=np.float64))
        else:
            squares = sum(float(np.sum(np.square(self._half_difference(rows))))  # not np.dot: BLAS threads would
                          for rows in self._chunks())                         # spin on the render's cores
        return relative_rmse(math.sqrt(squares / self.total.size), float(np.mean(self.total)) / self.n_total)


def checked_array(arrays, name, shape, dtype):
    """arrays[name] if it has this shape and dtype (a checkpoint's, checked), else ValueError."""
    a = arrays.get(name)
    if not isinstance(a, np.ndarray) or a.shape != tuple(shape) or a.dtype != dtype:
        raise ValueError(f"{name}: {getattr(a, 'dtype', None)} {getattr(a, 'shape', None)}, expected {np.dtype(dtype)} "
                         f"{tuple(shape)}")
    return a


def relative_rmse(rmse, mean):
    """(rmse, rmse relative to the image's mean value). Pixels are >= 0: a zero mean is a black image, exact (0).
    A NaN or Inf in the sums (a kernel bug, zeroed in the image and counted) makes the estimate useless, so the
    relative error is infinite and no target error stops the render on it."""
    if not (math.isfinite(rmse) and math.isfinite(mean)):
        return rmse, math.inf
    return rmse, rmse / mean if mean > 0 else 0.0


def pass_size(spp, work_per_sample, budget=PASS_WORK):
    """Samples per pass: a power of two, at most spp and with at most `budget` work units (rays, roughly) per
    pass, so a pass takes a fraction of a second (scene 0 at 512 x 512: its 16 samples in one pass; render.py
    halves the budget where a time limit or a target error may stop the render after any pass, so that it
    stops nearer either). The kernel traces several samples of a pixel at once where a pass holds them
    (kernels/tile.h), up to its lane width: passes of 8 samples instead of 1 (a budget of 2^22) saved kernel
    time and more wall time, the wall time also saving the host's per-pass accumulation (measured in commit
    3752c2c). A pass used to hold at most spp / 2 samples, so that two passes gave the error estimate's
    two halves; the first pass now sums its first half apart (first_half), and passes of 16 (16 samples of one
    pixel in a work-item's 16 lanes) instead of 8 took less kernel time on mesh_cornell and on the
    10^6-triangle torus of `bench --scaling` (passes of 4 instead of 2), scene 0 the same (measured in commit
    7a64eb6)."""
    size = 1
    while size * 2 <= spp and size * 2 * work_per_sample <= budget:
        size *= 2
    return size


def first_half(sample0, n):
    """How many of the first samples of the pass [sample0, sample0 + n) the kernel sums apart as well: half
    of the first pass, the first half of the first error estimate (Accumulator: the later estimates' halves
    are whole passes); 0 for the other passes."""
    return n // 2 if sample0 == 0 else 0
