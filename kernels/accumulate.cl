/* A progressive render's sums kept on the device between passes (raytrace/renderer/device_sums.py), so that a
 * pass sends nothing back but its error estimate's partial sums, and the host reads the images once, at the
 * end. The host's own sums (raytrace/renderer/progressive.py) are float64; kernels are float32 without
 * extensions, so a sum here is an unevaluated pair hi + lo of floats, a double-float (Dekker, "A floating-point
 * technique for extending the available precision", Numer. Math. 18, 1971): each addition's rounding error is
 * found exactly by Knuth's TwoSum (TAOCP vol. 2, 4.2.2) and carried in lo. An addition's only rounding is
 * that of lo + e, within u |lo + e| <= u (u |hi| + u |s|) <= 2 u^2 S (u = 2^-24, S the running sum of terms
 * >= 0), so after N additions the pair is within N 2^-47 of the exact sum: 2^-31 for 65536 passes, far below
 * the float32 image it becomes, as the host's float64 sums are. (A device that flushes subnormals loses at
 * most 2^-126 absolute a step.)
 *
 * Layouts, planar like the host's: `total_hi`, `total_lo` hold SUM_PLANES planes of width * height floats (R,
 * G, B and the rays traced, row y at y * width); `prefix` CHANNELS planes, the float32 sum of the first
 * n_prefix samples (the first half of the error estimate); a render launch's output `out` the planes of one
 * band of rows (render.cl), row y at y - row0.
 *
 * TwoSum needs its additions rounded as written: OpenCL C reassociates nothing without -cl-unsafe-math-
 * optimizations, which this program is never built with, and its default contraction of a * b + c into a fused
 * multiply-add only removes a rounding from the weighted sums below (TwoSum has no products). */

#define CHANNELS 3
#define SUM_PLANES 4       /* R, G, B, rays */
#define RAYS_PLANE 3       /* render.cl's output planes */
#define FIRST_HALF_PLANE 4

/* What add_band does with the prefix before adding: nothing, set it from the launch's first-half planes (the
 * first pass), or copy the total into it (the count is about to pass a power of two: progressive.py). */
#define PREFIX_KEEP 0
#define PREFIX_FROM_FIRST_HALF 1
#define PREFIX_FROM_TOTAL 2

/* *hi + *lo + x, renormalised so that hi is the pair's value rounded: TwoSum(hi, x) = s + e exactly, then
 * lo + e, then FastTwoSum(s, lo + e), exact where |s| >= |lo + e| (s holds the sum; lo + e its rounding
 * errors, smaller by 2^-24 or more). hi is then the float32 nearest the pair, the value the host's float64 sum
 * would round to but for the pair's own error (above). An Inf or NaN term leaves NaN, which the host counts and
 * zeroes like any other. */
inline void double_float_add(__global float *hi, __global float *lo, float x)
{
    const float a = *hi, s = a + x, b_part = s - a;
    const float e = (a - (s - b_part)) + (x - b_part);
    const float l = *lo + e, h = s + l;
    *lo = l - (h - s);
    *hi = h;
}

/* Add a render launch's band (rows [row0, row0 + rows) of the image) into the sums; one work-item per pixel,
 * (x, y - row0). */
__kernel void add_band(__global const float *out, int width, int height, int row0, int rows, int prefix_from,
                       __global float *total_hi, __global float *total_lo, __global float *prefix)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= width || y >= rows)
        return;
    const int band_plane = width * rows, plane = width * height;
    const int at = (row0 + y) * width + x, band_at = y * width + x;
    for (int c = 0; c < CHANNELS; ++c) {
        if (prefix_from == PREFIX_FROM_FIRST_HALF)
            prefix[c * plane + at] = out[(FIRST_HALF_PLANE + c) * band_plane + band_at];
        else if (prefix_from == PREFIX_FROM_TOTAL)
            prefix[c * plane + at] = total_hi[c * plane + at]; /* the pair rounded: add's invariant */
    }
    for (int p = 0; p < SUM_PLANES; ++p)
        double_float_add(total_hi + p * plane + at, total_lo + p * plane + at, out[p * band_plane + band_at]);
}

