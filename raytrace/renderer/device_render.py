"""A render on one device: the program for the scene's features, the scene's tables uploaded, and the image
rendered as bands of whole rows, one launch each, through one device output buffer of a band. render.py
drives it pass by pass in this process; renderer/distributed.py drives one per Dask worker, a band of one
pass a task."""
import dataclasses

import numpy as np
import pyopencl as cl

from .. import aovs as aov_types
from ..errors import API, InputError
from ..structs import tile_shape
from .cpu_target import apply_target, check_lanes, describe_target
from .device import context_for, default_lanes, describe, select_device
from .device_sums import DeviceSums, device_fits
from .interface import KernelArguments
from .packing import texture_tables
from .scene_tables import scene_tables
from .program import Features, render_program
from .progressive import CHANNELS, PASS_WORK, Accumulator

# The kernel's output planes, float32 (kernels/render.cl's): R, G, B sums, the ray count, R, G, B over the
# launch's first n_first samples; the AOVs' sums (aovs.planes), then a measuring build's counts
RAYS_PLANE, FIRST_HALF_PLANE, OUTPUT_PLANES = CHANNELS, CHANNELS + 1, 2 * CHANNELS + 1
# A COUNT_VISITS build's planes more: the nodes and primitives its traversals test (kernels/scene.h's VISITS_*)
VISIT_KINDS = ("closest_hit_nodes", "shadow_nodes", "closest_hit_primitives", "shadow_primitives", "path_lanes",
               "path_lane_steps")
WORK_PER_LAUNCH = 1 << 23     # work units (rays, roughly) of one launch on a CPU, so that a launch stays short


def work_per_launch(device):
    """Work units (rays, roughly) of one launch at most: WORK_PER_LAUNCH on a CPU (scene 0's 512 x 512 in 9
    launches of 60 rows, each a short launch: measured in commit 18becbe); on a GPU a whole pass
    (progressive.PASS_WORK), so that a launch holds enough work-items to keep every core busy to its end. A
    large GPU holds many times more resident work-items than a band of 60 rows of a 512-pixel image (30,720):
    most of it would wait for each band's tail (docs/gpu.md). Scene 0's and mesh_cornell's kernels took less
    time in one launch than in bands (measured in commit 77b202d)."""
    return WORK_PER_LAUNCH if device.type & cl.device_type.CPU else PASS_WORK


