/* The radiometric models' environment emitter (`[environment]`, docs/global-illumination.md): the radiance arriving
 * along every direction in which a ray leaves the scene. HAS_ENVIRONMENT builds it; `constant` is one radiance
 * everywhere (RenderParams.environment), `envmap` (HAS_ENVIRONMENT_MAP) an equirectangular image times that
 * value (its `scale`).
 *
 * The map follows Mitsuba 3's `envmap`: in the map's frame (environment_x, _y, _z: the world directions of
 * its local axes) a unit direction d has u = atan2(d.x, -d.z) / (2 pi) in [0, 1) and v = acos(d.y) / pi, so
 * the top row looks along +y, the image's centre along +z and u = 1/4 along +x. Texel (i, j) sits at u = (i +
 * 1/2) / w and, as in Mitsuba, v = j / (h - 1): the first row at the zenith, the last at the nadir (h >= 2).
 * The radiance between texels is bilinear, wrapping in u.
 *
 * Directions are sampled by a piecewise-constant 2D distribution (pbrt-v4's PiecewiseConstant2D, section
 * A.5.3 of the book; for environment maps pbrt-v3 section 14.2.4) over w x (h - 1) cells: cell (i, j) spans u
 * in [i, i + 1] / w and v in [j, j + 1] / (h - 1), between two rows. A row of cells is drawn by the marginal
 * distribution, then a cell by the row's conditional one, each by inverting its cumulative table, and (u, v)
 * uniformly within the cell. The host (raytrace/renderer/packing.py's environment_weights) weighs each cell
 * by the luminance the bilinear radiance has on average over it (its two rows' mean, their neighbours in u
 * weighing 1/8 each, so no direction with light has density 0) times sin(theta) at its centre, the area it
 * spans on the sphere. The density per steradian is p(u, v) / (2 pi^2 sin(theta)).
 *
 * The densities are read from the same float32 cumulative tables the sampling inverts: a texel's probability
 * is the difference of two table entries, which is exactly how often a uniform number lands between them, so
 * the density a direction is given is the one it was drawn with, however the tables rounded.
 *
 * environment_map holds, in floats: the texels' RGB, rows top to bottom (3 w h); the marginal table over the
 * rows of cells (h entries from 0 to exactly 1); then each row's conditional table (w + 1 entries each). */
#ifndef ENVIRONMENT_CL
#define ENVIRONMENT_CL

#include "scene.h"
#include "intersect.cl" /* (escapes: the shadow rays towards it) */

#if HAS_ENVIRONMENT_MAP
#define M_1_2PI_F (0.5f * M_1_PI_F)

/* The map's (u, v) of the unit world direction d. */
inline float2 environment_uv(__constant const RenderParams *p, float3 d)
{
    float x = dot(d, f3(p->environment_x)), y = dot(d, f3(p->environment_y)), z = dot(d, f3(p->environment_z));
    float u = atan2(x, -z) * M_1_2PI_F;
    u = u < 0.0f ? u + 1.0f : u;
    /* fmax and fmin return the number of a number and a NaN: a lane's garbage direction still reads in bounds */
    u = fmax(u, 0.0f);
    return (float2)(u < 1.0f ? u : 0.0f, fmin(fmax(acos(clamp(y, -1.0f, 1.0f)) * M_1_PI_F, 0.0f), 1.0f));
}

/* The texel's RGB, column i in [-1, w] wrapped. */
inline float3 environment_texel(__constant const RenderParams *p, __global const float *map, int i, int j)
{
    const int w = p->environment_width;
    i = i < 0 ? i + w : (i >= w ? i - w : i);
    __global const float *t = map + 3 * (j * w + i);
    return (float3)(t[0], t[1], t[2]);
}

/* The map's radiance along the unit world direction d (before its scale), bilinear between texels. */
inline float3 environment_lookup(__constant const RenderParams *p, __global const float *map, float3 d)
{
    float2 uv = environment_uv(p, d);
    float x = uv.x * (float)p->environment_width - 0.5f, y = uv.y * (float)(p->environment_height - 1);
    float fx = floor(x), fy = clamp(floor(y), 0.0f, (float)(p->environment_height - 2));
    int i = (int)fx, j = (int)fy;
    float a = x - fx, b = clamp(y - fy, 0.0f, 1.0f);
    float3 top = mix(environment_texel(p, map, i, j), environment_texel(p, map, i + 1, j), a);
    float3 bottom = mix(environment_texel(p, map, i, j + 1), environment_texel(p, map, i + 1, j + 1), a);
    return mix(top, bottom, b);
}

/* The index k in [0, n) of the cumulative table's step holding x in [0, 1): the last k with cdf[k] <= x
 * (cdf[0] = 0, cdf[n] = 1), so that cdf[k + 1] > x and the step has a positive probability. */
