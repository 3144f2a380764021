/* Lane-generic arithmetic: one work-item shades LANES pixels at once (8 on CPUs, 1 on GPUs).
 *
 * PoCL does not vectorise a branchy ray tracer across work-items, so on CPUs the kernel is written on
 * explicit vector types; on GPUs LANES=1 turns the same source into plain scalar code. Masks are the
 * results of comparisons (-1 per true lane for vectors, 1 for scalars): select() and the macros below
 * accept both, so never build a mask by hand. */
#ifndef LANES_H
#define LANES_H

#ifndef LANES
#define LANES 1
#endif

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)

#if LANES == 1
typedef float vfloat;
typedef int vint;
typedef uint vuint;
#define ANY(m) (m)
#define ALL(m) (m)
#define VLOAD(i, p) ((p)[i])
#define VSTORE(v, i, p) ((p)[i] = (v))
#define LANE_IDS 0
#define CONVERT_VFLOAT(v) ((float)(v))
#define AS_VUINT(v) ((uint)(v))
#else
typedef CAT(float, LANES) vfloat;
typedef CAT(int, LANES) vint;
typedef CAT(uint, LANES) vuint;
#define ANY(m) any(m)
#define ALL(m) all(m)
#define VLOAD(i, p) CAT(vload, LANES)(i, p)
#define VSTORE(v, i, p) CAT(vstore, LANES)(v, i, p)
#if LANES == 4
#define LANE_IDS ((int4)(0, 1, 2, 3))
#elif LANES == 8
#define LANE_IDS ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
#elif LANES == 16
#define LANE_IDS ((int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#else
#error "LANES must be 1, 4, 8 or 16"
#endif
#define CONVERT_VFLOAT(v) CAT(convert_float, LANES)(v)
#define AS_VUINT(v) CAT(as_uint, LANES)(v)
#endif

/* A mask as 0/1 floats, e.g. to count rays per lane. */
#define MASK_TO_ONE(m) select((vfloat)(0.0f), (vfloat)(1.0f), (m))

/* Three coordinates, one vfloat each: structure of arrays, so that LANES rays share one register each. */
typedef struct { vfloat x, y, z; } vec3;

inline vec3 v3(vfloat x, vfloat y, vfloat z) { vec3 r = {x, y, z}; return r; }
inline vec3 v3_add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
inline vec3 v3_sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
inline vec3 v3_scale(vec3 a, vfloat s) { return v3(a.x * s, a.y * s, a.z * s); }
inline vec3 v3_mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
/* a + s * b, the ray-point form o + t d */
inline vec3 v3_madd(vec3 a, vfloat s, vec3 b) { return v3(mad(s, b.x, a.x), mad(s, b.y, a.y), mad(s, b.z, a.z)); }
inline vfloat v3_dot(vec3 a, vec3 b) { return mad(a.x, b.x, mad(a.y, b.y, a.z * b.z)); }
inline vec3 v3_cross(vec3 a, vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
inline vec3 v3_normalize(vec3 a) { return v3_scale(a, rsqrt(v3_dot(a, a))); }
inline vec3 v3_select(vec3 a, vec3 b, vint m) /* b where m, else a */
{
    return v3(select(a.x, b.x, m), select(a.y, b.y, m), select(a.z, b.z, m));
}
inline vec3 v3_splat(float x, float y, float z) { return v3((vfloat)(x), (vfloat)(y), (vfloat)(z)); }
inline vfloat v3_max_abs(vec3 a) { return fmax(fabs(a.x), fmax(fabs(a.y), fabs(a.z))); }

/* The way between lane-generic code and scalar code run once per lane (gathers such as texture lookups):
 * spill a vec3 to per-lane arrays, read or write lane i as a float3, and load the arrays back. */
typedef struct { float x[LANES], y[LANES], z[LANES]; } Lanes3;

inline Lanes3 v3_spill(vec3 v)
{
    Lanes3 a;
    VSTORE(v.x, 0, a.x);
    VSTORE(v.y, 0, a.y);
    VSTORE(v.z, 0, a.z);
    return a;
}
inline float3 lane3(const Lanes3 *a, int i) { return (float3)(a->x[i], a->y[i], a->z[i]); }
inline void set_lane3(Lanes3 *a, int i, float3 v) { a->x[i] = v.x; a->y[i] = v.y; a->z[i] = v.z; }
inline vec3 v3_fill(const Lanes3 *a) { return v3(VLOAD(0, a->x), VLOAD(0, a->y), VLOAD(0, a->z)); }

#endif
