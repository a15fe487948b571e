"""One hand-built quad per test of the paper's flip cascade (SPEC 3.3-3.5).

Every quad is the same eight-vertex patch: the edge AB under study, its
triangles ABC and BAD, and one outer triangle on each side of the quad, so
that each of A, B, C, D has a non-empty span (the triangles around it other
than ABC and BAD)::

        P2 ---- C ---- P1          r = -s
          \\   / \\   /
           \\ /   \\ /
            A ----- B              r = 0   (A at c = -1, B at c = +1)
           / \\   / \\
          /   \\ /   \\
        P3 ---- D ---- P4          r = +s

Flipping AB gives DCA and CDB. The spans are then
NS_C = n(CBP1) + n(ACP2), NS_D = n(DAP3) + n(BDP4),
NS_A = n(ACP2) + n(DAP3), NS_B = n(CBP1) + n(BDP4).

The expected figures in each test are worked out by hand in its comments
(unit normals from cross products, angles from their components); each test
checks that the figures send the quad past every earlier test and that the
test under study rejects it, and, where the test has a threshold, that moving
the threshold across the hand figure changes the verdict.
"""

import math

import numpy as np
import pytest

from rangemesh import Orthographic
from rangemesh._core import FlipSettings, build_halfedges, disparity_verdict, flip_loop
from rangemesh.paper.flipping import Verdict

from .helpers import core_settings

A, B, C, D, P1, P2, P3, P4 = range(8)
FACES = np.array([[A, B, C], [B, A, D], [C, B, P1], [A, C, P2], [D, A, P3], [B, D, P4]], np.int64)
DEFAULTS = {"delta": 20.0, "epsilon": 0.3, "max_angle": 160.0, "min_bend": 5.0}


def _patch(s, z):
    """Vertices (r, c, z) of the patch with C, D at r = -s, +s; z lists A, B, C, D, P1..P4."""
    rc = [(0, -1), (0, 1), (-s, 0), (s, 0), (-s, 1), (-s, -1), (s, -1), (s, 1)]
    return np.array([(r, c, h) for (r, c), h in zip(rc, z, strict=True)], float)


def _verdict(vertices, **params):
    p = DEFAULTS | params
    triangles, halfedges = build_halfedges(FACES, len(vertices))
    normals = np.empty((len(FACES), 3))
    for t, (a, b, c) in enumerate(FACES):
        n = np.cross(vertices[b] - vertices[a], vertices[c] - vertices[a])
        normals[t] = n / np.linalg.norm(n)
    assert triangles[0] == A and triangles[1] == B  # half-edge 0 is A -> B
    settings = core_settings(FlipSettings, delta=math.radians(p["delta"]), epsilon=math.radians(p["epsilon"]),
                             max_angle=math.radians(p["max_angle"]), min_bend=math.radians(p["min_bend"]))
    v = disparity_verdict(triangles, halfedges, normals, vertices, 0, settings)
    return Verdict(v)


def test_the_patch_is_what_the_docstring_draws():
    v = _patch(2, [0] * 8)
    r, c = v[:, 0], v[:, 1]
    for a, b, d in FACES:  # every face counter-clockwise in (r, c)
        assert (r[b] - r[a]) * (c[d] - c[a]) - (c[b] - c[a]) * (r[d] - r[a]) > 0
    # the quad A-D-B-C is strictly convex, so the flip is possible
    for a, b, d in ((D, C, A), (C, D, B)):
        assert (r[b] - r[a]) * (c[d] - c[a]) - (c[b] - c[a]) * (r[d] - r[a]) > 0


def test_t2_rejects_a_flip_that_changes_no_disparity():
    # A flat patch: every normal is (0, 0, 1), every disparity is 0 before and after.
    assert _verdict(_patch(2, [0] * 8)) is Verdict.T2_DISPARITY_CHANGE


