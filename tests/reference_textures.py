"""Independent float64 numpy reference for textures (the texture conventions, sections 1-6): image
decoding, the MIP pyramid, the four filters, per-shape uv parameterisations, the shading frame, normal
and bump maps, and ray differentials.

Inputs are plain numpy arrays and numbers; nothing is imported from raytrace, so a bug in the renderer
cannot hide in both the kernel and this file. Everything is float64 and vectorised over N points.
Images are H x W x C arrays, row 0 at the top; a texel is addressed as level[j, i] (row j, column i).
"""
import numpy as np


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _rows(a, n):
    """a as an n x 3 float64 array (a single 3-vector is broadcast)."""
    return np.broadcast_to(np.asarray(a, dtype=np.float64), (n, 3)).copy()


def _coordinate_system(n):
    """pbrt's CoordinateSystem: two unit vectors that with unit n (N x 3) form an orthonormal basis."""
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    e1 = np.stack([1 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]], axis=-1)
    e2 = np.stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]], axis=-1)
    return e1, e2


# --- 2. images -----------------------------------------------------------------------------------------

def srgb_to_linear(c):
    """sRGB decode, elementwise, of c in [0, 1]."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def image_to_linear(pixels, srgb):
    """H x W x 3 float64 linear values of an H x W x C image (C in 1..4; 2-D means C = 1). Integer codes
    are divided by 255 (uint8) or 65535 (uint16) and sRGB-decoded when srgb is True; float data is used
    as is. 1 or 2 channels: grey replicated to r, g, b; the alpha channel (2nd of 2, 4th of 4) is ignored."""
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    if pixels.dtype == np.uint8 or pixels.dtype == np.uint16:
        x = pixels.astype(np.float64) / np.iinfo(pixels.dtype).max
        if srgb:
            x = srgb_to_linear(x)
    elif np.issubdtype(pixels.dtype, np.floating):
        x = pixels.astype(np.float64)
    else:
        raise TypeError(f"unsupported pixel type {pixels.dtype}")
    c = x.shape[2]
    assert 1 <= c <= 4, c
    return np.repeat(x[:, :, :1], 3, axis=2) if c <= 2 else x[:, :, :3].copy()


# --- 3. MIP pyramid ------------------------------------------------------------------------------------

def box_weights(n, m):
    """m x n matrix A: A[k, i] = |[i, i+1) intersect [k r, (k+1) r)| / r with r = n / m, so each row sums
    to 1 and (A x)[k] is the exact average of the piecewise-constant x over output texel k."""
    r = n / m
    lo = np.arange(m)[:, None] * r
    hi = (np.arange(m)[:, None] + 1) * r
    i = np.arange(n)[None, :]
    overlap = np.clip(np.minimum(hi, i + 1) - np.maximum(lo, i), 0, None)
    return overlap / r


def downsample(level):
    """One pyramid step: H x W x C -> max(1, H//2) x max(1, W//2) x C by exact area averaging."""
    h, w = level.shape[:2]
    ah = box_weights(h, max(1, h // 2))
    aw = box_weights(w, max(1, w // 2))
    return np.einsum("ki,ijc,lj->klc", ah, np.asarray(level, dtype=np.float64), aw)


def pyramid(level0):
    """[level 0, level 1, ..., the 1 x 1 level]: 1 + floor(log2(max(W, H))) levels."""
    levels = [np.asarray(level0, dtype=np.float64)]
    while levels[-1].shape[0] > 1 or levels[-1].shape[1] > 1:
        levels.append(downsample(levels[-1]))
    return levels


# --- 4. wrap modes and filters -------------------------------------------------------------------------

def wrap_index(i, n, mode):
    """Integer texel indices i wrapped into [0, n) by "repeat", "clamp" or "mirror"."""
    i = np.asarray(i, dtype=np.int64)
    if mode == "repeat":
        return np.mod(i, n)
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    if mode == "mirror":
        m = np.mod(i, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    raise ValueError(mode)


def nearest(level0, s, t, mode):
    """N x C: the level-0 texel (floor(s W), floor(t H)), wrapped."""
    h, w = level0.shape[:2]
    i = wrap_index(np.floor(np.asarray(s, dtype=np.float64) * w), w, mode)
    j = wrap_index(np.floor(np.asarray(t, dtype=np.float64) * h), h, mode)
    return level0[j, i]


def bilinear(level, s, t, mode):
    """N x C: bilinear interpolation in one level between the four texel centres around (s, t)."""
    h, w = level.shape[:2]
    x = np.asarray(s, dtype=np.float64) * w - 0.5
    y = np.asarray(t, dtype=np.float64) * h - 0.5
    i, j = np.floor(x), np.floor(y)
    fx, fy = (x - i)[:, None], (y - j)[:, None]
    i0, i1 = wrap_index(i, w, mode), wrap_index(i + 1, w, mode)
    j0, j1 = wrap_index(j, h, mode), wrap_index(j + 1, h, mode)
    return ((1 - fx) * (1 - fy) * level[j0, i0] + fx * (1 - fy) * level[j0, i1]
            + (1 - fx) * fy * level[j1, i0] + fx * fy * level[j1, i1])


def _at_lod(levels, s, t, d, mode):
    """Bilinear lookups in levels floor(d) and floor(d) + 1 (capped), linearly blended by frac(d)."""
    n = len(levels)
    l0 = np.floor(d).astype(np.int64)
    f = (d - l0)[:, None]
    out = np.zeros((len(d), levels[0].shape[2]))
    for l in np.unique(l0):                              # one level pair at a time
        k = l0 == l
        a = bilinear(levels[l], s[k], t[k], mode)
        b = bilinear(levels[min(l + 1, n - 1)], s[k], t[k], mode)
        out[k] = (1 - f[k]) * a + f[k] * b
    return out


def _lod(width, n_levels):
    """D = clamp(log2 width, 0, n_levels - 1), with width 0 giving 0."""
    with np.errstate(divide="ignore"):
        return np.clip(np.where(width > 0, np.log2(np.where(width > 0, width, 1)), 0), 0, n_levels - 1)


def _axes(levels, dsdx, dtdx, dsdy, dtdy):
    """The two footprint axes in level-0 texels, N x 2 each."""
    h, w = levels[0].shape[:2]
    a = np.stack([np.asarray(dsdx, dtype=np.float64) * w, np.asarray(dtdx, dtype=np.float64) * h], -1)
    b = np.stack([np.asarray(dsdy, dtype=np.float64) * w, np.asarray(dtdy, dtype=np.float64) * h], -1)
    return a, b


def trilinear(levels, s, t, dsdx, dtdx, dsdy, dtdy, mode):
    """N x C: mip-mapped lookup at D = clamp(log2 L, 0, n - 1), L = the longer footprint axis in texels."""
    a, b = _axes(levels, dsdx, dtdx, dsdy, dtdy)
    width = np.maximum(np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1))
    s, t = np.asarray(s, dtype=np.float64), np.asarray(t, dtype=np.float64)
    return _at_lod(levels, s, t, _lod(width, len(levels)), mode)


def anisotropic(levels, s, t, dsdx, dtdx, dsdy, dtdy, mode):
    """N x C: mean of N <= 8 trilinear probes spread along the major footprint axis, at the LOD of the
    width max(|minor|, |major| / 8). The x axis is the major one when both have the same length."""
    h, w = levels[0].shape[:2]
    a, b = _axes(levels, dsdx, dtdx, dsdy, dtdy)
    la, lb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    a_major = la >= lb
    major = np.where(a_major[:, None], a, b)
    lmaj, lmin = np.maximum(la, lb), np.minimum(la, lb)
    width = np.maximum(lmin, lmaj / 8)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(width > 0, lmaj / width, 1.0)
    count = np.clip(np.ceil(np.round(ratio, 3)), 1, 8).astype(np.int64)
    d = _lod(width, len(levels))
    major_st = major / np.array([w, h])
    s, t = np.asarray(s, dtype=np.float64), np.asarray(t, dtype=np.float64)
    out = np.zeros((len(s), levels[0].shape[2]))
    for n in np.unique(count):
        k = count == n
        for p in range(n):
            off = (p + 0.5) / n - 0.5
            out[k] += _at_lod(levels, s[k] + off * major_st[k, 0], t[k] + off * major_st[k, 1], d[k], mode)
        out[k] /= n
    return out


def lookup(levels, filter_name, s, t, derivs, mode):
    """Dispatch on filter_name; derivs = (dsdx, dtdx, dsdy, dtdy) (unused by nearest and bilinear)."""
    s = np.atleast_1d(np.asarray(s, dtype=np.float64))
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    if filter_name == "nearest":
        return nearest(levels[0], s, t, mode)
    if filter_name == "bilinear":
        return bilinear(levels[0], s, t, mode)
    if filter_name == "trilinear":
        return trilinear(levels, s, t, *derivs, mode)
    if filter_name == "anisotropic":
        return anisotropic(levels, s, t, *derivs, mode)
    raise ValueError(filter_name)


def texture_coords(u, v, derivs_uv, uv_scale=(1, 1), uv_offset=(0, 0)):
    """(s, t, (dsdx, dtdx, dsdy, dtdy)) after the material's transform u' = su u + ou, v' = sv v + ov;
    s = u', t = 1 - v'. derivs_uv = (dudx, dvdx, dudy, dvdy) of the untransformed uv."""
    (su, sv), (ou, ov) = uv_scale, uv_offset
    dudx, dvdx, dudy, dvdy = (np.asarray(x, dtype=np.float64) for x in derivs_uv)
    return (su * np.asarray(u, dtype=np.float64) + ou, 1 - (sv * np.asarray(v, dtype=np.float64) + ov),
            (su * dudx, -sv * dvdx, su * dudy, -sv * dvdy))


# --- 1. surface parameterisations ----------------------------------------------------------------------

def tangent_from(dpdu, n):
    """T = normalize(dpdu - n (n . dpdu)); where dpdu has no tangential part, any unit vector orthogonal
    to n (pbrt's CoordinateSystem)."""
    tang = dpdu - n * _dot(n, dpdu)[:, None]
    length = np.linalg.norm(tang, axis=1)
    ok = length > 1e-12 * np.maximum(np.linalg.norm(dpdu, axis=1), 1e-300)
    fallback = _coordinate_system(n)[0]
    return np.where(ok[:, None], tang / np.where(ok, length, 1)[:, None], fallback)


def rectangle_surface(center, size, normal, tangent, p):
    """u, v, dpdu, dpdv, normal, tangent of points p (N x 3) on a rectangle (full size (sx, sy))."""
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    n, t = _rows(normal, len(p)), _rows(tangent, len(p))
    b = np.cross(n, t)
    rel = p - np.asarray(center, dtype=np.float64)
    sx, sy = size
    return dict(u=_dot(rel, t) / sx + 0.5, v=_dot(rel, b) / sy + 0.5, dpdu=sx * t, dpdv=sy * b,
                normal=n, tangent=tangent_from(sx * t, n))


def triangle_surface(vertices, uvs, b1, b2):
    """p, u, v, dpdu, dpdv, normal, tangent at barycentrics (b1, b2) (weights of v1, v2), N points.
    uvs None means (0,0), (1,0), (0,1). A degenerate uv mapping, |det| <= 1e-9 max(|duv02|, |duv12|)^2,
    gives the orthonormal pair CoordinateSystem(N_g)."""
    v0, v1, v2 = np.asarray(vertices, dtype=np.float64)
    uv = np.array([[0, 0], [1, 0], [0, 1]], dtype=np.float64) if uvs is None else np.asarray(uvs, np.float64)
    b1 = np.atleast_1d(np.asarray(b1, dtype=np.float64))
    b2 = np.atleast_1d(np.asarray(b2, dtype=np.float64))
    b0 = 1 - b1 - b2
    n_pts = len(b1)
    ng = _rows(_normalize(np.cross(v1 - v0, v2 - v1)), n_pts)
    duv02, duv12, dp02, dp12 = uv[0] - uv[2], uv[1] - uv[2], v0 - v2, v1 - v2
    det = duv02[0] * duv12[1] - duv02[1] * duv12[0]
    scale = max(np.linalg.norm(duv02), np.linalg.norm(duv12)) ** 2
    if abs(det) > 1e-9 * scale:
        dpdu = _rows((duv12[1] * dp02 - duv02[1] * dp12) / det, n_pts)
        dpdv = _rows((duv02[0] * dp12 - duv12[0] * dp02) / det, n_pts)
    else:
        dpdu, dpdv = _coordinate_system(ng)
    uvp = b0[:, None] * uv[0] + b1[:, None] * uv[1] + b2[:, None] * uv[2]
    p = b0[:, None] * v0 + b1[:, None] * v1 + b2[:, None] * v2
    return dict(p=p, u=uvp[:, 0], v=uvp[:, 1], dpdu=dpdu, dpdv=dpdv, normal=ng,
                tangent=tangent_from(dpdu, ng))


def ellipsoid_surface(center, M, p):
    """u, v, dpdu, dpdv, normal (outward), tangent of points p (N x 3) on the ellipsoid p = c + M q."""
    M = np.asarray(M, dtype=np.float64)
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    q = _normalize((p - np.asarray(center, dtype=np.float64)) @ np.linalg.inv(M).T)
    theta = np.arctan2(q[:, 1], q[:, 0])
    theta = np.where(theta <= -np.pi, np.pi, theta)     # (-pi, pi]
    phi = np.arccos(np.clip(q[:, 2], -1, 1))
    zero = np.zeros_like(theta)
    dqdu = 2 * np.pi * np.stack([-q[:, 1], q[:, 0], zero], -1)
    dqdv = -np.pi * np.stack([np.cos(phi) * np.cos(theta), np.cos(phi) * np.sin(theta), -np.sin(phi)], -1)
    around = np.stack([-np.sin(theta), np.cos(theta), zero], -1)
    return dict(u=theta / (2 * np.pi) + 0.5, v=1 - phi / np.pi, dpdu=dqdu @ M.T, dpdv=dqdv @ M.T,
                normal=_normalize(q @ np.linalg.inv(M)), tangent=_normalize(around @ M.T))


# --- 5. shading frame, normal maps, bump maps ----------------------------------------------------------

def shading_frame(surface):
    """(T, B, N_uv): N_uv = N_g turned to the side of dpdu x dpdv (N_g on ties), B = N_uv x T."""
    n, tang = surface["normal"], surface["tangent"]
    side = _dot(n, np.cross(surface["dpdu"], surface["dpdv"]))
    n_uv = np.where((side >= 0)[:, None], n, -n)
    return tang, np.cross(n_uv, tang), n_uv


def normal_map_normal(frame, rgb):
    """normalize(m.x T + m.y B + m.z N_uv), m = 2 rgb - 1 (rgb: N x 3 filtered map values)."""
    tang, bit, n_uv = frame
    m = 2 * np.asarray(rgb, dtype=np.float64)[:, :3] - 1
    return _normalize(m[:, :1] * tang + m[:, 1:2] * bit + m[:, 2:3] * n_uv)


def height_gradient(levels, filter_name, u, v, derivs_uv, mode, uv_scale=(1, 1), uv_offset=(0, 0)):
    """(h, hu, hv): the height (first channel) at (u', v') and its forward differences along u' and v'
    with steps du = max(0.5 (|du'dx| + |du'dy|), 1/(2W)), dv likewise with H; every lookup uses the same
    filter and footprint. hu, hv are per unit u', v' (pair them with dpdu' = dpdu / su, dpdv' = dpdv / sv)."""
    h_img, w_img = levels[0].shape[:2]
    s, t, derivs = texture_coords(u, v, derivs_uv, uv_scale, uv_offset)
    dsdx, dtdx, dsdy, dtdy = derivs
    du = np.maximum(0.5 * (np.abs(dsdx) + np.abs(dsdy)), 1 / (2 * w_img))
    dv = np.maximum(0.5 * (np.abs(dtdx) + np.abs(dtdy)), 1 / (2 * h_img))
    h = lookup(levels, filter_name, s, t, derivs, mode)[:, 0]
    hu = (lookup(levels, filter_name, s + du, t, derivs, mode)[:, 0] - h) / du
    hv = (lookup(levels, filter_name, s, t - dv, derivs, mode)[:, 0] - h) / dv    # v' + dv is t - dv
    return h, hu, hv


def bump_normal(dpdu, dpdv, N, k, hu, hv):
    """The normal N tilted by the height's surface gradient: normalize(N - k g), g the vector orthogonal to
    N with g . dpdu = hu and g . dpdv = hv (a 3 x 3 solve per point). Where N is the normal of dpdu x dpdv
    this is normalize((dpdu + k hu N) x (dpdv + k hv N)) turned to N's side; with a normal-mapped N it
    tilts that normal the same way. Pass the transformed dpdu', dpdv' that match hu, hv."""
    rows = np.stack([dpdu, dpdv, N], axis=1)                              # N x 3 x 3
    rhs = np.stack([hu, hv, np.zeros(len(N))], axis=1)[..., None]
    g = np.linalg.solve(rows, rhs)[..., 0]
    return _normalize(N - k * g)


# --- 6. ray differentials ------------------------------------------------------------------------------

def camera_basis(position, look_at, up):
    """(forward, right, up'): forward = normalize(look_at - position), right = normalize(forward x up),
    up' = right x forward."""
    f = _normalize(np.asarray(look_at, dtype=np.float64) - np.asarray(position, dtype=np.float64))
    r = _normalize(np.cross(f, np.asarray(up, dtype=np.float64)))
    return f, r, np.cross(r, f)


def camera_direction(basis, fov_deg, focal, width, height, x, y):
    """N x 3 UNnormalised D = f F + sx R + sy U at continuous pixel (x, y), row 0 at the top, with
    sx = (2x/W - 1) (W/H) f tan(fov/2), sy = (1 - 2y/H) f tan(fov/2)."""
    fwd, right, up = basis
    half = focal * np.tan(np.radians(fov_deg) / 2)
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    sx = (2 * x / width - 1) * (width / height) * half
    sy = (1 - 2 * y / height) * half
    return focal * fwd + sx[:, None] * right + sy[:, None] * up


def ray_differentials(basis, fov_deg, focal, width, height, x, y, delta):
    """(D, D_x, D_y): D_x = D + delta (2/W) scale_x R, D_y = D - delta (2/H) scale_y U; these are exactly
    the directions through pixels (x + delta, y) and (x, y + delta)."""
    _, right, up = basis
    scale_y = focal * np.tan(np.radians(fov_deg) / 2)
    scale_x = width / height * scale_y
    d = camera_direction(basis, fov_deg, focal, width, height, x, y)
    return d, d + delta * (2 / width) * scale_x * right, d - delta * (2 / height) * scale_y * up


def surface_differentials(o, p, normal, d_x, d_y):
    """(dpdx, dpdy): where the offset rays o + s D_x, o + s D_y meet the tangent plane at p, minus p."""
    o, p, n = np.asarray(o, dtype=np.float64), np.asarray(p, dtype=np.float64), np.asarray(normal, np.float64)
    dist = _dot(p - o, n)
    p_x = o + d_x * (dist / _dot(d_x, n))[:, None]
    p_y = o + d_y * (dist / _dot(d_y, n))[:, None]
    return p_x - p, p_y - p


def uv_derivatives(dpdu, dpdv, dpdx, dpdy):
    """(dudx, dvdx, dudy, dvdy): least-squares solutions of dpdx = dudx dpdu + dvdx dpdv (and for y) by
    the normal equations; non-finite results become 0, the rest are clamped to [-1e8, 1e8]."""
    a00, a01, a11 = _dot(dpdu, dpdu), _dot(dpdu, dpdv), _dot(dpdv, dpdv)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = 1 / (a00 * a11 - a01 * a01)
        out = []
        for dp in (dpdx, dpdy):
            b0, b1 = _dot(dpdu, dp), _dot(dpdv, dp)
            out += [(a11 * b0 - a01 * b1) * inv, (a00 * b1 - a01 * b0) * inv]
    dudx, dvdx, dudy, dvdy = (np.clip(np.where(np.isfinite(r), r, 0), -1e8, 1e8) for r in out)
    return dudx, dvdx, dudy, dvdy


def footprint_by_offset_pixels(uv_of_pixel, x, y, delta):
    """(dudx, dvdx, dudy, dvdy) = uv(x + delta, y) - uv(x, y) and uv(x, y + delta) - uv(x, y): on a plane
    whose u, v are affine in p, this is what the tangent-plane formula gives, up to round-off."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    u0, v0 = uv_of_pixel(x, y)
    ux, vx = uv_of_pixel(x + delta, y)
    uy, vy = uv_of_pixel(x, y + delta)
    return ux - u0, vx - v0, uy - u0, vy - v0
