"""What the path model's tests share (kernels/path_tracing.cl): the furnace scene, the test of an image's mean
against its expected value, the kernel that traces paths from chosen surface points by the renderer's
estimator or by one of two simpler ones of its own (ESTIMATORS), the test that the estimators agree, the
specular BSDFs' build options and Fresnel reference, and the sphere in a constant environment.

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


# The start of every path-tracing test kernel: ESTIMATE(s, ts, r, hit, sp, light_samples, ps, rays), the radiance
# along the camera ray r, whose first hit is `hit`, shaded at sp, by the estimator ESTIMATOR names: 0, the renderer's
# (path_tracing.cl's trace_path: light sampled both ways, combined by MIS), or, with CUT, the same stopped before the
# ray of the last vertex max_depth allows is traced (trace_path's cut); 1 and 2, this file's own path tracers,
# written from the BSDF interface (bsdf.cl), light_sampling.cl, the closest hit and the environment alone, so that
# the renderer's MIS weights, which add to 1 over the two techniques, are checked against estimators that have none.
# 1 samples the lights (by area or, LIGHT_SOLID_ANGLE, by solid angle) and the environment (by its map, or constant,
# by the cosine about the normal) at every vertex, and counts what the BSDF's sample reaches only where no such
# sample could have met it: a delta lobe's direction, or one not above both ng and n (through glass, say); 2 counts
# what the BSDF's sample reaches, always, and samples nothing else. Both end paths by the renderer's Russian roulette
# (roulette.cl: from vertex rr_depth, q = min(max(throughput), 0.95)); any roulette keeps them unbiased. 1 counting
# what the BSDF's sample reaches everywhere, a light sample without its cos(theta_l), or the environment's samples
# scaled by 0.9 fail the tests that use them (seen).
ESTIMATORS = """
#ifndef CUT
#define CUT 0
#endif
#if ESTIMATOR == 0
#include "path_tracing.cl"
#define ESTIMATE(s, ts, r, hit, sp, samples, ps, rays) trace_path(s, ts, r, hit, sp, samples, ps, rays, CUT)
#else
#include "vmath.h"
#include "bsdf.cl"
#include "warp.cl"
#include "roulette.cl"

/* light_sampling.cl's model: a sample counts above the surface (ng and n) and in front of the light, and
 * weighs f cos(theta_s) cos(theta_l) / r^2 (a colour, bsdf.cl's value), times the light's area over the
 * sample count (lights_sum): no MIS weight. Sampled by solid angle (solid_angle > 0), 1 / p_light =
 * solid_angle, and the area's factor is undone. */
#define LIGHT_VALUE_VEC3 1
inline vint sample_counts(ShadingPoint sp, vec3 l, vec3 light_normal)
{
    return (v3_dot(sp.ng, l) > 0.0f) & (v3_dot(sp.n, l) > 0.0f) & (v3_dot(light_normal, l) < 0.0f);
}
#if LIGHT_SOLID_ANGLE
inline vec3 sample_weight(ShadingPoint sp, vec3 w, vec3 l, vec3 light_normal, vec3 v, float area, int n,
                          vint active, vfloat solid_angle)
{
    vfloat g = SELECT(-v3_dot(light_normal, l) / v3_dot(w, w), solid_angle / area, solid_angle > 0.0f);
    return v3_scale(bsdf_eval(sp, v, l, active), g);
}
#else
inline vec3 sample_weight(ShadingPoint sp, vec3 w, vec3 l, vec3 light_normal, vec3 v, float area, int n,
                          vint active)
{
    return v3_scale(bsdf_eval(sp, v, l, active), -v3_dot(light_normal, l) / v3_dot(w, w));
}
#endif
inline float light_scale(__global const Light *light) { return 4.0f * light->shape.half_x * light->shape.half_y; }
#include "light_sampling.cl"
#if HAS_ENVIRONMENT
#include "environment.cl"
#endif

