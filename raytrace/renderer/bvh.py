"""A bounding volume hierarchy over axis-aligned boxes, built with binned SAH (pbrt-v4 section 7.3).

The caller gives one box per primitive (triangles, rectangles, ellipsoids alike); the tree never looks
at the primitives themselves. The build is vectorised over a whole level of the tree at a time: one
numpy pass bins, evaluates and partitions every node of the level, so the Python overhead is per level
(a few dozen for a million boxes), not per node.

The result is flattened depth-first (pbrt-v4 section 7.3.4, "Compact BVH for traversal"): the left
child of an interior node is the next node, so a node stores only its right child. `BVH_NODE` is 32
bytes: count > 0 is a leaf holding primitives order[offset : offset + count]; count <= 0 is an interior
node whose right child is node `offset` and whose split axis is -count (traversal visits the nearer
child first by the ray direction's sign on that axis).
"""
import numpy as np

from ..structs import BVH_NODE, BVH_STACK  # traversal pushes at most one node per level: depth <= BVH_STACK

# SAH costs relative to one primitive intersection, both 1 as issue 9 asks (pbrt-v4 7.3.2 uses 1/2 for
# traversal); to be tuned against the kernel's traversal once there is one.
TRAVERSAL_COST = 1.0
INTERSECTION_COST = 1.0


def build(lo, hi, max_leaf=4, bins=16):
    """BVH over the boxes [lo[i], hi[i]] ((N, 3) arrays): (nodes as BVH_NODE, order as int32).

    Node boxes are float32, rounded outwards so that each contains the float64 boxes below it. Every
    leaf holds 1..max_leaf primitives: a node is split when that is cheaper by SAH, or when it is too
    big for a leaf (then by the best SAH split, or in two halves if all its centroids coincide).
    """
    # The active primitives' boxes and centroids travel with them (gathered by a permutation that stays
    # within each node), rather than being gathered from the input at random every level.
    if max_leaf < 1 or bins < 2:
        raise ValueError(f"need max_leaf >= 1 and bins >= 2, got {max_leaf} and {bins}")
    box = _float32_boxes(lo, hi)
    centroid = 0.5 * (box[:3].astype(np.float64) - box[3:])
    levels, order = [], np.empty(box.shape[1], np.int32)
    prims, counts, first = np.arange(box.shape[1]), np.array([box.shape[1]]), np.array([0])
    while len(counts):
        level = _split_level(box, centroid, counts, max_leaf, bins)
        leaf_prim = np.repeat(level["leaf"], counts)
        perm = level.pop("perm")
        moved = prims[perm]
        order[(np.repeat(first, counts) + _ranks(counts))[leaf_prim]] = moved[leaf_prim]
        keep = perm[~leaf_prim]
        prims, box, centroid = moved[~leaf_prim], box[:, keep], centroid[:, keep]
        level["first"], level["counts"] = first, counts
        levels.append(level)
        split = ~level["leaf"]
        counts = np.stack([level["left_count"], counts - level["left_count"]], 1)[split].ravel()
        first = np.stack([first, first + level["left_count"]], 1)[split].ravel()
    if len(levels) > BVH_STACK:
        raise ValueError(f"the BVH is {len(levels)} levels deep, more than the kernel's stack of {BVH_STACK}")
    return _flatten(levels), order


def sah_cost(nodes):
    """SAH cost of a built tree (pbrt-v4 section 7.3.2): the sum over nodes of area(node) / area(root)
    times TRAVERSAL_COST for an interior node or INTERSECTION_COST * count for a leaf."""
    area = _area(np.concatenate([nodes["lo"], -nodes["hi"]], 1).T)
    weight = np.where(nodes["count"] > 0, INTERSECTION_COST * nodes["count"], TRAVERSAL_COST)
    return float(np.sum(area * weight) / area[0])


