/* Warps of uniform points in [0, 1)^2 to directions with a given density (Mitsuba 3's warp.h, pbrt-v4's
 * sampling.h): what the diffuse BSDF and the constant environment sample by. */
#ifndef WARP_CL
#define WARP_CL

#include "local_frame.cl"

/* A uniform point on the unit disk from u in [0, 1)^2: Shirley and Chiu's concentric map (pbrt-v4 section
 * A.5.1, Mitsuba's square_to_uniform_disk_concentric), which keeps strata and distances close. */
inline vec2 uniform_disk_concentric(vec2 u)
{
    vfloat a = MAD(2.0f, u.x, -1.0f), b = MAD(2.0f, u.y, -1.0f);
    vint first = vabs(a) > vabs(b);
    vfloat r = SELECT(b, a, first);
    /* phi = x (first) or pi/2 - x, |x| <= pi/4: cos and sin of x, exchanged for pi/2 - x, inline (vmath.h) */
    vfloat x = SELECT((M_PI_4_F * a) / b, (M_PI_4_F * b) / a, first), sin_x, cos_x;
    x = SELECT(x, (vfloat)(0.0f), (a == 0.0f) & (b == 0.0f));
    vsincos_quarter(x, &sin_x, &cos_x);
    vec2 p = {r * SELECT(sin_x, cos_x, first), r * SELECT(cos_x, sin_x, first)};
    return p;
}

/* A direction about the unit normal n with density cos(theta) / pi, from u in [0, 1)^2: Malley's method, a
 * uniform point on the disk (uniform_disk_concentric) lifted to the hemisphere. */
inline vec3 cosine_direction(vec3 n, vec2 u)
{
    vec2 p = uniform_disk_concentric(u);
    vfloat dx = p.x, dy = p.y;
    vfloat dz = sqrt(vmax((vfloat)(0.0f), 1.0f - dx * dx - dy * dy));
    vec3 t, bt;
    orthonormal_frame(n, &t, &bt);
    return v3_add(v3_add(v3_scale(t, dx), v3_scale(bt, dy)), v3_scale(n, dz));
}

#endif
