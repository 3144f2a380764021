/* Filtered texture lookups over a MIP pyramid (Williams 1983; pbrt-v4 section 10.4.3), for LANES points of
 * one texture (textures.cl).
 *
 * The footprint of a pixel sample on the texture is given by the derivatives of (s, t) with respect to the
 * image's x and y (dst = (ds/dx, dt/dx, ds/dy, dt/dy), from ray differentials: surface.cl). A lookup is in
 * two steps: texture_filter turns the footprint into levels, weights and probes once, and texture_filtered
 * applies them at a point; a bump map applies one filter at three nearby points. */
#ifndef MIPMAP_CL
#define MIPMAP_CL

#include "textures.cl"

#define MAX_ANISOTROPY 8

typedef struct { vfloat s_x, t_x, s_y, t_y; } Footprint; /* ds/dx, dt/dx, ds/dy, dt/dy */

typedef struct {
    int filter, encoding;  /* FILTER_*, TEXELS_* */
    vint l0, l1;           /* the levels l0 and l0 + 1 (at most the top) of the continuous level D, */
    Levels fine, coarse;   /* and where they are (nearest, bilinear: level 0) */
    vfloat f;              /* coarse's weight D - l0 */
    int blend;             /* f > 0 in some lane */
    vec2 axis;             /* anisotropic: the major axis of the footprint in (s, t), */
    vint probes;           /* the number of probes along it (1 to MAX_ANISOTROPY), */
    vfloat count;          /* and that number as a float */
} TextureFilter;

/* The lengths of the two footprint axes in level-0 texels. */
inline void footprint_lengths(TextureStore ts, int texture, Footprint dst, vfloat *lx, vfloat *ly)
{
    MipLevel level = ts.levels[ts.textures[texture].first_level];
    *lx = v2_length(dst.s_x * level.width, dst.t_x * level.height);
    *ly = v2_length(dst.s_y * level.width, dst.t_y * level.height);
}

/* Trilinear: the level of the longer footprint axis, as docs/textures.md's D = log2 L. Anisotropic: up to
 * MAX_ANISOTROPY probes spread along the major axis of the footprint, each at the level of the minor axis
 * (the approach of GPU hardware and of Feline, McCormack et al. 1999); lanes take their own number of
 * probes. Nearest and bilinear read level 0. */
inline TextureFilter texture_filter(TextureStore ts, int texture, Footprint dst, int filter)
{
    TextureFilter tf;
    tf.filter = filter;
    tf.encoding = ts.textures[texture].encoding;
    tf.probes = 1; /* every field set, whichever the filter reads */
    tf.count = 1.0f;
    tf.axis.x = tf.axis.y = 0.0f;
    vfloat width = 0.0f;
    if (filter == FILTER_TRILINEAR || filter == FILTER_ANISOTROPIC) {
        vfloat lx, ly;
        footprint_lengths(ts, texture, dst, &lx, &ly);
        vfloat major = vmax(lx, ly);
        width = major;
        if (filter == FILTER_ANISOTROPIC) {
            width = vmax(vmin(lx, ly), major / MAX_ANISOTROPY);
            /* no footprint (width 0 or NaN): one probe, at st, on level 0 */
            vfloat ratio = SELECT((vfloat)(1.0f), major / width, width > 0.0f);
            vint n = CONVERT_VINT(-vfloor(1e-3f - ratio)); /* ceil(ratio - 1e-3) */
            tf.probes = SELECT(SELECT(n, 1, n < 1), MAX_ANISOTROPY, n > MAX_ANISOTROPY);
            tf.count = CONVERT_VFLOAT(tf.probes);
            vint along_x = lx >= ly;
            tf.axis.x = SELECT(dst.s_y, dst.s_x, along_x);
            tf.axis.y = SELECT(dst.t_y, dst.t_x, along_x);
        }
    }
    int top = ts.textures[texture].n_levels - 1;
    /* width 0 or NaN: level 0 */
    vfloat d = SELECT((vfloat)(0.0f), vmin(vmax(vlog2(width), 0.0f), (float)top), width > 0.0f);
    tf.l0 = CONVERT_VINT(d);
    tf.l1 = SELECT(tf.l0, tf.l0 + 1, tf.l0 < top);
    tf.f = d - CONVERT_VFLOAT(tf.l0);
    tf.blend = ANY(tf.f > 0.0f);
    tf.fine = mip_levels(ts, texture, tf.l0);
    tf.coarse = tf.blend ? mip_levels(ts, texture, tf.l1) : tf.fine;
    return tf;
}

/* Whether textures a and b have the same level-0 size and number of levels: a filter found for one then
 * serves the other (texture_filter_move). A material's maps are mostly made together, at one size. */
inline int same_shape(TextureStore ts, int a, int b)
{
    __global const Texture *ta = &ts.textures[a], *tb = &ts.textures[b];
    MipLevel la = ts.levels[ta->first_level], lb = ts.levels[tb->first_level];
    return ta->n_levels == tb->n_levels && la.width == lb.width && la.height == lb.height;
}

/* Makes *tf, found for a texture of the same shape, the filter of `texture`: the same levels, weights and probes
 * (they depend on the footprint and the shape alone), at texture's own offsets. In place: a filter is 14
 * vectors, and a copy of it is a call to memcpy. */
inline void texture_filter_move(TextureStore ts, int texture, TextureFilter *tf)
{
    tf->encoding = ts.textures[texture].encoding;
    tf->fine = mip_levels(ts, texture, tf->l0);
    tf->coarse = tf->blend ? mip_levels(ts, texture, tf->l1) : tf->fine;
}

/* (1 - f) level l0 + f level l0 + 1 (where f = 0 the blend leaves level l0's value exactly). */
inline vec3 texture_blended(TextureStore ts, const TextureFilter *tf, vec2 st, int wrap)
{
    vec3 fine = texture_bilinear(ts, tf->encoding, tf->fine, st, wrap);
    if (!tf->blend)
        return fine;
    return v3_mix(fine, texture_bilinear(ts, tf->encoding, tf->coarse, st, wrap), tf->f);
}

/* The filter's value at st. */
inline vec3 texture_filtered(TextureStore ts, const TextureFilter *tf, vec2 st, int wrap)
{
    switch (tf->filter) {
    case FILTER_NEAREST: return texture_nearest(ts, tf->encoding, tf->fine, st, wrap);
    case FILTER_BILINEAR: return texture_bilinear(ts, tf->encoding, tf->fine, st, wrap);
    case FILTER_ANISOTROPIC: {
        vec3 sum = v3_splat(0.0f, 0.0f, 0.0f);
        for (int k = 0; k < MAX_ANISOTROPY && ANY(k < tf->probes); ++k) {
            vfloat w = (k + 0.5f) / tf->count - 0.5f;
            vec2 probe = {MAD(tf->axis.x, w, st.x), MAD(tf->axis.y, w, st.y)};
            sum = v3_select(sum, v3_add(sum, texture_blended(ts, tf, probe, wrap)), k < tf->probes);
        }
        return v3_scale(sum, 1.0f / tf->count);
    }
    default: return texture_blended(ts, tf, st, wrap);
    }
}

inline vec3 texture_lookup(TextureStore ts, int texture, vec2 st, Footprint dst, int filter, int wrap)
{
    TextureFilter tf = texture_filter(ts, texture, dst, filter);
    return texture_filtered(ts, &tf, st, wrap);
}

#endif
