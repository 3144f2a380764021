/* Sample points: a pixel sample's numbers, drawn dimension pair by dimension pair (pbrt-v4's Sampler), from the
 * host's pattern tables or from the Owen-scrambled Sobol sequence, randomised per pixel.
 *
 * A table holds a pattern's points in 0.32 fixed point, the same for every pixel. Used as it is, every
 * pixel would see the same pattern and the image would show its structure (aliasing) instead of noise, so
 * random and low-discrepancy patterns are randomised from a key: a hash of the seed, the pixel and the
 * stream (the pixel samples, or the light samples of one pixel sample and one light). Fixed point keeps
 * every randomisation exact: a toroidal shift is an integer addition mod 2^32, Owen scrambling permutes
 * bits, and the float result (v >> 8) 2^-24 lies in [0, 1 - 2^-24], never at 1.
 *
 * Those tables stratify a stream's points among themselves only: the light points of one pixel sample are
 * spread over the light, but with one light sample per pixel sample each is a fresh random point, and the
 * error falls like independent random numbers' (N^-1/2). `sobol` instead draws every dimension pair of
 * every pixel sample from one sequence over the pixel's samples (pbrt-v4's PaddedSobolSampler; Burley,
 * "Practical Hash-based Owen Scrambling", JCGT 2020, section 4): dimension pair d of pixel sample i is the
 * 2D Sobol point at index i (light points: i n + j, the n light samples of pixel sample i), Owen-scrambled
 * under a key of the pixel and d, the index itself first Owen-scrambled under another key for d > 0. An
 * Owen scramble of the index maps each aligned block of 2^m indices to an aligned block, whose Sobol points
 * are a (0, m, 2)-net, so every pair stays stratified over every power-of-two prefix of the pixel's samples
 * (the passes of a progressive render, and the error estimate's halves), while the pairs' independent
 * shuffles decorrelate them from one another, as padding by random permutations does (Kollig and Keller,
 * "Efficient Multidimensional Sampling", 2002). Dimension pair 0 is the pixel offset, unshuffled, in the
 * table's Gray-code order; pair 1 + l is light l's. */
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
inline vuint laine_karras(vuint v, vuint seed)
{
    v ^= v * 0x3d20adeaU;
    v += seed;
    v *= (seed >> 16) | 1U;
    v ^= v * 0x05526c56U;
    v ^= v * 0x53a22864U;
    return v;
}

inline vuint owen_scramble(vuint v, vuint seed) { return reverse_bits(laine_karras(reverse_bits(v), seed)); }

/* Sobol's second dimension at index i, bits reversed (bit p is the coefficient of 2^-(p+1)): its generator
 * matrix is Pascal's triangle mod 2, so by Lucas' theorem bit p is the xor of the bits k of i whose set bits
 * include p's, a transform over supersets done in five shifts (dimension 1 of scipy's and Joe and Kuo's
 * direction numbers; the first dimension is i itself, bits reversed). */
inline vuint sobol_pascal(vuint i)
{
    i ^= (i >> 1) & 0x55555555U;
    i ^= (i >> 2) & 0x33333333U;
    i ^= (i >> 4) & 0x0f0f0f0fU;
    i ^= (i >> 8) & 0x00ff00ffU;
    return i ^ (i >> 16);
}

/* The Owen-scrambled 2D Sobol point at `index` (point gray(index) of the sequence: the table's order, the
 * same points in every aligned block of 2^m) in 0.32 fixed point, each coordinate scrambled under its own
 * key from `key` (owen_scramble in the bit-reversed domain, the reversals of i and of the scramble cancel). */
inline void sobol_owen(vuint index, vuint key, vuint *x, vuint *y)
{
    vuint i = index ^ (index >> 1);
    *x = reverse_bits(laine_karras(i, hash(key ^ 0x68e31da4U)));
    *y = reverse_bits(laine_karras(sobol_pascal(i), hash(key ^ 0xb5297a4dU)));
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
    }
    vec2 u = {fixed_to_unit(x), fixed_to_unit(y)};
    return u;
}

/* Point `index` of the sequence's dimension pair keyed `key`, shuffled in the lanes of `shuffle` (d > 0) or
 * not (the pixel offsets). */
inline vec2 sequence_2d(vuint index, vuint key, vint shuffle)
{
    vuint x, y;
    if (ANY(shuffle))
        index = SELECT(index, owen_scramble(index, hash(key ^ 0x2c1b3c6dU)), shuffle);
    sobol_owen(index, key, &x, &y);
    vec2 u = {fixed_to_unit(x), fixed_to_unit(y)};
    return u;
}

/* A pixel sample's numbers (pbrt-v4's Sampler: StartPixelSample, then one dimension pair after another): the
 * pixel's key, the sample's index in the pixel, and the next dimension pair, each lane's own: the path model's
 * lanes start their pixels' next samples as their paths end (render.cl), each at its own pair. */
typedef struct {
    vuint key;
    vint index;
    vint dimension;
} PixelSample;

inline PixelSample start_pixel_sample(vuint pixel_key, vint index)
{
    PixelSample ps = {pixel_key, index, (vint)(0)};
    return ps;
}

/* Where the points of one dimension pair come from, n of them per pixel sample (a light's n samples): the key
 * and the index of the pixel sample's first point. */
typedef struct {
    vuint key;
    vuint first;
    vint shuffle;
} SampleStream;

/* The next dimension pair of ps, with n points per pixel sample. The table patterns keep their streams: the
 * pixel offsets' under the pixel's key (point i of the table for sample i), light l's under a key of the
 * pixel sample and l (points 0 .. n-1 of the table for every pixel sample). */
inline SampleStream next_stream(PixelSample *ps, Sampler sampler, int n)
{
    const vint d = ps->dimension++, later = d > 0; /* pair 0 is the pixel offset */
    SampleStream st = {ps->key, AS_VUINT(ps->index), later};
    if (sampler.randomize == RANDOMIZE_SOBOL) {
        if (ANY(later))
            st.key = SELECT(st.key, stream_key(ps->key, AS_VUINT(d)), later);
        st.first *= (uint)n;
    } else if (ANY(later)) {
        st.key = SELECT(st.key, stream_key(stream_key(ps->key, st.first), AS_VUINT(d - 1)), later);
        st.first = SELECT(st.first, (vuint)(0), later);
    }
    return st;
}

/* next_stream for the lanes of `lanes` only: the other lanes' pair counters stay where they are. */
inline SampleStream next_stream_in(PixelSample *ps, Sampler sampler, int n, vint lanes)
{
    const vint d = ps->dimension;
    SampleStream st = next_stream(ps, sampler, n);
    ps->dimension = SELECT(d, ps->dimension, lanes);
    return st;
}

/* Each lane's point j (of the stream's n per pixel sample) of the stream st, from the pattern `table`. */
inline vec2 stream_2d(__global const uint2 *table, Sampler sampler, SampleStream st, vint j)
{
    if (sampler.randomize == RANDOMIZE_SOBOL)
        return sequence_2d(st.first + AS_VUINT(j), st.key, st.shuffle);
    return sample_2d(table, AS_VINT(st.first) + j, sampler, st.key);
}

#endif
