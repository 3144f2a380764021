"""Tools that measure and verify the renderer: bench, scaling, converge, stability, compile, probe (small test
kernels), figures and assets. They use the renderer; the renderer never imports them."""
