"""assert_valid_mesh: SPEC P4, checked independently of the code under test; the tests' shared helpers."""

import signal
import subprocess

import numpy as np
import pytest


def _orient(p, f):
    r = p[f, 0].astype(np.int64)
    c = p[f, 1].astype(np.int64)
    return (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0]) - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0])


def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def _union(parent, a, b):
    ra, rb = _find(parent, a), _find(parent, b)
    if ra != rb:
        parent[max(ra, rb)] = min(ra, rb)


def assert_valid_mesh(mesh, valid=None, *, check_overlap=True, wrap=False):
    """SPEC P4: every property a mesh from rangemesh must have.

    With `wrap` (a 360-degree image, column W-1 beside column 0) the mesh is
    checked on the cylinder: a clockwise face is a seam face, allowed when
    all its vertices lie on columns 0 and W-1 and it is counter-clockwise
    once its column-0 vertices move to column W; the overlap check then
    uses those unrolled columns.
    """
    v, f, p = mesh.vertices, mesh.faces, mesh.pixels
    assert v.ndim == 2 and v.shape[1] == 3 and v.dtype == np.float64
    assert f.ndim == 2 and f.shape[1] == 3 and np.issubdtype(f.dtype, np.integer)
    assert p.shape == (len(v), 2)
    assert np.isfinite(v).all()
    if len(f) == 0:
        assert mesh.stats.reason, "an empty mesh must say why"
        return
    assert f.min() >= 0 and f.max() < len(v)
    # every vertex is used, and pixels are distinct
    assert np.array_equal(np.unique(f), np.arange(len(v))), "unreferenced vertex"
    lin = p[:, 0].astype(np.int64) * mesh.image_shape[1] + p[:, 1]
    assert np.unique(lin).size == len(p), "two vertices on one pixel"
    if valid is not None:
        assert valid[p[:, 0], p[:, 1]].all(), "a vertex sits on a background pixel"
    # no degenerate triangle, all counter-clockwise in (r, c)
    assert (f[:, 0] != f[:, 1]).all() and (f[:, 1] != f[:, 2]).all() and (f[:, 0] != f[:, 2]).all()
    area = _orient(p, f)
    w = mesh.image_shape[1]
    seam = np.zeros(len(f), bool)
    if wrap:
        seam = area < 0
        sc = p[f[seam], 1]
        assert np.isin(sc, (0, w - 1)).all(), "a seam face off columns 0 and W-1"
        unrolled = np.stack([p[:, 0], np.where(p[:, 1] == 0, w, p[:, 1])], axis=1)
        assert (_orient(unrolled, f[seam]) > 0).all(), "a seam face is not counter-clockwise"
        area = np.where(seam, 1, area)
    assert (area > 0).all(), f"{(area <= 0).sum()} faces are not counter-clockwise"
    # no repeated triangle
    assert np.unique(np.sort(f, axis=1), axis=0).shape[0] == len(f), "repeated triangle"
    # each directed edge once (consistent orientation), each undirected edge <= 2 faces
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]).astype(np.int64)
    n = len(v)
    dkey = directed[:, 0] * n + directed[:, 1]
    assert np.unique(dkey).size == dkey.size, "a directed edge appears twice"
    lo, hi = np.minimum(directed[:, 0], directed[:, 1]), np.maximum(directed[:, 0], directed[:, 1])
    ukey = lo * n + hi
    _, counts = np.unique(ukey, return_counts=True)
    assert counts.max() <= 2, "an edge has more than two triangles"
    n_edges = counts.size
    # one fan per vertex: union the corners of triangles that share an edge at that vertex
    corner_of = {}
    for t, face in enumerate(f.tolist()):
        for k, vert in enumerate(face):
            corner_of[(t, vert)] = 3 * t + k
    parent = list(range(3 * len(f)))
    twin = {}
    for t, face in enumerate(f.tolist()):
        for k in range(3):
            a, b = face[k], face[(k + 1) % 3]
            twin[(a, b)] = t
    for (a, b), t in twin.items():
        u = twin.get((b, a))
        if u is not None and u > t:
            for vert in (a, b):
                _union(parent, corner_of[(t, vert)], corner_of[(u, vert)])
    roots = {}
    for t, face in enumerate(f.tolist()):
        for k, vert in enumerate(face):
            roots.setdefault(vert, set()).add(_find(parent, 3 * t + k))
    multi = [vert for vert, rs in roots.items() if len(rs) > 1]
    assert not multi, f"vertices with several fans: {multi[:5]}"
    # Euler: V - E + F = 2C - B, C components, B boundary loops (planar, one fan per vertex)
    comp = list(range(n))
    for a, b, c in f.tolist():
        _union(comp, a, b)
        _union(comp, b, c)
    n_comp = len({_find(comp, i) for i in range(n)})
    boundary = {a: b for (a, b) in twin if (b, a) not in twin}
    seen, loops = set(), 0
    for start in boundary:
        if start in seen:
            continue
        loops += 1
        x = start
        while x not in seen:
            seen.add(x)
            x = boundary[x]
    assert len(boundary) == len(seen)
    assert n - n_edges + len(f) == 2 * n_comp - loops, "Euler characteristic"
    if mesh.stats.triangles:
        assert mesh.stats.triangles == len(f)
        assert mesh.stats.vertices == len(v)
        assert mesh.stats.edges == n_edges
    if check_overlap:
        pc = p[f, 1].astype(np.float64)
        if seam.any():
            pc[seam] = np.where(pc[seam] == 0, w, pc[seam])
        assert_no_overlap(p, f, mesh.image_shape, columns=pc)