def _float32_boxes(lo, hi):
    """(6, N) float32 rows lo_x, lo_y, lo_z, -hi_x, -hi_y, -hi_z: lo rounded down and hi rounded up, so
    the float32 box contains the float64 one; hi is negated so one minimum serves both ends of a union."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    if lo.ndim != 2 or lo.shape[1] != 3 or lo.shape != hi.shape or not len(lo):
        raise ValueError(f"need lo and hi of the same shape (N >= 1, 3), got {lo.shape} and {hi.shape}")
    if not (np.isfinite(lo).all() and np.isfinite(hi).all() and (lo <= hi).all()):
        raise ValueError("boxes must be finite with lo <= hi")
    lo32, hi32 = lo.astype(np.float32), hi.astype(np.float32)
    lo32 = np.where(lo32 > lo, np.nextafter(lo32, np.float32(-np.inf)), lo32)
    hi32 = np.where(hi32 < hi, np.nextafter(hi32, np.float32(np.inf)), hi32)
    return np.ascontiguousarray(np.concatenate([lo32, -hi32], 1).T)


def _area(b):
    """Surface areas (float64) of boxes in the (6, ...) layout of _float32_boxes."""
    d = -b[3:].astype(np.float64) - b[:3]
    return 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])


def _ranks(counts):
    """Each element's index within its node, for nodes holding `counts` consecutive elements."""
    starts = np.cumsum(counts) - counts
    return np.arange(counts.sum()) - np.repeat(starts, counts)


