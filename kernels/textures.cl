/* Texel fetches, wrap modes and bilinear filtering inside one MIP level, for LANES points of one texture.
 *
 * All levels of all textures live in one buffer of 32-bit words (the host packs them; raytrace/scene/mipmap.py).
 * 8-bit textures keep one word per RGBA texel on the device, a quarter of float4's memory and bandwidth,
 * and are decoded here: sRGB colour maps through a 256-entry table (exact, and cheaper than pow), data
 * maps by / 255. Height maps hold each texel's quad (types.h): a bilinear lookup reads one texel, of one
 * word (8-bit maps), two (16-bit: code / 65535) or four (float).
 * Coordinates follow OpenImageIO's (s, t): texel (i, j), row j from the top, has its centre at
 * ((i + 1/2) / W, (j + 1/2) / H); the renderer's v runs up the image, so t = 1 - v.
 *
 * The texture is the same for every lane (material.cl groups lanes by material); the points, and so the
 * levels and texels, differ per lane: the arithmetic runs on lanes, and only the loads are one per lane.
 * Lookups give RGB: no caller reads alpha. */
#ifndef TEXTURES_CL
#define TEXTURES_CL

#include "scene.h"
#include "vmath.h"

/* Where each lane's level starts in the texel buffer, and its size: lanes may sit on different levels. */
typedef struct { vint offset, width, height; } Levels;

inline Levels mip_levels(TextureStore ts, int texture, vint level)
{
    __global const MipLevel *levels = ts.levels + ts.textures[texture].first_level;
    int first = FIRST_LANE(level);
    if (ALL(level == first)) { /* the common case: neighbouring pixels share a level */
        MipLevel m = levels[first];
        Levels r = {(vint)(m.offset), (vint)(m.width), (vint)(m.height)};
        return r;
    }
    int l[LANES], offset[LANES], width[LANES], height[LANES];
    VSTORE(level, l);
    for (int i = 0; i < LANES; ++i) {
        MipLevel m = levels[l[i]];
        offset[i] = m.offset;
        width[i] = m.width;
        height[i] = m.height;
    }
    Levels r = {VLOAD_INT(offset), VLOAD_INT(width), VLOAD_INT(height)};
    return r;
}

/* The 8-bit channel at bit `shift` of each lane's word, as a float in [0, 255]. */
inline vfloat channel8(vuint word, int shift) { return CONVERT_VFLOAT(AS_VINT((word >> shift) & 0xffU)); }

/* The texel buffer's word at each lane's index: one load per lane. */
ALWAYS_INLINE vuint texel_words(TextureStore ts, vint index)
{
    int at[LANES];
    uint words[LANES];
    VSTORE(index, at);
    for (int k = 0; k < LANES; ++k)
        words[k] = ts.texels[at[k]];
    return VLOAD_UINT(words);
}

/* The 16-bit half of each lane's word at bit `shift`, as a height in [0, 1]. */
inline vfloat height16(vuint word, int shift)
{
    return CONVERT_VFLOAT(AS_VINT((word >> shift) & 0xffffU)) * (1.0f / 65535.0f);
}

/* Each lane's 8-bit texel word (r in the low byte) decoded to linear RGB: sRGB through the table (three loads
 * per lane), data by / 255 (a height map's height thrice). */
ALWAYS_INLINE vec3 decode8(TextureStore ts, int encoding, vuint word)
{
    float r[LANES], g[LANES], b[LANES];
    if (encoding == TEXELS_UNORM8 || encoding == TEXELS_QUAD8) {
        vec3 c = v3_scale(v3(channel8(word, 0), channel8(word, 8), channel8(word, 16)), (vfloat)(1.0f / 255.0f));
        return encoding == TEXELS_QUAD8 ? v3(c.x, c.x, c.x) : c;
    }
    uint words[LANES];
    VSTORE(word, words);
    for (int k = 0; k < LANES; ++k) {
        r[k] = ts.srgb_to_linear[words[k] & 0xffU];
        g[k] = ts.srgb_to_linear[(words[k] >> 8) & 0xffU];
        b[k] = ts.srgb_to_linear[(words[k] >> 16) & 0xffU];
    }
    return v3(VLOAD(r), VLOAD(g), VLOAD(b));
}

/* Texel (i, j) of each lane's level, decoded to linear RGB: one load per lane and word (three more through
 * the sRGB table), the decoding on lanes; a height map's height thrice. Inlined: its result would otherwise
 * pass through memory. */
