"""Hypothesis properties of the motion representations (``momu.features.root_motion``; issue 32).

``root_velocity`` holds every joint's x/z relative to the root and the root's horizontal velocity
(m/s, forward differences, the last repeated); integrating it from the first root position gives
the positions back, and it cannot see where on the floor the dancer is. ``positions`` is the
identity. MoMu's :class:`~momu.methods.momu.conditions.Conditions` starts the path at the origin.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from momu.features.root_motion import check_representation, from_root_velocity, to_root_velocity
from momu.methods.momu.conditions import Conditions

coordinates = st.floats(min_value=-10.0, max_value=10.0, allow_nan=False, allow_infinity=False, width=64)
motions = st.tuples(st.integers(1, 12), st.integers(1, 5)).flatmap(
    lambda shape: arrays(np.float64, (shape[0], shape[1], 3), elements=coordinates)
)
fps_values = st.sampled_from([20.0, 25.0, 30.0, 60.0])


def conditions(representation: str, root: int) -> Conditions:
    return Conditions(None, None, True, representation, root)


@given(motion=motions, fps=fps_values, data=st.data())
def test_root_velocity_round_trips_from_the_first_root_position(
    motion: np.ndarray, fps: float, data: st.DataObject
) -> None:
    root = data.draw(st.integers(0, motion.shape[1] - 1))
    rep = to_root_velocity(motion, fps, root)
    assert rep.shape == motion.shape and rep.dtype == motion.dtype
    start = (float(motion[0, root, 0]), float(motion[0, root, 2]))
    np.testing.assert_allclose(from_root_velocity(rep, fps, root, start), motion, rtol=1e-9, atol=1e-9)


@given(motion=motions, fps=fps_values, shift=st.tuples(coordinates, coordinates), data=st.data())
def test_root_velocity_is_translation_invariant_and_keeps_heights(
    motion: np.ndarray, fps: float, shift: tuple[float, float], data: st.DataObject
) -> None:
    root = data.draw(st.integers(0, motion.shape[1] - 1))
    rep = to_root_velocity(motion, fps, root)
    moved = motion + np.array([shift[0], 0.0, shift[1]])
    np.testing.assert_allclose(to_root_velocity(moved, fps, root), rep, atol=1e-9)
    np.testing.assert_array_equal(rep[..., 1], motion[..., 1])  # heights (Y up) untouched
    if motion.shape[0] > 1:  # the root's x/z hold its velocity: forward differences, the last repeated
        vel = np.diff(motion[:, root, [0, 2]], axis=0) * fps
        np.testing.assert_allclose(rep[:-1, root, [0, 2]], vel, atol=1e-9)
        np.testing.assert_allclose(rep[-1, root, [0, 2]], vel[-1], atol=1e-9)


@given(motion=motions, fps=fps_values, data=st.data())
def test_conditions_motion_out_starts_the_path_at_the_origin(
    motion: np.ndarray, fps: float, data: st.DataObject
) -> None:
    root = data.draw(st.integers(0, motion.shape[1] - 1))
    motion32 = motion.astype(np.float32)
    cond = conditions("root_velocity", root)
    back = cond.motion_out(cond.motion_in(motion32, fps), fps)
    assert back.dtype == np.float32
    expected = motion32.astype(np.float64) - np.array([motion[0, root, 0], 0.0, motion[0, root, 2]])
    np.testing.assert_allclose(back, expected, rtol=1e-4, atol=1e-3)


@given(motion=motions, fps=fps_values)
def test_positions_representation_is_the_identity(motion: np.ndarray, fps: float) -> None:
    cond = conditions("positions", 0)
    assert cond.motion_in(motion, fps) is motion
    assert cond.motion_out(motion, fps) is motion


def test_representation_names_and_dimensions_are_checked() -> None:
    check_representation("positions", 2)
    check_representation("root_velocity", 3)
    with pytest.raises(
        ValueError, match="unknown motion representation 'world'; valid: positions, root_velocity"
    ):
        check_representation("world")
    with pytest.raises(ValueError, match="'root_velocity' needs 3D keypoints"):
        check_representation("root_velocity", 2)
    with pytest.raises(ValueError, match=r"expected \(T, J, 3\) positions"):
        to_root_velocity(np.zeros((4, 3, 2)), 30.0, 0)
