"""T2M's pre-trained text–motion evaluator: strict loading of its checkpoint layout, GloVe/POS inputs,
embeddings and the Table 2 metrics through it (random weights; momu ships none)."""

from __future__ import annotations

import logging
import pickle
from pathlib import Path

import numpy as np
import pytest
import torch
from omegaconf import OmegaConf
from scipy.spatial.transform import Rotation
from tests.fixtures.layouts import write_humanml3d
from tests.fixtures.t2m_files import SMALL, WORDS, t2m_state, write_t2m

from momu.data.files import DataFileError
from momu.data.humanml3d import HumanML3DConfig, HumanML3DDataset
from momu.data.types import Clip
from momu.engine.accelerate_setup import RunConfig, make_accelerator
from momu.engine.context import RunContext
from momu.engine.table import parse_table_args, resolve_row_configs, run_table
from momu.features.mofusion_pose import encode_pose
from momu.features.skeletons import forward_kinematics, get_skeleton
from momu.methods.mofusion.config import MoFusionConfig, MoFusionEvalConfig, check_config
from momu.methods.mofusion.evaluate_text import calibrate_text, t2m_evaluator
from momu.methods.mofusion.tables_text import table2_spec
from momu.metrics.t2m_evaluator import CHECKPOINT_MODULES, T2MDims, T2MEvaluator
from momu.metrics.t2m_words import POS_ENUMERATOR, WordVectorizer, caption_arrays
from momu.metrics.text_motion import caption_tokens, mm_distances, r_precision_hits
from momu.registry import METRICS

_T2M_KEYS = ("evaluator_checkpoint", "glove_dir", "evaluator_meta_dir")
CAPTIONS = [
    ["a/DET", "person/NOUN", "walk/VERB", "forward/ADV"],
    ["a/DET", "man/NOUN", "jump/VERB"],
    ["the/DET", "person/NOUN", "turn/VERB", "left/ADV"],
    ["a/DET", "person/NOUN", "jump/VERB", "and/CCONJ", "turn/VERB"],
]


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, str, str]:
    return write_t2m(tmp_path_factory.mktemp("t2m")).args


@pytest.fixture(scope="module")
def full(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, str, str]:
    """T2M's real widths (random weights, fresh optimiser states: ~80 MB)."""
    return write_t2m(tmp_path_factory.mktemp("t2m_full"), state=t2m_state(dims=T2MDims(), step=False)).args