ALWAYS_INLINE vec3 texel_fetch(TextureStore ts, int encoding, Levels level, vint i, vint j)
{
    int at[LANES];
    float r[LANES], g[LANES], b[LANES];
    vint index = j * level.width + i;
    if (encoding == TEXELS_FLOAT || encoding == TEXELS_QUADF) {
        VSTORE(level.offset + 4 * index, at);
        __global const float *texels = (__global const float *)ts.texels;
        for (int k = 0; k < LANES; ++k)
            r[k] = texels[at[k]];
        if (encoding == TEXELS_QUADF)
            return v3(VLOAD(r), VLOAD(r), VLOAD(r));
        for (int k = 0; k < LANES; ++k) {
            g[k] = texels[at[k] + 1];
            b[k] = texels[at[k] + 2];
        }
        return v3(VLOAD(r), VLOAD(g), VLOAD(b));
    }
    if (encoding == TEXELS_QUAD16) {
        vfloat h = height16(texel_words(ts, level.offset + 2 * index), 0);
        return v3(h, h, h);
    }
    return decode8(ts, encoding, texel_words(ts, level.offset + index));
}

/* The heights of a height map's texel (i, j) and of its neighbours (i + 1, j), (i, j + 1), (i + 1, j + 1), from
 * its quad (TEXELS_QUAD8, TEXELS_QUAD16 or TEXELS_QUADF): one texel read per lane, decoded as texel_fetch
 * decodes each. */
typedef struct { vfloat h00, h10, h01, h11; } Quad;

ALWAYS_INLINE Quad quad_fetch(TextureStore ts, int encoding, Levels level, vint i, vint j)
{
    Quad q;
    vint index = j * level.width + i;
    if (encoding == TEXELS_QUAD8) {
        vuint word = texel_words(ts, level.offset + index);
        q.h00 = channel8(word, 0) * (1.0f / 255.0f);
        q.h10 = channel8(word, 8) * (1.0f / 255.0f);
        q.h01 = channel8(word, 16) * (1.0f / 255.0f);
        q.h11 = channel8(word, 24) * (1.0f / 255.0f);
        return q;
    }
    if (encoding == TEXELS_QUAD16) {
        int at[LANES];
        uint w0[LANES], w1[LANES];
        VSTORE(level.offset + 2 * index, at);
        for (int k = 0; k < LANES; ++k) {
            w0[k] = ts.texels[at[k]];
            w1[k] = ts.texels[at[k] + 1];
        }
        vuint upper = VLOAD_UINT(w0), lower = VLOAD_UINT(w1);
        q.h00 = height16(upper, 0);
        q.h10 = height16(upper, 16);
        q.h01 = height16(lower, 0);
        q.h11 = height16(lower, 16);
        return q;
    }
    int at[LANES];
    float h00[LANES], h10[LANES], h01[LANES], h11[LANES];
    VSTORE(level.offset + 4 * index, at);
    __global const float *texels = (__global const float *)ts.texels;
    for (int k = 0; k < LANES; ++k) {
        h00[k] = texels[at[k]];
        h10[k] = texels[at[k] + 1];
        h01[k] = texels[at[k] + 2];
        h11[k] = texels[at[k] + 3];
    }
    q.h00 = VLOAD(h00);
    q.h10 = VLOAD(h10);
    q.h01 = VLOAD(h01);
    q.h11 = VLOAD(h11);
    return q;
}

/* The words of texels (i0, j0), (i1, j0), (i0, j1) and (i1, j1) of each lane's level (one-word encodings),
 * loaded in one loop: LLVM then issues each lane's four loads together, where four texel_fetch calls each
 * passed their lanes' indices through memory on their own (a visible share of textured_cornell's time:
 * measured in commit 4e50421). */
typedef struct { vuint w00, w10, w01, w11; } Words4;

ALWAYS_INLINE Words4 four_words(TextureStore ts, Levels level, vint i0, vint i1, vint j0, vint j1)
{
    int a00[LANES], a10[LANES], a01[LANES], a11[LANES];
    uint w00[LANES], w10[LANES], w01[LANES], w11[LANES];
    vint row0 = level.offset + j0 * level.width, row1 = level.offset + j1 * level.width;
    VSTORE(row0 + i0, a00);
    VSTORE(row0 + i1, a10);
    VSTORE(row1 + i0, a01);
    VSTORE(row1 + i1, a11);
    for (int k = 0; k < LANES; ++k) {
        w00[k] = ts.texels[a00[k]];
        w10[k] = ts.texels[a10[k]];
        w01[k] = ts.texels[a01[k]];
        w11[k] = ts.texels[a11[k]];
    }
    Words4 w = {VLOAD_UINT(w00), VLOAD_UINT(w10), VLOAD_UINT(w01), VLOAD_UINT(w11)};
    return w;
}

/* i mod n in [0, n). The callers' indices come from reduce_coordinate, within a period of [0, n), where one
 * addition or subtraction does; integer division (tens of cycles a lane) only for anything else. */
