/* Area emitters on shapes (Mitsuba 3's `area` emitter on any shape; types.h's Emitter): sampling a point of an
 * emitting shape seen from a reference point, and the density of that sampling at a point a ray hit, which
 * the path model's multiple importance sampling weighs light reached by a BSDF's sample with.
 *
 * A mesh is sampled by area: a triangle in proportion to its area (a binary search on the host's cumulative
 * table), then a uniform point on it (pbrt-v4 section A.5.4's SampleUniformTriangle, Heitz's low-distortion
 * map), so that the density is 1 / A over the whole mesh; a rectangle and a disk uniformly over their area; a
 * cylinder uniformly in (phi, z), whose density by area is 1 / (2 pi |dp/dphi x dp/dz|) at the point (constant
 * but under a non-uniform scale across the axis, which makes the tube elliptic). A sphere is
 * sampled by the cone of directions it subtends (pbrt-v4 section 6.2.4, Sphere::Sample with a reference point;
 * Mitsuba's sphere does the same), whose density 1 / (2 pi (1 - cos(theta_max))) is uniform over the cone.
 * Densities are per unit solid angle at the reference point: an area density p_A becomes p_A r^2 / cos(theta_l).
 *
 * A shape emits from its front side only (where its normal points; Mitsuba's `area`): a sample counts only where
 * the reference point sees that side (the models' sample_counts), and a point inside a sphere gets none.
 *
 * The delta lights (HAS_DELTA_EMITTERS; Mitsuba 3.9.1's point, spot, directional and projector, each in its
 * src/emitters/NAME.cpp; pbrt-v4 section 12.1) have one "sample" each, the light itself: its radiance / pdf is
 * what arrives at the reference point, pdf = r^2 (a directional light's 1, its radiance the irradiance). Its
 * normal points from the light towards the reference point, so that the models' rule for the side a light emits
 * from passes. */
#ifndef EMITTERS_CL
#define EMITTERS_CL

#include "primitive.cl"
#include "local_frame.cl"
#include "vmath.h"

#if HAS_DELTA_EMITTERS
#include "lookups.cl"
#endif

typedef struct {
    vec3 p;     /* the point sampled */
    vec3 n;     /* the unit normal of its emitting side */
    vfloat err; /* p's distance from the surface along n (ray.h) */
    vfloat pdf; /* the sample's density per unit solid angle at the reference point; 0: no sample */
    vec3 radiance; /* what arrives along the sample per unit of 1 / pdf: an area emitter's radiance, a delta
                    * light's intensity (times its falloff, its image) or irradiance */
    vint delta;    /* a delta light's sample (no BSDF sample meets it: its MIS weight is 1) */
} EmitterSample;

/* 1 - cos(theta_max) of the cone a sphere of squared radius r2 subtends from a point at squared distance d2 >
 * r2 from its centre, and through *sin2_max, sin^2(theta_max) = r2 / d2. Below sin^2 = 0.00068523 (about 1.5
 * degrees) 1 - sqrt(1 - s) cancels: its series s / 2 is used there, as pbrt-v4 does. */
inline vfloat cone_one_minus_cos(vfloat r2, vfloat d2, vfloat *sin2_max)
{
    vfloat s = r2 / d2;
    *sin2_max = s;
    return SELECT(1.0f - sqrt(vmax(1.0f - s, 0.0f)), 0.5f * s, s < 0.00068523f);
}

#if HAS_CYLINDERS
/* |dp/dphi x dp/dz| at the unit tube's point q = (cos phi, sin phi, z): the world area of a unit of (phi, z)
 * there. */
inline vfloat cylinder_jacobian(__global const Cylinder *tube, vec3 q)
{
    vec3 dphi = mat3_apply(tube->to_world, v3(-q.y, q.x, (vfloat)(0.0f)));
    vec3 dz = v3_splat(tube->to_world[2], tube->to_world[5], tube->to_world[8]);
    vec3 c = v3_cross(dphi, dz);
    return sqrt(v3_dot(c, c));
}
#endif

