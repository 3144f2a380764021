"""What the path model's tests share (kernels/path_tracing.cl): the furnace scene, the test of an image's mean
against its expected value, the kernel that traces paths from chosen surface points with either technique or
both, the test that the techniques agree, the specular BSDFs' build options and Fresnel reference, and the
sphere in a constant environment.

Estimates are compared with their expected values through their standard errors: each pixel (or lane) is an
independent estimate (its own randomisation of the sequence, kernels/samplers.cl), so the mean over n of them
has a standard error of sd / sqrt(n), sd their spread. The checks allow 5 standard errors: a chance of about
6e-7 per comparison for a normal mean (the central limit holds well over thousands of pixels of these
bounded-variance cases), plus 1e-5 relative for float32 rounding, far below that."""
import dataclasses

import numpy as np

import raytrace
from raytrace import samplers
from raytrace.renderer.packing import texture_tables
from raytrace.renderer.program import Features
from raytrace.commands.stability.probe import planar, scene_args

from helpers import SURFACE_POINT


# The furnace's six walls: each a light's centre (and inward normal, its negation) and tangent.
FACES = [([1, 0, 0], [0, 1, 0]), ([-1, 0, 0], [0, 1, 0]), ([0, 1, 0], [0, 0, 1]), ([0, -1, 0], [0, 0, 1]),
         ([0, 0, 1], [1, 0, 0]), ([0, 0, -1], [1, 0, 0])]


def furnace(albedo, radiance=1.0, max_depth=-1):
    """A closed cube of six lights of `radiance` facing in, each reflecting with a diffuse albedo, the camera
    at its centre: every path from the camera meets a wall at every vertex."""
    return raytrace.load_dict({
        "camera": {"position": [0.1, -0.2, 0.05], "look_at": [0.3, 1.0, 0.2], "up": [0, 0, 1], "fov": 100.0},
        "image": {"width": 48, "height": 48},
        "render": {"shading": "path", "max_depth": max_depth},
        "materials": {"grey": {"colour": [albedo] * 3}},
        "lights": [{"center": c, "size": [2.0, 2.0], "normal": [-x for x in c], "tangent": t, "radiance": radiance,
                    "material": "grey"} for c, t in FACES]})


def assert_mean(image, expected):
    pixels = np.asarray(image).reshape(-1, 3)
    mean, se = pixels.mean(axis=0), pixels.std(axis=0, ddof=1) / np.sqrt(len(pixels))
    assert np.all(np.abs(mean - expected) <= 5 * se + 1e-5 * expected), (mean, se, expected)
    return mean, se


# The end of a test kernel that traces paths from a surface point, once s, ts, r, hit and sp are made: the
# mean of trace_path over pixel samples 0 .. samples-1 written to out (TRACE's, and the rough conductor's).
PATH_MEAN = """    vfloat rays = 0.0f;
    vuint key = pixel_key(AS_VUINT(I * LANES + LANE_IDS), s.params->seed);
    vec3 sum = v3_splat(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < samples; ++i) {
        PixelSample ps = start_pixel_sample(key, (vint)(i));
        ps.dimension = 1;
        sum = v3_add(sum, trace_path(&s, ts, r, hit, sp, light_samples, &ps, &rays));
    }
    OUT3(out, v3_scale(sum, 1.0f / (float)samples));
}
"""


TRACE = """
#include "path_tracing.cl"
""" + SURFACE_POINT + """/* Lane i's estimate of the radiance leaving p (normal nrm, albedo 1 there) towards a viewer above it: the mean of
 * trace_path over pixel samples 0 .. samples-1, as render.cl traces a camera ray's hit. */
__kernel void trace(int n, SCENE_PARAMETERS, TEXTURE_PARAMETERS, __global const uint2 *light_samples,
                    __global const float *p, __global const float *nrm, int samples, __global float *out)
{
    const Scene s = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    vec3 at = IN3(p), normal = IN3(nrm);
    Ray r;
    Hit hit = surface_hit(at, normal, &r);
#if SHADED /* material 0's BSDF */
    ShadingPoint sp = shading_point(&s, ts, r, hit);
#else /* a white Lambertian surface */
    ShadingPoint sp = white(at, normal);
#endif
""" + PATH_MEAN