def band_rows(r, max_band_bytes, planes=OUTPUT_PLANES, launch_work=WORK_PER_LAUNCH):
    """Rows a launch renders: at most max_band_bytes of output in `planes` (but at least one row) and
    launch_work work units (work_per_launch). Any banding gives the same sums, pixel by pixel; a Dask task is
    one band of one pass."""
    row_bytes = planes * np.dtype(np.float32).itemsize * r.width
    work_per_row = r.width * r.work * r.passes[0][1]
    return max(1, min(r.height, max_band_bytes // row_bytes, launch_work // work_per_row))


GPU_WORK_GROUP = (16, 8)  # work-items (tiles of pixels) of a work-group on a GPU, columns x rows


def work_group_shape(device, kernel, lanes):
    """The launch's local size, or None for the runtime's choice.
    - CPUs, the vector kernel: one work-item per work-group: PoCL then runs no work-item loop around it, and
      the cores share out the small groups evenly (faster than the default on scene 0: measured in commit
      df1c824).
    - GPUs: GPU_WORK_GROUP, a block of 16 x 8 neighbouring pixels, so that a group's rays meet the same BVH
      nodes and texels in the multiprocessor's cache. On a GPU (whole-pass launches) this took less time than
      the runtime's choice on scene 0, textured_cornell and mesh_cornell, and of the shapes of 64 and 128 tried
      (8 x 4 ... 64 x 2) none was much faster on any of the three (measured in commit 77b202d). Where the
      kernel cannot run groups that large (its registers), the runtime's choice.
    - The scalar kernel on CPUs: the runtime's choice."""
    if device.type & cl.device_type.CPU:
        return (1, 1) if lanes > 1 else None
    largest = kernel.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE, device)
    return GPU_WORK_GROUP if largest >= GPU_WORK_GROUP[0] * GPU_WORK_GROUP[1] else None


def launch_grid(tiles, local_size):
    """The global size for a grid of `tiles` (columns, rows of tiles): rounded up to whole work-groups of
    local_size (OpenCL 1.2 needs that); the kernel stores nothing beyond the band or the image."""
    if local_size is None:
        return tiles
    return tuple(-(-n // size) * size for n, size in zip(tiles, local_size))


class _Bands:
    """The image as bands of whole rows (band_rows), one launch each, through one device output buffer of a
    band. A launch is a grid of the kernel's tiles of pixels, shaped by the launch's sample count
    (structs.tile_shape), in work-groups of local_size (work_group_shape); the last tiles may reach past the
    band or the image, and the kernel stores nothing there. A measuring build's counts (VISIT_KINDS) add up
    pixel by pixel in `visits`, a float64 array of VISIT_KINDS x height x width."""

    def __init__(self, context, width, height, rows, lanes, local_size, planes=OUTPUT_PLANES, aov_planes=0):
        self.local_size = local_size
        self.rows, self.lanes, self.tile = rows, lanes, tile_shape(lanes, 1)
        self.width, self.height = width, height
        self.planes, self.aov_planes = planes, aov_planes
        self.visits = np.zeros((self.planes - OUTPUT_PLANES - aov_planes, height, width))  # empty unless counting
        self.host = np.empty(self.planes * self.rows * width, np.float32)
        self.device = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, self.host.nbytes)

    def set_samples(self, n, n_first):
        """The launches that follow hold n pixel samples, the first n_first of them summed apart too: their
        tiles' shape, and whether they store those sums."""
        self.tile, self.n_first = tile_shape(self.lanes, n), n_first

    def starts(self):
        """The first row of every band, in the order a pass adds them."""
        return range(0, self.height, self.rows)

    def launch_band(self, queue, args, row0, rows=None):
        """Enqueue the band of `rows` (default: as many as fit, up to the image's end) from row0, with the
        kernel's other `args` set; returns (its event, rows)."""
        rows = min(self.rows, self.height - row0) if rows is None else rows
        args.set("out", self.host, self.device)
        args.set("row0", np.int32(row0))
        args.set("row1", np.int32(row0 + rows))
        columns, tile_rows = self.tile
        tiles = (-(-self.width // columns), -(-rows // tile_rows))
        return args.launch(queue, launch_grid(tiles, self.local_size), self.local_size), rows

    def run_band(self, queue, args, row0, rows=None):
        """Launch the band of `rows` (default: as many as fit, up to the image's end) from row0 with the
        kernel's other `args` set: (its CHANNELS x rows x width float32 sums and those of the first n_first
        samples or None, views of the host buffer; rays traced; kernel seconds; the AOV planes' sums, a view,
        or None without AOVs)."""
        event, rows = self.launch_band(queue, args, row0, rows)
        event.wait()
        out = self.host[:self.planes * rows * self.width].reshape(self.planes, rows, self.width)
        cl.enqueue_copy(queue, out, self.device)
        aovs_end = OUTPUT_PLANES + self.aov_planes
        self.visits[:, row0:row0 + rows] += out[aovs_end:]
        first = out[FIRST_HALF_PLANE:FIRST_HALF_PLANE + CHANNELS] if self.n_first else None
        return (out[:CHANNELS], first, out[RAYS_PLANE].sum(dtype=np.float64),
                (event.profile.end - event.profile.start) * 1e-9, out[OUTPUT_PLANES:aovs_end] if self.aov_planes else None)

    def run_pass(self, queue, args, acc):
        """Every band, its sums and rays added into `acc`, an Accumulator on the host or DeviceSums; returns
        the kernel seconds. Into DeviceSums the bands are added by the device, in the queue's order, and nothing
        is read back."""
        if isinstance(acc, DeviceSums):
            events = []
            for row0 in self.starts():
                event, rows = self.launch_band(queue, args, row0)
                acc.add_band(self.device, row0, rows, self.n_first > 0)
                events.append(event)
            cl.wait_for_events(events)
            return sum((e.profile.end - e.profile.start) * 1e-9 for e in events)
        seconds = 0.0
        for row0 in self.starts():
            sums, first, band_rays, band_seconds, aovs = self.run_band(queue, args, row0)
            acc.add_rows(row0, sums, first, band_rays, aovs)
            seconds += band_seconds
        return seconds


class DeviceRender:
    """Everything a render keeps on its device: the program for the scene's features, the scene's tables
    uploaded, and the bands' output buffer. Built once per render here, once per worker and scene on a Dask
    cluster (renderer/distributed.py)."""

    def __init__(self, scene, options, r):
        self.device = select_device(options.device)
        context, self.queue = context_for(self.device)
        if options.lanes or options.features:
            check_lanes(apply_target(self.device), (options.features or options).lanes, "render()", "lanes")
        self.features = options.features or Features.of(scene, options.lanes or default_lanes(self.device))
        if self.features.aovs != aov_types.mask(scene.aovs):  # a forced variant stores the render's AOVs too
            self.features = dataclasses.replace(self.features, aovs=aov_types.mask(scene.aovs))
        program, self.build_seconds = render_program(context, self.features)
        self.args = KernelArguments(cl.Kernel(program, "render"))
        try:
            textures = texture_tables(scene)
            self.buffers = self.args.upload(context, {
                **scene_tables(scene, r.width, r.height, r.spp, r.n_light, options.texture_filter, r.pixel, r.light,
                               options.seed, self.features),
                **textures, "pixel_samples": r.pixel.table(), "light_samples": r.light.table()})
        except (MemoryError, cl.MemoryError):
            raise InputError(scene.path, "shapes", f"{scene.triangle_count} triangles, {len(scene.textures)} textures",
                             "out of memory building the scene's BVH and tables") from None
        self.texture_bytes = textures["texels"].nbytes if scene.textures else 0  # the packed texels of every level
        aov_planes = aov_types.plane_count(self.features.aovs)
        planes = OUTPUT_PLANES + aov_planes + len(VISIT_KINDS) * self.features.count_visits
        rows = band_rows(r, options.max_band_bytes, planes, work_per_launch(self.device))
        local_size = work_group_shape(self.device, self.args.kernel, self.features.lanes)
        self.bands = _Bands(context, r.width, r.height, rows, self.features.lanes, local_size, planes, aov_planes)

    def set_samples(self, sample0, n, n_first):
        """The launches that follow render the pixel samples [sample0, sample0 + n), the first n_first of them
        summed apart too (a pass of render.Resolved)."""
        self.args.set("sample0", np.int32(sample0))
        self.args.set("n_samples", np.int32(n))
        self.args.set("n_first", np.int32(n_first))
        self.bands.set_samples(n, n_first)

    def info(self):
        """What the statistics say of the device and its build."""
        bands = self.bands
        return {"device": describe(self.device), "build_options": [*self.features.options()],
                "build_seconds": self.build_seconds, "texture_bytes": self.texture_bytes,
                "extra": {"target": describe_target(self.device, self.features.lanes), "band_rows": bands.rows,
                          "work_group": bands.local_size,
                          "device_output_bytes": bands.host.nbytes,
                          "device_bytes": sum(b.size for b in self.buffers.values()) + bands.device.size,
                          **({"visits": dict(zip(VISIT_KINDS, bands.visits.sum(axis=(1, 2)).tolist())),
                              "visit_maps": bands.visits} if self.features.count_visits else {})}}


def sums_on_device(device, counting, accumulate, width, height, aovs=False):
    """Whether a render's passes add up on its device (DeviceSums) rather than on the host (Accumulator): as
    the option `accumulate` says, and where it is None on a GPU whose memory holds the sums
    (device_sums.device_fits); a measuring build (count_visits) reads its counts back each pass, so on the host,
    and so does a render with AOVs (DeviceSums holds the beauty's sums only). On a CPU the host's sums are as
    near as the device's: the device's memory is the host's."""
    if accumulate is None:
        return (not device.type & cl.device_type.CPU and not counting and not aovs
                and device_fits(device, width, height))
    if accumulate == "device" and aovs:
        raise InputError(API, "accumulate", accumulate, 'a render with AOVs adds them up on the host: use "host" or '
                         "None")
    if accumulate == "device" and counting:
        raise InputError(API, "accumulate", accumulate, "a counting build (features.count_visits) reads "
                         'its counts back every pass: use "host"')
    if accumulate == "device" and not device_fits(device, width, height):
        raise InputError(API, "accumulate", accumulate, f"the sums of a {width}x{height} image do not fit "
                         f"the device's memory ({describe(device)}): use \"host\"")
    return accumulate == "device"


class LocalPasses:
    """The passes of a render on this process's device."""

    def __init__(self, scene, options, r):
        # decided, and an accumulate the device cannot take refused, before the program is built
        counting = options.features is not None and options.features.count_visits  # never from a scene
        self.on_device = sums_on_device(select_device(options.device), counting, options.accumulate, r.width,
                                        r.height, bool(scene.aovs))
        self.d, self.passes = DeviceRender(scene, options, r), r.passes
        self.shape, self.sums = (CHANNELS, r.height, r.width), None
        self.aov_planes = self.d.bands.aov_planes

    def accumulator(self):
        """Where the passes add up: DeviceSums on the device, or the host's Accumulator (sums_on_device)."""
        if self.on_device:
            self.sums = DeviceSums(self.d.queue.context, self.d.queue, self.shape[2], self.shape[1])
            return self.sums
        return Accumulator(self.shape, self.aov_planes)

    def run_pass(self, k, acc):
        """Pass k's bands added into `acc` (accumulator()); returns the kernel seconds."""
        self.d.set_samples(*self.passes[k])
        return self.d.bands.run_pass(self.d.queue, self.d.args, acc)

    def info(self):
        info = self.d.info()
        info["extra"]["sums"] = "device" if self.on_device else "host"
        if self.sums is not None:
            info["extra"]["device_bytes"] += self.sums.nbytes
        return info

    def device_fingerprint(self):
        """What a checkpoint of this render records of its device: the device and the kernel variant."""
        info = self.d.info()
        return {"device": info["device"], "build_options": info["build_options"]}

    def cancel(self):
        pass
