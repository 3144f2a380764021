"""Helpers the test modules share: the checkout's paths, the command line run as a user runs it, the
planar layout of the test kernels' arrays, kernels that report the device's constants, texture lookups in the
kernel, in OpenImageIO and as the device stores the levels, a Phong scene without its ambient term, mounts, a
stand-in peer renderer and the check of a measurement record. Fixtures are in conftest.py; what the path
model's tests share is in path_support.py. No test module imports another (tests/test_layout.py)."""
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pyopencl as cl
import pytest

import raytrace
from raytrace import structs
from raytrace.structs import LANE_WIDTHS
from raytrace.renderer import packing
from raytrace.renderer.cpu_target import apply_target, is_pocl_cpu
from raytrace.renderer.device import describe, list_devices, select_device
from raytrace.renderer.program import build
from raytrace.scene import mipmap
from raytrace.commands import child_env
from raytrace.commands.stability.probe import planar  # noqa: F401 (for the tests)

ROOT = Path(__file__).resolve().parent.parent
CORNELL = str(ROOT / "scenes" / "cornell.toml")

# The session's device (RAYTRACE_DEVICE moves it: .ci/gpu runs the suite on a GPU, where PoCL may be absent).
_session = select_device(None)
SESSION_DEVICE, SESSION_KIND = describe(_session), "cpu" if _session.type & cl.device_type.CPU else "gpu"
on_pocl = pytest.mark.skipif(not is_pocl_cpu(_session), reason=f"about PoCL's CPU device; this session's is "
                                                                 f"{SESSION_DEVICE}")


def runnable_lane_widths():
    """Every lane width the kernel accepts that this machine's target runs (cpu_target.py): 1, 4, 8 and, on
    AVX-512, 16."""
    target = apply_target(_session)
    return [n for n in LANE_WIDTHS if n > 0 and (target is None or n <= target.lanes_max)]


def lane_id(n):
    return f"lanes{n}"


# The scalar width and the widest: for the tests that run a whole path through the kernel and compare estimators
# statistically (means over 1024 lanes). What differs by lane width is the code that handles a packet (select on
# vector masks against scalar comparisons, vloadn/vstoren, lanes leaving a loop at different times): 1 runs the
# scalar forms, the widest the vector ones, and 4 and 8 the same vector code as the widest with fewer lanes.
# The functions such a test composes are each tested at every width by their own tests (conftest's `lanes`),
# and the path loop's packet handling by test_path_regeneration.py and test_tiles.py, at every width.
LANE_ENDS = sorted({runnable_lane_widths()[0], runnable_lane_widths()[-1]})
at_lane_ends = pytest.mark.parametrize("lanes", LANE_ENDS, ids=lane_id)
needs_a_cpu_device = pytest.mark.skipif(not any(d.type & cl.device_type.CPU for _, d in list_devices()),
                                        reason="needs an OpenCL CPU device (PoCL); this machine has none")


# The test kernels' surface point (test_direct_lighting.py, path_support.py): a hit at `at` with the unit
# normal `normal` and material 0, seen by the ray r from one unit above it; `white`, the same point as a white
# Lambertian shading point. Paste it into a kernel source after the includes.
SURFACE_POINT = """
inline Hit surface_hit(vec3 at, vec3 normal, Ray *r)
{
    Hit hit = no_hit();
    hit.t = (vfloat)(1.0f);
    hit.p = at;
    hit.n = normal;
    hit.material = (vint)(0);
    r->o = v3_add(at, normal);
    r->d = v3_scale(normal, -1.0f);
    return hit;
}
inline ShadingPoint white(vec3 at, vec3 normal)
{
    ShadingPoint sp = {at, (vfloat)(0.0f), normal, normal, v3_splat(1.0f, 1.0f, 1.0f), (vfloat)(1.0f)};
    return sp;
}
"""


def run(*args, env=None, module="raytrace", **kwargs):
    """`python -m raytrace ARGS` (or another `module`: a rig of benchmarks/), its output captured, in `env`
    (default: this process's environment); kwargs go to subprocess.run (cwd, preexec_fn)."""
    return subprocess.run([sys.executable, "-m", module, *map(str, args)], capture_output=True, text=True,
                          env=child_env(env), **kwargs)


def without_ambient(path):
    """The scene of `path` with its Phong ambient term removed (raytrace.parameters): direct lighting has none,
    and render(shading="direct") refuses a scene that has one."""
    scene = raytrace.load_file(path)
    params = raytrace.parameters(scene)
    del params["ambient"]
    params.update()
    return scene


def mount(*args):
    """`mount ARGS`, or skip the test where this user may not mount."""
    r = subprocess.run(["mount", *map(str, args)], capture_output=True, text=True)
    if r.returncode:
        pytest.skip(f"mount not permitted here: {r.stderr.strip()}")


# A stand-in for another renderer, as converge --peer runs one: `peer.py SAMPLER SPP OUT` writes an 8 x 8 image
# of 0.3 plus noise that falls with spp (at least 4, as Mitsuba's ldsampler) and prints its timing.
FAKE_PEER = """
import json, sys
import numpy as np, OpenImageIO as oiio
sampler, spp, out = sys.argv[1], max(4, int(sys.argv[2])), sys.argv[3]
noise = np.random.default_rng(spp).normal(0, 0.2 / spp ** 0.5, (8, 8, 3)).astype(np.float32)
oiio.ImageBuf(np.ascontiguousarray(0.3 + noise)).write(out)
print("\\x1b[0m" + json.dumps({"sampler": sampler, "spp": spp, "median_s": 0.01 * spp}))  # after colour codes, as Mitsuba
"""


