"""A progressive render's sums kept on its device between passes (kernels/accumulate.cl), for a GPU.

The host's Accumulator (progressive.py) reads every pass's output back and adds it in float64; on a GPU, whose
kernels are fast, that host work outweighed them (docs/gpu.md, from the record
benchmarks/results/2026-11-26-h100-ci-gpu.json). Here a pass's bands are added on the device as double-floats,
a pass sends back only its error estimate's partial sums (at most MAX_PARTIALS pairs, 512 KB), and the host
reads the image, its variance and the ray count once, at the end.
The estimate's halves, prefix and counts follow the Accumulator's rules exactly (the same n_prefix, the same
weights), so both give the same images to within the roundings argued in kernels/accumulate.cl
(tests/test_device_sums.py)."""
import math

import numpy as np
import pyopencl as cl

from .interface import KernelArguments
from .program import build
from .progressive import CHANNELS, Halves, relative_rmse

SUM_PLANES = CHANNELS + 1  # R, G, B and the rays traced (kernels/accumulate.cl)
PREFIX_KEEP, PREFIX_FROM_FIRST_HALF, PREFIX_FROM_TOTAL = 0, 1, 2
# The device's bytes a pixel at the peak, images() resolving: the hi and lo sums, the prefix, the image and its
# variance
BYTES_PER_PIXEL = 4 * (2 * SUM_PLANES + CHANNELS + 2 * CHANNELS)
ESTIMATE_ROWS = 16  # rows of a column an estimate_partials work-item sums (32 work-items a column at 512 rows)
MAX_PARTIALS = 1 << 16  # work-items of estimate_partials, and partial sums read back, at most

_programs = {}


def accumulate_program(context):
    """kernels/accumulate.cl built for `context`, once per context."""
    if context not in _programs:
        _programs[context], _ = build(context, '#include "accumulate.cl"\n')
    return _programs[context]