def _split_level(box, centroid, counts, max_leaf, bins):
    """Bounds, leaf-or-split decision and partition of every node of one level at once.

    box (6, n) and centroid (3, n) hold the nodes' primitives back to back (node k has counts[k] of
    them). Returns the nodes' bounds (6, K), `leaf` (K,), axis and left_count (K,), and `perm`, the
    gather that partitions each node's run: the left child's primitives first, then the right child's.
    """
    starts = np.cumsum(counts) - counts
    node = np.repeat(np.arange(len(counts)), counts)
    bounds = np.minimum.reduceat(box, starts, axis=1)
    lo, hi = np.minimum.reduceat(centroid, starts, axis=1), np.maximum.reduceat(centroid, starts, axis=1)
    # Bins span the node's centroid bounds (pbrt-v4 7.3.2); small nodes get one bin per primitive.
    n_bins = np.minimum(counts, bins)
    with np.errstate(divide="ignore"):
        scale = np.where(hi > lo, n_bins / (hi - lo), 0.0)
    bin_of = np.minimum(((centroid - lo[:, node]) * scale[:, node]).astype(np.int64), n_bins[node] - 1)
    cost, axis, split = _best_splits(box, bin_of, node, n_bins, bounds, counts)
    found = np.isfinite(cost)
    leaf = ~((found & (cost < INTERSECTION_COST * counts)) | (counts > max_leaf))
    # A node too big for a leaf whose centroids all coincide cannot be binned: halve it as it is.
    halve = ~leaf & ~found
    rank = _ranks(counts)
    goes_left = np.where(halve[node], rank < (counts // 2)[node], bin_of[axis[node], np.arange(len(node))]
                         <= split[node])
    left_count = np.add.reduceat(goes_left.astype(np.int64), starts)
    return {"bounds": bounds, "leaf": leaf, "axis": axis, "left_count": left_count,
            "perm": _partition(goes_left, node, starts, left_count)}


def _best_splits(box, bin_of, node, n_bins, bounds, counts):
    """The cheapest binned SAH split of every node over all three axes: (cost, axis, last bin on the
    left), cost = inf where no split leaves primitives on both sides."""
    best_cost = np.full(len(counts), np.inf)
    best_axis, best_split = np.zeros(len(counts), np.int64), np.zeros(len(counts), np.int64)
    first_bin = np.cumsum(n_bins) - n_bins
    node_area = _area(bounds)
    for axis in range(3):
        bin_count, bin_box = _fill_bins(box, first_bin[node] + bin_of[axis], n_bins.sum())
        # One dense sweep per bin count: nodes with w bins form a (w, K_w) block.
        for w in np.unique(n_bins[n_bins > 1]):
            nodes = np.flatnonzero(n_bins == w)
            index = np.arange(w)[:, None] + first_bin[nodes]
            cost, split = _sweep(bin_count[index], bin_box[:, index], node_area[nodes], counts[nodes])
            better = cost < best_cost[nodes]
            best_cost[nodes[better]], best_axis[nodes[better]], best_split[nodes[better]] = \
                cost[better], axis, split[better]
    return best_cost, best_axis, best_split


def _fill_bins(box, key, n_bins):
    """Primitive count (n_bins,) and union of boxes (6, n_bins) per bin; key is each primitive's bin."""
    bin_box = np.full((6, n_bins), np.inf, np.float32)
    for row in range(6):
        np.minimum.at(bin_box[row], key, box[row])
    return np.bincount(key, minlength=n_bins), bin_box


def _sweep(bin_count, bin_box, node_area, counts):
    """SAH cost of splitting after each bin (pbrt-v4 7.3.2: a forward and a backward scan), for K nodes
    of w bins: bin_count (w, K), bin_box (6, w, K). Returns the cheapest cost and its bin, per node."""
    by_bin = np.moveaxis(bin_box, 1, 0)
    left = np.moveaxis(_scan(np.minimum, by_bin)[:-1], 0, 1)
    right = np.moveaxis(_scan(np.minimum, by_bin[::-1])[-2::-1], 0, 1)
    n_left = _scan(np.add, bin_count)[:-1]
    n_right = counts - n_left
    with np.errstate(invalid="ignore", divide="ignore"):  # empty sides (inf boxes), zero-area nodes
        cost = TRAVERSAL_COST + INTERSECTION_COST * (n_left * _area(left) + n_right * _area(right)) / node_area
    cost = np.where((n_left > 0) & (n_right > 0) & np.isfinite(cost), cost, np.inf)
    split = np.argmin(cost, axis=0)
    return cost[split, np.arange(len(split))], split


def _scan(ufunc, a):
    """Inclusive scan along axis 0 as one whole-slice operation per step (ufunc.accumulate runs its inner
    loop along the short axis here, and is several times slower: measured in commit cd6cb18)."""
    out = a.copy()
    for j in range(1, len(out)):
        ufunc(out[j - 1], out[j], out=out[j])
    return out


def _partition(goes_left, node, starts, left_count):
    """The gather that stably partitions each node's run of primitives, left ones first (prefix sums,
    no sort)."""
    before = np.cumsum(goes_left) - goes_left
    lefts_before = before - before[starts][node]
    rights_before = np.arange(len(node)) - starts[node] - lefts_before
    slot = starts[node] + np.where(goes_left, lefts_before, left_count[node] + rights_before)
    perm = np.empty_like(slot)
    perm[slot] = np.arange(len(slot))
    return perm


def _flatten(levels):
    """The level-by-level nodes as BVH_NODE in depth-first order. Nodes are numbered breadth-first, and
    the children of a split node are consecutive in the next level, so child ids follow from counts."""
    size = [len(level["leaf"]) for level in levels]
    base = np.cumsum([0] + size)
    leaf = np.concatenate([level["leaf"] for level in levels])
    left = np.full(len(leaf), -1)
    for k, level in enumerate(levels):
        split = np.flatnonzero(~level["leaf"])
        left[base[k] + split] = base[k + 1] + 2 * np.arange(len(split))
    # Subtree sizes bottom-up, then depth-first positions top-down (left subtree, then right).
    subtree = np.ones(len(leaf), np.int64)
    for k in reversed(range(len(levels))):
        ids = np.arange(base[k], base[k + 1])[~levels[k]["leaf"]]
        subtree[ids] += subtree[left[ids]] + subtree[left[ids] + 1]
    position = np.zeros(len(leaf), np.int64)
    for k in range(len(levels)):
        ids = np.arange(base[k], base[k + 1])[~levels[k]["leaf"]]
        position[left[ids]] = position[ids] + 1
        position[left[ids] + 1] = position[ids] + 1 + subtree[left[ids]]
    nodes = np.empty(len(leaf), BVH_NODE)
    bounds = np.concatenate([level["bounds"] for level in levels], 1)
    nodes["lo"][position], nodes["hi"][position] = bounds[:3].T, -bounds[3:].T
    counts = np.concatenate([level["counts"] for level in levels])
    first = np.concatenate([level["first"] for level in levels])
    axis = np.concatenate([level["axis"] for level in levels])
    nodes["offset"][position] = np.where(leaf, first, position[np.where(leaf, 0, left + 1)])
    nodes["count"][position] = np.where(leaf, counts, -axis)
    return nodes