def traced(harness, scene, p, n, sampling, lanes=1024, samples=16, shaded=False, solid_angle=False, **defines_too):
    """(cases, lanes) estimates of the red channel leaving points p, light reaching them sampled as
    `sampling` says (path_tracing.cl's PATH_SAMPLING: 0 MIS, 1 the lights alone, 2 the BSDF alone); with
    `shaded`, the points have material 0's BSDF, else a white Lambertian one; with `solid_angle`, the lights
    sampled by solid angle (LIGHT_SOLID_ANGLE); defines_too, more build options (RR_DEPTH)."""
    pattern = samplers.pattern("sobol", 1)
    features = dataclasses.replace(Features.of(scene, harness.lanes), direct_lighting=False, path_tracing=True)
    defines = dict(option[2:].split("=") for option in features.options() if not option.startswith("-DLANES"))
    args = {**scene_args(scene, light_samples=1, light_pattern=pattern, features=features),
            **texture_tables(scene), "light_samples": pattern.table(), "p": planar(np.repeat(p, lanes, axis=0)),
            "nrm": planar(np.repeat(n, lanes, axis=0)), "samples": np.int32(samples)}
    out = harness.run(TRACE, "trace", len(p) * lanes, args, {"out": 3}, **defines, PATH_SAMPLING=sampling,
                      SHADED=int(shaded), LIGHT_SOLID_ANGLE=int(solid_angle), **defines_too)["out"]
    return out[0].reshape(len(p), lanes)


def assert_techniques_agree(est):
    """The three estimators' means (PATH_SAMPLING 0, 1, 2: {k: (cases, lanes)}) agree pairwise within 5
    standard errors of each difference, plus float32 rounding; returns (means, standard errors)."""
    mean = {k: e.mean(axis=1) for k, e in est.items()}
    se = {k: e.std(axis=1, ddof=1) / np.sqrt(e.shape[1]) for k, e in est.items()}
    for a, b in ((0, 1), (0, 2), (1, 2)):
        bound = 5 * np.hypot(se[a], se[b]) + 1e-5 * np.abs(mean[a])
        assert np.all(np.abs(mean[a] - mean[b]) <= bound), (a, b, mean, se)
    return mean, se


# The build options of the test kernels of the BSDFs (Fresnel, the specular and the diffuse samples).
SPECULAR = dict(HAS_PATH_TRACING=1, HAS_CONDUCTORS=1, HAS_DIELECTRICS=1, HAS_RECTANGLES=1)


def fresnel_reference(cos_i, eta, k):
    """Unpolarised Fresnel reflectance of the interface to a medium of complex index eta + i k (relative), in
    complex float64 (Born and Wolf): the conductor's, and with k = 0 the dielectric's (1 beyond the critical
    angle, where the complex cos_t is imaginary and |r| = 1 exactly)."""
    n = eta + 1j * k
    sin2_t = (1 - cos_i**2) / n**2
    cos_t = np.sqrt(1 - sin2_t + 0j)
    cos_t = np.where(cos_t.imag < 0, -cos_t, cos_t)  # the decaying wave: Im(n cos_t) >= 0
    r_s = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    r_p = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    return 0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)


def environment_scene(material, radiance=1.0):
    """One sphere of `material` in a constant environment, filling the middle of the image; no light: the
    environment alone lights it."""
    return raytrace.load_dict({
        "camera": {"position": [0.0, -3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0, 0, 1], "fov": 40.0},
        "image": {"width": 64, "height": 64}, "render": {"shading": "path"},
        "environment": {"type": "constant", "radiance": radiance},
        "materials": {"m": material},
        "lights": [],
        "shapes": [{"type": "ellipsoid", "material": "m", "center": [0, 0, 0],
                    "axes": [[0.8, 0, 0], [0, 0.8, 0], [0, 0, 0.8]]}]})