def assert_no_overlap(p, f, shape, *, columns=None):
    """No point of a fine, off-lattice grid lies strictly inside two triangles.

    `columns` (F, 3), if given, replaces each face's vertex columns (unrolled seam faces).
    """
    step = 0.25
    offs = (0.0913, 0.1771)  # off the pixel lattice: never on an edge of integer triangles
    h, w = shape
    count = np.zeros((int(h / step) + 2, int(w / step) + 6), np.int32)
    pr = p[f, 0].astype(np.float64)
    pc = p[f, 1].astype(np.float64) if columns is None else columns
    for t in range(len(f)):
        r0, r1, r2 = pr[t]
        c0, c1, c2 = pc[t]
        i0 = int(np.floor((min(r0, r1, r2) - offs[0]) / step))
        i1 = int(np.ceil((max(r0, r1, r2) - offs[0]) / step))
        j0 = int(np.floor((min(c0, c1, c2) - offs[1]) / step))
        j1 = int(np.ceil((max(c0, c1, c2) - offs[1]) / step))
        ii, jj = np.mgrid[max(i0, 0) : i1 + 1, max(j0, 0) : j1 + 1]
        rr = ii * step + offs[0]
        cc = jj * step + offs[1]
        w0 = (r2 - r1) * (cc - c1) - (c2 - c1) * (rr - r1)
        w1 = (r0 - r2) * (cc - c2) - (c0 - c2) * (rr - r2)
        w2 = (r1 - r0) * (cc - c0) - (c1 - c0) * (rr - r0)
        inside = (w0 > 0) & (w1 > 0) & (w2 > 0)
        count[ii[inside], jj[inside]] += 1
    assert count.max() <= 1, "two triangles overlap in the image plane"


def canonical_faces(mesh):
    """Faces as pixel triples, rotation-normalised and sorted (order-free comparison)."""
    lin = mesh.pixels[:, 0].astype(np.int64) * mesh.image_shape[1] + mesh.pixels[:, 1]
    tri = lin[mesh.faces]
    k = np.argmin(tri, axis=1)
    if len(tri) == 0:
        return tri
    rolled = np.stack([np.roll(row, -s) for row, s in zip(tri, k, strict=True)])
    return rolled[np.lexsort(rolled.T[::-1])]


def interrupt(proc: subprocess.Popen, timeout: float = 60) -> str:
    """Send `proc` SIGINT and return its stderr once it ends; killed (and the test failed) if it
    has not ended within `timeout` seconds, so no child outlives its test."""
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f"the process went on {timeout} s after SIGINT")
    return err


def one_error_line(capsys, code, expected_code=2, match=None):
    """The CLI ended with `expected_code` and said exactly one line on stderr."""
    err = capsys.readouterr().err
    assert code == expected_code, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("rangemesh: error: "), err
    assert "Traceback" not in err
    if match:
        assert match in lines[0], lines[0]
    return lines[0]


def chair_depths():
    """The committed 96 x 96 crop of odetics/chair-range (depths 7 .. 254)."""
    from .golden import crops

    return crops()["chair"][0].astype(np.float64)


def core_settings(cls, **fields):
    """A bound settings object of `rangemesh._core` (`FlipSettings`, `FitSettings`) with these fields."""
    settings = cls()
    for name, value in fields.items():
        setattr(settings, name, value)  # (a name the class lacks raises AttributeError)
    return settings