inline vint modulo(vint i, vint n)
{
    vint far = (i < -n) | (i >= 2 * n);
    if (ANY(far))
        i = SELECT(i, i % n, far);
    i = SELECT(i, i + n, i < 0);
    return SELECT(i, i - n, i >= n);
}

/* An integer texel index i into [0, n) by the wrap mode. */
inline vint wrap_index(vint i, vint n, int mode)
{
    if (mode == WRAP_CLAMP)
        return SELECT(SELECT(i, 0, i < 0), n - 1, i >= n);
    if (mode == WRAP_MIRROR) {
        vint m = modulo(i, 2 * n);
        return SELECT(m, 2 * n - 1 - m, m >= n);
    }
    return modulo(i, n);
}

/* A continuous texel coordinate x brought near [0, n) without changing what wrap_index makes of it, so
 * that its floor fits an int however large u grows (uv_scale 1e6, a grazing floor). NaN becomes 0. Where
 * x / period rounds by more than a period (|x| beyond about 2^24 periods, where x's float spacing exceeds
 * the texture's), the remainder can land anywhere, even beyond an int: such lanes take 0, as good a point
 * of the period as any at that resolution. */
inline vfloat reduce_coordinate(vfloat x, vint n, int mode)
{
    vfloat size = CONVERT_VFLOAT(n);
    x = SELECT((vfloat)(0.0f), x, vabs(x) < INFINITY);
    if (mode == WRAP_CLAMP)
        return vmin(vmax(x, -1.0f), size);
    vfloat period = mode == WRAP_MIRROR ? 2.0f * size : size;
    vfloat r = x - period * vfloor(x / period);
    return SELECT((vfloat)(0.0f), r, vabs(r) < 2.0f * period);
}

/* The texel of each lane's level whose cell contains st. */
inline vec3 texture_nearest(TextureStore ts, int encoding, Levels level, vec2 st, int wrap)
{
    vfloat x = reduce_coordinate(st.x * CONVERT_VFLOAT(level.width), level.width, wrap);
    vfloat y = reduce_coordinate(st.y * CONVERT_VFLOAT(level.height), level.height, wrap);
    vint i = wrap_index(CONVERT_VINT(vfloor(x)), level.width, wrap);
    vint j = wrap_index(CONVERT_VINT(vfloor(y)), level.height, wrap);
    return texel_fetch(ts, encoding, level, i, j);
}

/* Bilinear interpolation between the four texel centres around st in each lane's level. A height map reads
 * one quad per lane where no lane's four texels wrap around an edge, and mixes its heights with the same
 * operations as the four texels': the same result. */
inline vec3 texture_bilinear(TextureStore ts, int encoding, Levels level, vec2 st, int wrap)
{
    vfloat x = reduce_coordinate(st.x * CONVERT_VFLOAT(level.width) - 0.5f, level.width, wrap);
    vfloat y = reduce_coordinate(st.y * CONVERT_VFLOAT(level.height) - 0.5f, level.height, wrap);
    vfloat fx = vfloor(x), fy = vfloor(y);
    vfloat wx = x - fx, wy = y - fy;
    vint ix = CONVERT_VINT(fx), iy = CONVERT_VINT(fy);
    vint i0 = wrap_index(ix, level.width, wrap), i1 = wrap_index(ix + 1, level.width, wrap);
    vint j0 = wrap_index(iy, level.height, wrap), j1 = wrap_index(iy + 1, level.height, wrap);
    if (TEXELS_ARE_QUADS(encoding) && ALL((i1 == i0 + 1) & (j1 == j0 + 1))) {
        Quad q = quad_fetch(ts, encoding, level, i0, j0);
        vfloat top = MAD(wx, q.h10 - q.h00, q.h00), bottom = MAD(wx, q.h11 - q.h01, q.h01);
        vfloat h = MAD(wy, bottom - top, top);
        return v3(h, h, h);
    }
    if (encoding == TEXELS_SRGB8 || encoding == TEXELS_UNORM8 || encoding == TEXELS_QUAD8) {
        Words4 w = four_words(ts, level, i0, i1, j0, j1);
        vec3 top = v3_mix(decode8(ts, encoding, w.w00), decode8(ts, encoding, w.w10), wx);
        vec3 bottom = v3_mix(decode8(ts, encoding, w.w01), decode8(ts, encoding, w.w11), wx);
        return v3_mix(top, bottom, wy);
    }
    vec3 top = v3_mix(texel_fetch(ts, encoding, level, i0, j0), texel_fetch(ts, encoding, level, i1, j0), wx);
    vec3 bottom = v3_mix(texel_fetch(ts, encoding, level, i0, j1), texel_fetch(ts, encoding, level, i1, j1), wx);
    return v3_mix(top, bottom, wy);
}

#endif
