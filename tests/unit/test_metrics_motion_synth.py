"""FID_k / Div_k on the built-in synthetic dance data (smpl24): same-style sets are closer."""

from __future__ import annotations

import pytest

from momu.registry import METRICS

synth = pytest.importorskip("momu.data.synth")


@pytest.fixture(scope="module")
def styled_clips() -> dict[str, list]:
    cfg = synth.SynthConfig(
        num_clips=48, min_seconds=6.0, max_seconds=6.0, styles=["ballet", "hiphop"], seed=1, sample_rate=8000
    )
    dataset = synth.SynthDance(cfg)
    out: dict[str, list] = {"ballet": [], "hiphop": []}
    for i in range(len(dataset)):
        clip = dataset[i]
        out[clip.style].append(clip)
    return out


def test_fid_k_separates_styles(styled_clips: dict[str, list]) -> None:
    ballet, hiphop = styled_clips["ballet"], styled_clips["hiphop"]
    assert len(ballet) == len(hiphop) == 24 and ballet[0].skeleton == "smpl24"
    fid_k = METRICS.build("fid_k")
    reference = ballet[12:]
    same = fid_k(ballet[:12], reference)["fid_k"]
    other = fid_k(hiphop[:12], reference)["fid_k"]
    assert 0 < same < other / 2


def test_div_k_of_a_mixture_exceeds_one_style(styled_clips: dict[str, list]) -> None:
    ballet, hiphop = styled_clips["ballet"], styled_clips["hiphop"]
    div_k = METRICS.build("div_k")
    one_style = div_k(ballet[:12], ballet)["div_k"]
    mixed = div_k(ballet[:6] + hiphop[:6], ballet)["div_k"]
    assert mixed > one_style
