"""The per-pixel Z-test that judges one renderer's image against another's (raytrace against Mitsuba 3 in
devtools/peers/xml_check.py): is every difference between the two explained by their noise?

Each image is a Monte Carlo estimate: `mean` (H x W x 3) with `var`, the estimated variance of each value's
mean (of the mean, not of one sample: the caller divides by its sample count, or takes the spread of K
independent renders' means over K). For each of the N = 3HW values

    z = (mean - ref) / sqrt(var + ref_var)

is, where both estimates are unbiased, close to a standard normal variate. A value passes where |z| is at most
the threshold of a two-sided test at level alpha_1, Sidak's correction of alpha for N tests:
alpha_1 = 1 - (1 - alpha)^(1/N), so that, the values being independent, the chance that *any* of the N
exceeds it is alpha (1% by default; N = 64 x 64 x 3 = 12,288 gives alpha_1 = 8.2e-7 and a threshold of
4.93). The image passes where at least `pass_fraction` of its values pass (99.75%), and every tile test
below passes.

Why a Z-test and not an RMSE. An RMSE sums every difference squared into one number whose noise is the
noise of the images themselves: a lobe 2% too bright over a tenth of the image adds 0.04% of the squared
signal there to the mean squared error, lost in the images' own noise at any sample count a test can afford,
and an RMSE has no scale (how small is small enough, at this sample count, on this scene?). The Z-test
divides each difference by its own noise, so a dark, converged pixel is held to a tight bound and a noisy one
to a loose one; its threshold follows from a false-failure rate chosen in advance, not from a tolerance
tuned until the test passes; and it says which pixels fail (side_by_side draws them).

Tiles: a bias smaller than one pixel's noise. A path tracer's pixel at the sample counts a test affords is
noisy: on a small Cornell box of rectangles (xml_check's test scene, 64 x 64), Mitsuba's 4096 samples leave a
median 0.7% of each value, raytrace's 256 1.7%. A 2% bias is then about one standard deviation per value,
and no per-value threshold of ~5 catches it. Summed over a tile of s x s pixels, the bias grows as s^2 and the
noise as s: the same test on the tiles' sums (z = sum(mean - ref) / sqrt(sum(var + ref_var)), per channel)
catches a 2% bias over a tenth of a 64 x 64 image at 3% noise per value (tests/test_judge.py). judge() tests
tiles of 4 and 16 pixels and the whole image (`tiles`; a last tile of a row or column may be smaller), each
scale with its own Sidak threshold at `tile_alpha` = 1e-4 and the same pass_fraction (of a few hundred
tiles, that allows none to fail, or one).

The false-failure rate of the whole test, under the null (both renderers unbiased). With independent,
normal values and exact variances, each |z| exceeds the threshold with probability alpha_1, independently,
so the chance that any value exceeds it is exactly alpha = 1% (Sidak is exact for independent tests). The
image fails only where more than (1 - pass_fraction) N values do: for N = 12,288, 31 or more, when the
expected count is N alpha_1 = 0.01; the binomial chance of that is below 1e-90. Requiring every value to pass
would make the false-failure rate 1%; requiring 99.75% makes the pixels' share of it negligible, and leaves
a margin for what the ideal null leaves out. The tiles' scales, allowed hardly any failure, fail an unbiased
image at their alpha, 1e-4 each: 3e-4 in all, so that a corpus of 30 scenes judged in CI fails falsely about
once in a hundred runs. What the ideal null leaves out:
- variances estimated, not known. With the variance of the mean taken from K chunks' spread, z is a
  Student t variate, heavier-tailed than the normal: with K = 16 on both sides (15 degrees of freedom each),
  P(|z| > 4.93) is 1.8e-4, not 8.2e-7, and some value of 12,288 exceeds the normal threshold in most images
  (tests/test_judge.py measures it). judge() takes each side's degrees of freedom (dof, ref_dof) and then
  maps each t to the normal variate of the same two-sided p-value, with Welch-Satterthwaite's degrees of
  freedom per value (or tile), nu = (sum(var + ref_var))^2 / sum(var^2 / dof + ref_var^2 / ref_dof): the
  thresholds, the z map and the rates stay as stated. Without them (None: the variances exact) the rates are
  those of exact variances. A tile's sum has many more degrees of freedom than a pixel's, and is near normal;
- chunk means that are not normal: a path tracer's samples are skewed (rare bright paths), so a chunk of few
  samples has a skewed mean and one tail of a pixel's z is heavier than the normal's (the tiles' sums are
  nearer normal, being sums of many);
- correlated pixels: a pixel filter wider than a pixel (Mitsuba's default Gaussian) shares samples between
  neighbours. The per-value rate is unchanged but the count of exceedances is over-dispersed (they come in
  clumps), and a tile's variance, summed as if its pixels were independent, is too small. The box filter
  keeps the pixels independent: the corpus's scenes use it;
- fewer than 400 values (N (1 - pass_fraction) < 1): then not one value may fail, and the rate is alpha.

Zero variance. A value that sees only a light (every sample the emitter's radiance) or only black has zero
variance on both sides, and z is 0/0 or x/0. There the two must agree to float32 rounding: |mean - ref| at
most RELATIVE = 1e-5 of the larger of the two plus ABSOLUTE = 1e-9 (per pixel summed, for a tile). The
relative part: the mean of n copies of one float32 value summed in float32 one after another is off by a
number of units in the last place that grows with n (measured over 300 values: up to 3.7e-6 of the value
for n = 256, 7.5e-6 for 512, 1.5e-5 for 1024), so 1e-5 (84 units in the last place) holds for renders of
up to 512 samples per chunk summed per pixel in float32 (Mitsuba's film), and for any summed in float64
(raytrace's passes): the rig's chunks are of 4096 / 16 = 256. The absolute part: 1e-9 is 5,000 times below the 8-bit encoding's first step,
(1/255)^2.2 = 5e-6, and keeps two values that differ by a denormal's rounding equal. The allowance applies
to every value, not only those of zero variance: a light's value whose chunks differ by one rounding has a
variance of ~1e-14 of its square, and a z that means nothing; in a noisy value it is far below the noise and
changes nothing. Such a value's z is 0; one of zero variance outside the allowance has an infinite z and
fails.
"""
import dataclasses
import math

