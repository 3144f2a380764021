/* The per-pixel pipeline: generate camera rays, intersect, find the material's shading point, shade (the
 * scene's model: the course's Phong, or direct lighting), accumulate.
 *
 * One work-item renders a tile of LANES pixels, TILE_COLUMNS x TILE_ROWS (lanes.h), lane by lane along its
 * rows: work-item (i, j) starts at pixel x = TILE_COLUMNS i, y = row0 + TILE_ROWS j. A launch renders the
 * band of rows [row0, row1) with the pixel samples [sample0, sample0 + n_samples) of a progressive render
 * (the host accumulates passes); lanes beyond the band or the image's width compute and store nothing. The
 * output holds the band only, so its size is bounded whatever the image's: planes of width * (row1 - row0)
 * floats, row y at y - row0: R, G, B (sums over the launch's pixel samples, linear) and the number of rays
 * traced for the pixel. A measuring build (COUNT_VISITS, scene.h) stores VISIT_KINDS planes more: the counts of
 * nodes and primitives the work-item's traversals tested, each shared equally among its pixels. */
#include "camera.cl"
#if HAS_DIRECT_LIGHTING
#include "direct_lighting.cl"
#else
#include "shading.cl" /* the course's Phong model */
#endif

/* sum += x, Kahan-compensated (Higham, "Accuracy and Stability of Numerical Algorithms", section 4.3): the
 * error stays within 2 roundings of the sum for any number of terms, where a plain float32 running sum of n
 * samples drifts by up to n roundings (2e-4 relative at 32768 equal samples, measured). An Inf sample makes
 * the sum NaN (Inf - Inf in the carry), which the host counts and zeroes like any other. */
inline void kahan_add(vec3 *sum, vec3 *carry, vec3 x)
{
    vec3 y = v3_sub(x, *carry);
    vec3 t = v3_add(*sum, y);
    *carry = v3_sub(v3_sub(t, *sum), y);
    *sum = t;
}

#if COUNT_VISITS
/* The number of lanes set in `mask`: the pixels among which a measuring build shares its counts. */
inline int count_lanes(vint mask)
{
    int m[LANES], n = 0;
    VSTORE(mask, m);
    for (int i = 0; i < LANES; ++i)
        n += m[i] != 0;
    return n;
}
#endif

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

__kernel void render(SCENE_PARAMETERS, TEXTURE_PARAMETERS,
                     __global const uint2 *pixel_samples, /* the pixel and light sample tables (samplers.cl) */
                     __global const uint2 *light_samples, int sample0, int n_samples, int row0, int row1,
                     __global float *out)
{
#if COUNT_VISITS
    int visits[VISIT_KINDS] = {0};
    Scene scene = SCENE_FROM_PARAMETERS;
    scene.visits = visits;
#else
    const Scene scene = SCENE_FROM_PARAMETERS;
#endif
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    const int width = params->width, height = params->height;
    const vint x = TILE_COLUMNS * (int)get_global_id(0) + LANE_IDS % TILE_COLUMNS;
    const vint y = row0 + TILE_ROWS * (int)get_global_id(1) + LANE_IDS / TILE_COLUMNS;
    const vint active = (x < width) & (y < row1);
    if (!ANY(active))
        return;

    vuint key = pixel_key(AS_VUINT(y * width + x), params->seed);
    vec3 sum = v3_splat(0.0f, 0.0f, 0.0f), carry = sum; /* compensated: a launch may hold 32768 samples */
    vfloat rays = 0.0f;
    for (int s = sample0; s < sample0 + n_samples; ++s) {
        vec2 offset = sample_2d(pixel_samples, s, params->pixel_sampler, key);
        Ray ray = generate_camera_ray(camera, CONVERT_VFLOAT(x) + offset.x, CONVERT_VFLOAT(y) + offset.y, 1.0f / width,
                                      1.0f / height);
        Hit hit = closest_hit(&scene, ray, (vfloat)(INFINITY));
        ShadingPoint sp = shading_point(&scene, ts, ray, hit);
        kahan_add(&sum, &carry, shade(&scene, ray, hit, sp, light_samples, stream_key(key, s), &rays));
    }
    rays += (float)n_samples;

    const int plane = width * (row1 - row0);
    const vint index = (y - row0) * width + x;
    store_lanes(out, index, sum.x, active);
    store_lanes(out + plane, index, sum.y, active);
    store_lanes(out + 2 * plane, index, sum.z, active);
    store_lanes(out + 3 * plane, index, rays, active);
#if COUNT_VISITS
    const float pixels = (float)count_lanes(active);
    for (int k = 0; k < VISIT_KINDS; ++k)
        store_lanes(out + (4 + k) * plane, index, (vfloat)(visits[k] / pixels), active);
#endif
}
