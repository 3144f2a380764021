"""BVH node visits and primitive tests per ray, counted by the render kernel itself: the figures that explain
where a mesh's time goes (`bench` and `bench --scaling` print them beside the seconds), the two terms of the
surface area heuristic's cost (pbrt-v4 section 7.3.2) as the render's own rays meet them; and for the path
model, how busy the lanes of its bounce loop are.

A measuring build of the scene's kernel (Features.count_visits: -DCOUNT_VISITS, kernels/scene.h) counts every
node whose box a traversal tests and every primitive it tests, once per work-item: with packets, one test
covers all of a work-item's lanes, so a figure below 1 per ray is the packets' saving. The counting build
renders the same image bit for bit (tests/test_visits.py); its seconds are not the renderer's and are not
reported."""
import dataclasses

import numpy as np

from ..render import render
from ..renderer.device import default_lanes, select_device
from ..renderer.program import Features

# The per-ray figures of node_visits, in the order bench and bench --scaling list them.
PER_RAY = ("visits_per_camera_ray", "visits_per_shadow_ray", "primitives_per_camera_ray", "primitives_per_shadow_ray")


def node_visits(scene, features=None, **render_kwargs):
    """What the render's traversals test per camera ray (closest-hit traversals) and per shadow ray: BVH
    nodes and primitives, with the ray counts they are divided by, the per-pixel maps of node visits (height
    x width, summed over the pixel's samples) and how concentrated the shadow rays' node visits are, for the
    kernel variant `features` (default: the one render() picks). Without a BVH the kernel loops over every
    shape: 0 nodes, and every shape a primitive test. In the path model, also the share of lanes with a vertex
    to shade at each step of a work-item's paths (path_lanes_busy: 1 when no lane ever waits; None in the other
    models)."""
    features = features or Features.of(scene, default_lanes(select_device(render_kwargs.get("device"))))
    _, stats = render(scene, features=dataclasses.replace(features, count_visits=True), **render_kwargs)
    visits = stats.extra["visits"]
    camera_rays = stats.width * stats.height * stats.spp
    shadow_rays = stats.rays - camera_rays
    shadow_divisor = max(shadow_rays, 1)  # no shadow rays: no shadow counts either, 0 per ray
    closest_map, shadow_map = stats.extra["visit_maps"][:2]
    return {"camera_rays": camera_rays, "shadow_rays": shadow_rays,
            "visits_per_camera_ray": visits["closest_hit_nodes"] / camera_rays,
            "visits_per_shadow_ray": visits["shadow_nodes"] / shadow_divisor,
            "primitives_per_camera_ray": visits["closest_hit_primitives"] / camera_rays,
            "primitives_per_shadow_ray": visits["shadow_primitives"] / shadow_divisor,
            "pixels_with_half_the_shadow_visits": pixels_with_half(shadow_map),
            "path_lanes_busy": (visits["path_lanes"] / visits["path_lane_steps"] if visits["path_lane_steps"]
                                else None),
            "closest_hit_map": closest_map, "shadow_map": shadow_map}


def pixels_with_half(visit_map):
    """The smallest fraction of the image's pixels whose visits make up half of all (0 without any): how
    concentrated a traversal's cost is. A pixel's visits are its work-items' shared equally among their
    pixels (kernels/render.cl), so a packet's cost is spread over its tile."""
    per_pixel = np.sort(visit_map.ravel())[::-1]
    total = per_pixel.sum()
    if total <= 0:
        return 0.0
    return (np.searchsorted(np.cumsum(per_pixel), total / 2) + 1) / per_pixel.size


def plot_maps(labelled, path, spp):
    """The visit maps of several renders side by side (`labelled`: (label, node_visits result) pairs), camera
    rays above and shadow rays below, as BVH nodes per pixel sample, each row on one colour scale so that the
    renders compare. Needs matplotlib (the analysis extra), imported here."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    kinds = (("closest_hit_map", "camera rays"), ("shadow_map", "shadow rays"))
    fig, axes = plt.subplots(2, len(labelled), figsize=(3.2 * len(labelled) + 1, 6.4), squeeze=False)
    for row, (key, what) in zip(axes, kinds):
        top = max(v[key].max() for _, v in labelled) / spp or 1.0
        for ax, (label, v) in zip(row, labelled):
            shown = ax.imshow(v[key] / spp, cmap="magma", vmin=0, vmax=top, interpolation="nearest")
            ax.set_title(f"{label}: {what}", fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
        fig.colorbar(shown, ax=list(row), shrink=0.8, label="BVH nodes per pixel sample")
    fig.savefig(path, dpi=100)
    plt.close(fig)