/* ESTIMATOR 1 (lights) or 2 (the BSDF alone), as above. */
inline vec3 trace_alone(const Scene *s, TextureStore ts, Ray r, Hit hit, ShadingPoint sp,
                        __global const uint2 *light_samples, PixelSample *ps, vfloat *rays)
{
    const int max_depth = s->params->max_depth, lights = ESTIMATOR == 1;
    Sampler bounce = s->params->light_sampler;
    if (bounce.randomize != RANDOMIZE_SOBOL)
        bounce.randomize = RANDOMIZE_INDEPENDENT;
    const vec3 zero = v3_splat(0.0f, 0.0f, 0.0f);
    vec3 beta = v3_splat(1.0f, 1.0f, 1.0f), radiance = zero;
    vint alive = (vint)(-1) != 0, whole = alive; /* whole: what the ray reaches counts */
    for (int depth = 1;; ++depth) {
        if (max_depth != 0) {
            vint lit = alive & whole & (hit.t < INFINITY);
            radiance = v3_add(radiance, v3_select(zero, v3_mul(beta, hit.emitted), lit));
#if HAS_ENVIRONMENT
            vint escaped = alive & whole & (hit.t == INFINITY);
            if (ANY(escaped))
                radiance = v3_add(radiance, v3_select(zero, v3_mul(beta, environment_radiance(s, r.d, escaped)),
                                                      escaped));
#endif
        }
        alive &= (hit.t < INFINITY) & (hit.material >= 0);
        if (max_depth >= 0 && depth >= max_depth)
            alive = (vint)(0) != 0;
        if (!ANY(alive))
            return radiance;
        const vec3 wo = v3_scale(r.d, -1.0f);
        if (lights) {
            const vint smooth = alive & !bsdf_is_delta(sp);
            vec3 direct = lights_sum(s, sp, wo, smooth, light_samples, ps, rays);
            radiance = v3_add(radiance, v3_select(zero, v3_mul(beta, direct), alive));
#if HAS_ENVIRONMENT
            vec2 ue = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0));
            if (ANY(smooth)) {
#if HAS_ENVIRONMENT_MAP
                vfloat pdf_e;
                vec3 we = sample_environment(s, ue, smooth, &pdf_e);
#else
                vec3 we = cosine_direction(sp.n, ue);
                vfloat pdf_e = v3_dot(sp.n, we) * M_1_PI_F;
#endif
                vint sampled = smooth & (v3_dot(sp.ng, we) > 0.0f) & (v3_dot(sp.n, we) > 0.0f) & (pdf_e > 0.0f);
                Ray towards = {offset_ray_origin(sp.p, sp.err, sp.ng), we};
                vint open = sampled & (closest_hit(s, towards, SELECT((vfloat)(-1.0f), (vfloat)(INFINITY),
                                                                        sampled)).t == INFINITY);
                if (ANY(open)) {
                    vec3 e = v3_mul(bsdf_eval(sp, wo, we, open), environment_radiance(s, we, open));
                    radiance = v3_add(radiance, v3_select(zero, v3_mul(beta, v3_scale(e, 1.0f / pdf_e)), open));
                }
            }
#endif
        }
        vec2 u = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0));
        vec2 v = stream_2d(light_samples, bounce, next_stream(ps, bounce, 1), (vint)(0));
        BSDFSample bs = bsdf_sample(sp, wo, v.y, u, alive);
        vfloat cos_g = v3_dot(sp.ng, bs.wi);
        alive &= (bs.pdf > 0.0f) & SELECT(cos_g > 0.0f, cos_g < 0.0f, bs.transmit);
        beta = v3_select(beta, v3_mul(beta, bs.weight), alive);
        alive &= russian_roulette(alive & ((vint)(depth) >= s->params->rr_depth), v.x, &beta);
        whole = bs.delta | (cos_g <= 0.0f) | (v3_dot(sp.n, bs.wi) <= 0.0f);
        if (!lights)
            whole = (vint)(-1) != 0;
        r.o = offset_ray_origin(sp.p, sp.err, v3_select(sp.ng, v3_scale(sp.ng, -1.0f), bs.transmit));
        r.d = bs.wi;
        *rays += MASK_TO_ONE(alive);
        hit = closest_hit(s, r, SELECT((vfloat)(-1.0f), (vfloat)(INFINITY), alive));
        sp = shading_point(s, ts, r, hit);
    }
}
#define ESTIMATE trace_alone
#endif
"""


# The end of a test kernel that traces paths from a surface point, once s, ts, r, hit and sp are made: the
# mean of ESTIMATE over pixel samples 0 .. samples-1 written to out (TRACE's, and the rough conductor's).
PATH_MEAN = """    vfloat rays = 0.0f;
    vuint key = pixel_key(AS_VUINT(I * LANES + LANE_IDS), s.params->seed);
    vec3 sum = v3_splat(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < samples; ++i) {
        PixelSample ps = start_pixel_sample(key, (vint)(i));
        ps.dimension = 1;
        sum = v3_add(sum, ESTIMATE(&s, ts, r, hit, sp, light_samples, &ps, &rays));
    }
    OUT3(out, v3_scale(sum, 1.0f / (float)samples));
}
"""


TRACE = ESTIMATORS + SURFACE_POINT + """
/* Lane i's estimate of the radiance leaving p (normal nrm, albedo 1 there) towards a viewer above it: the mean
 * of ESTIMATE over pixel samples 0 .. samples-1, as render.cl traces a camera ray's hit. */
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


def traced(harness, scene, p, n, sampling, lanes=1024, samples=16, shaded=False, solid_angle=False, cut=False,
           **defines_too):
    """(cases, lanes) estimates of the red channel leaving points p by the estimator `sampling` (ESTIMATORS'
    ESTIMATOR: 0 the renderer's MIS, 1 the lights alone, 2 the BSDF alone); with `shaded`, the points have
    material 0's BSDF, else a white Lambertian one; with `solid_angle`, the lights sampled by solid angle
    (LIGHT_SOLID_ANGLE); with `cut` (MIS), no ray traced from the last vertex max_depth allows; defines_too,
    more build options."""
    pattern = samplers.pattern("sobol", 1)
    features = dataclasses.replace(Features.of(scene, harness.lanes), direct_lighting=False, path_tracing=True)
    defines = dict(option[2:].split("=") for option in features.options() if not option.startswith("-DLANES"))
    args = {**scene_args(scene, light_samples=1, light_pattern=pattern, features=features),
            **texture_tables(scene), "light_samples": pattern.table(), "p": planar(np.repeat(p, lanes, axis=0)),
            "nrm": planar(np.repeat(n, lanes, axis=0)), "samples": np.int32(samples)}
    out = harness.run(TRACE, "trace", len(p) * lanes, args, {"out": 3}, **defines, ESTIMATOR=sampling,
                      SHADED=int(shaded), LIGHT_SOLID_ANGLE=int(solid_angle), CUT=int(cut), **defines_too)["out"]
    return out[0].reshape(len(p), lanes)


def assert_techniques_agree(est):
    """The three estimators' means (ESTIMATOR 0, 1, 2: {k: (cases, lanes)}) agree pairwise within 5
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
