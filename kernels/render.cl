/* The per-pixel pipeline: generate camera rays, intersect, find the material's shading point, shade (the
 * scene's model: the course's Phong, direct lighting, or path tracing), accumulate.
 *
 * A launch renders the band of rows [row0, row1) with the pixel samples [sample0, sample0 + n_samples) of a
 * progressive render (the host accumulates passes). One work-item renders a tile of pixels, several samples of
 * each at once where n_samples allows (tile.h); in the path model each lane starts its next sample as its path
 * ends (render_paths). Lanes beyond the band or the image's width store nothing. The output holds the band
 * only, so its size is bounded whatever the image's: planes of width * (row1 - row0) floats, row y at y -
 * row0: R, G, B (sums over the launch's pixel samples, linear), the number of rays traced for the pixel, and,
 * where n_first > 0, R, G, B again over the launch's first n_first samples only: the first half of a pass that
 * holds both halves of the host's error estimate (raytrace/renderer/progressive.py), so that a pass may hold
 * all of a render's samples and a work-item's lanes as many of a pixel's. A render with AOVs (HAS_AOVS,
 * aovs.cl) stores AOV_PLANES planes more: their sums over the same samples, weighted as the beauty's. A
 * measuring build (COUNT_VISITS, scene.h) stores VISIT_KINDS planes after those: the counts of nodes and
 * primitives the work-item's traversals tested, each shared equally among its pixels. */
#include "camera.cl"
#include "tile.h"
#if HAS_RFILTER
#include "film_filter.cl"
#endif
#if HAS_PATH_TRACING
#include "path_tracing.cl"
#elif HAS_DIRECT_LIGHTING
#include "direct_lighting.cl"
#else
#include "shading.cl" /* the course's Phong model */
#endif
#if RADIOMETRIC
#include "hide_emitters.cl"
#endif
#if HAS_AOVS
#include "aovs.cl"
#endif

/* The output's planes (above): R, G, B, the ray count, R, G, B of the first n_first samples, the AOVs
 * (AOV_PLANES, types.h), the counts. */
#define RAYS_PLANE 3
#define FIRST_HALF_PLANE 4
#define OUTPUT_PLANES 7
#if HAS_AOVS
#define VISITS_PLANE (OUTPUT_PLANES + AOV_PLANES)
#else
#define VISITS_PLANE OUTPUT_PLANES
#endif

/* sum += x, Kahan-compensated (Higham, "Accuracy and Stability of Numerical Algorithms", section 4.3): the
 * error stays within 2 roundings of the sum for any number of terms, where a plain float32 running sum of n
 * samples drifts by up to n roundings (2e-4 relative at 32768 equal samples, measured). An Inf sample makes
 * the sum NaN (Inf - Inf in the carry), which the host counts and zeroes like any other. */
inline void kahan_add_plane(vfloat *sum, vfloat *carry, vfloat x)
{
    vfloat y = x - *carry, t = *sum + y;
    *carry = (t - *sum) - y;
    *sum = t;
}

inline void kahan_add(vec3 *sum, vec3 *carry, vec3 x)
{
    kahan_add_plane(&sum->x, &carry->x, x.x);
    kahan_add_plane(&sum->y, &carry->y, x.y);
    kahan_add_plane(&sum->z, &carry->z, x.z);
}


/* *s + b, where *s and b are two lanes' partial sums and *e and e_b the rounding errors they carry: the sum
 * rounded, and its own rounding error, found exactly by Knuth's TwoSum, added to the errors. The same in
 * both lanes of a pair: a + b rounds the same either way, and TwoSum's error is exact. */
inline void add_partners(vfloat *s, vfloat *e, vfloat b, vfloat e_b)
{
    vfloat a = *s, t = a + b, b_part = t - a;
    *e = (*e + e_b) + ((a - (t - b_part)) + (b - b_part));
    *s = t;
}

/* Each pixel's sums over its `group` lanes (tile.h), in every lane of it: the lanes' compensated sums (sum -
 * carry, rounded once) added pairwise, lane l with lane l ^ w at w = 1, 2, 4 ... below group (a butterfly),
 * the additions' rounding errors kept exactly and added at the end (add_partners). That is Ogita, Rump and
 * Oishi's Sum2 ("Accurate sum and dot product", SIAM J. Sci. Comput., 2005) in a pairwise order, and its
 * bound holds for any order: within one rounding of the lanes' exact sum plus (group - 1) roundings of the
 * error terms, which are each a rounding of a partial sum. Each step is a few vector instructions, where a
 * running sum over the lanes waits on each addition in turn: with passes of 16, a work-item's seven running
 * sums took a visible share of scene 0's profile, and summing this way saves part of it (measured in commit
 * c22b53c). */
