/* Texel fetches, wrap modes and bilinear filtering inside one MIP level.
 *
 * All levels of all textures live in one buffer of 32-bit words (the host packs them; raytrace/mipmap.py).
 * 8-bit textures keep one word per RGBA texel on the device, a quarter of float4's memory and bandwidth,
 * and are decoded here: sRGB colour maps through a 256-entry table (exact, and cheaper than pow), data
 * maps by / 255. Coordinates follow OpenImageIO's (s, t): texel (i, j), row j from the top, has its centre
 * at ((i + 1/2) / W, (j + 1/2) / H); the renderer's v runs up the image, so t = 1 - v.
 *
 * This file is scalar: a texture lookup is a gather that differs per pixel, so the lane-generic callers
 * (material.cl) run it once per lane. */
#ifndef TEXTURES_CL
#define TEXTURES_CL

#include "scene.h"
#include "vmath.h"

inline float4 unpack_rgba8(uint word) { return convert_float4(as_uchar4(word)); }

inline float4 texel_fetch(TextureStore ts, int encoding, MipLevel level, int i, int j)
{
    int index = j * level.width + i;
    if (encoding == TEXELS_FLOAT)
    {
        __global const float *t = (__global const float *)ts.texels + level.offset + 4 * index;
        return (float4)(t[0], t[1], t[2], t[3]);
    }
    uint word = ts.texels[level.offset + index];
    if (encoding == TEXELS_UNORM8)
        return unpack_rgba8(word) * (1.0f / 255.0f);
    uchar4 c = as_uchar4(word);
    return (float4)(ts.srgb_to_linear[c.x], ts.srgb_to_linear[c.y], ts.srgb_to_linear[c.z], c.w * (1.0f / 255.0f));
}

/* i mod n in [0, n). The callers' indices come from reduce_coordinate, within a period of [0, n), where one
 * addition or subtraction does; integer division (tens of cycles) only for anything else. */
inline int modulo(int i, int n)
{
    if (i < -n || i >= 2 * n)
        i %= n;
    return i < 0 ? i + n : (i >= n ? i - n : i);
}

/* An integer texel index i into [0, n) by the wrap mode. */
inline int wrap_index(int i, int n, int mode)
{
    if (mode == WRAP_CLAMP)
        return clamp_int(i, 0, n - 1);
    if (mode == WRAP_MIRROR) {
        int m = modulo(i, 2 * n);
        return m < n ? m : 2 * n - 1 - m;
    }
    return modulo(i, n);
}

/* A continuous texel coordinate x brought near [0, n) without changing what wrap_index makes of it, so
 * that its floor fits an int however large u grows (uv_scale 1e6, a grazing floor). NaN becomes 0. */
inline float reduce_coordinate(float x, int n, int mode)
{
    if (!finite1(x))
        return 0.0f;
    if (mode == WRAP_CLAMP)
        return min1(max1(x, -1.0f), (float)n);
    float period = mode == WRAP_MIRROR ? 2.0f * n : (float)n;
    return x - period * floor1(x / period);
}

inline MipLevel mip_level(TextureStore ts, int texture, int level)
{
    return ts.levels[ts.textures[texture].first_level + level];
}

/* Level 0, the texel whose cell contains st. */
inline float4 texture_nearest(TextureStore ts, int texture, float2 st, int wrap)
{
    MipLevel level = mip_level(ts, texture, 0);
    float x = reduce_coordinate(st.x * level.width, level.width, wrap);
    float y = reduce_coordinate(st.y * level.height, level.height, wrap);
    int i = wrap_index((int)floor1(x), level.width, wrap), j = wrap_index((int)floor1(y), level.height, wrap);
    return texel_fetch(ts, ts.textures[texture].encoding, level, i, j);
}

/* Bilinear interpolation between the four texel centres around st in one level. */
inline float4 texture_bilinear(TextureStore ts, int texture, int level_index, float2 st, int wrap)
{
    MipLevel level = mip_level(ts, texture, level_index);
    int encoding = ts.textures[texture].encoding;
    float x = reduce_coordinate(st.x * level.width - 0.5f, level.width, wrap);
    float y = reduce_coordinate(st.y * level.height - 0.5f, level.height, wrap);
    float fx = floor1(x), fy = floor1(y);
    float wx = x - fx, wy = y - fy;
    int i0 = wrap_index((int)fx, level.width, wrap), i1 = wrap_index((int)fx + 1, level.width, wrap);
    int j0 = wrap_index((int)fy, level.height, wrap), j1 = wrap_index((int)fy + 1, level.height, wrap);
    float4 top = mix4(texel_fetch(ts, encoding, level, i0, j0), texel_fetch(ts, encoding, level, i1, j0), wx);
    float4 bottom = mix4(texel_fetch(ts, encoding, level, i0, j1), texel_fetch(ts, encoding, level, i1, j1), wx);
    return mix4(top, bottom, wy);
}

#endif
