"""Procedural textures for the course's scenes: a grid and two matching material sets (bricks, stones).

`generate(out_dir, seed)` writes, all 512 x 512 and tileable (periodic in u and v, so `repeat` wrapping shows
no seams: every noise field is FFT-filtered white noise and every distance wraps around the tile):

- `grid.png` (8-bit sRGB RGB): scene 1's aliasing and MIP-map test. Light cells (linear 0.85, code 237)
  between dark lines (linear 0.05, code 63) two texels wide every 64 texels, an 8 x 8 grid of cells; each line
  starts on a cell boundary (texels 64 k and 64 k + 1), so copies of the tile join into the same grid. The
  lines are aligned to the texel pairs of the MIP pyramid: a line straddling a multiple of 64 (texels
  64 k - 1 and 64 k) would be split over two texels at every level of a box-filtered pyramid, which doubles
  the blur of trilinear filtering (docs/textures.md's filter figure).
- `bricks_height.png`, `stones_height.png` (16-bit, one channel, data in [0, 1]): the relief. Bricks: running
  bond, 6 courses of 2 bricks per tile (3 : 1 bricks, as real ones with their joints), alternate courses
  offset by half a brick; mortar joints low (about 0.1), faces high (0.8 to 0.9 per brick) with rounded
  corners and bevelled edges, plus faint noise. Stones: cobbles on a periodic Voronoi diagram (6 staggered
  rows of 6 jittered sites); each stone is a dome rising smoothly with the distance to its cell's border,
  separated from its neighbours by low sandy gaps (about 0.05), plus faint noise.
- `bricks_normal.png`, `stones_normal.png` (8-bit RGB, data): tangent-space normals derived from the 16-bit
  height as stored in the file. The texture covers TILE_SIZE x TILE_SIZE scene units and the relief is
  z = HEIGHT_SCALE * h(u, v), with u to the right and v up the image (v = 1 is row 0 of the file), so
  n = normalize(-dz/dx, -dz/dy, 1) with x along u and y along v (upward, towards row 0), by periodic central
  differences; rgb = round(255 (n + 1) / 2). A brick's top edge tilts towards +y (green > 128), its right edge
  towards +x (red > 128). A scene reproduces the same relief with height_scale = HEIGHT_SCALE and a uv_scale
  that makes one tile span TILE_SIZE units, and then the normal map and the bump map of the height agree.
- `bricks_colour.png`, `stones_colour.png` (8-bit sRGB RGB): albedo. Reddish-brown bricks varying per brick,
  grey mortar; grey to beige stones varying per stone, dark gaps. Colour and height come from the same cell
  structure (same brick ids, same Voronoi labels, same signed distance to the edge): the mortar / gap colour is
  exactly where the height map is at its joint level (distance inside the brick or stone < 0), with a
  one-texel antialiased transition.

The colour maps are built in linear RGB and encoded with the sRGB curve (what the renderer decodes); height and
normal maps are data and carry no colour space. The files are deterministic: the same seed gives the same
bytes (numpy default_rng streams spawned from SeedSequence(seed), one per material; fixed sizes; OIIO's
PNG writer puts no date in the file).
"""
import errno
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from ..outputs import Outputs

SIZE = 512            # texels per side of every texture (a power of two, for the MIP pyramid)
TILE_SIZE = 0.5       # scene units covered by one tile of the bricks / stones maps
HEIGHT_SCALE = 0.02   # scene units of relief for height 1 (the z of the surface is HEIGHT_SCALE * h)

GRID_CELLS = 8        # grid.png: 8 x 8 cells of 64 texels
GRID_LINE = 2         # texels per line, from each cell boundary on
GRID_LIGHT, GRID_DARK = 0.85, 0.05   # linear values of cells and lines

SRGB_SPACE, DATA_SPACE = "srgb_rec709_scene", "Raw"   # "Raw" writes no sRGB / gAMA chunk: data maps
LINEAR_SPACE = "lin_rec709"   # sky.exr: linear radiance

