/* Filtered texture lookups over a MIP pyramid (Williams 1983; pbrt-v4 section 10.4.3), for LANES points of
 * one texture (textures.cl).
 *
 * The footprint of a pixel sample on the texture is given by the derivatives of (s, t) with respect to the
 * image's x and y (dst = (ds/dx, dt/dx, ds/dy, dt/dy), from ray differentials: surface.cl). */
#ifndef MIPMAP_CL
#define MIPMAP_CL

#include "textures.cl"

#define MAX_ANISOTROPY 8

typedef struct { vfloat s_x, t_x, s_y, t_y; } Footprint; /* ds/dx, dt/dx, ds/dy, dt/dy */

/* (1 - f) level l0 + f level l0 + 1 at the continuous level D = log2(width in level-0 texels). */
inline vec3 texture_at_width(TextureStore ts, int texture, vec2 st, vfloat width, int wrap)
{
    int top = ts.textures[texture].n_levels - 1;
    /* width 0 or NaN: level 0 */
    vfloat d = SELECT((vfloat)(0.0f), vmin(vmax(vlog2(width), 0.0f), (float)top), width > 0.0f);
    vint l0 = CONVERT_VINT(d);
    vfloat f = d - CONVERT_VFLOAT(l0);
    vec3 fine = texture_bilinear(ts, texture, l0, st, wrap);
    vint blend = f > 0.0f;
    if (!ANY(blend))
        return fine;
    vec3 coarse = texture_bilinear(ts, texture, SELECT(l0, l0 + 1, l0 < top), st, wrap);
    return v3_select(fine, v3_mix(fine, coarse, f), blend);
}

/* The lengths of the two footprint axes in level-0 texels. */
inline void footprint_lengths(TextureStore ts, int texture, Footprint dst, vfloat *lx, vfloat *ly)
{
    MipLevel level = ts.levels[ts.textures[texture].first_level];
    *lx = v2_length(dst.s_x * level.width, dst.t_x * level.height);
    *ly = v2_length(dst.s_y * level.width, dst.t_y * level.height);
}

/* Trilinear: the level of the longer footprint axis, as the README's D = log2 L. */
inline vec3 texture_trilinear(TextureStore ts, int texture, vec2 st, Footprint dst, int wrap)
{
    vfloat lx, ly;
    footprint_lengths(ts, texture, dst, &lx, &ly);
    return texture_at_width(ts, texture, st, vmax(lx, ly), wrap);
}

/* Anisotropic: up to MAX_ANISOTROPY trilinear probes spread along the major axis of the footprint, each
 * at the level of the minor axis (the approach of GPU hardware and of Feline, McCormack et al. 1999). Lanes
 * take their own number of probes; the loop runs to the largest. */
inline vec3 texture_anisotropic(TextureStore ts, int texture, vec2 st, Footprint dst, int wrap)
{
    vfloat lx, ly;
    footprint_lengths(ts, texture, dst, &lx, &ly);
    vfloat major = vmax(lx, ly), width = vmax(vmin(lx, ly), major / MAX_ANISOTROPY);
    vint footprint = width > 0.0f;
    vfloat ratio = SELECT((vfloat)(1.0f), major / width, footprint);
    vint n = CONVERT_VINT(-vfloor(1e-3f - ratio)); /* ceil(ratio - 1e-3) */
    n = SELECT(SELECT(n, 1, n < 1), MAX_ANISOTROPY, n > MAX_ANISOTROPY);
    vfloat count = CONVERT_VFLOAT(n);
    vint along_x = lx >= ly;
    vec2 axis = {SELECT(dst.s_y, dst.s_x, along_x), SELECT(dst.t_y, dst.t_x, along_x)};
    vec3 sum = v3_splat(0.0f, 0.0f, 0.0f);
    for (int k = 0; k < MAX_ANISOTROPY && ANY(k < n); ++k) {
        vfloat w = (k + 0.5f) / count - 0.5f;
        vec2 probe = {MAD(axis.x, w, st.x), MAD(axis.y, w, st.y)};
        vec3 c = texture_at_width(ts, texture, probe, width, wrap);
        sum = v3_select(sum, v3_add(sum, c), k < n);
    }
    sum = v3_scale(sum, 1.0f / count);
    if (ALL(footprint))
        return sum;
    return v3_select(texture_bilinear(ts, texture, (vint)(0), st, wrap), sum, footprint);
}

inline vec3 texture_lookup(TextureStore ts, int texture, vec2 st, Footprint dst, int filter, int wrap)
{
    switch (filter) {
    case FILTER_NEAREST: return texture_nearest(ts, texture, st, wrap);
    case FILTER_BILINEAR: return texture_bilinear(ts, texture, (vint)(0), st, wrap);
    case FILTER_ANISOTROPIC: return texture_anisotropic(ts, texture, st, dst, wrap);
    default: return texture_trilinear(ts, texture, st, dst, wrap);
    }
}

#endif
