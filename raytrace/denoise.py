"""Denoising a render with Intel Open Image Denoise (OIDN, https://www.openimagedenoise.org), through PyPI's
pyoidn: the package's `denoise` extra, imported only here and only when asked (`render --denoise`,
render(denoise=True), raytrace.denoise(image)).

OIDN's "RT" filter is a neural network trained on path-traced images; given the beauty's first-hit albedo
and normal (the AOVs of the same render) it keeps the edges and textures the noise would otherwise take with
it. What it is given, as OIDN's documentation asks:
- the beauty as HDR linear radiance (hdr=True: our images are not clamped to [0, 1]; OIDN scales them by
  their own exposure), with its negative values (none from the kernel) raised to 0;
- the albedo in [0, 1] and the normal in [-1, 1] (any space: ours are world-space), NaN and Inf read as 0;
- cleanAux=False unless the auxiliary images are prefiltered: ours are averages of the render's own pixel
  samples, so at a few samples a pixel on an edge, a texture or behind a glass sphere is itself noisy, which
  the network trained on clean aux would keep as detail (OIDN's README: "cleanAux ... should not be enabled
  for noisy auxiliary images"). With `prefilter` the albedo and normal are first denoised by the RT filter
  alone and the beauty's pass then takes them as clean (what OIDN's README calls the highest quality, and
  Blender's "Accurate"); benchmarks/denoise.py measures both, and the default is the one it found closer to
  the reference (docs/performance.md).

The output is H x W x 3 float32, never NaN, Inf or negative (zeroed, and counted in the metadata: OIDN
writes none we have seen, but no file gets one)."""
import importlib

import numpy as np

from .errors import TRUE_OR_FALSE, InputError, missing_extra

EXTRA = "denoise"
MODULE = "pyoidn"
SOURCE = "denoise()"
PREFILTER = False  # the measured choice (benchmarks/denoise.py): see the module's docstring
# The AOVs OIDN takes as its albedo and normal, {OIDN's image: (name, type)} (raytrace/aovs.py): the first
# hit's diffuse reflectance and shading normal, the pair Mitsuba's own denoising (its OptixDenoiser) is given.
AUX = {"albedo": ("albedo", "albedo"), "normal": ("normal", "sh_normal")}
NOISY = "noisy"  # the layer that keeps a denoised Image's noisy beauty: image.aovs["noisy"], noisy.R ... in an EXR


def require(command):
    """The pyoidn module, or InputError naming the `denoise` extra, before any render work: `command` names
    what asked for it (the command line's --denoise, render()'s denoise)."""
    try:
        return importlib.import_module(MODULE)
    except ImportError:  # absent, or a broken install (its library not loadable)
        raise missing_extra(command, EXTRA, [MODULE]) from None


def _check(array, key, shape=None):
    from .image_file import check_array
    return check_array(array, SOURCE, key, shape)