SKY_WIDTH = 256        # sky.exr: texels around the horizon (half as many from zenith to nadir)
SUN_U, SUN_ELEVATION = 0.4, 35.0   # the sun's azimuth (the map's u) and its elevation, degrees
SUN_SIGMA, SUN_PEAK = 10.0, 27.0   # the sun's Gaussian width, degrees, and its peak radiance


# --- shared helpers --------------------------------------------------------------------------------------

def smoothstep(e0, e1, x):
    """0 below e0, 1 above e1, C1 in between: profiles without kinks, so the normals have no jumps."""
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def periodic_noise(rng, n, wavelength):
    """n x n zero-mean unit-variance noise with features of about `wavelength` texels. White noise filtered
    in the Fourier domain: only integer frequencies survive, so the field is periodic by construction."""
    k = np.hypot(*np.meshgrid(np.fft.fftfreq(n), np.fft.rfftfreq(n), indexing="ij"))  # cycles per texel
    spectrum = np.fft.rfft2(rng.standard_normal((n, n))) * np.exp(-2.0 * (k * wavelength) ** 2)
    field = np.fft.irfft2(spectrum, s=(n, n))
    field -= field.mean()
    return field / field.std()


def fbm(rng, n, wavelength, octaves=4, gain=0.5):
    """Fractal sum of periodic noise octaves (wavelength halving, amplitude times `gain`), unit variance."""
    total = sum(gain ** i * periodic_noise(rng, n, wavelength / 2 ** i) for i in range(octaves))
    return total / total.std()


def periodic_voronoi(sites, n, soften=0.0, rows_per_block=64):
    """Voronoi diagram of `sites` (K x 2, (x, y) in texels) on the n x n torus, at texel centres.
    Returns (label, border): the nearest site's index and the distance to the cell's border, the minimum over
    j of (|d_j|^2 - |d_1|^2) / (2 |d_j - d_1|) (the distance to the bisector with site j), where d_j is the
    wrapped vector to site j's nearest copy. soften > 0 takes a smooth minimum (-soften log sum exp(-b / soften))
    instead: it rounds the cells' corners and the creases along their medial axes. Row blocks bound the
    K x rows x n temporaries."""
    sites = np.asarray(sites, dtype=np.float64)
    x = np.arange(n) + 0.5
    label = np.empty((n, n), dtype=np.int64)
    border = np.empty((n, n))
    for r0 in range(0, n, rows_per_block):
        y = x[r0:r0 + rows_per_block]
        # wrapped offsets to every site: (K, rows, n); the wrap makes the diagram periodic
        dx = (x[None, None, :] - sites[:, 0, None, None] + n / 2) % n - n / 2
        dy = (y[None, :, None] - sites[:, 1, None, None] + n / 2) % n - n / 2
        dx, dy = np.broadcast_arrays(dx, dy)
        d2 = dx * dx + dy * dy
        nearest = np.argmin(d2, axis=0)
        dx1, dy1, d21 = (np.take_along_axis(a, nearest[None], axis=0) for a in (dx, dy, d2))
        with np.errstate(divide="ignore", invalid="ignore"):
            to_bisector = (d2 - d21) / (2.0 * np.hypot(dx - dx1, dy - dy1))
        np.put_along_axis(to_bisector, nearest[None], np.inf, axis=0)   # no bisector with itself
        nearest_border = to_bisector.min(axis=0)
        if soften > 0:   # log-sum-exp about the minimum, so the exponentials cannot underflow to log(0)
            nearest_border -= soften * np.log(np.exp(-(to_bisector - nearest_border) / soften).sum(axis=0))
        label[r0:r0 + len(y)] = nearest
        border[r0:r0 + len(y)] = nearest_border
    return label, border


