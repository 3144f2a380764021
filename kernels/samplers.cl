/* Sample points from the host's pattern tables, randomised per pixel and per sample stream.
 *
 * A table holds a pattern's points in 0.32 fixed point, the same for every pixel. Used as it is, every
 * pixel would see the same pattern and the image would show its structure (aliasing) instead of noise, so
 * random and low-discrepancy patterns are randomised from a key: a hash of the seed, the pixel and the
 * stream (the pixel samples, or the light samples of one pixel sample and one light). Fixed point keeps
 * every randomisation exact: a toroidal shift is an integer addition mod 2^32, Owen scrambling permutes
 * bits, and the float result (v >> 8) 2^-24 lies in [0, 1 - 2^-24], never at 1. */
#ifndef SAMPLERS_CL
#define SAMPLERS_CL

#include "types.h"

/* A 32-bit integer hash with low bias (Wellons' "lowbias32", https://nullprogram.com/blog/2018/07/31/). */
inline vuint hash(vuint x)
{
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

/* A key for a new stream below `key`: the hash of both, so that keys of different streams are unrelated. */
inline vuint stream_key(vuint key, vuint stream) { return hash(key ^ hash(stream)); }

/* The key of a pixel's sample streams, from the render's seed. */
inline vuint pixel_key(vuint pixel, uint seed) { return hash(pixel ^ hash((vuint)(seed) + 0x9e3779b9U)); }

inline vuint reverse_bits(vuint v)
{
    v = ((v >> 1) & 0x55555555U) | ((v & 0x55555555U) << 1);
    v = ((v >> 2) & 0x33333333U) | ((v & 0x33333333U) << 2);
    v = ((v >> 4) & 0x0f0f0f0fU) | ((v & 0x0f0f0f0fU) << 4);
    v = ((v >> 8) & 0x00ff00ffU) | ((v & 0x00ff00ffU) << 8);
    return (v >> 16) | (v << 16);
}

/* Hash-based Owen scrambling (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020; pbrt-v4's
 * FastOwenScrambler): in bit-reversed order each step only carries lower bits into higher ones, so every
 * digit of the result is flipped by a function of the digits above it: a nested uniform scramble, which
 * keeps (0, m, 2)-nets nets. */
inline vuint owen_scramble(vuint v, vuint seed)
{
    v = reverse_bits(v);
    v ^= v * 0x3d20adeaU;
    v += seed;
    v *= (seed >> 16) | 1U;
    v ^= v * 0x05526c56U;
    v ^= v * 0x53a22864U;
    return reverse_bits(v);
}

inline vfloat fixed_to_unit(vuint v) { return CONVERT_VFLOAT(v >> 8) * 0x1p-24f; }

/* Each lane's point i of the pattern `table`: one load where the lanes share i (a light sample, or every
 * pixel sample when a work-item's lanes hold one sample each: tile.h), else one per lane. */
inline void table_points(__global const uint2 *table, vint i, vuint *x, vuint *y)
{
    int first = FIRST_LANE(i);
    if (ALL(i == first)) {
        uint2 t = table[first];
        *x = (vuint)(t.x);
        *y = (vuint)(t.y);
        return;
    }
    int at[LANES];
    uint tx[LANES], ty[LANES];
    VSTORE(i, at);
    for (int k = 0; k < LANES; ++k) {
        uint2 t = table[at[k]];
        tx[k] = t.x;
        ty[k] = t.y;
    }
    *x = VLOAD_UINT(tx);
    *y = VLOAD_UINT(ty);
}

/* Each lane's point i of the pattern `table`, randomised as `sampler` says under the lane's key. */
inline vec2 sample_2d(__global const uint2 *table, vint i, Sampler sampler, vuint key)
{
    vuint x, y, index = AS_VUINT(i);
    table_points(table, i, &x, &y);
    switch (sampler.randomize) {
    case RANDOMIZE_INDEPENDENT:
        x = hash(key ^ hash(2U * index));
        y = hash(key ^ hash(2U * index + 1U));
        break;
    case RANDOMIZE_JITTER: /* the corner's low 8 bits are 0: the offset stays in the stratum after >> 8 */
        x += mul_hi(hash(key ^ hash(2U * index)), (vuint)(sampler.cell_x)) << 8;
        y += mul_hi(hash(key ^ hash(2U * index + 1U)), (vuint)(sampler.cell_y)) << 8;
        break;
    case RANDOMIZE_SHIFT:
        x += hash(key ^ 0x68e31da4U);
        y += hash(key ^ 0xb5297a4dU);
        break;
    case RANDOMIZE_OWEN:
        x = owen_scramble(x, hash(key ^ 0x68e31da4U));
        y = owen_scramble(y, hash(key ^ 0xb5297a4dU));
        break;
    }
    vec2 u = {fixed_to_unit(x), fixed_to_unit(y)};
    return u;
}

#endif