def _prepared(array, low, high):
    """`array` as contiguous float32 in [low, high], NaN and Inf as 0: what OIDN's inputs must be."""
    out = np.nan_to_num(np.asarray(array, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    return np.ascontiguousarray(np.clip(out, low, high), dtype=np.float32)


def _run(oidn, device, images, **flags):
    """One RT filter run over `images` ({slot: array}), its errors raised as RuntimeError."""
    flt = oidn.Filter(device, oidn.OIDN_FILTER_TYPE_RT)
    try:
        for slot, array in images.items():
            flt.set_image(slot, array, oidn.OIDN_FORMAT_FLOAT3)
        for name, value in flags.items():
            flt.set_bool(name, value)
        flt.set_quality(oidn.OIDN_QUALITY_HIGH)
        flt.commit()
        flt.execute()
        error = device.get_error()
        if error is not None:
            raise RuntimeError(f"Open Image Denoise failed: {error}")
    finally:
        flt.release()


def denoised_pixels(beauty, albedo=None, normal=None, prefilter=PREFILTER):
    """The H x W x 3 float32 denoised `beauty` (linear radiance) and the number of values zeroed (NaN, Inf)
    or raised to 0 (negative) in OIDN's output; `albedo` and `normal` as denoise()'s. No argument checks:
    denoise() makes them."""
    oidn = require(SOURCE)
    color = _prepared(beauty, 0.0, np.inf)
    aux = {}
    if albedo is not None:
        aux[oidn.OIDN_IMAGE_ALBEDO] = _prepared(albedo, 0.0, 1.0)
    if normal is not None:
        if albedo is None:  # OIDN takes a normal only beside an albedo
            raise InputError(SOURCE, "normal", None, "needs the albedo too (OIDN takes a normal only with one)")
        aux[oidn.OIDN_IMAGE_NORMAL] = _prepared(normal, -1.0, 1.0)
    output = np.empty_like(color)
    device = oidn.Device()
    try:
        device.commit()
        clean = bool(prefilter and aux)
        if clean:
            for slot, array in aux.items():  # each denoised in place (OIDN's README: "prefiltering")
                _run(oidn, device, {slot: array, oidn.OIDN_IMAGE_OUTPUT: array})
        _run(oidn, device, {oidn.OIDN_IMAGE_COLOR: color, **aux, oidn.OIDN_IMAGE_OUTPUT: output}, hdr=True,
             cleanAux=clean)
    finally:
        device.release()
    bad = ~np.isfinite(output) | (output < 0)
    output[bad] = 0.0
    return output, int(np.count_nonzero(bad))


def denoise(beauty, albedo=None, normal=None, *, prefilter=PREFILTER):
    """Denoise a render with Intel Open Image Denoise (the `denoise` extra: pip install 'raytrace[denoise]').

    beauty: an H x W x 3 image of linear radiance, a raytrace.Image or any array; albedo, normal: H x W x 3
    auxiliary images of the same render (the albedo in [0, 1], the normal in [-1, 1]; values outside are
    clamped), or None: an Image's own AOVs "albedo" and "normal" (render(..., aov="albedo,normal")) where it
    has them, else none (OIDN then sees the beauty alone, and blurs more). prefilter: denoise the albedo and normal
    first and take them as clean (raytrace.denoise's module docstring says which is the default and why).

    Returns an H x W x 3 float32 array; for a raytrace.Image, an Image with its stats, variance (the noisy
    image's) and AOVs, the noisy beauty added as the AOV "noisy", and metadata["denoised"] saying how, so that
    write() keeps both in an EXR; its metadata's estimated RMSE, the noisy image's, is noisy_estimated_rmse.
    InputError for arrays of the wrong shape or type, an Image denoised already (its AOV "noisy" would become
    the once-denoised image) or with an AOV "noisy" of its own, or when pyoidn is missing."""
    from .image import Image
    require(SOURCE)
    pixels = _check(beauty, "beauty")
    aovs = dict(getattr(beauty, "aovs", None) or {})
    if isinstance(beauty, Image) and "denoised" in beauty.metadata:
        raise InputError(SOURCE, "beauty", None, f"is denoised already (its noisy beauty: aovs[{NOISY!r}])")
    if NOISY in aovs:
        raise InputError(SOURCE, "beauty", None, f"has an AOV named {NOISY!r}, where denoising keeps the noisy "
                         "beauty: name the AOV otherwise")
    albedo = aovs.get(AUX["albedo"][0]) if albedo is None else albedo
    normal = aovs.get(AUX["normal"][0]) if normal is None else normal
    albedo = None if albedo is None else _check(albedo, "albedo", pixels.shape)
    normal = None if normal is None else _check(normal, "normal", pixels.shape)
    if not isinstance(prefilter, bool):
        raise InputError(SOURCE, "prefilter", prefilter, TRUE_OR_FALSE)
    output, zeroed = denoised_pixels(pixels, albedo, normal, prefilter)
    if not isinstance(beauty, Image):
        return output
    result = Image.of(output, beauty.variance, beauty.stats, aovs={**aovs, NOISY: np.asarray(beauty)})
    result.metadata = {**beauty.metadata, "denoised": described(albedo is not None, normal is not None, prefilter)}
    if "estimated_rmse" in result.metadata:  # the noisy image's error, not the denoised one's
        result.metadata["noisy_estimated_rmse"] = result.metadata.pop("estimated_rmse")
    if zeroed:
        result.metadata["denoise_zeroed_values"] = zeroed
    return result


def noisy_layers(aovs):
    """The file layer of a denoised image's noisy beauty among its `aovs` ({name: array}), if it has one:
    [(its channel names, the array)] (image_file.write_image_file's `aovs`), else []."""
    return [([f"{NOISY}.{c}" for c in "RGB"], aovs[NOISY])] if NOISY in aovs else []


def aov_request(aov, scene, source, key):
    """render()'s `aov` (None: the scene's AOVs) with the albedo and normal denoising takes added where it lacks
    them, as raytrace/aovs.py's pairs. InputError when it gives one of their names, or "noisy", to another
    type: the denoiser would read the wrong image, or the noisy beauty overwrite an AOV."""
    from . import aovs as aov_types
    pairs = list(scene.aovs if aov is None else aov_types.parse(aov, source, key))
    for name, kind in AUX.values():
        if (name, kind) not in pairs:
            if any(given == name for given, _ in pairs):
                raise InputError(source, key, aov, f"denoising needs the AOV {name!r} to be the {kind}")
            pairs.append((name, kind))
    if any(given == NOISY for given, _ in pairs):
        raise InputError(source, key, aov, f"denoising keeps the noisy image as {NOISY!r}: name the AOV otherwise")
    return aov_types.to_string(pairs)


def described(albedo, normal, prefilter):
    """What the metadata says of a denoised image: the denoiser, its version and what it was given."""
    import pyoidn
    given = "+".join(["beauty"] + ["albedo"] * albedo + ["normal"] * normal)
    aux = ("prefiltered" if prefilter else "noisy") if albedo else ""
    return (f"Intel Open Image Denoise {pyoidn.version.oidn_version}, RT filter, HDR, {given}"
            + (f" ({aux} aux)" if aux else ""))