def normal_map(height, tile_size=TILE_SIZE, height_scale=HEIGHT_SCALE):
    """Unit normals (H x W x 3) of z = height_scale * h over a tile_size square: normalize(-dz/dx, -dz/dy, 1),
    x along the columns, y UP the image (towards row 0). Periodic central differences, so the normals tile."""
    h = np.asarray(height, dtype=np.float64)
    dx = tile_size / h.shape[1]
    dy = tile_size / h.shape[0]
    dzdx = height_scale * (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / (2 * dx)  # column c+1 minus c-1
    dzdy = height_scale * (np.roll(h, 1, axis=0) - np.roll(h, -1, axis=0)) / (2 * dy)  # row r-1 is up: + y
    n = np.stack([-dzdx, -dzdy, np.ones_like(h)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def encode_normal(n):
    """rgb = (n + 1) / 2 as 8-bit data."""
    return np.round(255.0 * (np.asarray(n) + 1.0) / 2.0).astype(np.uint8)


def encode_srgb(linear):
    """The sRGB transfer curve (IEC 61966-2-1), what the renderer decodes, rounded to 8 bits."""
    x = np.clip(linear, 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    return np.round(255.0 * srgb).astype(np.uint8)


def quantize16(h):
    """Height in [0, 1] to the 16-bit codes that are written (and from which the normals are derived)."""
    return np.round(65535.0 * np.clip(h, 0.0, 1.0)).astype(np.uint16)


def write_png(path, pixels, colour_space):
    """Write an H x W (x C) uint8 / uint16 array as PNG into the file `path` itself (a temporary reserved by
    raytrace.outputs.Outputs) with OpenImageIO; OSError when it fails. OIIO's PNG writer adds no date; the
    colour space decides the sRGB / gAMA chunks; a failed write (a full disk) shows only in has_error."""
    pixels = np.ascontiguousarray(pixels if pixels.ndim == 3 else pixels[:, :, None])
    height, width, channels = pixels.shape
    spec = oiio.ImageSpec(width, height, channels, oiio.TypeDesc(pixels.dtype.name))
    spec.attribute("oiio:ColorSpace", colour_space)
    _write(path, spec, pixels)


def _write(path, spec, pixels):
    """Write `pixels` with `spec` into the file `path`; OSError with OpenImageIO's words when it fails."""
    out = oiio.ImageOutput.create(str(path))
    if (out is None or not out.open(str(path), spec) or not out.write_image(pixels) or out.has_error
            or not out.close() or out.has_error):
        message = oiio.geterror() or (out.geterror() if out else "") or "no writer"
        raise OSError(errno.EIO, message.splitlines()[0].strip(), str(path))


def write_exr(path, pixels, colour_space):
    """Write an H x W x C float array as a half-float, zip-compressed OpenEXR file into `path` itself, like
    write_png; an empty DateTime keeps OIIO from stamping the file with the time (capDate), so that the same
    seed gives the same bytes."""
    pixels = np.ascontiguousarray(pixels, np.float32)
    height, width, channels = pixels.shape
    spec = oiio.ImageSpec(width, height, channels, oiio.HALF)
    spec.attribute("oiio:ColorSpace", colour_space)
    spec.attribute("compression", "zip")
    spec.attribute("DateTime", "")
    _write(path, spec, pixels)


# --- the textures ----------------------------------------------------------------------------------------

def grid(n=SIZE):
    """Linear RGB grid: dark lines GRID_LINE texels wide from every cell boundary on, light cells."""
    on_line = np.arange(n) % (n // GRID_CELLS) < GRID_LINE
    line = on_line[:, None] | on_line[None, :]
    return np.repeat(np.where(line, GRID_DARK, GRID_LIGHT)[:, :, None], 3, axis=2)


def bricks(rng, n=SIZE, courses=6, per_course=2, mortar=4.0, bevel=5.0, corner=4.0):
    """(height, linear colour) of a running bond. `mortar`: half the joint width, `bevel`: the width of the
    edge's rise, `corner`: the radius of a brick's rounded corners, all in texels."""
    H, L = n / courses, n / per_course
    y = np.arange(n)[:, None] + 0.5                       # texel centres; rows run down, which is fine here
    x = np.arange(n)[None, :] + 0.5
    course = (y // H).astype(np.int64)
    xs = x + (course % 2) * L / 2                         # half-brick offset on alternate courses
    brick = course * per_course + (xs // L).astype(np.int64) % per_course   # wraps: a split brick is one id
    # signed distance inside the brick face (a rounded rectangle inset by the half joint): < 0 in the mortar
    q = np.stack(np.broadcast_arrays(np.abs(xs % L - L / 2) - (L / 2 - mortar - corner),
                                     np.abs(y % H - H / 2) - (H / 2 - mortar - corner)))
    inside = -(np.linalg.norm(np.maximum(q, 0), axis=0) + np.minimum(q.max(axis=0), 0) - corner)

    count = courses * per_course
    face = rng.uniform(0.8, 0.9, count)[brick] + 0.02 * fbm(rng, n, 48)   # per-brick level, faint waviness
    joint = 0.10 + 0.015 * periodic_noise(rng, n, 3)                        # gritty mortar
    height = joint + (face - joint) * smoothstep(0.0, bevel, inside)

    # colour: each brick between dark brown and orange-red, brighter or darker, mottled by noise
    dark, warm = np.array([0.20, 0.055, 0.035]), np.array([0.42, 0.13, 0.06])
    mix, shade = rng.uniform(0, 1, count)[brick], rng.uniform(0.75, 1.2, count)[brick]
    brick_rgb = (dark + mix[..., None] * (warm - dark)) * shade[..., None]
    brick_rgb *= (1 + 0.12 * fbm(rng, n, 24))[..., None]
    mortar_rgb = np.array([0.40, 0.38, 0.35]) * (1 + 0.08 * periodic_noise(rng, n, 2))[..., None]
    w = np.clip(inside + 0.5, 0.0, 1.0)[..., None]       # mortar exactly where the height is at joint level
    return np.clip(height, 0, 1), mortar_rgb + w * (brick_rgb - mortar_rgb)


def stones(rng, n=SIZE, rows=6, jitter=0.3, gap=2.0, rounding=18.0, soften=4.0):
    """(height, linear colour) of cobbles. `rows` staggered rows of `rows` sites (even, so the stagger tiles),
    jittered by +-jitter cells; `gap`: half the gap width, `rounding`: width of a stone's rounded edge,
    `soften`: the smooth minimum's scale that rounds the stones' corners, in texels."""
    cell = n / rows
    j, i = np.divmod(np.arange(rows * rows), rows)
    offsets = rng.uniform(-jitter, jitter, (rows * rows, 2))
    sites = (np.stack([i + 0.5 + 0.5 * (j % 2), j + 0.5], axis=1) + offsets) * cell % n
    label, border = periodic_voronoi(sites, n, soften)
    inside = border - gap                                 # < 0 in the gap between stones

    # dome: a rounded edge, then a gentle rise to the stone's innermost point (its largest border distance)
    deepest = np.zeros(len(sites))
    np.maximum.at(deepest, label.ravel(), inside.ravel())
    s = np.clip(inside / deepest[label], 0.0, 1.0)
    dome = smoothstep(0.0, rounding, inside) * (0.7 + 0.3 * (1 - (1 - s) ** 2))
    top = rng.uniform(0.72, 0.92, len(sites))[label] + 0.02 * fbm(rng, n, 32)
    floor = 0.05 + 0.01 * periodic_noise(rng, n, 2)      # sand in the gaps
    height = floor + (top - floor) * dome

    # colour: each stone between grey and beige, brighter or darker, mottled; dark gaps
    grey, beige = np.array([0.27, 0.27, 0.27]), np.array([0.42, 0.35, 0.26])
    mix, shade = rng.uniform(0, 1, len(sites))[label], rng.uniform(0.7, 1.15, len(sites))[label]
    stone_rgb = (grey + mix[..., None] * (beige - grey)) * shade[..., None]
    stone_rgb *= (1 + 0.15 * fbm(rng, n, 16) + 0.1 * (smoothstep(0, rounding, inside) - 1))[..., None]
    gap_rgb = np.array([0.045, 0.04, 0.035]) * (1 + 0.2 * periodic_noise(rng, n, 2))[..., None]
    w = np.clip(inside + 0.5, 0.0, 1.0)[..., None]        # gap colour exactly where the height is at gap level
    return np.clip(height, 0, 1), gap_rgb + w * (stone_rgb - gap_rgb)


FILES = ["grid.png", "bricks_height.png", "bricks_normal.png", "bricks_colour.png", "stones_height.png",
         "stones_normal.png", "stones_colour.png", "sky.exr"]


def sky(width=SKY_WIDTH, height=SKY_WIDTH // 2):
    """sky.exr: an equirectangular sky in the `envmap` layout (kernels/environment.cl; the top row looks up),
    linear RGB radiance. A sky blue at the zenith, paling to a whitish horizon (a smooth gradient in the
    elevation), a grey-brown ground below it, and a sun: a Gaussian lobe SUN_SIGMA wide about the direction
    at u = SUN_U and SUN_ELEVATION above the horizon, bright enough to dominate the light (about 60% of the
    irradiance on a level surface), so that importance sampling the map matters. The sun is 10 degrees wide:
    at 3 the caustics it casts through and off the materials scene's spheres, which a unidirectional path
    tracer finds only by its BSDF's rays, left an RMSE of 0.022 at 2048 spp against Mitsuba's (ours and its
    alike: the means agreed within 0.01%)."""
    u = (np.arange(width) + 0.5) / width
    v = np.arange(height) / (height - 1)  # the envmap layout's rows: the first at the zenith, the last at the nadir
    theta, phi = np.pi * v[:, None], 2 * np.pi * u[None, :]
    d = np.stack(np.broadcast_arrays(np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)),
                 axis=-1)
    elevation = np.pi / 2 - theta
    up = np.clip(np.sin(elevation), 0.0, 1.0)
    zenith, horizon, ground = np.array([0.25, 0.45, 0.9]), np.array([0.9, 0.95, 1.0]), np.array([0.25, 0.22, 0.2])
    t = up ** 0.5
    rgb = np.where(elevation[..., None] >= 0, (1 - t[..., None]) * horizon + t[..., None] * zenith,
                   np.broadcast_to(ground, (height, 1, 3)))
    rgb = np.broadcast_to(rgb, (height, width, 3)).copy()
    sun_phi, sun_theta = 2 * np.pi * SUN_U, np.pi / 2 - np.radians(SUN_ELEVATION)
    sun = np.array([np.sin(sun_phi) * np.sin(sun_theta), np.cos(sun_theta), -np.cos(sun_phi) * np.sin(sun_theta)])
    angle = np.arccos(np.clip(d @ sun, -1.0, 1.0))
    sigma = np.radians(SUN_SIGMA)
    rgb += SUN_PEAK * np.exp(-0.5 * (angle / sigma) ** 2)[..., None] * np.array([1.0, 0.9, 0.75])
    return rgb.astype(np.float32)


def textures(seed):
    """(file name, pixels, colour space) of every texture, made one after the other."""
    yield "grid.png", encode_srgb(grid()), SRGB_SPACE
    # one independent stream per material, so changing one texture leaves the other's bytes alone
    for name, make, stream in zip(("bricks", "stones"), (bricks, stones), np.random.SeedSequence(seed).spawn(2)):
        height, colour = make(np.random.default_rng(stream))
        codes = quantize16(height)
        yield f"{name}_height.png", codes, DATA_SPACE
        yield f"{name}_normal.png", encode_normal(normal_map(codes / 65535.0)), DATA_SPACE
        yield f"{name}_colour.png", encode_srgb(colour), SRGB_SPACE
    yield "sky.exr", sky(), LINEAR_SPACE


def generate(out_dir, seed=0, key="--out"):
    """Write grid.png and the bricks_* / stones_* height, normal and colour maps into out_dir (created if
    needed); the same seed gives byte-identical files. All or nothing: every file is checked and its
    temporary made before the first texture is computed, and all are renamed into place together at the
    end (raytrace/outputs.py); InputError naming `key` and out_dir for a path or a write that fails.
    Returns the written paths."""
    with Outputs() as outputs:
        outputs.make_directory(key, out_dir)
        temporary = {name: outputs.reserve(key, Path(out_dir) / name, given=out_dir) for name in FILES}
        for name, pixels, colour_space in textures(seed):
            with outputs.writing(temporary[name]):
                (write_exr if name.endswith(".exr") else write_png)(temporary[name], pixels, colour_space)
        outputs.commit()
    return [Path(out_dir) / name for name in FILES]