#if HAS_TRIANGLES
/* A uniform point of emitting mesh e's triangles (by area), from u: *p, *n (the triangle's front), *err. */
inline void sample_mesh(const Scene *s, __global const Emitter *e, vec2 u, vint active, vec3 *p, vec3 *n,
                        vfloat *err)
{
    float ux[LANES], uy[LANES];
    int use[LANES];
    Lanes3 v0, v1, v2, normal;
    VSTORE(u.x, ux);
    VSTORE(u.y, uy);
    VSTORE(active, use);
    for (int i = 0; i < LANES; ++i) {
        /* the first triangle whose cumulative share exceeds u, and u rescaled within its share */
        int lo = e->index, hi = e->index + e->count - 1;
        while (use[i] && lo < hi) {
            int mid = (lo + hi) / 2;
            if (s->emitter_triangles[mid].cdf > ux[i])
                hi = mid;
            else
                lo = mid + 1;
        }
        float below = lo > e->index ? s->emitter_triangles[lo - 1].cdf : 0.0f;
        float width = s->emitter_triangles[lo].cdf - below;
        ux[i] = width > 0.0f ? fmin((ux[i] - below) / width, 0x1.fffffep-1f) : 0.0f;
        __global const Triangle *tri = &s->triangles[s->emitter_triangles[lo].triangle];
        set_lane3(&v0, i, f3(tri->v0));
        set_lane3(&v1, i, f3(tri->v1));
        set_lane3(&v2, i, f3(tri->v2));
        set_lane3(&normal, i, f3(tri->normal));
    }
    vfloat a = VLOAD(ux), b = VLOAD(uy); /* Heitz's map of the square to barycentrics */
    vint first = a < b;
    vfloat b0 = SELECT(a - 0.5f * b, 0.5f * a, first), b1 = SELECT(0.5f * b, b - 0.5f * a, first);
    vfloat b2 = 1.0f - b0 - b1;
    *n = v3_fill(&normal);
    *p = corners_point(v3_fill(&v0), v3_fill(&v1), v3_fill(&v2), *n, b0, b1, b2, err); /* each lane's triangle */
}
#endif

#if HAS_DELTA_EMITTERS
/* The image value of a spot's texture or a projector's irradiance (lookup l) at Mitsuba's image coordinates
 * (u, v), v down the image: the lookup takes a surface's (u, v), v up (lookups.cl), and a point's footprint. */
inline vec3 delta_image(const Scene *s, int l, vfloat u, vfloat v)
{
    UVDerivatives none = {0.0f, 0.0f, 0.0f, 0.0f};
    vec2 uv = {u, 1.0f - v};
    return lookup_value(s->textures, l, uv, none, FILTER_BILINEAR);
}

/* Delta light e seen from ref (Mitsuba's sample_direction of each): es.radiance / es.pdf arrives at ref. */
inline EmitterSample sample_delta(const Scene *s, __global const Emitter *e, vec3 ref, vint active)
{
    EmitterSample es;
    es.err = 0.0f;
    es.radiance = v3_uniform(e->radiance);
    es.delta = (vint)(0) == 0;
    if (e->kind == EMITTER_DIRECTIONAL) { /* from beyond the scene (environment.cl's escapes), against its
                                           * direction: a finite shadow segment */
        es.n = v3_uniform(e->axis);
        es.p = v3_sub(ref, v3_scale(es.n, 4.0f * s->params->scene_extent));
        es.pdf = SELECT((vfloat)(0.0f), (vfloat)(1.0f), active);
        return es;
    }
    es.p = v3_uniform(e->position);
    vec3 w = v3_sub(ref, es.p); /* from the light to ref */
    vfloat d2 = v3_dot(w, w);
    es.n = v3_scale(w, vrsqrt(d2));
    es.pdf = SELECT((vfloat)(0.0f), d2, active & (d2 > 0.0f));
    if (e->kind == EMITTER_POINT)
        return es;
    vec3 q = mat3_apply(e->to_local, w); /* ref in the light's frame, +z its axis */
    vfloat u = MAD(0.5f * e->uv_scale[0], q.x / q.z, 0.5f), v = MAD(0.5f * e->uv_scale[1], q.y / q.z, 0.5f);
    if (e->kind == EMITTER_SPOT) { /* Mitsuba's falloff_curve: linear in the angle from beam_width to cutoff */
        vfloat cos_theta = q.z * vrsqrt(v3_dot(q, q));
        vfloat falloff = SELECT((e->cutoff - acos(vmin(cos_theta, 1.0f))) * e->inv_transition, (vfloat)(1.0f),
                                cos_theta >= e->cos_beam);
        active &= cos_theta > e->cos_cutoff;
        falloff = SELECT((vfloat)(0.0f), falloff, active);
        es.radiance = v3_scale(es.radiance, falloff);
    } else { /* the projector: its image at (u, v), times pi scale / (z^2 cos(theta)), Mitsuba's scale for an
              * irradiance pi scale E(u, v) on the plane z = 1; as a density's multiple: r^2 / (z^2 cos) */
        active &= (u >= 0.0f) & (u <= 1.0f) & (v >= 0.0f) & (v <= 1.0f) & (q.z > 0.0f);
        vfloat cos_theta = v3_dot(v3_uniform(e->axis), es.n);
        es.radiance = v3_scale(es.radiance, SELECT((vfloat)(0.0f), d2 / (q.z * q.z * cos_theta), active));
    }
    if (e->lookup >= 0 && ANY(active))
        es.radiance = v3_mul(es.radiance, delta_image(s, e->lookup, u, v));
    es.pdf = SELECT((vfloat)(0.0f), es.pdf, active);
    return es;
}
#endif

