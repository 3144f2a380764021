/* Lane-generic arithmetic: one work-item shades LANES pixels at once (the CPU's vector width, 1 on GPUs).
 *
 * PoCL does not vectorise a branchy ray tracer across work-items, so on CPUs the kernel is written on
 * explicit vector types; on GPUs LANES=1 turns the same source into plain scalar code. Masks are the
 * results of comparisons (-1 per true lane for vectors, 1 for scalars): select() and the macros below
 * accept both, so never build a mask by hand. */
#ifndef LANES_H
#define LANES_H

#include "limits.h"

#ifndef LANES
#define LANES 1
#endif
#if !LANE_WIDTH_ACCEPTED(LANES)
#error "LANES must be 1, 4, 8 or 16"
#endif

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)

#if LANES == 1
typedef float vfloat;
typedef int vint;
typedef uint vuint;
#define ANY(m) (m)
#define ALL(m) (m)
#define VLOADT(T, p) ((p)[0])
#define VSTORE(v, p) ((p)[0] = (v))
#define LANE_IDS 0
#define CONVERT_VFLOAT(v) ((float)(v))
#define AS_VUINT(v) as_uint(v)
#define AS_VFLOAT(v) as_float(v)
#define AS_VINT(v) as_int(v)
#define CONVERT_VINT(v) ((int)(v))
#define FIRST_LANE(v) (v)
#else
typedef CAT(float, LANES) vfloat;
typedef CAT(int, LANES) vint;
typedef CAT(uint, LANES) vuint;
#define ANY(m) (or_lanes(m) < 0)
#define ALL(m) (and_lanes(m) < 0)
/* A vector of type T to and from LANES consecutive private values, one component at a time: vloadN and
 * vstoreN are out-of-line calls on PoCL (see the primitives below). */
#if LANES == 4
#define LANE_IDS ((int4)(0, 1, 2, 3))
#define VLOADT(T, p) ((T)((p)[0], (p)[1], (p)[2], (p)[3]))
#define VSTORE(v, p) ((p)[0] = (v).s0, (p)[1] = (v).s1, (p)[2] = (v).s2, (p)[3] = (v).s3)
#elif LANES == 8
#define LANE_IDS ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
#define VLOADT(T, p) ((T)((p)[0], (p)[1], (p)[2], (p)[3], (p)[4], (p)[5], (p)[6], (p)[7]))
#define VSTORE(v, p) ((p)[0] = (v).s0, (p)[1] = (v).s1, (p)[2] = (v).s2, (p)[3] = (v).s3, \
                      (p)[4] = (v).s4, (p)[5] = (v).s5, (p)[6] = (v).s6, (p)[7] = (v).s7)
#elif LANES == 16
#define LANE_IDS ((int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#define VLOADT(T, p) ((T)((p)[0], (p)[1], (p)[2], (p)[3], (p)[4], (p)[5], (p)[6], (p)[7], (p)[8], (p)[9], \
                               (p)[10], (p)[11], (p)[12], (p)[13], (p)[14], (p)[15]))
#define VSTORE(v, p) ((p)[0] = (v).s0, (p)[1] = (v).s1, (p)[2] = (v).s2, (p)[3] = (v).s3, \
                      (p)[4] = (v).s4, (p)[5] = (v).s5, (p)[6] = (v).s6, (p)[7] = (v).s7, \
                      (p)[8] = (v).s8, (p)[9] = (v).s9, (p)[10] = (v).sa, (p)[11] = (v).sb, \
                      (p)[12] = (v).sc, (p)[13] = (v).sd, (p)[14] = (v).se, (p)[15] = (v).sf)
#endif
#define CONVERT_VFLOAT(v) CAT(convert_float, LANES)(v)
#define AS_VUINT(v) CAT(as_uint, LANES)(v)
#define AS_VFLOAT(v) CAT(as_float, LANES)(v)
#define AS_VINT(v) CAT(as_int, LANES)(v)
#define CONVERT_VINT(v) CAT(convert_int, LANES)(v)
#define FIRST_LANE(v) ((v).s0)
#endif
#define VLOAD(p) VLOADT(vfloat, p)
#define VLOAD_INT(p) VLOADT(vint, p)
#define VLOAD_UINT(p) VLOADT(vuint, p)

