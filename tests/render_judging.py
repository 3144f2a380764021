"""Judging renders against an expectation per pixel, as the tests of whole images do it: the mean image of
CHUNKS independent renders and the variance of that mean from their spread, then devtools/judge.py's verdict,
printed and asserted."""
import numpy as np

import raytrace

CHUNKS = 16  # independent renders per judged image: CHUNKS - 1 degrees of freedom for the variance


def chunked(table, lanes, spp, seed=0):
    """The mean image of CHUNKS renders of scene table `table` at spp each (seeds seed, seed + 1, ...) and the
    variance of that mean from their spread, as the judging rig takes them."""
    scene = raytrace.load_dict(table)
    images = np.array([np.asarray(raytrace.render(scene, spp=spp, lanes=lanes, seed=seed + k)[0], np.float64)
                       for k in range(CHUNKS)])
    return images.mean(axis=0), images.var(axis=0, ddof=1) / CHUNKS


def assert_judged(verdict, label):
    print(f"{label}: worst |z| {verdict.worst_z:.2f} (threshold {verdict.threshold:.2f}), {verdict.failures} "
          f"values over ({verdict.allowed} allowed), bias {verdict.bias}, bias z {verdict.bias_z}")
    assert verdict.passed, (label, verdict.worst_z, verdict.failures, verdict.bias_z)