def _joints(seed: int, frames: int = 45) -> np.ndarray:
    """A humanml22 motion: global joints ``(T, 22, 3)`` at 20 fps."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2, frames)[:, None, None]
    rotvec = 0.4 * np.sin(2.0 * t + rng.uniform(0, 6, size=(1, 22, 3)))
    mats = Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_matrix().reshape(frames, 22, 3, 3)
    root = np.concatenate([rng.normal() * t[:, 0], 0.9 + 0 * t[:, 0], 0.3 * t[:, 0]], axis=1)
    return forward_kinematics(get_skeleton("humanml22"), mats, root)


def _motion(seed: int, frames: int = 45) -> np.ndarray:
    """The same motion as MoFusion pose vectors ``(T, 66)``."""
    return encode_pose(_joints(seed, frames))


def test_checkpoint_in_t2m_layout_reloads_strictly(small: tuple[str, str, str]) -> None:
    ev = T2MEvaluator.load(*small, dims=SMALL)
    saved = torch.load(small[0], weights_only=True)
    assert set(saved) == {*CHECKPOINT_MODULES, "opt_text_encoder", "opt_motion_encoder", "epoch", "iter"}
    for key in CHECKPOINT_MODULES:
        got = getattr(ev, key).state_dict()
        assert got.keys() == saved[key].keys()
        assert all(torch.equal(got[k], saved[key][k]) for k in got)
    assert "epoch 11" in ev.describe() and ev.kind == "t2m"


def test_t2m_widths_are_the_reference_parameter_shapes(full: tuple[str, str, str]) -> None:
    """At T2M's own widths the parameter names and shapes are text2motion's (the real finest.tar's)."""
    ev = T2MEvaluator(WordVectorizer(np.zeros((1, 300), np.float32), {"unk": 0}), np.zeros(263), np.ones(263))
    shapes = {
        f"{m}.{k}": tuple(v.shape) for m in CHECKPOINT_MODULES for k, v in getattr(ev, m).state_dict().items()
    }
    assert shapes["movement_encoder.main.0.weight"] == (512, 259, 4)
    assert shapes["movement_encoder.main.3.weight"] == (512, 512, 4)
    assert shapes["movement_encoder.out_net.weight"] == (512, 512)
    assert shapes["motion_encoder.gru.weight_hh_l0_reverse"] == (3072, 1024)
    assert shapes["motion_encoder.hidden"] == (2, 1, 1024)
    assert shapes["motion_encoder.output_net.3.weight"] == (512, 1024)
    assert shapes["text_encoder.pos_emb.weight"] == (300, len(POS_ENUMERATOR))
    assert shapes["text_encoder.gru.weight_ih_l0"] == (1536, 512)
    assert shapes["text_encoder.output_net.1.weight"] == (512,)  # LayerNorm
    assert len(shapes) == 6 + 17 + 19  # T2M: movement 6, motion 17, text 19 tensors
    assert T2MEvaluator.load(*full).embed_motions([_motion(0)]).shape == (1, 512)
    # the registered metrics' own route to it: three paths in their config
    paths = dict(zip(("t2m_checkpoint", "glove_dir", "t2m_meta_dir"), full, strict=True))
    assert METRICS.build("mm_dist", paths).evaluator.kind == "t2m"


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (
            lambda s: s["text_encoder"].pop("gru.weight_ih_l0"),
            r"key 'text_encoder': missing \['gru.weight_ih_l0'\]",
        ),
        (
            lambda s: s["motion_encoder"].update(extra=torch.zeros(1)),
            r"key 'motion_encoder'.*unexpected \['extra'\]",
        ),
        (lambda s: s.pop("movement_encoder"), "missing key 'movement_encoder'"),
        (
            lambda s: s["movement_encoder"].update({"out_net.bias": torch.zeros(3)}),
            "wrong shapes: out_net.bias",
        ),
    ],
)
def test_checkpoint_key_errors_name_the_file(tmp_path: Path, edit, match: str) -> None:
    state = t2m_state(step=False)
    edit(state)
    paths = write_t2m(tmp_path, state=state)
    with pytest.raises(DataFileError, match=match) as info:
        T2MEvaluator.load(*paths.args, dims=SMALL)
    assert str(info.value).startswith(str(paths.checkpoint)) and "\n" not in str(info.value)


class _Payload:
    def __reduce__(self) -> tuple[object, tuple[str]]:
        return (print, ("code ran",))


def test_arbitrary_pickles_and_bad_side_files_are_refused(tmp_path: Path) -> None:
    paths = write_t2m(tmp_path, state={**t2m_state(step=False), "payload": _Payload()})
    with pytest.raises(
        DataFileError, match=r"finest\.tar: not a checkpoint torch\.load\(weights_only=True\)"
    ):
        T2MEvaluator.load(*paths.args, dims=SMALL)
    paths = write_t2m(tmp_path / "b")
    with open(paths.glove / "our_vab_words.pkl", "wb") as f:
        pickle.dump([w for w in WORDS if w != "unk"], f)
    with pytest.raises(DataFileError, match=r"our_vab_words\.pkl: no 'unk' word"):
        T2MEvaluator.load(*paths.args, dims=SMALL)
    with open(paths.glove / "our_vab_words.pkl", "wb") as f:
        f.write(pickle.dumps(_Payload()))
    with pytest.raises(DataFileError, match="refusing to load global 'builtins.print'"):
        T2MEvaluator.load(*paths.args, dims=SMALL)
    paths = write_t2m(tmp_path / "c")
    np.save(paths.meta / "std.npy", np.ones(251))
    with pytest.raises(DataFileError, match=r"std\.npy: expected 263"):
        T2MEvaluator.load(*paths.args, dims=SMALL)
    (paths.meta / "mean.npy").unlink()
    with pytest.raises(FileNotFoundError, match=r"mean\.npy"):
        T2MEvaluator.load(*paths.args, dims=SMALL)


