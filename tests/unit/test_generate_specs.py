"""What ``momu generate inbetween`` / ``edit`` keep and regenerate: the keyframe, time and joint specs,
writing the kept part back exactly, and MoFusion's in-betweening / editing of odd-length motions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from momu.cli.generate_io import GenerateInputError
from momu.cli.generate_motion import keep_given
from momu.cli.generate_specs import edit_region, parse_joints, parse_keyframes, parse_time


def test_keyframes_are_times_end_and_steps_at_the_model_rate() -> None:
    assert parse_keyframes("0, 1.5 ,end", 81, 20.0) == [0, 30, 80]
    assert parse_keyframes("every:1", 81, 20.0) == [0, 20, 40, 60, 80]
    assert parse_keyframes("every:1.5", 50, 20.0) == [0, 30, 49]  # and the last frame
    assert parse_keyframes("2.01,2.0,LAST", 41, 20.0) == [40]  # the same frame once
    assert parse_keyframes("0.024", 10, 20.0) == [0]  # rounds to the nearest frame
    for spec, message in [
        ("", "--keyframes is empty"),
        ("1,,2", "an empty item"),
        ("one", "'one' is not a time"),
        ("-1", "must be a time >= 0"),
        ("nan", "must be a time >= 0"),
        ("4.1", "4.1 s is past the end of the motion (its last frame is at 4.00 s)"),
        ("every:0", "a step under one frame"),
        ("every:0.05", "every frame is a keyframe"),
    ]:
        with pytest.raises(GenerateInputError, match=message.replace("(", r"\(").replace(")", r"\)")):
            parse_keyframes(spec, 81, 20.0)


def test_time_stretches_are_end_exclusive_and_open_ended() -> None:
    assert np.flatnonzero(parse_time("1:1.5", 60, 20.0)).tolist() == list(range(20, 30))
    mask = parse_time(":0.25, 2.5:", 60, 20.0)
    assert np.flatnonzero(mask).tolist() == [0, 1, 2, 3, 4, *range(50, 60)]
    assert parse_time("0:3", 60, 20.0).all()
    for spec, message in [
        ("1", "expected START:END"),
        ("1:2:3", "expected START:END"),
        ("2:1", "covers no frame"),
        ("1:1.01", "covers no frame"),
        ("0:3.1", "3.1 s is past the end of the motion"),
        ("a:2", "start 'a' is not a time"),
    ]:
        with pytest.raises(GenerateInputError, match=message):
            parse_time(spec, 60, 20.0)


def test_joints_by_name_and_with_everything_below() -> None:
    from momu.features.skeletons import get_skeleton

    names = get_skeleton("smpl24").joint_names
    picked = lambda spec: [names[i] for i in np.flatnonzero(parse_joints(spec, "smpl24"))]  # noqa: E731
    assert picked("L_Knee,head") == ["l_knee", "head"]
    assert picked("l_shoulder+") == ["l_shoulder", "l_elbow", "l_wrist", "l_hand"]
    assert picked("l_hip+") == ["l_hip", "l_knee", "l_ankle", "l_foot"]
    assert parse_joints("pelvis+", "smpl24").all()
    with pytest.raises(GenerateInputError, match="--joints: smpl24 has no joint 'l_arm' \\(joints: pelvis, "):
        parse_joints("l_arm", "smpl24")


def test_edit_region_needs_a_choice_and_something_kept() -> None:
    region = edit_region("1:2", "l_wrist", 60, 20.0, "humanml22")
    assert region.shape == (60, 22) and region.sum() == 20 and region[20:40, 20].all()
    assert edit_region(None, "head", 60, 20.0, "humanml22")[:, 15].all()
    assert edit_region("0:1", None, 60, 20.0, "humanml22")[:20].all()
    with pytest.raises(GenerateInputError, match="--time START:END and/or --joints NAMES is needed"):
        edit_region(None, None, 60, 20.0, "humanml22")
    with pytest.raises(GenerateInputError, match="nothing would be kept"):
        edit_region("0:", "pelvis+", 60, 20.0, "humanml22")


def test_keep_given_copies_kept_joints_and_carries_them_with_a_new_root() -> None:
    rng = np.random.default_rng(0)
    given, generated = rng.normal(size=(6, 4, 3)), rng.normal(size=(6, 4, 3))
    keep = np.ones((6, 4), dtype=bool)
    keep[1, 2] = False  # one joint regenerated
    keep[3, 0] = False  # the root regenerated: the other joints keep their offset from it
    keep[4] = False  # a whole frame regenerated
    out = keep_given(generated, given, keep, root=0)
    exact = keep & keep[:, :1]
    np.testing.assert_array_equal(out[exact], given[exact])
    np.testing.assert_array_equal(out[~keep], generated[~keep])
    np.testing.assert_allclose(out[3, 1:] - out[3, :1], given[3, 1:] - given[3, :1], atol=1e-12)
    np.testing.assert_array_equal(out[3, 0], generated[3, 0])


def test_inbetween_and_edit_keep_an_odd_length_motion(tmp_path: Path) -> None:
    """``MoFusionModel.inbetween`` / ``edit`` return as many frames as the motion has, at the model's
    rate (an odd count used to lose its last frame, and a keyframe on it failed)."""
    from tests.helpers.tiny_models import tiny_mofusion_model

    from momu.methods.mofusion.model import MoFusionModel

    model = MoFusionModel.load(tiny_mofusion_model(tmp_path / "t", "text"))
    for frames in (41, 42, 9):
        motion = np.random.default_rng(frames).normal(0, 0.3, (frames, 22, 3))
        (out,) = model.inbetween([motion], [[0, frames - 1]], ["a person walks"], [0])
        assert out.shape == (frames, 22, 3)
        np.testing.assert_allclose(out[[0, -1]], motion[[0, -1]], atol=1e-5)
        region = np.zeros((frames, 22), dtype=bool)
        region[2:5] = True
        (out,) = model.edit([motion], [region], ["a person waves"], [0])
        assert out.shape == (frames, 22, 3)
    # at another rate: 61 frames at 60 fps are 21 at 20 fps
    (out,) = model.inbetween([np.zeros((61, 22, 3))], [[0, 20]], ["a person"], [0], fps=60.0)
    assert out.shape == (21, 22, 3)
