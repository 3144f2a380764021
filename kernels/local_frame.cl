/* The local frame of a shading point: z along the shading normal, in which the BSDFs of kernels/bsdfs/ work
 * (pbrt-v4's Frame, Mitsuba 3's Frame3f). Isotropic BSDFs need only some frame about the normal; an
 * anisotropic one takes its x axis from the shading point's tangent. */
#ifndef LOCAL_FRAME_CL
#define LOCAL_FRAME_CL

#include "vmath.h"

/* Unit vectors *t and *b completing the unit n to a right-handed orthonormal frame, without a branch or a
 * cancellation (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017). */
inline void orthonormal_frame(vec3 n, vec3 *t, vec3 *b)
{
    vfloat sign = vcopysign((vfloat)(1.0f), n.z), a = -1.0f / (sign + n.z), c = n.x * n.y * a;
    *t = v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = v3(c, sign + n.y * n.y * a, -n.y);
}

typedef struct { vec3 t, b, n; } LocalFrame;

/* A right-handed orthonormal frame about the unit n (orthonormal_frame). */
inline LocalFrame local_frame(vec3 n)
{
    LocalFrame f;
    f.n = n;
    orthonormal_frame(n, &f.t, &f.b);
    return f;
}

/* World direction v in the frame's coordinates, and back. */
inline vec3 to_local(LocalFrame f, vec3 v) { return v3(v3_dot(v, f.t), v3_dot(v, f.b), v3_dot(v, f.n)); }
inline vec3 from_local(LocalFrame f, vec3 v)
{
    return v3_add(v3_add(v3_scale(f.t, v.x), v3_scale(f.b, v.y)), v3_scale(f.n, v.z));
}

/* wo mirrored about the unit normal n. */
inline vec3 reflected(vec3 wo, vec3 n) { return v3_sub(v3_scale(n, 2.0f * v3_dot(wo, n)), wo); }

#endif
