/* Ray-disk intersection: Mitsuba 3's disk, the unit disk x^2 + y^2 <= 1 in the plane z = 0 of its local
 * space, under the affine map center + to_world x (types.h). The ray is mapped into local space, where t is
 * the same (the direction is mapped, not renormalised), and meets the plane at t = -o.z / d.z: rectangle.cl's
 * plane test, with its rounding bounds counted in local space (pbrt-v4's Disk intersects in object space
 * too). */
#ifndef DISK_CL
#define DISK_CL

#include "affine.h"
#include "ray.h"
#include "types.h"

/* t of the plane crossing where it lies within the disk, else +inf (also for a ray in the plane); *dt: a bound
 * on t's rounding error; *q: the crossing in local space (its z is not used). o = to_local (o_world - center)
 * rounds oc once and its row of MAD()s 5 times (affine.h): o.z is within e_num = gamma(6) |row 3| |oc| of
 * its exact value; d.z within e_den = gamma(5) |row 3| |d|; t = -o.z * (1 / d.z) rounds 6 times more (the
 * reciprocal counts 5, ray.h). So dt = |t| (e_num / |o.z| + e_den / |d.z| + gamma(6)) to first order, formed
 * without the divisions. An origin on the plane to within rounding (|o.z| <= e_num: a ray leaving the disk)
 * gets dt >= |t|, never a hit (ray.h's ranges need t > dt); a ray nearly in the plane (|d.z| <= e_den) too. */
inline vfloat intersect_disk(__global const Disk *k, Ray r, vfloat tmax, vfloat *dt, vec3 *q)
{
    vec3 oc = v3_sub(r.o, v3_uniform(k->center));
    vec3 o = mat3_apply(k->to_local, oc), d = mat3_apply(k->to_local, r.d);
    vfloat inv_den = 1.0f / d.z;
    vfloat t = -o.z * inv_den;
    *dt = 0.0f;
    *q = o;
    if (!ANY((t > 0.0f) & (t <= tmax))) /* behind every lane, or beyond */
        return (vfloat)(INFINITY);
    *q = v3_madd(o, t, d);
    vint inside = MAD(q->x, q->x, q->y * q->y) <= 1.0f;
    if (!ANY(inside))
        return (vfloat)(INFINITY);
    const __global float *row = k->to_local + 6;
    vfloat e_num = GAMMA(6) * MAD(vabs(row[0]), vabs(oc.x), MAD(vabs(row[1]), vabs(oc.y), vabs(row[2]) * vabs(oc.z)));
    vfloat e_den = GAMMA(5) * MAD(vabs(row[0]), vabs(r.d.x), MAD(vabs(row[1]), vabs(r.d.y), vabs(row[2]) * vabs(r.d.z)));
    *dt = MAD(vabs(t), e_den, e_num) * vabs(inv_den) + GAMMA(6) * vabs(t);
    return SELECT((vfloat)(INFINITY), t, inside);
}

/* The disk's unit normal, the same everywhere: to_local^T (0, 0, 1), its third row, times normal_sign (the
 * inverse transpose of to_world, as Mitsuba's Normal3f transforms). */
inline vec3 disk_normal(__global const Disk *k)
{
    vec3 n = v3_splat(k->to_local[6], k->to_local[7], k->to_local[8]);
    return v3_scale(v3_normalize(n), k->normal_sign);
}

/* The world point of local (x, y, 0), center + to_world (x, y, 0): the hit put back on the plane (its local z
 * dropped: pbrt-v4's reprojection), or a point a light sample picks (x = r cos phi, y = r sin phi). *err: its
 * distance from the plane that to_local describes, along the unit normal n. Each coordinate is a row of two
 * MAD()s (4 roundings) plus the centre (1, which is also all the centre's term takes); and to_world and its
 * stored inverse are each rounded once from one float64 pair, which moves the planes they describe apart by
 * at most 3 roundings of |to_world| |(x, y, 0)| along the normal: gamma(8) of it, gamma(1) of |center|. The
 * error of (x, y) itself moves the point within the plane, not off it. */
inline vec3 disk_point(__global const Disk *k, vfloat x, vfloat y, vec3 n, vfloat *err)
{
    vec3 on_shape = v3(x, y, (vfloat)(0.0f));
    vec3 centre = v3_uniform(k->center);
    vec3 p = v3_add(centre, mat3_apply(k->to_world, on_shape));
    vec3 box = v3_add(v3_scale(v3_abs(centre), GAMMA(1)),
                      v3_scale(mat3_apply_abs(k->to_world, v3_abs(on_shape)), GAMMA(8)));
    *err = error_along(n, box);
    return p;
}

#endif