inline vfloat pixel_sums(vfloat sum, vfloat carry, int group)
{
    vfloat s = sum - carry, e = 0.0f;
#if LANES >= 4
    if (group >= 2)
        add_partners(&s, &e, PARTNERS_1(s), PARTNERS_1(e));
    if (group >= 4)
        add_partners(&s, &e, PARTNERS_2(s), PARTNERS_2(e));
#endif
#if LANES >= 8
    if (group >= 8)
        add_partners(&s, &e, PARTNERS_4(s), PARTNERS_4(e));
#endif
#if LANES >= 16
    if (group >= 16)
        add_partners(&s, &e, PARTNERS_8(s), PARTNERS_8(e));
#endif
    return s + e;
}

/* plane[index] = value in the active lanes. */
inline void store_lanes(__global float *plane, vint index, vfloat value, vint active)
{
    float v[LANES];
    int a[LANES], at[LANES];
    VSTORE(value, v);
    VSTORE(active, a);
    VSTORE(index, at);
    for (int i = 0; i < LANES; ++i)
        if (a[i])
            plane[at[i]] = v[i];
}

/* A work-item's sums per lane over its pixel samples (compensated: a launch may hold 32768 samples), over those
 * before sample0 + n_first, and the rays traced after the camera rays. */
typedef struct {
    vec3 sum, carry, first_sum, first_carry;
    vfloat rays;
#if HAS_AOVS
    vfloat aov[AOV_PLANES], aov_carry[AOV_PLANES]; /* the AOVs' (aovs.cl), compensated as the beauty's */
#endif
} Sums;

/* The lanes' pixel samples of `value` (their indices: index) added to the sums, in the lanes of `lanes`. */
inline void add_samples(Sums *sums, vec3 value, vint lanes, vint index, int first_end, int n_first)
{
    vec3 sum = sums->sum, carry = sums->carry;
    kahan_add(&sum, &carry, value);
    sums->sum = v3_select(sums->sum, sum, lanes);
    sums->carry = v3_select(sums->carry, carry, lanes);
    if (n_first > 0) { /* uniform: the first pass only */
        vec3 first_sum = sums->first_sum, first_carry = sums->first_carry;
        kahan_add(&first_sum, &first_carry, v3_select(v3_splat(0.0f, 0.0f, 0.0f), value, index < first_end));
        sums->first_sum = v3_select(sums->first_sum, first_sum, lanes);
        sums->first_carry = v3_select(sums->first_carry, first_carry, lanes);
    }
}

#if HAS_AOVS
/* The AOVs of the lanes' camera rays (aovs.cl's aov_values: r, the ray that met hit, from the camera's origin
 * o) added to their sums, times the samples' filter weights, in the lanes of `lanes`. */
inline void add_aovs(Sums *sums, const Scene *s, Ray r, vec3 o, Hit hit, ShadingPoint sp, vfloat weight,
                     vint lanes)
{
    vfloat value[AOV_PLANES];
    aov_values(s, r, o, hit, sp, value);
    for (int k = 0; k < AOV_PLANES; ++k) {
        vfloat x = value[k];
#if HAS_RFILTER
        x *= weight;
#endif
        vfloat sum = sums->aov[k], carry = sums->aov_carry[k];
        kahan_add_plane(&sum, &carry, x);
        sums->aov_carry[k] = SELECT(sums->aov_carry[k], carry, lanes);
        sums->aov[k] = SELECT(sums->aov[k], sum, lanes);
    }
}
#endif

/* Lane l's camera ray through its pixel (x, y) of the crop window for the pixel sample ps (whose pair counter
 * is advanced in the lanes of `lanes` only: the pixel offset's pair, and a thin lens's lens point's after it,
 * which no other camera draws), *tmax where its far clip plane ends it, and *weight its reconstruction
 * filter's weight (film_filter.cl; 1 with the box filter, whose offsets are uniform in the pixel). The pixel
 * is placed in the whole film (camera.cl). */
