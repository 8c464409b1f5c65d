"""``momu data check`` on generated fixtures in every layout: clean ones pass, planted bad files are named."""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.fixtures import layouts

from momu.cli import main

# Options a layout needs beyond --root (ballroom's beat annotations live in a side folder).
OPTIONS: dict[str, list[str]] = {"ballroom": ["--set", "beats_dir=beats"]}
GOOD_ITEMS = {"aistpp": 3, "dance_with_melody": 2, "loris": 3, "d2m": 9, "ballroom": 3, "humanml3d": 3}


def _check(capsys: pytest.CaptureFixture[str], name: str, root: Path, *extra: str) -> tuple[int, str]:
    code = main(["data", "check", name, "--root", str(root), *OPTIONS.get(name, []), *extra])
    return code, capsys.readouterr().out


@pytest.mark.parametrize("name", sorted(layouts.LAYOUT_BAD_KINDS))
def test_check_passes_on_a_clean_fixture(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    getattr(layouts, f"write_{name}")(tmp_path)
    code, out = _check(capsys, name, tmp_path, "--set", "sample_rate=null")
    n = GOOD_ITEMS[name]
    assert code == 0, out
    assert f"items: {n} ({n} ok, 0 bad)" in out and "result: OK" in out and "BAD" not in out
    assert "duration: total" in out and "splits:" in out


@pytest.mark.parametrize("name", sorted(layouts.LAYOUT_BAD_KINDS))
def test_check_names_every_planted_bad_file(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    planted = getattr(layouts, f"write_{name}")(tmp_path, layouts.LAYOUT_BAD_KINDS[name])
    code, out = _check(capsys, name, tmp_path, "--set", "sample_rate=null")
    assert code == 1
    bad_lines = [line for line in out.splitlines() if line.startswith("BAD ")]
    assert len(bad_lines) == len(planted), out
    for kind, path in planted.items():
        assert any(line.startswith(f"BAD {path}: ") for line in bad_lines), (
            f"{kind}: {path} not named in\n{out}"
        )
    n = GOOD_ITEMS[name]
    assert f"items: {n + len(planted)} ({n} ok, {len(planted)} bad)" in out
    assert f"result: {len(planted)} bad file(s)" in out
    assert not (tmp_path / "PWNED").exists()  # the crafted AIST++ pickle ran nothing


def test_check_summary_reports_fps_joints_splits_and_styles(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layouts.write_aistpp(tmp_path)
    code, out = _check(capsys, "aistpp", tmp_path)
    assert code == 0
    assert "fps: 60 3" in out and "skeleton: coco17 (17 joints x 3D): 3" in out
    assert (
        "audio: 16000 Hz 3" in out
        and "splits: train 2, val 1" in out
        and "styles: gBR 1, gJB 1, gPO 1" in out
    )
    code, out = _check(
        capsys, "aistpp", tmp_path, "--set", "split=val", "load_audio=false", "motion=keypoints2d"
    )
    assert code == 0 and "items: 1 (1 ok, 0 bad)" in out and "audio: none" in out
    assert "skeleton: coco17 (17 joints x 2D): 1" in out


def test_check_usage_errors_exit_2_and_unopenable_datasets_exit_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["data", "check", "no_such_dataset", "--root", str(tmp_path)]) == 2
    layouts.write_humanml3d(tmp_path)
    assert main(["data", "check", "humanml3d", "fsp=20", "--root", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "fsp" in err and "fps" in err
    code, out = _check(capsys, "humanml3d", tmp_path / "missing")
    assert code == 1 and "BAD" in out and "does not exist" in out and "cannot open the dataset" in out