import numpy as np
from scipy import stats

RELATIVE = 1e-5  # float32 rounding allowed between two values (the module's docstring)
ABSOLUTE = 1e-9
TILES = (4, 16, None)  # the tile scales judge() tests besides the pixels' (None: the whole image)
TILE_ALPHA = 1e-4


def sidak_threshold(n, alpha=0.01):
    """The |z| threshold of a two-sided test at level alpha_1 = 1 - (1 - alpha)^(1/n): the chance that any of
    n independent standard normal variates exceeds it is alpha."""
    alpha_1 = -math.expm1(math.log1p(-alpha) / n)
    return float(stats.norm.isf(alpha_1 / 2))


def _tile_sums(a, tile):
    """The sums of H x W x C `a` over tiles of tile x tile pixels (the last of a row or column may be
    smaller), per channel; tile None: over the whole image (1 x 1 x C)."""
    if tile is None:
        return a.sum(axis=(0, 1), keepdims=True)
    if tile == 1:
        return a
    a = np.add.reduceat(a, np.arange(0, a.shape[0], tile), axis=0)
    return np.add.reduceat(a, np.arange(0, a.shape[1], tile), axis=1)


def _check(mean, var, ref, ref_var, dof, ref_dof):
    mean, var, ref, ref_var = (np.asarray(a, dtype=np.float64) for a in (mean, var, ref, ref_var))
    if not (mean.shape == var.shape == ref.shape == ref_var.shape) or mean.ndim != 3:
        raise ValueError(f"judge: the four images must be H x W x C alike: mean {mean.shape}, var {var.shape}, "
                         f"ref {ref.shape}, ref_var {ref_var.shape}")
    if np.any(var < 0) or np.any(ref_var < 0):
        raise ValueError("judge: a negative variance")
    for name, d in (("dof", dof), ("ref_dof", ref_dof)):
        if d is not None and not d > 0:
            raise ValueError(f"judge: {name} = {d!r}: must be positive (None: an exact variance)")
    return mean, var, ref, ref_var


def z_scores(mean, var, ref, ref_var, dof=None, ref_dof=None, tile=1):
    """The float64 z of each value (the module's docstring), H x W x C, or of each tile's sums (tile: pixels
    per side; None: the whole image): (mean - ref) / sqrt(var + ref_var), or, where dof or ref_dof is given
    (the degrees of freedom of the variance estimates; None: exact), the standard normal variate of the same
    two-sided p-value as that t under Welch-Satterthwaite's degrees of freedom (t itself where that p-value
    underflows). 0 where the two agree to
    float32 rounding (RELATIVE, ABSOLUTE); +-inf where they differ beyond it with zero variance, and where
    either value is NaN or infinite."""
    mean, var, ref, ref_var = _check(mean, var, ref, ref_var, dof, ref_dof)
    inverse = lambda d: 0.0 if d is None else 1.0 / d  # noqa: E731
    finite = _tile_sums((np.isfinite(mean) & np.isfinite(ref)).astype(np.float64), tile) == _tile_sums(
        np.ones_like(mean), tile)
    mean, ref = np.nan_to_num(mean), np.nan_to_num(ref)  # the non-finite ones' z is set below
    size = _tile_sums(np.ones_like(mean), tile)
    m, r = _tile_sums(mean, tile), _tile_sums(ref, tile)
    total = _tile_sums(var + ref_var, tile)
    dfterm = _tile_sums(var ** 2 * inverse(dof) + ref_var ** 2 * inverse(ref_dof), tile)
    diff = m - r
    rounding = np.abs(diff) <= RELATIVE * np.maximum(np.abs(m), np.abs(r)) + ABSOLUTE * size
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        z = diff / np.sqrt(total)
        nu = total ** 2 / dfterm  # inf where the variances are exact; NaN where they are 0
        t = np.abs(z)
        mapped = np.isfinite(t) & np.isfinite(nu) & (nu > 0)
        # the same one-sided tail probability as a normal variate; where it underflows, t itself (larger than
        # that variate: a failure either way, and finite)
        tail = stats.t.sf(t[mapped], nu[mapped])
        z[mapped] = np.sign(z[mapped]) * np.where(tail > 0, stats.norm.isf(tail), t[mapped])
    z[np.isnan(z)] = np.inf  # 0/0 outside the rounding allowance
    z[rounding] = 0.0
    z[~finite] = np.inf
    return z


