/* Textured parameters: the value of a material's parameter at the lanes' hits, from its TextureLookup (types.h),
 * one of Mitsuba 3's texture plugins: `bitmap` (an image through the course's MIP-mapped lookups, mipmap.cl, with
 * the lookup's own wrap mode and filter: Mitsuba's filter_type, nearest or bilinear on the finest level, or the
 * render's filter) and `checkerboard`.
 *
 * The lookup's to_uv maps the surface's (u, v) to the image's (s, t) (the host composes the flip between the
 * surface's v, up, and the image's rows, down: raytrace/renderer/packing.py), and the footprint of the pixel
 * sample with it: a trilinear or anisotropic filter sees the footprint the transform stretched. */
#ifndef LOOKUPS_CL
#define LOOKUPS_CL

#include "mipmap.cl"
#include "surface.cl"

/* A lookup's texture coordinates (s, t) of the surface's (u, v): its to_uv rows m (t down the image). */
inline vec2 lookup_st(__global const float *m, vec2 uv)
{
    vec2 st = {MAD(uv.x, m[0], MAD(uv.y, m[1], m[2])), MAD(uv.x, m[3], MAD(uv.y, m[4], m[5]))};
    return st;
}

/* Lookup l's colour at uv, whose pixel sample's footprint in (u, v) is duv; render_filter is the render's
 * texture filter (FILTER_*), which a lookup of filter -1 takes. Every lane computes. A float parameter's lookup
 * (luminance set) gives its value thrice: an image's luminance, a checkerboard colour's mean, as Mitsuba's
 * eval_1 has them. */
inline vec3 lookup_value(TextureStore ts, int l, vec2 uv, UVDerivatives duv, int render_filter)
{
    __global const TextureLookup *t = &ts.lookups[l];
    __global const float *m = t->to_uv;
    vec2 st = lookup_st(m, uv);
    vec3 c;
    if (t->kind == LOOKUP_CHECKERBOARD) {
        /* Mitsuba's checkerboard: colour0 where the fractions of s and t lie on the same side of 1/2 (its
         * eval_1, a float parameter's, swaps the two: kept, since it is what Mitsuba renders) */
        vint same = ((st.x - vfloor(st.x)) > 0.5f) == ((st.y - vfloor(st.y)) > 0.5f);
        if (t->luminance)
            same = !same;
        c = v3_select(v3_uniform(t->colour1), v3_uniform(t->colour0), same);
        if (t->luminance) { /* a float parameter: Mitsuba's eval_1 of an rgb colour is its channels' mean */
            vfloat y = (c.x + c.y + c.z) * (1.0f / 3.0f);
            return v3(y, y, y);
        }
        return c;
    } else {
        Footprint dst = {MAD(duv.u_x, m[0], duv.v_x * m[1]), MAD(duv.u_x, m[3], duv.v_x * m[4]),
                         MAD(duv.u_y, m[0], duv.v_y * m[1]), MAD(duv.u_y, m[3], duv.v_y * m[4])};
        c = texture_lookup(ts, t->texture, st, dst, t->filter >= 0 ? t->filter : render_filter, t->wrap);
    }
    if (t->luminance) {
        vfloat y = luminance(c);
        c = v3(y, y, y);
    }
    return c;
}

/* The gradient (dh/du, dh/dv) of lookup l's value h (its luminance) at uv, as Mitsuba's eval_1_grad: the
 * derivative of the bilinear interpolation between the four texels around st on the finest level, through to_uv
 * by the chain rule; 0 for a nearest lookup and a checkerboard (constant almost everywhere). Mitsuba scales its
 * (dh/ds, dh/dt) by the resolution after to_uv's transpose rather than before: the same for square images or a
 * to_uv without rotation. */
inline vec2 lookup_gradient(TextureStore ts, int l, vec2 uv)
{
    __global const TextureLookup *t = &ts.lookups[l];
    __global const float *m = t->to_uv;
    vec2 zero = {(vfloat)(0.0f), (vfloat)(0.0f)};
    if (t->kind != LOOKUP_BITMAP || t->filter == FILTER_NEAREST)
        return zero;
    Levels level = mip_levels(ts, t->texture, (vint)(0));
    int encoding = ts.textures[t->texture].encoding;
    vfloat w = CONVERT_VFLOAT(level.width), hgt = CONVERT_VFLOAT(level.height);
    vec2 st = lookup_st(m, uv);
    vfloat x = reduce_coordinate(st.x * w - 0.5f, level.width, t->wrap);
    vfloat y = reduce_coordinate(st.y * hgt - 0.5f, level.height, t->wrap);
    vfloat fx = vfloor(x), fy = vfloor(y);
    vfloat wx = x - fx, wy = y - fy;
    vint ix = CONVERT_VINT(fx), iy = CONVERT_VINT(fy);
    vint i0 = wrap_index(ix, level.width, t->wrap), i1 = wrap_index(ix + 1, level.width, t->wrap);
    vint j0 = wrap_index(iy, level.height, t->wrap), j1 = wrap_index(iy + 1, level.height, t->wrap);
    vfloat f00 = luminance(texel_fetch(ts, encoding, level, i0, j0));
    vfloat f10 = luminance(texel_fetch(ts, encoding, level, i1, j0));
    vfloat f01 = luminance(texel_fetch(ts, encoding, level, i0, j1));
    vfloat f11 = luminance(texel_fetch(ts, encoding, level, i1, j1));
    vfloat ds = w * MAD(1.0f - wy, f10 - f00, wy * (f11 - f01)); /* dh/ds, dh/dt */
    vfloat dt = hgt * MAD(1.0f - wx, f01 - f00, wx * (f11 - f10));
    vec2 g = {MAD(m[0], ds, m[3] * dt), MAD(m[1], ds, m[4] * dt)};
    return g;
}

#endif
