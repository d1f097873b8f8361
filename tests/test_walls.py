"""Wall geometry (seed 4.1 and 4.2): ghost placement and reflection."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sphfluid._core import walls as W

H = 0.05
FLOOR = np.array([[[-1.0, 0.0], [1.0, 0.0]]])


def ghosts(segments, p, nearest_only=False):
    g = W.ghosts(np.asarray(segments, float), np.asarray(p, float), H, nearest_only)
    return sorted(map(tuple, np.round(g, 12)))


def test_ghost_at_the_foot_of_the_perpendicular():
    assert ghosts(FLOOR, [0.3, 0.02]) == [(0.3, 0.0)]


def test_no_ghost_beyond_the_support():
    assert ghosts(FLOOR, [0.3, H]) == []
    assert ghosts(FLOOR, [0.3, -0.06]) == []


def test_ghost_clamped_to_a_free_end_point():
    assert ghosts(FLOOR, [1.02, 0.01]) == [(1.0, 0.0)]
    assert ghosts(FLOOR, [1.04, 0.04]) == []  # farther than h from the end


def test_collinear_joint_gives_one_ghost_not_two():
    pieces = [[[-1.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [1.0, 0.0]]]
    for x in (-0.001, 0.0, 0.001):
        assert len(ghosts(pieces, [x, 0.02])) == 1


def test_inner_corner_gives_a_ghost_on_each_wall():
    corner = [[[0.0, 1.0], [0.0, 0.0]], [[0.0, 0.0], [1.0, 0.0]]]
    assert ghosts(corner, [0.02, 0.03]) == [(0.0, 0.03), (0.02, 0.0)]


def test_outer_corner_gives_one_ghost_at_the_vertex():
    corner = [[[0.0, 1.0], [0.0, 0.0]], [[0.0, 0.0], [1.0, 0.0]]]
    assert ghosts(corner, [-0.02, -0.02]) == [(0.0, 0.0)]


def test_outer_corner_keeps_its_vertex_ghost_among_the_nearest():
    corner = [[[0.0, 1.0], [0.0, 0.0]], [[0.0, 0.0], [1.0, 0.0]]]
    assert ghosts(corner, [-0.02, -0.02], nearest_only=True) == [(0.0, 0.0)]
    assert ghosts(FLOOR, [1.02, 0.01], nearest_only=True) == [(1.0, 0.0)]  # a free end


def test_a_joint_another_piece_comes_nearer_than_is_not_among_the_nearest():
    # a wall in pieces shorter than h (a probe's): beside the long piece, the
    # short one's far joint is within h but the long piece is nearer there
    pieces = [[[0.0, -1.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.01]], [[0.0, 0.01], [0.0, 1.0]]]
    p = [0.02, 0.03]
    assert ghosts(pieces, p) == [(0.0, 0.0), (0.0, 0.03)]
    assert ghosts(pieces, p, nearest_only=True) == [(0.0, 0.03)]


def test_a_convex_vertex_is_nearest_whichever_way_its_segments_run():
    # the vertex is the second segment's end b here (the first's end a)
    corner = [[[0.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [0.0, 0.0]]]
    assert ghosts(corner, [-0.02, -0.02], nearest_only=True) == [(0.0, 0.0)]
    square = [[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.0, 1.0]], [[1.0, 1.0], [0.0, 1.0]],
              [[0.0, 1.0], [0.0, 0.0]]]  # a closed polyline's first and last joint
    assert ghosts(square, [-0.02, -0.01], nearest_only=True) == [(0.0, 0.0)]
    nudged = [[[0.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [1e-12, 1e-12]]]  # within the tolerance
    assert len(ghosts(nudged, [-0.02, -0.02], nearest_only=True)) == 1


def test_where_three_segments_meet_no_end_point_ghost_is_nearest():
    # a fin on a convex corner: whatever the order, the vertex gives wcsph no ghost
    star = [[[0.0, 0.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 1.0]], [[0.0, 0.0], [-1.0, -1.0]]]
    for order in ([0, 1, 2], [2, 1, 0], [1, 2, 0]):
        walls = [star[k] for k in order]
        assert ghosts(walls, [-0.03, -0.01], nearest_only=True) == [(-0.02, -0.02)]
    assert len(ghosts(star, [-0.03, -0.01])) == 2  # the seed keeps its end-point ghost


def collide(segments, x_old, x_new, v, e=1.0):
    x, vv = W.collide(np.asarray(segments, float), np.asarray(x_old, float),
                      np.asarray(x_new, float), np.asarray(v, float), e, H)
    return np.array(x), np.array(vv)


def test_reflection_off_a_floor():
    x, v = collide(FLOOR, [0.0, 0.01], [0.02, -0.03], [1.0, -2.0])
    assert x == pytest.approx([0.02, 0.03], abs=1e-6)
    assert v == pytest.approx([1.0, 2.0])


def test_restitution_scales_the_normal_velocity():
    x, v = collide(FLOOR, [0.0, 0.01], [0.0, -0.03], [0.0, -4.0], e=0.5)
    assert v == pytest.approx([0.0, 2.0])
    assert x[1] == pytest.approx(0.015, abs=1e-6)


def test_no_collision_without_crossing():
    x, v = collide(FLOOR, [0.0, 0.01], [0.5, 0.002], [1.0, -0.2])
    assert x == pytest.approx([0.5, 0.002]) and v == pytest.approx([1.0, -0.2])
    x, v = collide(FLOOR, [0.0, 0.01], [0.5, 0.01], [1.0, 0.0])  # parallel to the wall
    assert x == pytest.approx([0.5, 0.01])


def test_several_bounces_in_one_step_in_a_channel():
    channel = [[[-1.0, 0.0], [1.0, 0.0]], [[-1.0, 0.1], [1.0, 0.1]]]
    # Up 0.3 in one step: off the roof (after 0.05), off the floor (after 0.1 more);
    # the roof comes again, and a wall bounces a particle once per step, so it
    # stops just under the roof with no normal velocity.
    x, v = collide(channel, [0.0, 0.05], [0.3, 0.35], [3.0, 3.0])
    assert 0.0 < x[1] < 0.1
    assert x[1] == pytest.approx(0.1, abs=1e-6)
    assert v == pytest.approx([3.0, 0.0])


def test_bounces_off_two_walls_of_a_wedge():
    wedge = [[[-1.0, 1.0], [0.0, 0.0]], [[0.0, 0.0], [1.0, 1.0]]]
    x, v = collide(wedge, [-0.1, 0.5], [-0.1, -0.5], [0.0, -10.0])
    # Inside the wedge means y >= |x|.
    assert x[1] >= abs(x[0]) - 1e-9
    assert np.linalg.norm(v) == pytest.approx(10.0)


def crosses(segments, p0, p1):
    for (a, b) in np.asarray(segments, float):
        d, e, w = p1 - p0, b - a, a - p0
        den = d[0] * e[1] - d[1] * e[0]
        if den == 0:
            continue
        s = (w[0] * e[1] - w[1] * e[0]) / den
        u = (w[0] * d[1] - w[1] * d[0]) / den
        if 0 < s < 1 and 0 < u < 1:
            return True
    return False


def cross2(u, w):
    return u[0] * w[1] - u[1] * w[0]


BOX = [[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.0, 1.0]], [[1.0, 1.0], [0.0, 1.0]],
       [[0.0, 1.0], [0.0, 0.0]]]
# A box with a thin V inside it: paths may hit the box and the V in one step.
V_IN_BOX = BOX + [[[0.3, 0.8], [0.5, 0.2]], [[0.5, 0.2], [0.7, 0.8]]]

coord = st.floats(0.001, 0.999)
move = st.floats(-3.0, 3.0)


@settings(max_examples=300, deadline=None)
@given(coord, coord, move, move, st.floats(0.0, 1.0))
def test_a_path_never_leaves_a_closed_box(x0, y0, dx, dy, e):
    start = np.array([x0, y0])
    end, v = collide(V_IN_BOX, start, start + [dx, dy], [dx, dy], e)
    assert 0.0 <= end[0] <= 1.0 and 0.0 <= end[1] <= 1.0
    # Reflection never adds speed (up to round-off, which is coarse for subnormal speeds).
    assert np.linalg.norm(v) <= np.hypot(dx, dy) * (1 + 1e-12) + 1e-150


@settings(max_examples=300, deadline=None)
@given(st.floats(-1.0, 1.0), st.floats(1e-6, 1.0), move, move, st.floats(0.0, 1.0))
def test_a_path_stays_on_its_side_of_a_wall(x0, y0, dx, dy, e):
    end, _ = collide([[[-10.0, 0.0], [10.0, 0.0]]], [x0, y0], [x0 + dx, y0 + dy], [dx, dy], e)
    assert end[1] > 0.0


def test_zero_length_wall_is_rejected():
    with pytest.raises(ValueError, match=r"walls\[0\]: wall segment has zero length"):
        W.ghosts(np.array([[[0.0, 0.0], [0.0, 0.0]]]), np.array([0.0, 0.0]), H)


def test_the_wall_crossings_stopped_are_counted():
    """Two lone particles thrown at the floor: one bounce each, counted; a third
    between them, moving along the floor, crosses nothing. A step the guard
    refuses adds nothing."""
    import copy

    from conftest import BASE_SCENE
    from sphfluid import InstabilityError, Simulation

    sim = Simulation(copy.deepcopy(BASE_SCENE), threads=1)
    pos = np.array([[0.2, 0.01], [0.8, 0.01], [0.5, 0.3]])
    vel = np.array([[0.0, -20.0], [0.0, -20.0], [1.0, 0.0]])
    sim.set_state(pos, vel)
    assert sim.wall_crossings == 0
    sim.step()
    assert sim.wall_crossings == 2 and (sim.positions[:, 1] > 0).all()
    assert sim.stats()["wall_crossings"] == 2
    sim.set_state(pos, np.array([[0.0, -1e9], [0.0, -20.0], [1.0, 0.0]]))  # trips the guard
    with pytest.raises(InstabilityError):
        sim.step()
    assert sim.wall_crossings == 2