inline Ray camera_ray(const Scene *s, Tile tile, PixelSample *ps, __global const uint2 *pixel_samples, vint lanes,
                      vfloat *tmax, vfloat *weight)
{
    __constant const Camera *cam = s->camera;
    vec2 offset = stream_2d(pixel_samples, s->params->pixel_sampler,
                            next_stream_in(ps, s->params->pixel_sampler, 1, lanes), (vint)(0));
    vec2 lens = offset;
#if HAS_THIN_LENS
    lens = stream_2d(pixel_samples, s->params->pixel_sampler, next_stream_in(ps, s->params->pixel_sampler, 1, lanes),
                     (vint)(0));
#endif
    *weight = (vfloat)(1.0f);
#if HAS_RFILTER
    vfloat weight_x, weight_y;
    offset.x = rfilter_offsets(cam, offset.x, tile.x, cam->crop_width, &weight_x);
    offset.y = rfilter_offsets(cam, offset.y, tile.y, cam->crop_height, &weight_y);
    *weight = weight_x * weight_y;
#endif
    return generate_camera_ray(cam, CONVERT_VFLOAT(tile.x + cam->crop_x) + offset.x,
                               CONVERT_VFLOAT(tile.y + cam->crop_y) + offset.y, lens, tmax);
}

#if HAS_PATH_TRACING
/* The path model's pixel samples: each lane follows its own path, and where the path ends starts its pixel's
 * next sample (path regeneration: Novak, Havran and Dachsbacher, "Path Regeneration for Interactive Path
 * Tracing", Eurographics 2010 short papers), so that a packet's lanes stay busy while its longest path goes
 * on; a lane's samples are its own, in the same order, and give the same sums as trace_path's one sample at a
 * time in every lane (tests/test_path_regeneration.py renders that way in a kernel of its own, to the bit).
 * The lanes' closest-hit traversal is one, camera rays and bounces together; the lanes without a ray (outside
 * the image, or done) search none of it. */
inline void render_paths(const Scene *s, TextureStore ts, Tile tile, vint active, vuint key,
                         __global const uint2 *pixel_samples, __global const uint2 *light_samples, int sample0,
                         int n_samples, int n_first, Sums *sums)
{
    const int end = sample0 + n_samples;
    PixelSample ps = start_pixel_sample(key, (vint)(0));
    PathState path = {0};
    vint next = sample0 + tile.sample, in_path = (vint)(0) != 0;
    vfloat weight = (vfloat)(1.0f); /* the lanes' samples' filter weights (camera_ray) */
    for (;;) {
        vint start = active & !in_path & (next < end);
        vfloat tmax = SELECT((vfloat)(-1.0f), (vfloat)(INFINITY), in_path);
        if (ANY(start)) {
            ps.index = SELECT(ps.index, next, start);
            ps.dimension = SELECT(ps.dimension, (vint)(0), start);
            next = SELECT(next, next + tile.group, start);
            vfloat camera_tmax, camera_weight;
            start_paths(&path, camera_ray(s, tile, &ps, pixel_samples, start, &camera_tmax, &camera_weight), start);
            tmax = SELECT(tmax, camera_tmax, start);
            weight = SELECT(weight, camera_weight, start);
            in_path |= start;
        }
        if (!ANY(in_path))
            return;
        Hit hit = closest_hit(s, path.r, tmax);
#if HAS_AOVS
        const vint camera = in_path & (path.depth == 0);
        const vec3 camera_o = path.r.o;
#endif
        if (s->params->hide_emitters) /* the camera rays pass the emitters */
            hit = pass_emitters(s, &path.r, hit, tmax, in_path & (path.depth == 0));
        vint alive = path_hit(s, &path, hit, in_path);
#if HAS_AOVS /* the camera rays' first hits, shaded also where their paths end there */
        if (ANY(camera)) {
            ShadingPoint sp = shading_point(s, ts, path.r, hit);
            add_aovs(sums, s, path.r, camera_o, hit, sp, weight, camera);
            if (ANY(alive))
                alive = path_vertex(s, ts, &path, sp, alive, light_samples, &ps, &sums->rays);
        } else if (ANY(alive))
#else
        if (ANY(alive))
#endif
            alive = path_vertex(s, ts, &path, shading_point(s, ts, path.r, hit), alive, light_samples, &ps,
                                &sums->rays);
        vint ended = in_path & !alive;
        if (ANY(ended)) {
#if HAS_RFILTER
            add_samples(sums, v3_scale(path.radiance, weight), ended, ps.index, sample0 + n_first, n_first);
#else
            add_samples(sums, path.radiance, ended, ps.index, sample0 + n_first, n_first);
#endif
            in_path = alive;
        }
    }
}
#else
/* The pixel samples of the course's model and of the direct one: a camera ray and its shading, group samples
 * of each pixel at a step (tile.h). */