inline int cdf_step(__global const float *cdf, int n, float x)
{
    int lo = 0, hi = n;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (cdf[mid] <= x)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* The density per unit (u, v) of the cell (i, j) (clamped into the w x (h - 1) cells): its probability times
 * their count. */
inline float environment_uv_density(__constant const RenderParams *p, __global const float *map, int i, int j)
{
    const int w = p->environment_width, h = p->environment_height - 1;
    i = clamp(i, 0, w - 1);
    j = clamp(j, 0, h - 1);
    __global const float *marginal = map + 3 * w * (h + 1), *conditional = marginal + (h + 1) + j * (w + 1);
    return (marginal[j + 1] - marginal[j]) * (conditional[i + 1] - conditional[i]) * (float)(w * h);
}

/* The density per steradian with which environment_sample draws the unit world direction d. */
inline float environment_density(__constant const RenderParams *p, __global const float *map, float3 d)
{
    float2 uv = environment_uv(p, d);
    float sin_theta = sin(uv.y * M_PI_F);
    float density = environment_uv_density(p, map, (int)(uv.x * (float)p->environment_width),
                                            (int)(uv.y * (float)(p->environment_height - 1)));
    return sin_theta > 0.0f ? density / (2.0f * M_PI_F * M_PI_F * sin_theta) : 0.0f;
}

/* A world direction drawn from the map's distribution by the uniform point xi, and *density its density per
 * steradian (0 at the poles, where the map's parametrisation folds: such a sample carries no weight). */
inline float3 environment_sample(__constant const RenderParams *p, __global const float *map, float2 xi,
                                 float *density)
{
    const int w = p->environment_width, h = p->environment_height - 1; /* cells */
    __global const float *marginal = map + 3 * w * (h + 1);
    int j = cdf_step(marginal, h, xi.y);
    __global const float *conditional = marginal + (h + 1) + j * (w + 1);
    int i = cdf_step(conditional, w, xi.x);
    float pv = marginal[j + 1] - marginal[j], pu = conditional[i + 1] - conditional[i];
    float u = ((float)i + clamp((xi.x - conditional[i]) / pu, 0.0f, 1.0f)) / (float)w;
    float v = ((float)j + clamp((xi.y - marginal[j]) / pv, 0.0f, 1.0f)) / (float)h;
    float phi = 2.0f * M_PI_F * u, theta = M_PI_F * v;
    float sin_theta = sin(theta), cos_theta = cos(theta);
    float3 l = (float3)(sin(phi) * sin_theta, cos_theta, -cos(phi) * sin_theta);
    float uv_density = pv * pu * (float)(w * h);
    *density = sin_theta > 0.0f ? uv_density / (2.0f * M_PI_F * M_PI_F * sin_theta) : 0.0f;
    return l.x * f3(p->environment_x) + l.y * f3(p->environment_y) + l.z * f3(p->environment_z);
}
#endif

/* The lanes of `active` whose ray from o along the unit d leaves the scene: no shape and no light meets it
 * before it is beyond every coordinate the scene has (the segment to o + 4 extent d, |o| being within
 * sqrt(3) extent of the origin). */
inline vint escapes(const Scene *s, vec3 o, vec3 d, vint active PASSES_PARAMETER)
{
    Ray r = {o, v3_scale(d, 4.0f * s->params->scene_extent)};
    vint blocked = occluded(s, r, 0u, active PASSES(passes) OWN(-1));
    vfloat dt, u, v;
    for (int i = 0; i < s->params->n_lights; ++i) {
        vfloat t = intersect_rectangle(&s->lights[i].shape, r, (vfloat)(1.0f), &dt, &u, &v);
        blocked |= hit_on_segment(t, dt);
    }
    return active & !blocked;
}

/* The environment's radiance along each lane's unit direction d, in the lanes of `lanes` (0 in the others: a
 * map's lookups are one lane at a time, and a packet's lanes seldom all need one). */
inline vec3 environment_radiance(const Scene *s, vec3 d, vint lanes)
{
    const vec3 scale = v3_uniform(s->params->environment);
#if HAS_ENVIRONMENT_MAP
    float x[LANES], y[LANES], z[LANES], r[LANES], g[LANES], b[LANES];
    int used[LANES];
    VSTORE(d.x, x);
    VSTORE(d.y, y);
    VSTORE(d.z, z);
    VSTORE(lanes, used);
    for (int i = 0; i < LANES; ++i) {
        float3 e = used[i] ? environment_lookup(s->params, s->environment_map, (float3)(x[i], y[i], z[i])) : 0.0f;
        r[i] = e.x;
        g[i] = e.y;
        b[i] = e.z;
    }
    return v3_mul(scale, v3(VLOAD(r), VLOAD(g), VLOAD(b)));
#else
    return scale;
#endif
}

#if HAS_ENVIRONMENT_MAP
/* Each lane's direction drawn from the map by the point xi, and *density its density per steradian, in the
 * lanes of `lanes` (the others: the zero vector, density 0). */
inline vec3 sample_environment(const Scene *s, vec2 xi, vint lanes, vfloat *density)
{
    float u[LANES], v[LANES], x[LANES], y[LANES], z[LANES], p[LANES];
    int used[LANES];
    VSTORE(xi.x, u);
    VSTORE(xi.y, v);
    VSTORE(lanes, used);
    for (int i = 0; i < LANES; ++i) {
        p[i] = 0.0f;
        float3 d = used[i] ? environment_sample(s->params, s->environment_map, (float2)(u[i], v[i]), &p[i]) : 0.0f;
        x[i] = d.x;
        y[i] = d.y;
        z[i] = d.z;
    }
    *density = VLOAD(p);
    return v3(VLOAD(x), VLOAD(y), VLOAD(z));
}

/* The density per steradian with which sample_environment draws each lane's unit direction d, in the lanes of
 * `lanes` (0 in the others). */
inline vfloat environment_pdf(const Scene *s, vec3 d, vint lanes)
{
    float x[LANES], y[LANES], z[LANES], p[LANES];
    int used[LANES];
    VSTORE(d.x, x);
    VSTORE(d.y, y);
    VSTORE(d.z, z);
    VSTORE(lanes, used);
    for (int i = 0; i < LANES; ++i)
        p[i] = used[i] ? environment_density(s->params, s->environment_map, (float3)(x[i], y[i], z[i])) : 0.0f;
    return VLOAD(p);
}
#endif

#endif
