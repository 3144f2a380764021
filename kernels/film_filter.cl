/* The film's reconstruction filters (Mitsuba 3's rfilters: tent, gaussian, mitchell, lanczos; the box filter
 * needs none of this), by filter importance sampling (pbrt-v4 section 8.8.3, FilterSampler): each camera ray's
 * offset from its pixel's centre is drawn along each axis with a density p close to |f|, and its sample
 * weighted by f / p over the filter's integral, so that a pixel's plain average of weighted samples tends to
 * the filter's normalised convolution of the image, as Mitsuba's splatting (sum f L / sum f) does: the same
 * limit, other noise. No sample leaves its pixel's sums, so no atomics across work-items or Dask bands.
 *
 * Mitsuba's filters are separable (its ImageBlock weighs a sample by f(dx) f(dy)), and so is the sampling: each
 * axis draws from a piecewise-linear density through |f| at the nodes of the Camera's table (a node on each
 * half-integer offset), by inverting its integral. Mitsuba's film takes no sample outside the crop window (its
 * sample_border is off by default), so a pixel near the window's edge averages over the part of its filter
 * inside: a sample outside weighs 0 and the weights are over the filter's integral inside, read at
 * half-integer nodes from the table of f's cumulative integral (exact there). */
#ifndef FILM_FILTER_CL
#define FILM_FILTER_CL

#include "types.h"

/* Mitsuba's filter at offset x, in pixels (src/rfilters/): tent 1 - |x| / radius (a = 1 / radius); gaussian
 * exp(-x^2 / (2 stddev^2)) less its value at 4 stddev (a = -1 / (2 stddev^2), b = exp(a (4 stddev)^2)), the
 * formula its GPU variants take (its CPU ones fit a polynomial to it); mitchell of B = a, C = b, radius 2;
 * lanczos sinc(x) sinc(x / lobes), lobes = a. */
inline float rfilter_eval(__constant const Camera *cam, float x)
{
    const float a = cam->rfilter_a, b = cam->rfilter_b, ax = fabs(x);
    switch (cam->rfilter) {
    case RFILTER_TENT:
        return fmax(0.0f, 1.0f - ax * a);
    case RFILTER_GAUSSIAN:
        return fmax(0.0f, exp(a * x * x) - b);
    case RFILTER_MITCHELL: {
        const float x2 = ax * ax, x3 = x2 * ax;
        if (ax >= 2.0f)
            return 0.0f;
        if (ax < 1.0f)
            return (1.0f / 6.0f) * ((12.0f - 9.0f * a - 6.0f * b) * x3 + (-18.0f + 12.0f * a + 6.0f * b) * x2 +
                                    (6.0f - 2.0f * a));
        return (1.0f / 6.0f) * ((-a - 6.0f * b) * x3 + (6.0f * a + 30.0f * b) * x2 + (-12.0f * a - 48.0f * b) * ax +
                                (8.0f * a + 24.0f * b));
    }
    case RFILTER_LANCZOS: {
        if (ax < 1e-6f)
            return 1.0f;
        if (ax > a)
            return 0.0f;
        const float x1 = M_PI_F * ax, x2 = x1 / a;
        return (sin(x1) * sin(x2)) / (x1 * x2);
    }
    }
    return 0.0f;
}

/* An offset along one axis from u in [0, 1) with the table's density, which *density receives: the bin whose
 * cumulative range holds u, then the point of the bin where the density's integral (a quadratic of a linear
 * density) reaches u, in the stable form 2a / (p0 + sqrt(p0^2 + 2 slope a)) of the root. */
inline float rfilter_sample(__constant const Camera *cam, float u, float *density)
{
    int lo = 0, hi = cam->rfilter_bins;
    while (hi - lo > 1) {
        const int mid = (lo + hi) / 2;
        if (cam->rfilter_cdf[mid] <= u)
            lo = mid;
        else
            hi = mid;
    }
    const float h = cam->rfilter_step, p0 = cam->rfilter_pdf[lo], slope = (cam->rfilter_pdf[lo + 1] - p0) / h;
    const float a = u - cam->rfilter_cdf[lo], root = p0 + sqrt(fmax(0.0f, p0 * p0 + 2.0f * slope * a));
    const float t = root > 0.0f ? clamp(2.0f * a / root, 0.0f, h) : 0.0f;
    *density = p0 + slope * t;
    return MAD((float)lo, h, -cam->rfilter_reach) + t;
}

/* The filter's integral over the offsets in [lo, hi] (half-integers, or the table's ends), over its whole. */
inline float rfilter_share(__constant const Camera *cam, float lo, float hi)
{
    const float reach = cam->rfilter_reach;
    const int i = (int)rint((fmax(lo, -reach) + reach) / cam->rfilter_step);
    const int j = (int)rint((fmin(hi, reach) + reach) / cam->rfilter_step);
    return cam->rfilter_cumulative[j] - cam->rfilter_cumulative[i];
}

/* One axis's offsets of the lanes' samples from their pixels' centres (pixel: the pixel's index in the crop
 * window of `window` pixels), from u in [0, 1), and each sample's weight along the axis: f / (p * the filter's
 * integral inside the window), 0 outside it; with the camera's rfilter_border (Mitsuba's sample_border), the
 * window bounds nothing: f / (p * the whole integral). */
inline vfloat rfilter_offsets(__constant const Camera *cam, vfloat u, vint pixel, int window, vfloat *weight)
{
    float us[LANES], w[LANES];
    int at[LANES];
    VSTORE(u, us);
    VSTORE(pixel, at);
    for (int l = 0; l < LANES; ++l) {
        float density;
        const float x = rfilter_sample(cam, us[l], &density);
        const float centre = (float)at[l] + 0.5f, lo = -centre, hi = (float)window - centre;
        const int border = cam->rfilter_border; /* no window: the whole filter */
        const float inside = border ? cam->rfilter_integral : rfilter_share(cam, lo, hi) * cam->rfilter_integral;
        const int in = (border || (x >= lo && x < hi)) && density > 0.0f;
        w[l] = in ? rfilter_eval(cam, x) / (density * inside) : 0.0f;
        us[l] = 0.5f + x;
    }
    *weight = VLOAD(w);
    return VLOAD(us);
}

#endif