/* The value of the pixel (x, y)'s half difference in channel c, (A - B) sqrt(nA nB) / N with A the mean of the
 * first n_prefix samples and B of the rest, as one linear combination of the sums (progressive.py's
 * Halves.weights): prefix * prefix_weight + total * total_weight, the weights computed by the host in float64
 * and rounded once. The total is hi alone, the pair rounded (double_float_add's invariant): reading lo too
 * would give the same float and double the total's memory traffic. */
inline float half_difference(__global const float *total_hi, __global const float *prefix, int at,
                             float prefix_weight, float total_weight)
{
    return prefix[at] * prefix_weight + total_hi[at] * total_weight;
}

/* Partial sums for the error estimate: work-item (x, k) sums, over the rows k, k + chunks, k + 2 chunks ...
 * of column x and its CHANNELS channels, the squared half differences and the sums' values (for the estimate
 * relative to the image's mean); the host adds the width * chunks pairs in float64. Neighbouring work-items
 * read neighbouring pixels. A float32 running sum of n terms >= 0, n = CHANNELS * ceil(height / chunks), is
 * within n - 1 roundings of its value: 47 u (2^-18.4) for 16 rows, under 2^-10 at most (16384 rows in 4 chunks),
 * either way a negligible error in an error estimate. */
__kernel void estimate_partials(__global const float *total_hi, __global const float *prefix, int width,
                                int height, int chunks, float prefix_weight, float total_weight,
                                __global float2 *partials)
{
    const int x = get_global_id(0), k = get_global_id(1);
    if (x >= width || k >= chunks)
        return;
    const int plane = width * height;
    float squares = 0.0f, values = 0.0f;
    for (int y = k; y < height; y += chunks)
        for (int c = 0; c < CHANNELS; ++c) {
            const int at = c * plane + y * width + x;
            const float d = half_difference(total_hi, prefix, at, prefix_weight, total_weight);
            squares += d * d;
            values += total_hi[at];
        }
    partials[k * width + x] = (float2)(squares, values);
}

/* The mean of n samples whose sum is the pair hi + lo: m = hi / n, then corrected by the residual, which
 * fma(-m, n, hi) finds exactly (m is within a few ulps of hi / n, so hi - m n is a float; fma rounds once, and
 * OpenCL C requires its fma to be correctly rounded), over n. The correction is a few ulps of m at most, so
 * its own roundings (and a device's division, within 2.5 ulps of the quotient where the program is not built
 * with -cl-fp32-correctly-rounded-divide-sqrt) reach the result only as a fraction of an ulp: the mean is
 * within little more than half an ulp of the pair's quotient, as the host's float64 mean rounded once is. A
 * constant sample gives itself back exactly: hi + lo = c n exactly, the residual plus lo is n (c - m)
 * exactly (a few ulps of c times n <= 2^16), and m + (c - m) = c. */
inline float mean_of(float hi, float lo, float n)
{
    const float m = hi / n;
    return m + (fma(-m, n, hi) + lo) / n;
}

/* The images, interleaved H x W x CHANNELS: the mean of the samples (mean_of) and, where has_variance, the
 * estimated variance of each pixel's mean, the squared half difference. */
__kernel void resolve_images(__global const float *total_hi, __global const float *total_lo,
                             __global const float *prefix, int width, int height, float n,
                             int has_variance, float prefix_weight, float total_weight, __global float *image,
                             __global float *variance)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= width || y >= height)
        return;
    const int plane = width * height, pixel = y * width + x;
    for (int c = 0; c < CHANNELS; ++c) {
        const int at = c * plane + pixel;
        image[CHANNELS * pixel + c] = mean_of(total_hi[at], total_lo[at], n);
        if (has_variance) {
            const float d = half_difference(total_hi, prefix, at, prefix_weight, total_weight);
            variance[CHANNELS * pixel + c] = d * d;
        }
    }
}