def assert_record_well_formed(path):
    """A measurement record (docs/performance.md) says on which machine, at which commit, by which command its
    figures were measured, and each figure is a number with a unit."""
    record = json.loads(path.read_text())
    assert set(record) == {"machine", "date", "commit", "command", "figures"}, path
    assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", record["date"]) and re.fullmatch(r"[0-9a-f]{7,40}", record["commit"])
    assert record["command"].startswith(("python -m ", ".ci/")) and record["figures"]
    for figure in record["figures"]:
        assert set(figure) == {"what", "value", "unit"} and isinstance(figure["value"], (int, float)), figure


LOOKUP = """
#include "mipmap.cl"
/* LANES lookups per work-item, each lane its own point and footprint (and so its own levels). */
__kernel void lookup(int n, TEXTURE_PARAMETERS, int texture, int filter, int wrap, __global const float *st,
                     __global const float *dst, __global float *out)
{
    TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec2 p = {IN(st), IN(st + n)};
    Footprint f = {IN(dst), IN(dst + n), IN(dst + 2 * n), IN(dst + 3 * n)};
    OUT3(out, texture_lookup(ts, texture, p, f, filter, wrap));
}
"""


def kernel_lookup(harness, textures, index, filter_name, wrap, s, t, derivs=None):
    """RGB of texture `index` of the packed `textures` at (s, t), float64 N x 3."""
    count, n = len(s), -(-len(s) // 8) * 8  # padded to a multiple of the lane width
    pad = lambda a: np.concatenate([a, np.zeros(a.shape[:-1] + (n - count,))], axis=-1)  # noqa: E731
    derivs = np.zeros((4, count)) if derivs is None else np.asarray(derivs, dtype=np.float64)
    s, t, derivs = pad(np.asarray(s, dtype=np.float64)), pad(np.asarray(t, dtype=np.float64)), pad(derivs)
    texels, levels, table = packing.pack_textures(textures)
    args = {"textures": table, "mip_levels": levels, "texels": texels,
            "srgb_to_linear": mipmap.SRGB8_TO_LINEAR.astype(np.float32), "texture": np.int32(index),
            "lookups": packing.lookup_structs([])[0],
            "filter": np.int32(structs.FILTERS[filter_name]), "wrap": np.int32(structs.WRAP_MODES[wrap]),
            "st": np.stack([s, t]).astype(np.float32), "dst": np.asarray(derivs).astype(np.float32)}
    return harness.run(LOOKUP, "lookup", n, args, {"out": 3})["out"][:, :count].T


def stored_levels(texture):
    """The levels as the device holds them, decoded to linear float64 (8-bit ones through the same table
    the kernel uses, 16-bit ones as code / 65535): what the filters must interpolate. A height map's quads
    (structs.QUAD_TEXELS) give each texel's own height, in all three channels, as the kernel's lookups do."""
    quads = texture.encoding in structs.QUAD_TEXELS
    if texture.encoding in structs.FLOAT_TEXELS:
        levels = [level.astype(np.float64) for level in texture.levels]
    elif texture.encoding == structs.TEXELS_QUAD16:
        levels = [level / 65535.0 for level in texture.levels]
    else:
        levels = [mipmap.decode_8bit(level, texture.encoding == structs.TEXELS_SRGB8) for level in texture.levels]
    return [np.repeat(level[..., :1], 3, axis=2) if quads else level[..., :3] for level in levels]


def openimageio_lookup(folder, image, mipmode, s, t, derivs=None):
    """OpenImageIO's TextureSystem on `image` (made into a tiled, MIP-mapped file), periodic wrapping,
    bilinear interpolation, the given MipMode; derivs (dsdx, dtdx, dsdy, dtdy) default to 0."""
    path = str(folder / "t.tx")
    assert oiio.ImageBufAlgo.make_texture(oiio.MakeTxTexture, oiio.ImageBuf(image), path, oiio.ImageSpec())
    system, opt = oiio.TextureSystem(), oiio.TextureOpt()
    opt.swrap = opt.twrap = oiio.Wrap.Periodic
    opt.mipmode, opt.interpmode = mipmode, oiio.InterpMode.Bilinear
    derivs = np.zeros((4, len(s))) if derivs is None else derivs
    return np.array([system.texture(path, opt, a, b, *map(float, d), 3) for a, b, d in zip(s, t, derivs.T)])


def run_int_kernel(cl_env, source, n, options=()):
    """Run a one-work-item kernel `values(__global int *out)` from `source` (with types.h included), built
    with `options`; its n ints."""
    context, queue = cl_env
    program, _ = build(context, f'#include "types.h"\n{source}', list(options))
    out = np.zeros(max(n, 1), np.int32)
    buf = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, out.nbytes)
    cl.Kernel(program, "values")(queue, (1,), None, buf)
    cl.enqueue_copy(queue, out, buf)
    return out[:n].tolist()


def values_kernel(expressions):
    """The source of a kernel `values` that stores each C expression's int value, in order."""
    body = "\n".join(f"    out[{i}] = {e};" for i, e in enumerate(expressions))
    return f"__kernel void values(__global int *out)\n{{\n{body}\n}}\n"


def same_tables(a, b):
    """Equality that counts NaN equal to NaN and tells 1 from 1.0 and -0.0 from 0.0."""
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b))
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same_tables(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(same_tables(x, y) for x, y in zip(a, b))
    return a == b