inline void render_samples(const Scene *s, TextureStore ts, Tile tile, vuint key, __global const uint2 *pixel_samples,
                           __global const uint2 *light_samples, int sample0, int n_samples, int n_first, Sums *sums)
{
    const vint all = (vint)(-1) != 0;
    for (int first = sample0; first < sample0 + n_samples; first += tile.group) {
        PixelSample ps = start_pixel_sample(key, first + tile.sample);
        vfloat tmax, weight;
        Ray ray = camera_ray(s, tile, &ps, pixel_samples, all, &tmax, &weight);
        Hit hit = closest_hit(s, ray, tmax);
#if HAS_AOVS
        const vec3 camera_o = ray.o;
#endif
#if RADIOMETRIC
        if (s->params->hide_emitters)
            hit = pass_emitters(s, &ray, hit, tmax, all);
#endif
        ShadingPoint sp = shading_point(s, ts, ray, hit);
#if HAS_AOVS
        add_aovs(sums, s, ray, camera_o, hit, sp, weight, all);
#endif
        vec3 value = shade(s, ray, hit, sp, light_samples, &ps, &sums->rays);
#if HAS_RFILTER
        value = v3_scale(value, weight);
#endif
        add_samples(sums, value, all, ps.index, sample0 + n_first, n_first);
    }
}
#endif

/* The work-item's sums (and the camera rays) stored as its pixels' in the output's planes (above), by each
 * pixel's first lane; a measuring build's counts shared equally among its pixels. */
inline void store_sums(const Scene *s, Tile tile, vint active, const Sums *sums, int n_samples, int n_first,
                       int row0, int row1, __global float *out)
{
    const int width = s->params->width;
    const vfloat rays = sums->rays + (float)(n_samples / tile.group); /* and the camera rays */

    const int plane = width * (row1 - row0);
    const vint index = (tile.y - row0) * width + tile.x;
    const vint stored = active & (tile.sample == 0); /* a pixel's first lane */
    store_lanes(out, index, pixel_sums(sums->sum.x, sums->carry.x, tile.group), stored);
    store_lanes(out + plane, index, pixel_sums(sums->sum.y, sums->carry.y, tile.group), stored);
    store_lanes(out + 2 * plane, index, pixel_sums(sums->sum.z, sums->carry.z, tile.group), stored);
    store_lanes(out + RAYS_PLANE * plane, index, pixel_sums(rays, (vfloat)(0.0f), tile.group), stored);
    if (n_first > 0) {
        __global float *first = out + FIRST_HALF_PLANE * plane;
        store_lanes(first, index, pixel_sums(sums->first_sum.x, sums->first_carry.x, tile.group), stored);
        store_lanes(first + plane, index, pixel_sums(sums->first_sum.y, sums->first_carry.y, tile.group), stored);
        store_lanes(first + 2 * plane, index, pixel_sums(sums->first_sum.z, sums->first_carry.z, tile.group), stored);
    }
#if HAS_AOVS
    for (int k = 0; k < AOV_PLANES; ++k)
        store_lanes(out + (OUTPUT_PLANES + k) * plane, index, pixel_sums(sums->aov[k], sums->aov_carry[k], tile.group),
                    stored);
#endif
#if COUNT_VISITS
    const float pixels = (float)count_lanes(stored);
    for (int k = 0; k < VISIT_KINDS; ++k)
        store_lanes(out + (VISITS_PLANE + k) * plane, index, (vfloat)(s->visits[k] / pixels), stored);
#endif
}

__kernel void render(SCENE_PARAMETERS, TEXTURE_PARAMETERS,
                     __global const uint2 *pixel_samples, /* the pixel and light sample tables (samplers.cl) */
                     __global const uint2 *light_samples, int sample0, int n_samples, int n_first, int row0,
                     int row1, __global float *out)
{
    Scene scene = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
#if COUNT_VISITS
    int visits[VISIT_KINDS] = {0};
    scene.visits = visits;
#endif
#if HAS_NULLS || HAS_DELTA_EMITTERS
    scene.textures = ts;
#endif
    const int width = params->width, height = params->height;
    const Tile tile = work_item_tile(row0, n_samples);
    const vint x = tile.x, y = tile.y, active = (x < width) & (y < row1);
    if (!ANY(active))
        return;

    /* keyed by its place in the whole film: a crop window's pixels are the film's */
    const int film_width = scene.camera->film_width;
    vuint key = pixel_key(AS_VUINT((y + scene.camera->crop_y) * film_width + x + scene.camera->crop_x), params->seed);
    Sums sums = {0};
#if HAS_PATH_TRACING
    render_paths(&scene, ts, tile, active, key, pixel_samples, light_samples, sample0, n_samples, n_first, &sums);
#else
    render_samples(&scene, ts, tile, key, pixel_samples, light_samples, sample0, n_samples, n_first, &sums);
#endif
    store_sums(&scene, tile, active, &sums, n_samples, n_first, row0, row1, out);
}
