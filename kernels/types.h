/* Every struct the kernel reads from the host. Mirrored once, field for field, by the numpy dtypes in
 * raytrace/types.py; tests/test_types.py checks sizes and offsets against this device's compiler.
 * Only 4-byte scalars and arrays of them: no float3/float4 members, so no hidden padding anywhere. */
#ifndef TYPES_H
#define TYPES_H

#include "lanes.h"

typedef struct { float x, y, z; } Vec3f;

typedef struct {
    Vec3f position, forward, right, up; /* orthonormal basis of SPEC.md section 1 */
    float scale_x;                      /* (W/H) * f * tan(fov/2) */
    float scale_y;                      /* f * tan(fov/2) */
    float focal_length;
} Camera;

typedef struct {
    Vec3f center, normal, tangent, bitangent; /* bitangent = normal x tangent */
    float half_x, half_y;                     /* half of the size along tangent and bitangent */
    int material;
} Rectangle;

typedef struct {
    Vec3f v0, v1, v2;
    Vec3f normal; /* normalize((v1 - v0) x (v2 - v1)) */
    int material;
} Triangle;

typedef struct {
    Vec3f center;
    float world_to_unit[9]; /* row-major inverse of [a b c]: world offsets to unit-sphere space */
    int material;
} Ellipsoid;

typedef struct {
    Rectangle shape; /* shape.material is unused */
    Vec3f colour;
} Light;

typedef struct {
    Vec3f colour; /* ka = kd = ks = colour (the course's model) */
    float shininess;
} Material;

typedef struct {
    Vec3f ambient;
    int n_rectangles, n_triangles, n_ellipsoids, n_lights;
    int spp, light_samples;
    int width, height;
} RenderParams;

inline vec3 v3_uniform(Vec3f a) { return v3_splat(a.x, a.y, a.z); }

#endif