def test_words_take_glove_vectors_and_t2m_pos_tags(small: tuple[str, str, str]) -> None:
    words = WordVectorizer.load(small[1])
    vectors = np.load(Path(small[1]) / "our_vab_data.npy")

    def tag(token: str) -> str:
        return next(k for k, v in POS_ENUMERATOR.items() if v == int(np.argmax(words(token)[1])))

    assert tag("person/NOUN") == "NOUN" and tag("walk/VERB") == "Act_VIP" and tag("left/ADV") == "Loc_VIP"
    assert tag("zebra/NOUN") == "OTHER" and tag("and/CCONJ") == "OTHER"
    np.testing.assert_array_equal(words("person/NOUN")[0], vectors[WORDS.index("person")])
    np.testing.assert_array_equal(words("zebra/NOUN")[0], vectors[WORDS.index("unk")])
    w, p = caption_arrays(words, CAPTIONS[0])
    assert w.shape == (6, 300) and p.shape == (6, 15)  # sos + 4 words + eos
    np.testing.assert_array_equal(w[0], vectors[WORDS.index("sos")])
    assert caption_arrays(words, ["a/DET"] * 30)[0].shape == (22, 300)  # at most 20 words


def test_embeddings_are_deterministic_ordered_and_batch_independent(small: tuple[str, str, str]) -> None:
    ev = T2MEvaluator.load(*small, dims=SMALL)
    texts = [" ".join(c) for c in CAPTIONS]
    t = ev.embed_texts(texts, CAPTIONS)
    assert t.shape == (4, SMALL.embedding)
    np.testing.assert_array_equal(ev.embed_texts(texts, CAPTIONS), t)
    np.testing.assert_allclose(ev.embed_texts(texts[::-1], CAPTIONS[::-1]), t[::-1], atol=1e-6)
    np.testing.assert_allclose(ev.embed_texts(texts[1:2], CAPTIONS[1:2]), t[1:2], atol=1e-6)
    poses = [_motion(i, frames) for i, frames in enumerate((45, 33, 61, 80))]
    m = ev.embed_motions(poses)
    np.testing.assert_array_equal(ev.embed_motions(poses), m)
    np.testing.assert_allclose(ev.embed_motions(poses[::-1], batch=3), m[::-1], atol=1e-6)
    np.testing.assert_allclose(ev.embed_motions(poses[2:3]), m[2:3], atol=1e-6)
    assert np.linalg.matrix_rank(m) > 1
    with pytest.raises(ValueError, match="word/POS tokens"):
        ev.embed_texts(texts)
    with pytest.raises(ValueError, match=r"\(T, 66\)"):
        ev.embed_motions([np.zeros((40, 72))])
    with pytest.raises(ValueError, match="shorter than 4"):
        ev.embed_motions([poses[0][:4]])


def test_r_precision_and_mm_dist_through_the_registered_metrics(small: tuple[str, str, str]) -> None:
    ev = T2MEvaluator.load(*small, dims=SMALL)
    clips = [
        Clip(
            id=f"c{i}",
            motion=_joints(i),
            fps=20.0,
            skeleton="humanml22",
            text=[" ".join(c)],
            meta={"text_tokens": c},
        )
        for i, c in enumerate(CAPTIONS * 2)
    ]
    r = METRICS.build("r_precision", {"batch": 4, "top_k": 2}, evaluator=ev)(clips)["r_precision"]
    d = METRICS.build("mm_dist", {}, evaluator=ev)(clips)["mm_dist"]
    text = ev.embed_texts([c.text[0] for c in clips], [c.meta["text_tokens"] for c in clips])
    motion = ev.embed_motions([encode_pose(c.motion) for c in clips])
    assert r == pytest.approx(r_precision_hits(text, motion, batch=4, top_k=2).mean())
    assert d == pytest.approx(mm_distances(text, motion).mean()) and d > 0
    assert METRICS.build("r_precision", {"batch": 4, "top_k": 2}, evaluator=ev)(clips)["r_precision"] == r
    with pytest.raises(ValueError, match="also needs glove_dir, t2m_meta_dir"):
        METRICS.build("mm_dist", {"t2m_checkpoint": small[0]})


def test_humanml3d_clips_carry_their_tokens(tmp_path: Path) -> None:
    write_humanml3d(tmp_path / "hml")
    clip = HumanML3DDataset(HumanML3DConfig(root=str(tmp_path / "hml"), split="train"))[0]
    assert caption_tokens(clip) == ["a/DET", "person/NOUN", "walk/VERB", "forward/ADV"]
    assert caption_tokens(Clip(id="x", motion=np.zeros((2, 22, 3)), fps=20.0, text=["a caption"])) is None


