/* A work-item's share of a launch: the pixels and the pixel samples its lanes hold.
 *
 * Each step of a work-item traces one pixel sample in every lane. Its lanes hold `group` samples of each of
 * LANES / group pixels at once, lane l sample l % group of pixel l / group: group is the largest power of two
 * that divides the launch's sample count, at most LANES. The more of a packet's rays start inside one pixel,
 * the closer together they stay, and the fewer BVH nodes the packet opens where a mesh's triangles are finer
 * than its spread of rays (bvh.cl). Counted by the kernel (raytrace/commands/visits.py, 16 lanes): mesh_cornell's shadow
 * rays open 0.321 nodes a ray with 8 samples of 2 pixels against 0.504 with one sample of 16, its camera rays
 * 0.934 against 1.211; the 10^6-triangle torus of `bench --scaling` (its passes of 2 samples: 2 samples of 8
 * pixels against one of 16) 4.24 against 4.82 and 2.17 against 2.40; scene 0's counts change by 2% at most.
 * A pass may hold all of a render's samples (raytrace/renderer/progressive.py), so scene 0's 16 samples are
 * 16 of one pixel a work-item: the pass rule alone saves mesh_cornell time against passes of 8 (measured in
 * commit c22b53c).
 *
 * The pixels form a tile as nearly square as their count allows (4 x 4, 4 x 2, 2 x 2, 2 x 1, 1 x 1), so that
 * its rays stay close together too: with 16 lanes, 16 pixels in 4 x 4 instead of 16 x 1 took less time on
 * mesh_cornell and on scene 0 (measured in commit ae03f8d). The host sizes its launch grid by
 * the same rules (raytrace/structs.py: samples_at_once and tile_shape). */
#ifndef TILE_H
#define TILE_H

#include "lanes.h"

inline int samples_at_once(int n_samples)
{
    int power = n_samples & -n_samples; /* the lowest set bit */
    return power < 1 ? 1 : power < LANES ? power : LANES;
}

inline int tile_rows(int pixels) { return pixels >= 16 ? 4 : pixels >= 4 ? 2 : 1; }

/* Work-item (i, j)'s lanes: each lane's pixel (x, y), and which of the `group` samples of a step it takes
 * (render.cl's loop). Its tile of pixels starts at x = columns i, y = row0 + rows j. */
typedef struct { vint x, y, sample; int group; } Tile;

inline Tile work_item_tile(int row0, int n_samples)
{
    Tile t;
    t.group = samples_at_once(n_samples);
    int pixels = LANES / t.group, rows = tile_rows(pixels), columns = pixels / rows;
    vint pixel = LANE_IDS / t.group;
    t.sample = LANE_IDS % t.group;
    t.x = columns * (int)get_global_id(0) + pixel % columns;
    t.y = row0 + rows * (int)get_global_id(1) + pixel / columns;
    return t;
}

#endif
