/* Filtered texture lookups over a MIP pyramid (Williams 1983; pbrt-v4 section 10.4.3).
 *
 * The footprint of a pixel sample on the texture is given by the derivatives of (s, t) with respect to the
 * image's x and y (dst = (ds/dx, dt/dx, ds/dy, dt/dy), from ray differentials: surface.cl). Scalar code, run
 * once per lane like textures.cl. */
#ifndef MIPMAP_CL
#define MIPMAP_CL

#include "textures.cl"

#define MAX_ANISOTROPY 8

/* (1 - f) level l0 + f level l0 + 1 at the continuous level D = log2(width in level-0 texels). */
inline float4 texture_at_width(TextureStore ts, int texture, float2 st, float width, int wrap)
{
    int top = ts.textures[texture].n_levels - 1;
    float d = width > 0.0f ? min1(max1(log2_1(width), 0.0f), (float)top) : 0.0f; /* width 0 or NaN: level 0 */
    int l0 = (int)d;
    float f = d - l0;
    float4 fine = texture_bilinear(ts, texture, l0, st, wrap);
    return f > 0.0f ? mix4(fine, texture_bilinear(ts, texture, (l0 < top ? l0 + 1 : top), st, wrap), f) : fine;
}

/* The two footprint axes in level-0 texels. */
inline void footprint_axes(TextureStore ts, int texture, float4 dst, float2 *ax, float2 *ay)
{
    MipLevel level = mip_level(ts, texture, 0);
    float2 size = (float2)(level.width, level.height);
    *ax = dst.s01 * size;
    *ay = dst.s23 * size;
}

/* Trilinear: the level of the longer footprint axis, as the README's D = log2 L. */
inline float4 texture_trilinear(TextureStore ts, int texture, float2 st, float4 dst, int wrap)
{
    float2 ax, ay;
    footprint_axes(ts, texture, dst, &ax, &ay);
    return texture_at_width(ts, texture, st, max1(length_of(ax), length_of(ay)), wrap);
}

/* Anisotropic: up to MAX_ANISOTROPY trilinear probes spread along the major axis of the footprint, each
 * at the level of the minor axis (the approach of GPU hardware and of Feline, McCormack et al. 1999). */
inline float4 texture_anisotropic(TextureStore ts, int texture, float2 st, float4 dst, int wrap)
{
    float2 ax, ay;
    footprint_axes(ts, texture, dst, &ax, &ay);
    float lx = length_of(ax), ly = length_of(ay);
    float major = max1(lx, ly), width = max1(min1(lx, ly), major / MAX_ANISOTROPY);
    if (!(width > 0.0f))
        return texture_bilinear(ts, texture, 0, st, wrap);
    int n = clamp_int((int)ceil(major / width - 1e-3f), 1, MAX_ANISOTROPY);
    float2 axis_st = lx >= ly ? dst.s01 : dst.s23;
    float4 sum = (float4)(0.0f);
    for (int k = 0; k < n; ++k)
        sum += texture_at_width(ts, texture, st + axis_st * ((k + 0.5f) / n - 0.5f), width, wrap);
    return sum / n;
}

inline float4 texture_lookup(TextureStore ts, int texture, float2 st, float4 dst, int filter, int wrap)
{
    switch (filter) {
    case FILTER_NEAREST: return texture_nearest(ts, texture, st, wrap);
    case FILTER_BILINEAR: return texture_bilinear(ts, texture, 0, st, wrap);
    case FILTER_ANISOTROPIC: return texture_anisotropic(ts, texture, st, dst, wrap);
    default: return texture_trilinear(ts, texture, st, dst, wrap);
    }
}

#endif