def test_t3_rejects_a_sliver_on_a_smooth_region():
    # s = 6, P1 and P2 lifted to z = 1, the quad flat.
    # n(CBP1) = (1, -6, 6)/sqrt(73), n(ACP2) = (1, 6, 6)/sqrt(73):
    #   NS_C = (2, 0, 12)/sqrt(73), at atan(2/12) = 9.46 deg from n(ABC) = (0, 0, 1): disp 9.46 deg;
    #   NS_D = 2 (0, 0, 1): disp 0. disp_AB = 9.46 deg.
    #   NS_A = (1, 6, 6 + sqrt(73))/sqrt(73), at atan(sqrt(37)/14.544) = 22.7 deg from n(DCA)
    #   = (0, 0, 1): over delta = 20 deg, so pi. disp_CD = pi: T2 passes.
    # DCA and CDB are flat: bend 0 < delta. The angle of DCA at A is
    # 180 - 2 atan(1/6) = 161.08 deg > max_angle = 160: T3 rejects.
    v = _patch(6, [0, 0, 0, 0, 1, 1, 0, 0])
    assert _verdict(v) is Verdict.T3_DEGENERATE
    assert _verdict(v, max_angle=161.0) is Verdict.T3_DEGENERATE
    # above 161.08 deg the sliver is allowed, and the flat new pair fails T4 (bend 0)
    assert _verdict(v, max_angle=161.2) is Verdict.T4_BEND


def test_t4_rejects_a_flip_that_does_not_change_the_shape():
    # s = 2, P1 and P2 lifted to z = 0.5, the quad flat.
    # n(CBP1) = (0.5, -1, 2)/sqrt(5.25), n(ACP2) = (0.5, 1, 2)/sqrt(5.25):
    #   NS_C = (1, 0, 4)/sqrt(5.25): atan(1/4) = 14.04 deg from (0, 0, 1); NS_D: 0. disp_AB = 14.04.
    #   NS_A = (0.5, 1, 2 + sqrt(5.25))/sqrt(5.25): atan(sqrt(1.25)/4.2913) = 14.60 deg; NS_B the
    #   same by symmetry. disp_CD = 14.60 deg; the change 0.56 deg >= epsilon = 0.3: T2 passes.
    # DCA, CDB flat: bend 0 < delta, but their largest angle (at A, between AD = (2, 1) and
    # AC = (-2, 1)) is 180 - 2 atan(1/2) = 126.87 deg < 160, so T3 passes; bend 0 <= min_bend: T4.
    v = _patch(2, [0, 0, 0, 0, 0.5, 0.5, 0, 0])
    assert _verdict(v) is Verdict.T4_BEND
    # T2 is what this quad only just passes: a coarser epsilon rejects it there instead
    assert _verdict(v, epsilon=0.5) is Verdict.T4_BEND
    assert _verdict(v, epsilon=0.6) is Verdict.T2_DISPARITY_CHANGE


def test_t5_keeps_a_crease_along_the_edge():
    # A roof z = -|r|/2 with its ridge on AB (s = 2): every C-side triangle lies in the plane
    # of normal nL = (-1/2, 0, 1)/|.|, every D-side one in nR = (1/2, 0, 1)/|.|.
    #   NS_C = 2 nL = n(ABC) direction, NS_D = 2 nR = n(BAD) direction: disp_AB = 0.
    #   n(DCA): DC = (-4, 0, 0), DA = (-2, -1, 1), DC x DA = (0, 4, 4): (0, 1, 1)/sqrt(2);
    #   NS_A = nL + nR points along (0, 0, 1): 45 deg > delta, so disp_CD = pi: T2 passes.
    #   n(CDB) = (0, -1, 1)/sqrt(2): bend 90 deg >= delta (T3 passes) and > min_bend (T4 passes).
    #   angle(NS_C, NS_D) = 2 atan(1/2) = 53.13 deg > 2 angle(NS_A, NS_B) = 0: T5 rejects.
    v = _patch(2, [0, 0, -1, -1, -1, -1, -1, -1])
    assert _verdict(v) is Verdict.T5_CREASE
    # T4's threshold is not what decides: raising min_bend up to the 90 deg bend changes nothing
    assert _verdict(v, min_bend=89.0) is Verdict.T5_CREASE
    assert _verdict(v, min_bend=91.0) is Verdict.T4_BEND


