"""A slow, plain-Python flip stage written from SPEC.md section 3 (paper II.B.2-3).

It shares no code with the kernels: triangles are a set of vertex triples,
the queue is a linear scan, spans are found by searching every triangle.
Settled choices it follows, from the SPEC and the README: edge ids in
half-edge order of the input faces (a flip keeps the id: AB becomes CD),
ties in the queue to the smaller id, gains rounded to a given quantum, the
edge-length bound checked before T1, the angle tolerance of T5.
"""

import math

import numpy as np

from .reference import bresenham

NAMES = ["t1_deadlock", "t2_disparity_change", "t3_degenerate", "t4_bend", "t5_crease",
         "final_test", "flipped", "max_edge"]
ANGLE_TOL = 1e-9


def _lift(r, c, d, cam):
    if cam[0] == 0.0:
        return np.array([cam[1] * r, cam[2] * c, cam[3] * d])
    z = d * cam[5]
    return np.array([(c - cam[3]) * z / cam[1], (r - cam[4]) * z / cam[2], z])


def _angle(u, v):
    c = np.cross(u, v)
    return math.atan2(math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), float(np.dot(u, v)))


def _normal(V, tri):
    a, b, c = (V[i] for i in tri)
    n = np.cross(b - a, c - a)
    norm = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    return n / norm if norm > 0 else np.zeros(3)


def _max_angle(V, tri):
    out = 0.0
    for k in range(3):
        p, q, s = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
        out = max(out, _angle(V[q] - V[p], V[s] - V[p]))
    return out


def edge_error(a, b, P, V, depth, valid, cam):
    """SPEC 3.1: distances of the valid pixels of the Bresenham line AB to the 3-D segment AB."""
    if tuple(P[b]) < tuple(P[a]):
        a, b = b, a
    p, d = V[a], V[b] - V[a]
    dd = float(np.dot(d, d))
    total = 0.0
    for r, c in bresenham(P[a], P[b]):
        if not valid[r, c]:
            continue
        q = _lift(r, c, depth[r, c], cam) - p
        t = min(max(float(np.dot(q, d)) / dd, 0.0), 1.0) if dd > 0 else 0.0
        e = q - t * d
        total += math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    return total


def _orient(P, a, b, c):
    return (int(P[b, 0]) - int(P[a, 0])) * (int(P[c, 1]) - int(P[a, 1])) - \
           (int(P[b, 1]) - int(P[a, 1])) * (int(P[c, 0]) - int(P[a, 0]))


class FlipReference:
    """The whole flip stage; `run` returns (faces, log of (a, b, verdict name))."""

    def __init__(self, faces, P, V, depth, valid, cam, *, mode, delta, epsilon, max_angle,
                 min_bend, quantum, threshold=-math.inf, max_edge=math.inf):
        self.P, self.V, self.depth, self.valid, self.cam = P, V, depth, valid, cam
        self.mode, self.quantum, self.threshold = mode, quantum, threshold
        self.delta, self.epsilon = math.radians(delta), math.radians(epsilon)
        self.max_angle, self.min_bend = math.radians(max_angle), math.radians(min_bend)
        self.max_edge = max_edge
        self.tris = [tuple(int(x) for x in f) for f in faces]   # CCW triangles
        # edge ids in half-edge order: the first time an undirected edge is met
        self.edges = []
        seen = {}
        for t in self.tris:
            for k in range(3):
                key = frozenset((t[k], t[(k + 1) % 3]))
                if key not in seen:
                    seen[key] = len(self.edges)
                    self.edges.append(key)
        self.err = [edge_error(*sorted(e), P, V, depth, valid, cam) for e in self.edges]
        self.gain = [self._gain(x) for x in range(len(self.edges))]
        self.former = set()

    def _quad(self, x):
        """(A, B, C, D): AB the edge, ABC and BAD its two CCW triangles; None on the border."""
        a, b = tuple(self.edges[x])
        found = {}
        for t in self.tris:
            for k in range(3):
                if {t[k], t[(k + 1) % 3]} == {a, b}:
                    found[(t[k], t[(k + 1) % 3])] = t[(k + 2) % 3]
        if len(found) < 2:
            return None
        (a, b), c = next(iter(found.items()))
        return a, b, c, found[(b, a)]

    def _gain(self, x):
        q = self._quad(x)
        if q is None:
            return -math.inf
        a, b, c, d = q
        if _orient(self.P, d, b, c) <= 0 or _orient(self.P, c, a, d) <= 0:
            return -math.inf   # quad A-D-B-C not strictly convex
        g = self.err[x] - edge_error(c, d, self.P, self.V, self.depth, self.valid, self.cam)
        return round(g / self.quantum) * self.quantum

    def _span(self, v, quad):
        normals = [_normal(self.V, t) for t in self.tris if v in t and t not in quad]
        return np.array([math.fsum(n[i] for n in normals) for i in range(3)]) if normals \
            else np.zeros(3)

    def _disp(self, ns, n):
        if not ns.any():
            return math.pi
        a = _angle(ns, n)
        return a if a < self.delta else math.pi

    def _verdict(self, x):
        a, b, c, d = self._quad(x)
        if float(np.sum((self.P[c] - self.P[d]).astype(np.int64) ** 2)) > self.max_edge ** 2:
            return "max_edge"
        if frozenset((c, d)) in self.former:
            return "t1_deadlock"
        if self.mode == "error":
            return "flipped"
        quad = [(a, b, c), (b, a, d)]
        quad = [t for t in self.tris if set(t) in (set(quad[0]), set(quad[1]))]
        ns = {v: self._span(v, quad) for v in (a, b, c, d)}
        abc, bad = _normal(self.V, (a, b, c)), _normal(self.V, (b, a, d))
        dca, cdb = _normal(self.V, (d, c, a)), _normal(self.V, (c, d, b))
        disp_ab = max(self._disp(ns[c], abc), self._disp(ns[d], bad))
        disp_cd = max(self._disp(ns[a], dca), self._disp(ns[b], cdb))
        bend = _angle(dca, cdb)
        if abs(disp_ab - disp_cd) < self.epsilon:
            return "t2_disparity_change"
        if bend < self.delta and max(_max_angle(self.V, (d, c, a)),
                                     _max_angle(self.V, (c, d, b))) > self.max_angle:
            return "t3_degenerate"
        if not bend > self.min_bend:
            return "t4_bend"
        if _angle(ns[c], ns[d]) > 2.0 * _angle(ns[a], ns[b]) + ANGLE_TOL:
            return "t5_crease"
        return "flipped" if disp_ab > disp_cd else "final_test"

    def run(self):
        log = []
        while self.edges:
            x = max(range(len(self.edges)), key=lambda i: (self.gain[i], -i))
            g = self.gain[x]
            if g == -math.inf or g < self.threshold or (self.mode == "error" and g <= 0):
                break
            verdict = self._verdict(x)
            a, b, c, d = self._quad(x)
            log.append((min(a, b), max(a, b), verdict))
            if verdict != "flipped":
                self.gain[x] = -math.inf
                continue
            self.former.add(frozenset((a, b)))
            self.tris = [t for t in self.tris if set(t) not in ({a, b, c}, {a, b, d})]
            self.tris += [(d, c, a), (c, d, b)]
            self.edges[x] = frozenset((c, d))
            self.err[x] = edge_error(c, d, self.P, self.V, self.depth, self.valid, self.cam)
            outer = [self.edges.index(frozenset(e)) for e in ((b, c), (c, a), (a, d), (d, b))]
            for y in [x] + outer:
                self.gain[y] = self._gain(y)
        return np.array(self.tris), log
