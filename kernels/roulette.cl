/* Russian roulette (pbrt-v4 section 13.1.1; Mitsuba 3's `path`), which the renderer's path tracer
 * (path_tracing.cl's path_vertex) and the tests' own (tests/path_support.py) play alike: from vertex rr_depth
 * on (RenderParams, render.rr_depth: Mitsuba's rr_depth, default 5; a run-time value, so that changing it
 * rebuilds nothing), a path continues with probability q = min(max(throughput), RR_MAX_Q) and its throughput
 * is divided by q, so that the estimate stays unbiased while dim paths end. */
#ifndef ROULETTE_CL
#define ROULETTE_CL

#include "vmath.h"

#define RR_MAX_Q 0.95f /* a path always has a chance to end there, however bright its throughput */

/* The lanes that survive the roulette played on the lanes of `roulette` with the uniform number u, throughput
 * *beta (divided by q on those lanes); the other lanes survive untouched. */
inline vint russian_roulette(vint roulette, vfloat u, vec3 *beta)
{
    if (!ANY(roulette))
        return (vint)(-1) != 0;
    vfloat q = vmin(vmax(beta->x, vmax(beta->y, beta->z)), (vfloat)(RR_MAX_Q));
    *beta = v3_select(*beta, v3_scale(*beta, 1.0f / vmax(q, (vfloat)(1e-30f))), roulette);
    return !roulette | (u < q);
}

#endif