def estimate_chunks(width, height):
    """Work-items per column of estimate_partials: one per ESTIMATE_ROWS rows, at most MAX_PARTIALS in all."""
    return max(1, min(-(-height // ESTIMATE_ROWS), MAX_PARTIALS // width))


def device_fits(device, width, height):
    """Whether a width x height render's sums and images fit the device: every buffer within its largest
    allocation and all of them, at their peak (BYTES_PER_PIXEL), within half its memory (the scene's tables and
    the band buffer need the rest)."""
    largest = SUM_PLANES * width * height * 4
    needed = width * height * BYTES_PER_PIXEL + estimate_chunks(width, height) * width * 8
    return largest <= device.max_mem_alloc_size and needed <= device.global_mem_size // 2


class DeviceSums(Halves):
    """The per-pixel sums of a progressive render on the device: the Accumulator's interface, with bands added
    from the render kernel's output buffer (add_band) instead of host arrays."""

    def __init__(self, context, queue, width, height):
        super().__init__()
        self.queue, self.width, self.height = queue, width, height
        program = accumulate_program(context)
        self.kernels = {name: KernelArguments(cl.Kernel(program, name))
                        for name in ("add_band", "estimate_partials", "resolve_images")}
        pixels = width * height
        self.total_hi, self.total_lo = (cl.Buffer(context, cl.mem_flags.READ_WRITE, SUM_PLANES * pixels * 4)
                                        for _ in range(2))
        for buffer in (self.total_hi, self.total_lo):
            cl.enqueue_fill_buffer(queue, buffer, np.float32(0), 0, buffer.size)
        self.prefix = cl.Buffer(context, cl.mem_flags.READ_WRITE, CHANNELS * pixels * 4)
        self.chunks = estimate_chunks(width, height)
        self.partials = np.empty((self.chunks, width, 2), np.float32)
        self.partials_buffer = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, self.partials.nbytes)
        self.nbytes = pixels * BYTES_PER_PIXEL + self.partials.nbytes  # the images' buffers at the end included
        self.has_prefix = False
        sums = {"total_hi": self.total_hi, "total_lo": self.total_lo, "prefix": self.prefix}
        for name, args in self.kernels.items():
            for key, buffer in sums.items():
                if key in args.names:  # estimate_partials reads hi alone
                    args.set(key, np.empty(0, np.float32), buffer)
            args.set("width", np.int32(width))
            args.set("height", np.int32(height))

    def add_band(self, out, row0, rows, has_first):
        """Enqueue the addition of the render launch's output buffer `out` (the band of `rows` rows from row0;
        with its first-half planes where has_first) into the sums; end_pass() counts the pass."""
        if has_first:
            prefix_from = PREFIX_FROM_FIRST_HALF
        elif self.prefix_from_total():
            prefix_from = PREFIX_FROM_TOTAL
        else:
            prefix_from = PREFIX_KEEP
        self.has_prefix |= prefix_from != PREFIX_KEEP
        args = self.kernels["add_band"]
        args.set("out", np.empty(0, np.float32), out)
        args.set("row0", np.int32(row0))
        args.set("rows", np.int32(rows))
        args.set("prefix_from", np.int32(prefix_from))
        args.launch(self.queue, (self.width, rows))

    def _weights(self, args):
        """Set the half difference's weights (Halves.weights), computed in float64 and rounded once."""
        prefix_weight, total_weight = self.weights()
        args.set("prefix_weight", np.float32(prefix_weight))
        args.set("total_weight", np.float32(total_weight))

    def estimated_rmse(self, keep_variance=False):
        """As Accumulator.estimated_rmse: from the device's partial sums, added here in float64.
        keep_variance is the host's economy; the device makes the variance image once, in images()."""
        if not self.has_prefix:
            return None, None
        args = self.kernels["estimate_partials"]
        self._weights(args)
        args.set("chunks", np.int32(self.chunks))
        args.set("partials", self.partials, self.partials_buffer)
        args.launch(self.queue, (self.width, self.chunks))
        cl.enqueue_copy(self.queue, self.partials, self.partials_buffer)
        squares, values = self.partials.reshape(-1, 2).sum(axis=0, dtype=np.float64)
        count = CHANNELS * self.width * self.height
        return relative_rmse(math.sqrt(squares / count), values / count / self.n_total)

    def rays_traced(self):
        """The rays traced, over every pass so far: the rays plane of both halves of the sums, added here."""
        pixels = self.width * self.height
        total = 0.0
        for buffer in (self.total_hi, self.total_lo):
            plane = np.empty(pixels, np.float32)
            cl.enqueue_copy(self.queue, plane, buffer, src_offset=CHANNELS * pixels * 4)
            total += float(plane.sum(dtype=np.float64))
        return total

    def state(self):
        """(counts, arrays) as Accumulator.state: the double-float sums as their two float32 halves, read back."""
        arrays = {}
        for name, buffer in (("total_hi", self.total_hi), ("total_lo", self.total_lo), ("prefix", self.prefix)):
            if name != "prefix" or self.has_prefix:
                arrays[name] = np.empty(buffer.size // 4, np.float32)
                cl.enqueue_copy(self.queue, arrays[name], buffer)
        return self.counts(), arrays

    def restore(self, counts, arrays):
        """The state() of DeviceSums of the same size, written to the device; ValueError for one that is not."""
        from .progressive import checked_array
        self.restore_counts(counts)
        self.has_prefix = "prefix" in arrays
        for name, buffer in (("total_hi", self.total_hi), ("total_lo", self.total_lo), ("prefix", self.prefix)):
            if name in arrays or name != "prefix":
                cl.enqueue_copy(self.queue, buffer, checked_array(arrays, name, (buffer.size // 4,), np.float32))
        self.queue.finish()

    def mean(self):
        """The image so far, H x W x CHANNELS float32, the sums kept (a watcher's: watch.PassReport.image)."""
        pixels = self.width * self.height
        hi, lo = (np.empty(CHANNELS * pixels, np.float32) for _ in range(2))
        cl.enqueue_copy(self.queue, hi, self.total_hi)
        cl.enqueue_copy(self.queue, lo, self.total_lo)
        total = (hi.astype(np.float64) + lo).reshape(CHANNELS, self.height, self.width)
        return np.moveaxis(total / max(self.n_total, 1), 0, -1).astype(np.float32)

    def images(self):
        """(mean, variance or None), H x W x CHANNELS float32, as Accumulator.images; the sums are spent."""
        shape = (self.height, self.width, CHANNELS)
        image = np.empty(shape, np.float32)
        variance = np.empty(shape, np.float32) if self.has_prefix else None
        image_buffer = cl.Buffer(self.queue.context, cl.mem_flags.WRITE_ONLY, image.nbytes)
        variance_buffer = cl.Buffer(self.queue.context, cl.mem_flags.WRITE_ONLY, image.nbytes if self.has_prefix else 4)
        args = self.kernels["resolve_images"]
        args.set("n", np.float32(max(self.n_total, 1)))  # exact: at most MAX_SAMPLES = 2^16
        args.set("has_variance", np.int32(self.has_prefix))
        if self.has_prefix:
            self._weights(args)
        else:
            args.set("prefix_weight", np.float32(0))
            args.set("total_weight", np.float32(0))
        args.set("image", image, image_buffer)
        args.set("variance", image, variance_buffer)
        args.launch(self.queue, (self.width, self.height))
        cl.enqueue_copy(self.queue, image, image_buffer)
        if variance is not None:
            cl.enqueue_copy(self.queue, variance, variance_buffer)
        self.total_hi = self.total_lo = self.prefix = self.kernels = None
        return image, variance