@pytest.mark.parametrize(("lifted", "expected"), [(A, Verdict.FLIPPED), (C, Verdict.FINAL_TEST)])
def test_the_final_test_flips_when_the_edge_has_the_larger_disparity(lifted, expected):
    # s = 2, P1 and P2 at z = 0.5 (the T4 patch) and one more vertex lifted by 0.2, which bends
    # the new pair: lifting A, n(DCA) = (0, 0.8, 4)/|.| is atan(0.2) = 11.31 deg off n(CDB) =
    # (0, 0, 1): bend 11.31 deg, over min_bend and under delta, no sliver.
    # The disparities, by the SPEC's formulas in plain NumPy below (not by the kernel), degrees:
    #   A lifted: disp_AB 15.15, disp_CD 14.60 -> AB has the larger disparity: flip.
    #   C lifted: disp_AB  8.33, disp_CD 14.44 -> keep AB: the final test rejects.
    z = [0, 0, 0, 0, 0.5, 0.5, 0, 0]
    z[lifted] = 0.2
    v = _patch(2, z)

    def n(a, b, c):
        u = np.cross(v[b] - v[a], v[c] - v[a])
        return u / np.linalg.norm(u)

    def ang(p, q):
        return math.degrees(math.atan2(np.linalg.norm(np.cross(p, q)), np.dot(p, q)))

    def disp(ns, nt):
        return ang(ns, nt) if ang(ns, nt) < DEFAULTS["delta"] else 180.0

    ns_a, ns_b = n(A, C, P2) + n(D, A, P3), n(C, B, P1) + n(B, D, P4)
    ns_c, ns_d = n(C, B, P1) + n(A, C, P2), n(D, A, P3) + n(B, D, P4)
    disp_ab = max(disp(ns_c, n(A, B, C)), disp(ns_d, n(B, A, D)))
    disp_cd = max(disp(ns_a, n(D, C, A)), disp(ns_b, n(C, D, B)))
    bend = ang(n(D, C, A), n(C, D, B))
    assert abs(disp_ab - disp_cd) >= DEFAULTS["epsilon"]                   # T2 passes
    assert DEFAULTS["min_bend"] < bend < DEFAULTS["delta"]                 # T3 (no sliver), T4
    assert ang(ns_c, ns_d) <= 2 * ang(ns_a, ns_b)                          # T5 passes
    assert (disp_ab > disp_cd) == (expected is Verdict.FLIPPED)
    assert _verdict(v) is expected


def _flip_log(vertices, **params):
    """The first decisions of the whole flip stage on the patch, with no pixel to measure."""
    p = DEFAULTS | params
    triangles, halfedges = build_halfedges(FACES, len(vertices))
    pixels = vertices[:, :2].astype(np.int64)
    depth, valid = np.zeros((5, 3)), np.zeros((5, 3), bool)
    settings = core_settings(FlipSettings, rule=0, threshold=-np.inf, delta=math.radians(p["delta"]),
                             epsilon=math.radians(p["epsilon"]), max_angle=math.radians(p["max_angle"]),
                             min_bend=math.radians(p["min_bend"]), quantum=2.0**-32, max_edge2=np.inf,
                             log_size=2)
    cam = Orthographic().as_array()
    log = flip_loop(triangles, halfedges, pixels, vertices, depth, valid, cam, settings).log
    return [(int(a), int(b), Verdict(v)) for a, b, v in log]


def test_t1_refuses_to_restore_an_edge_that_was_flipped_away():
    # The patch of the final test with A lifted, moved to pixels (rows 0..4, columns 0..2):
    # the final test flips AB to CD. No pixel is valid, so every edge error and every gain is
    # 0 and the queue pops by edge id: AB (id 0) first, then CD, which keeps AB's id. Flipping
    # CD would restore AB, an edge flipped away: T1 refuses it before any other test.
    v = _patch(2, [0.2, 0, 0, 0, 0.5, 0.5, 0, 0]) + [2.0, 1.0, 0.0]
    assert _flip_log(v) == [(A, B, Verdict.FLIPPED), (C, D, Verdict.T1_DEADLOCK)]