/* Lane-wise primitives written with operators. PoCL builds its builtin library for a generic x86-64 CPU
 * and the kernel for the host's, so LLVM will not inline one into the other: every vector select(), mad(),
 * fabs(), fmin(), any() ... stays an out-of-line call, and every call spills all vector registers (the
 * render kernel made 155 calls to mad alone). These compile to one or two instructions on any target. The
 * vector ?: is select() with the mask's most significant bit, a scalar ?: tests m != 0: the same rule as
 * select() in both widths. */
#define SELECT(a, b, m) ((m) ? (b) : (a)) /* b where m, else a */
#define MAD(a, b, c) ((a) * (b) + (c))    /* contracted to an fma where the target has one */
/* For the few functions that LLVM's cost model leaves out of line in a hot loop: a call passes the ray's
 * vectors through memory and spills the caller's (a shadow ray's leaf tests, bvh.cl, ran faster on
 * mesh_cornell inlined: measured in commit 72f0302). */
#define ALWAYS_INLINE __attribute__((always_inline)) inline
inline vfloat vabs(vfloat x) { return AS_VFLOAT(AS_VUINT(x) & 0x7fffffffU); }
/* min and max of numbers; unlike fmin and fmax, a NaN in a propagates (callers never pass one). */
inline vfloat vmin(vfloat a, vfloat b) { return SELECT(a, b, b < a); }
inline vfloat vmax(vfloat a, vfloat b) { return SELECT(a, b, b > a); }
/* |x| with the sign of s */
inline vfloat vcopysign(vfloat x, vfloat s)
{
    return AS_VFLOAT((AS_VUINT(x) & 0x7fffffffU) | (AS_VUINT(s) & 0x80000000U));
}
/* Whether any (all) lanes of a mask are set. Clang's reductions of a comparison's mask compile to one mask
 * test (ktestw with AVX-512, in perf annotate) where the shuffles below take ten instructions; ANY is the
 * traversal's branch at every node (bvh.cl). They are Clang builtins, not an OpenCL extension: a compiler
 * without them takes the shuffles. */
#ifdef __has_builtin
#if __has_builtin(__builtin_reduce_or) && __has_builtin(__builtin_reduce_and) && LANES > 1
#define HAS_REDUCE 1
#endif
#endif
#ifdef HAS_REDUCE
inline int or_lanes(vint m) { return __builtin_reduce_or(m); }
inline int and_lanes(vint m) { return __builtin_reduce_and(m); }
#elif LANES == 4
inline int or_lanes(int4 m) { int2 t = m.lo | m.hi; return t.x | t.y; }
inline int and_lanes(int4 m) { int2 t = m.lo & m.hi; return t.x & t.y; }
#elif LANES == 8
inline int or_lanes(int8 m) { int4 t = m.lo | m.hi; int2 u = t.lo | t.hi; return u.x | u.y; }
inline int and_lanes(int8 m) { int4 t = m.lo & m.hi; int2 u = t.lo & t.hi; return u.x & u.y; }
#elif LANES == 16
inline int or_lanes(int16 m) { int8 t = m.lo | m.hi; int4 u = t.lo | t.hi; int2 w = u.lo | u.hi; return w.x | w.y; }
inline int and_lanes(int16 m) { int8 t = m.lo & m.hi; int4 u = t.lo & t.hi; int2 w = u.lo & u.hi; return w.x & w.y; }
#endif

/* The smaller (larger) of a and b, component-wise: a where b is NaN, so that a NaN b is ignored. */
#define LANE_MIN(a, b) ((b) < (a) ? (b) : (a))
#define LANE_MAX(a, b) ((b) > (a) ? (b) : (a))

/* The smallest (largest) of a vector's lanes, for values that are numbers or infinities: halves compared
 * lane-wise (Clang's __builtin_reduce_min keeps fmin's NaN rules, one scalar step and NaN test per lane). */
#if LANES == 1
inline float min_lane(float x) { return x; }
inline float max_lane(float x) { return x; }
#else
inline float min_lane(vfloat x)
{
#if LANES == 16
    float8 x8 = LANE_MIN(x.lo, x.hi);
#elif LANES == 8
    float8 x8 = x;
#endif
#if LANES >= 8
    float4 x4 = LANE_MIN(x8.lo, x8.hi);
#else
    float4 x4 = x;
#endif
    float2 x2 = LANE_MIN(x4.lo, x4.hi);
    return LANE_MIN(x2.x, x2.y);
}
inline float max_lane(vfloat x)
{
#if LANES == 16
    float8 x8 = LANE_MAX(x.lo, x.hi);
#elif LANES == 8
    float8 x8 = x;
#endif
#if LANES >= 8
    float4 x4 = LANE_MAX(x8.lo, x8.hi);
#else
    float4 x4 = x;
#endif
    float2 x2 = LANE_MAX(x4.lo, x4.hi);
    return LANE_MAX(x2.x, x2.y);
}
#endif

