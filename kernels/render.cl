/* The per-pixel pipeline: generate camera rays, intersect, find the material's shading point, shade (the
 * scene's model: the course's Phong, or direct lighting), accumulate.
 *
 * One work-item renders LANES neighbouring pixels of one row: x = LANES * get_global_id(0) + lane,
 * y = row0 + get_global_id(1). A launch takes the pixel samples [sample0, sample0 + n_samples) of a
 * progressive render (the host accumulates passes). The output holds this launch's band of rows only, so
 * its size is bounded whatever the image's: planes of width * get_global_size(1) floats, row y at y - row0:
 * R, G, B (sums over the launch's pixel samples, linear) and the number of rays traced for the pixel. */
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

inline void store_lanes(__global float *plane, int index, vfloat value, vint active)
{
    float v[LANES];
    int a[LANES];
    VSTORE(value, v);
    VSTORE(active, a);
    for (int i = 0; i < LANES; ++i)
        if (a[i])
            plane[index + i] = v[i];
}

__kernel void render(SCENE_PARAMETERS, TEXTURE_PARAMETERS,
                     __global const uint2 *pixel_samples, /* the pixel and light sample tables (samplers.cl) */
                     __global const uint2 *light_samples, int sample0, int n_samples, int row0,
                     __global float *out)
{
    const Scene scene = SCENE_FROM_PARAMETERS;
    const TextureStore ts = TEXTURES_FROM_PARAMETERS;
    const int width = params->width, height = params->height;
    const int x0 = LANES * get_global_id(0), y = row0 + get_global_id(1);
    if (y >= height)
        return;
    vint active = (x0 + LANE_IDS) < width;
    vfloat x = CONVERT_VFLOAT(x0 + LANE_IDS);

    vuint key = pixel_key(AS_VUINT(y * width + x0 + LANE_IDS), params->seed);
    vec3 sum = v3_splat(0.0f, 0.0f, 0.0f), carry = sum; /* compensated: a launch may hold 32768 samples */
    vfloat rays = 0.0f;
    for (int s = sample0; s < sample0 + n_samples; ++s) {
        vec2 offset = sample_2d(pixel_samples, s, params->pixel_sampler, key);
        Ray ray = generate_camera_ray(camera, x + offset.x, (vfloat)(y) + offset.y, 1.0f / width, 1.0f / height);
        Hit hit = closest_hit(&scene, ray, (vfloat)(INFINITY));
        ShadingPoint sp = shading_point(&scene, ts, ray, hit);
        kahan_add(&sum, &carry, shade(&scene, ray, hit, sp, light_samples, stream_key(key, s), &rays));
    }
    rays += (float)n_samples;

    const int plane = width * (int)get_global_size(1), index = (y - row0) * width + x0;
    store_lanes(out, index, sum.x, active);
    store_lanes(out + plane, index, sum.y, active);
    store_lanes(out + 2 * plane, index, sum.z, active);
    store_lanes(out + 3 * plane, index, rays, active);
}