def test_mofusion_paper_preset_selects_t2m_or_warns_and_fails_early_on_bad_files(
    small: tuple[str, str, str],
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
    capsys: pytest.CaptureFixture[str],
) -> None:
    base = {"method": {"fps": 20.0, "evaluation": {"evaluator_kind": "t2m", "evaluator_checkpoint": None}}}
    with caplog.at_level(logging.WARNING):
        assert t2m_evaluator(OmegaConf.create(base)) is None
    assert "method.evaluation.evaluator_checkpoint, method.evaluation.glove_dir" in caplog.text
    assert t2m_evaluator(OmegaConf.create({"method": {"fps": 20.0, "evaluation": {}}})) is None  # momu's
    with pytest.raises(ValueError, match="evaluator_kind must be one of"):
        check_config(MoFusionConfig(evaluation=MoFusionEvalConfig(evaluator_kind="clip")))
    at_30 = {
        "method": {"fps": 30.0, "evaluation": dict(zip(_T2M_KEYS, small, strict=True), evaluator_kind="t2m")}
    }
    with pytest.raises(ValueError, match="reads 20 fps motion"):
        t2m_evaluator(OmegaConf.create(at_30))
    write_humanml3d(tmp_path / "hml")
    bad = tmp_path / "finest.tar"
    bad.write_bytes(b"not a checkpoint")
    argv = [
        "--preset",
        "paper",
        "--data",
        str(tmp_path / "hml"),
        "--out",
        str(tmp_path / "out"),
        "--tracker",
        "none",
    ]
    paths = [f"method.evaluation.evaluator_checkpoint={bad}", f"method.evaluation.glove_dir={small[1]}"]
    assert run_table(table2_spec(), [*argv, *paths, f"method.evaluation.evaluator_meta_dir={small[2]}"]) == 2
    err = capsys.readouterr().err
    assert f"{bad}: not a checkpoint" in err
    assert not (tmp_path / "out" / "mofusion_table2").exists()


def test_table2_calibration_runs_through_t2m_on_humanml3d(full: tuple[str, str, str], tmp_path: Path) -> None:
    """HumanML3D clips keep their tokens through the evaluation crop; each seed records the evaluator."""
    root = tmp_path / "hml"
    (root / "new_joints").mkdir(parents=True)
    (root / "texts").mkdir()
    ids = [f"{i:06d}" for i in range(12)]
    for i, item in enumerate(ids):
        np.save(root / "new_joints" / f"{item}.npy", _joints(i, 50).astype(np.float32))
        tokens = CAPTIONS[i % 4]
        caption = " ".join(t.split("/")[0] for t in tokens)
        (root / "texts" / f"{item}.txt").write_text(f"{caption}#{' '.join(tokens)}#0.0#0.0\n")
    (root / "test.txt").write_text("\n".join(ids[:8]) + "\n")
    (root / "train.txt").write_text("\n".join(ids[8:]) + "\n")
    spec = table2_spec()
    overrides = ["dataset.split=all", "lengths.short=2.0", "method.evaluation.num_clips=8"]
    overrides += ["method.evaluation.r_precision_batch=4"]
    overrides += [f"method.evaluation.{k}={v}" for k, v in zip(_T2M_KEYS, full, strict=True)]
    argv = ["--preset", "paper", "--data", str(root), "--out", str(tmp_path / "out"), *overrides]
    cfg = next(iter(resolve_row_configs(spec, parse_table_args(spec, argv)).values()))
    ctx = RunContext(
        accelerator=make_accelerator(RunConfig(tracker="none"), tmp_path / "out", "t", {}), out_dir=tmp_path
    )
    rows = calibrate_text(ctx, cfg, 0)
    real = rows["real text–motion pairs"]
    assert real.artifacts["text_evaluator"].startswith(f"T2M evaluator {full[0]}")
    assert real.clips["r_precision"]["row"].shape == (8, 1) and 0 <= real.metrics["r_precision"] <= 1
    assert (
        real.metrics["mm_dist"] > 0
        and real.metrics == calibrate_text(ctx, cfg, 0)["real text–motion pairs"].metrics
    )