/* x with each lane l exchanged for lane l ^ w, for w = 1, 2, 4, 8 below LANES: a swizzle, one permute
 * instruction (where OpenCL C's shuffle() would be an out-of-line call, as above). */
#if LANES == 4
#define PARTNERS_1(x) ((x).s1032)
#define PARTNERS_2(x) ((x).s2301)
#elif LANES == 8
#define PARTNERS_1(x) ((x).s10325476)
#define PARTNERS_2(x) ((x).s23016745)
#define PARTNERS_4(x) ((x).s45670123)
#elif LANES == 16
#define PARTNERS_1(x) ((x).s1032547698badcfe)
#define PARTNERS_2(x) ((x).s23016745ab89efcd)
#define PARTNERS_4(x) ((x).s45670123cdef89ab)
#define PARTNERS_8(x) ((x).s89abcdef01234567)
#endif

/* A mask as 0/1 floats, e.g. to count rays per lane. */
#define MASK_TO_ONE(m) SELECT((vfloat)(0.0f), (vfloat)(1.0f), (m))

/* The number of lanes set in `mask` (a measuring build's counts: render.cl, path_tracing.cl). */
inline int count_lanes(vint mask)
{
    int m[LANES], n = 0;
    VSTORE(mask, m);
    for (int i = 0; i < LANES; ++i)
        n += m[i] != 0;
    return n;
}

/* Two or three coordinates, one vfloat each: structure of arrays, so that LANES rays share one register
 * each. */
typedef struct { vfloat x, y; } vec2;
typedef struct { vfloat x, y, z; } vec3;

inline vec3 v3(vfloat x, vfloat y, vfloat z) { vec3 r = {x, y, z}; return r; }
inline vec3 v3_add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
inline vec3 v3_sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
inline vec3 v3_scale(vec3 a, vfloat s) { return v3(a.x * s, a.y * s, a.z * s); }
inline vec3 v3_mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
/* a + s * b, the ray-point form o + t d */
inline vec3 v3_madd(vec3 a, vfloat s, vec3 b) { return v3(MAD(s, b.x, a.x), MAD(s, b.y, a.y), MAD(s, b.z, a.z)); }
inline vfloat v3_dot(vec3 a, vec3 b) { return MAD(a.x, b.x, MAD(a.y, b.y, a.z * b.z)); }
inline vec3 v3_cross(vec3 a, vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
inline vec3 v3_normalize(vec3 a) { return v3_scale(a, rsqrt(v3_dot(a, a))); }
inline vec3 v3_select(vec3 a, vec3 b, vint m) /* b where m, else a */
{
    return v3(SELECT(a.x, b.x, m), SELECT(a.y, b.y, m), SELECT(a.z, b.z, m));
}
inline vec3 v3_splat(float x, float y, float z) { return v3((vfloat)(x), (vfloat)(y), (vfloat)(z)); }
inline vec3 v3_mix(vec3 a, vec3 b, vfloat t) { return v3_madd(a, t, v3_sub(b, a)); } /* a + (b - a) t */
inline vfloat v3_max_abs(vec3 a) { return vmax(vabs(a.x), vmax(vabs(a.y), vabs(a.z))); }

/* The way between lane-generic code and scalar code run once per lane (a textured hit's surface point,
 * material.cl's per-lane results): spill a vec3 to per-lane arrays, read or write lane i as a float3, and
 * load the arrays back. */
typedef struct { float x[LANES], y[LANES], z[LANES]; } Lanes3;

inline Lanes3 v3_spill(vec3 v)
{
    Lanes3 a;
    VSTORE(v.x, a.x);
    VSTORE(v.y, a.y);
    VSTORE(v.z, a.z);
    return a;
}
inline float3 lane3(const Lanes3 *a, int i) { return (float3)(a->x[i], a->y[i], a->z[i]); }
inline void set_lane3(Lanes3 *a, int i, float3 v) { a->x[i] = v.x; a->y[i] = v.y; a->z[i] = v.z; }
inline vec3 v3_fill(const Lanes3 *a) { return v3(VLOAD(a->x), VLOAD(a->y), VLOAD(a->z)); }

#endif
