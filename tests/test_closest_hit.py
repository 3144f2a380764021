"""Closest-hit selection over the whole course scene (kernels/intersect.cl) against the reference."""
import numpy as np

import reference
from helpers import planar
from raytrace.commands.stability.probe import CLOSEST_HIT, CLOSEST_HIT_OUTPUTS, scene_args


def random_rays(scene, n, seed):
    """Rays from points inside the box in all directions, and from the camera."""
    rng = np.random.default_rng(seed)
    o = rng.uniform([-0.95, -0.95, 0.05], [0.95, 0.95, 1.9], (n, 3))
    o[: n // 4] = scene.camera.position
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o.astype(np.float32).astype(float), d.astype(np.float32).astype(float)


def test_closest_hit_matches_reference(harness, cornell):
    """Same surface (material and light) for every ray but those whose two nearest hits lie within
    1e-4 of each other (float32 may order them either way); t relative 1e-5; face-forwarded normals 1e-4."""
    n = 2048
    o, d = random_rays(cornell, n, 11)
    out = harness.run(CLOSEST_HIT, "closest", n, {**scene_args(cornell), "o": planar(o), "d": planar(d)},
                      CLOSEST_HIT_OUTPUTS, HAS_RECTANGLES=1, HAS_TRIANGLES=1,
                      HAS_ELLIPSOIDS=1)
    ref = reference.closest_hit(cornell, o, d, tmin=0.0)
    beyond = np.where(np.isfinite(ref["t"]), ref["t"], 0) + 1e-4
    second = reference.closest_hit(cornell, o + beyond[:, None] * d, d, tmin=0.0)
    clear = ~np.isfinite(ref["t"]) | (second["t"] > 1e-4)
    assert np.count_nonzero(clear) > 0.95 * n
    np.testing.assert_array_equal(out["material"][clear], ref["material"][clear])
    np.testing.assert_array_equal(out["emitted"][clear] > 0, ref["light"][clear] >= 0)
    assert np.count_nonzero(ref["light"][clear] >= 0) > 5, "some rays must see the light"
    assert np.count_nonzero(~np.isfinite(ref["t"])) > 50, "some rays from the camera miss the box"
    np.testing.assert_array_equal(np.isfinite(out["t"][clear]), np.isfinite(ref["t"][clear]))
    clear &= np.isfinite(ref["t"])
    np.testing.assert_allclose(out["t"][clear], ref["t"][clear], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(out["nrm"].T[clear], ref["normal"][clear], atol=1e-4)
    assert np.all(np.sum(out["nrm"].T * d, axis=1)[clear] <= 1e-6), "normals face the incoming ray"


def test_shape_kinds_can_be_left_out(harness, cornell):
    """With HAS_ELLIPSOIDS=0 the ellipsoid is not compiled: rays at it see what lies behind it."""
    e = cornell.ellipsoids[0]
    o = np.tile(cornell.camera.position, (8, 1))
    d = e.center - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    args = {**scene_args(cornell), "o": planar(o), "d": planar(d)}
    outputs = CLOSEST_HIT_OUTPUTS
    full = harness.run(CLOSEST_HIT, "closest", 8, args, outputs, HAS_RECTANGLES=1, HAS_TRIANGLES=1, HAS_ELLIPSOIDS=1)
    without = harness.run(CLOSEST_HIT, "closest", 8, args, outputs, HAS_RECTANGLES=1, HAS_TRIANGLES=1,
                          HAS_ELLIPSOIDS=0)
    assert np.all(full["material"] == e.material)
    assert np.all(without["material"] != e.material) and np.all(without["t"] > full["t"])
