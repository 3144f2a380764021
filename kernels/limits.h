/* The limits host and kernel share: raytrace/structs.py mirrors each, and tests/test_types.py checks them
 * against this device's compiler. */
#ifndef LIMITS_H
#define LIMITS_H

#define BVH_STACK 64         /* levels of a BVH traversal's stack holds (bvh.cl): the host refuses deeper trees */
#define CULLED_RECTANGLES 32 /* rectangles shadow rays may skip: one bit each in a uint (types.h's Light) */
/* The entries of a roughplastic's table of its coat's transmittance (types.h's Material): Mitsuba 3's
 * MI_ROUGH_TRANSMITTANCE_RES. */
#define ROUGH_TRANSMITTANCE_RES 64
/* The textured parameters a material has room for (types.h's Material.maps, MAP_*). */
#define MAPS 21
/* The wrappers (blendbsdf, mask, twosided) a hit passes through to its BSDF, at most (wrappers.cl): the host
 * refuses deeper nesting. */
#define WRAPPER_DEPTH 8
/* The values of a principled or principledthin BSDF in types.h's Material (PRINCIPLED_* there). */
#define PRINCIPLED_PARAMETERS 19
/* The nodes of a reconstruction filter's sampling tables (types.h's Camera.rfilter_*): 128 bins at most. */
#define RFILTER_NODES 129
/* The lane widths lanes.h accepts: pixel samples a work-item holds at once. */
#define LANE_WIDTH_ACCEPTED(n) ((n) == 1 || (n) == 4 || (n) == 8 || (n) == 16)

#endif