/* Emitter e sampled from the reference point `ref` with u in [0, 1)^2, for the lanes of `active`. */
inline EmitterSample sample_emitter(const Scene *s, __global const Emitter *e, vec3 ref, vec2 u, vint active)
{
#if HAS_DELTA_EMITTERS
    if (EMITTER_IS_DELTA(e->kind))
        return sample_delta(s, e, ref, active);
#endif
    EmitterSample es;
    es.pdf = 0.0f;
    es.err = 0.0f;
    es.p = es.n = v3_splat(0.0f, 0.0f, 0.0f);
    es.radiance = v3_uniform(e->radiance);
    es.delta = (vint)(0);
#if HAS_ELLIPSOIDS
    if (e->kind == SHAPE_ELLIPSOID) {
        __global const Ellipsoid *sphere = &s->ellipsoids[e->index];
        vec3 to_centre = v3_sub(v3_uniform(sphere->center), ref);
        vfloat d2 = v3_dot(to_centre, to_centre), sin2_max;
        vfloat r2 = e->area * (0.25f * M_1_PI_F);
        vfloat one_minus_cos_max = cone_one_minus_cos(r2, d2, &sin2_max);
        /* theta within the cone (its series where the cone is narrow), then alpha: the angle at the centre
         * between the way back to ref and the point (pbrt-v4's Sphere::Sample) */
        vfloat cos_theta = MAD(-one_minus_cos_max, u.x, 1.0f);
        vfloat sin2_theta = SELECT(1.0f - cos_theta * cos_theta, sin2_max * u.x, sin2_max < 0.00068523f);
        cos_theta = SELECT(cos_theta, sqrt(1.0f - sin2_theta), sin2_max < 0.00068523f);
        vfloat sin_max = sqrt(sin2_max);
        vfloat cos_alpha = sin2_theta / sin_max + cos_theta * sqrt(vmax(1.0f - sin2_theta / sin2_max, 0.0f));
        vfloat sin_alpha = sqrt(vmax(1.0f - cos_alpha * cos_alpha, 0.0f));
        vfloat cos_phi, sin_phi = sincos(2.0f * M_PI_F * u.y, &cos_phi);
        vec3 w = v3_direction(to_centre), t, b;
        orthonormal_frame(w, &t, &b);
        /* the normal at the point: towards ref, tilted by alpha */
        vec3 n = v3_sub(v3_add(v3_scale(t, sin_alpha * cos_phi), v3_scale(b, sin_alpha * sin_phi)),
                        v3_scale(w, cos_alpha));
        vec3 q = mat3_apply(sphere->world_to_unit, n); /* the unit-sphere point, reprojected there */
        es.p = ellipsoid_point(sphere, q, n, &es.err);
        es.n = v3_scale(n, sphere->normal_sign); /* flipped: its front faces inwards, away from ref */
        es.pdf = SELECT((vfloat)(0.0f), 1.0f / (2.0f * M_PI_F * one_minus_cos_max), active & (d2 > r2));
        return es;
    }
#endif
    vfloat pdf_area = 1.0f / e->area;
#if HAS_DISKS
    if (e->kind == SHAPE_DISK) { /* uniform on the unit disk (r = sqrt(u)): uniform on its affine image too */
        __global const Disk *disk = &s->disks[e->index];
        vfloat r = sqrt(u.x), cos_phi, sin_phi = sincos(2.0f * M_PI_F * u.y, &cos_phi);
        es.n = disk_normal(disk);
        es.p = disk_point(disk, r * cos_phi, r * sin_phi, es.n, &es.err);
    }
#endif
#if HAS_CYLINDERS
    if (e->kind == SHAPE_CYLINDER) { /* uniform in (phi, z), whose image's area element varies under a
                                      * non-uniform scale: the density by area is the point's own */
        __global const Cylinder *tube = &s->cylinders[e->index];
        vfloat cos_phi, sin_phi = sincos(2.0f * M_PI_F * u.x, &cos_phi);
        vec3 q = v3(cos_phi, sin_phi, u.y);
        es.n = cylinder_normal(tube, q);
        es.p = cylinder_point(tube, q, es.n, &es.err);
        pdf_area = 1.0f / (2.0f * M_PI_F * cylinder_jacobian(tube, q));
    }
#endif
#if HAS_TRIANGLES
    if (e->kind == SHAPE_TRIANGLE)
        sample_mesh(s, e, u, active, &es.p, &es.n, &es.err);
#endif
#if HAS_RECTANGLES
    if (e->kind == SHAPE_RECTANGLE) {
        __global const Rectangle *rect = &s->rectangles[e->index];
        es.p = rectangle_point(rect, (2.0f * u.x - 1.0f) * rect->half_x, (2.0f * u.y - 1.0f) * rect->half_y,
                               &es.err);
        es.n = v3_uniform(rect->normal);
    }
#endif
    vec3 w = v3_sub(es.p, ref);
    vfloat d2 = v3_dot(w, w), cos_l = vabs(v3_dot(es.n, w)) * vrsqrt(d2);
    es.pdf = SELECT((vfloat)(0.0f), pdf_area * d2 / cos_l, active & (cos_l > 0.0f));
    return es;
}