def _plain(v):
    """v as JSON-ready values: an infinite or NaN number as the string "inf", "-inf" or "nan" (strict JSON
    has none)."""
    if isinstance(v, (tuple, list)):
        return [_plain(x) for x in v]
    if dataclasses.is_dataclass(v):
        return v.as_dict()
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else str(float(v))
    return v


@dataclasses.dataclass(frozen=True)
class Scale:
    """The test at one tile size (`tile` pixels per side; None: the whole image): `n` tile values (tiles x
    channels), Sidak's `threshold` at `alpha`, `failures` of which at most `allowed` for `passed`, the largest
    |z| `worst_z` at the tile whose first value is `worst_at` (row, column, channel). `z` is the tiles' map
    (not in as_dict)."""
    tile: int | None
    n: int
    alpha: float
    threshold: float
    failures: int
    allowed: int
    passed: bool
    worst_z: float
    worst_at: tuple
    z: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)

    def as_dict(self):
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name != "z"}


def _scale(z, tile, alpha, pass_fraction):
    n = z.size
    threshold = sidak_threshold(n, alpha)
    failures = int(np.count_nonzero(~(np.abs(z) <= threshold)))
    allowed = math.floor(round((1.0 - pass_fraction) * n, 9))
    worst = np.unravel_index(int(np.argmax(np.abs(z))), z.shape)
    step = 1 if tile is None else tile
    at = (worst[0] * step, worst[1] * step, worst[2])
    return Scale(tile=tile, n=n, alpha=alpha, threshold=threshold, failures=failures, allowed=allowed,
                 passed=failures <= allowed, worst_z=float(np.abs(z[worst])), worst_at=tuple(int(i) for i in at),
                 z=z)


