/* Multiple importance sampling's power heuristic with beta = 2 (Veach, "Robust Monte Carlo Methods for Light
 * Transport Simulation", 1997, section 9.2.4), which the direct and path models weigh light samples and BSDF
 * samples of the same light by. */
#ifndef MIS_CL
#define MIS_CL

#include "lanes.h"

/* 1 / (1 + x^2): the power heuristic's weight of a technique whose density (times its sample count) is 1 / x
 * times the other's. Formed from the ratio, it stays finite where either density does not (a light seen
 * edge-on, a delta lobe). */
inline vfloat power_weight(vfloat x) { return 1.0f / MAD(x, x, 1.0f); }

#endif