/* The density per unit solid angle with which sample_emitter() would have sampled the point p of emitter e
 * that a ray from ref met at distance `distance` with |cos(theta_l)| = cos_l. */
inline vfloat emitter_pdf(const Scene *s, __global const Emitter *e, vec3 ref, vec3 p, vfloat distance,
                          vfloat cos_l)
{
#if HAS_CYLINDERS
    if (e->kind == SHAPE_CYLINDER) {
        __global const Cylinder *tube = &s->cylinders[e->index];
        vec3 q = mat3_apply(tube->to_local, v3_sub(p, v3_uniform(tube->center)));
        vfloat inv = rsqrt(MAD(q.x, q.x, q.y * q.y)); /* put back on the unit circle */
        vfloat jacobian = cylinder_jacobian(tube, v3(q.x * inv, q.y * inv, q.z));
        return distance * distance / (2.0f * M_PI_F * jacobian * cos_l);
    }
#endif
#if HAS_ELLIPSOIDS
    if (e->kind == SHAPE_ELLIPSOID) {
        vec3 to_centre = v3_sub(v3_uniform(s->ellipsoids[e->index].center), ref);
        vfloat d2 = v3_dot(to_centre, to_centre), sin2_max, r2 = e->area * (0.25f * M_1_PI_F);
        vfloat one_minus_cos_max = cone_one_minus_cos(r2, d2, &sin2_max);
        return SELECT((vfloat)(0.0f), 1.0f / (2.0f * M_PI_F * one_minus_cos_max), d2 > r2);
    }
#endif
    return distance * distance / (e->area * cos_l);
}

#endif