@dataclasses.dataclass(frozen=True)
class Verdict:
    """judge()'s result. The pixels' test: `fraction` of the `n` values pass (|z| <= threshold); `failures` =
    n - passing, at most `allowed` = floor((1 - pass_fraction) n); `worst_z` is the largest |z| (inf: a
    zero-variance value that differs) at `worst_pixel` = (row, column, channel). `tiles`: the Scale of each
    tile size. `passed` where the pixels' test and every tile's pass. `bias` per channel is sum(mean) /
    sum(ref) - 1 over the image, `bias_z` its z (the whole image's tile). `z` is the pixels' map (not in
    as_dict)."""
    passed: bool
    fraction: float
    threshold: float
    n: int
    failures: int
    allowed: int
    worst_z: float
    worst_pixel: tuple
    bias: tuple
    bias_z: tuple
    alpha: float
    pass_fraction: float
    dof: float | None = None
    ref_dof: float | None = None
    tiles: tuple = ()
    z: np.ndarray = dataclasses.field(default=None, repr=False, compare=False)

    def as_dict(self):
        """The verdict as JSON-ready values (no z maps; an infinite or NaN number as a string)."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name != "z"}

    def failing_tiles(self):
        """H x W bool: the pixels of every failing tile, of any size but the whole image's (whose failure
        would cover the map)."""
        mask = np.zeros(self.z.shape[:2], bool)
        for s in self.tiles:
            if s.tile is None:
                continue
            bad = np.any(~(np.abs(s.z) <= s.threshold), axis=2)
            mask |= np.repeat(np.repeat(bad, s.tile, axis=0), s.tile, axis=1)[:mask.shape[0], :mask.shape[1]]
        return mask


def _ratio(num, den):
    if den != 0:
        return float(num / den)
    return 0.0 if num == 0 else math.copysign(math.inf, num)


def judge(mean, var, ref, ref_var, alpha=0.01, pass_fraction=0.9975, dof=None, ref_dof=None, tiles=TILES,
          tile_alpha=TILE_ALPHA):
    """The Verdict of the Z-test of `mean` (variance of each value's mean `var`, with `dof` degrees of freedom;
    None: exact) against `ref` (`ref_var`, `ref_dof`): H x W x 3 arrays; the pixels at `alpha`, each tile size
    of `tiles` at `tile_alpha`, each with pass_fraction. The module's docstring says what it tests and how
    often it fails an unbiased image."""
    for name, value in (("alpha", alpha), ("pass_fraction", pass_fraction), ("tile_alpha", tile_alpha)):
        if not 0 < value < 1 and not (name == "pass_fraction" and value == 1):
            raise ValueError(f"judge: {name} = {value!r}: must be in (0, 1)")
    pixels = _scale(z_scores(mean, var, ref, ref_var, dof, ref_dof), 1, alpha, pass_fraction)
    scales = tuple(_scale(z_scores(mean, var, ref, ref_var, dof, ref_dof, tile), tile, tile_alpha, pass_fraction)
                   for tile in tiles)
    sums = [np.sum(np.nan_to_num(np.asarray(a, np.float64)), axis=(0, 1)) for a in (mean, ref)]
    bias = tuple(_ratio(s - r, r) if r != 0 else _ratio(s, r) for s, r in zip(*sums))
    whole = next((s.z for s in scales if s.tile is None), None)
    if whole is None:
        whole = z_scores(mean, var, ref, ref_var, dof, ref_dof, None)
    return Verdict(passed=pixels.passed and all(s.passed for s in scales), fraction=1.0 - pixels.failures / pixels.n,
                   threshold=pixels.threshold, n=pixels.n, failures=pixels.failures, allowed=pixels.allowed,
                   worst_z=pixels.worst_z, worst_pixel=pixels.worst_at, bias=bias,
                   bias_z=tuple(float(v) for v in whole.ravel()), alpha=alpha, pass_fraction=pass_fraction,
                   dof=dof, ref_dof=ref_dof, tiles=scales, z=pixels.z)


def _srgb8(linear):
    """8-bit sRGB of linear values clipped to [0, 1]."""
    x = np.clip(np.nan_to_num(linear, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    encoded = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    return np.round(255.0 * encoded).astype(np.uint8)


def side_by_side(mean, ref, z, path, threshold=None, exposure=None, flagged=None):
    """Write to `path` (a PNG, by OpenImageIO) three panels side by side: `mean` (raytrace), `ref` (Mitsuba)
    and the |z| map. The images are the sRGB encoding of the clipped linear values times `exposure` (default:
    1 over the reference's 90th percentile value, the same for both: a light seen directly is clipped); the
    map is grey, |z| / threshold per pixel (its largest channel; threshold default: Sidak's at 1% for z's
    size), white at the threshold, red where a value fails, and tinted orange (half the grey, half orange)
    where the H x W bool `flagged` (Verdict.failing_tiles()) is set on a pixel that does not fail itself.
    Small images are enlarged by whole pixels to at least 256 rows."""
    import OpenImageIO as oiio
    mean, ref, z = (np.asarray(a, dtype=np.float64) for a in (mean, ref, z))
    if threshold is None:
        threshold = sidak_threshold(z.size)
    if exposure is None:
        finite = ref[np.isfinite(ref)]
        top = float(np.percentile(finite, 90)) if finite.size else 0.0
        exposure = 1.0 / top if top > 0 else 1.0
    level = np.max(np.nan_to_num(np.abs(z), nan=np.inf), axis=2) / threshold
    zmap = np.repeat(np.round(255.0 * np.clip(level, 0.0, 1.0))[..., None], 3, axis=2).astype(np.uint8)
    if flagged is not None:
        flagged = np.asarray(flagged, bool)
        zmap[flagged] = np.round(0.5 * zmap[flagged] + (127.5, 80.0, 0.0)).astype(np.uint8)
    zmap[level > 1] = (255, 0, 0)
    height = z.shape[0]
    scale = max(1, math.ceil(256 / height))
    gap = np.full((height * scale, max(2, scale), 3), 64, np.uint8)
    panels = [np.repeat(np.repeat(p, scale, axis=0), scale, axis=1)
              for p in (_srgb8(mean * exposure), _srgb8(ref * exposure), zmap)]
    pixels = np.ascontiguousarray(np.concatenate([panels[0], gap, panels[1], gap, panels[2]], axis=1))
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], 3, oiio.UINT8)):
        raise OSError(f"side_by_side: cannot write {path}: {oiio.geterror()}")
    ok = out.write_image(pixels)
    out.close()
    if not ok:
        raise OSError(f"side_by_side: cannot write {path}: {out.geterror()}")
