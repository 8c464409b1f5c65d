"""AIST++ (Li et al., ICCV 2021) from its published annotation layout; registered as ``aistpp``.

Layout under ``root`` (the AIST++ annotations folder, plus the AIST music)::

    motions/<seq>.pkl        {"smpl_poses": (T, 72), "smpl_trans": (T, 3), "smpl_scaling": (1,), ...}
    keypoints3d/<seq>.pkl    {"keypoints3d": (T, 17, 3), "keypoints3d_optim": (T, 17, 3)}
                             COCO-17, centimetres, may hold NaN
    keypoints2d/<seq>.pkl    {"keypoints2d": (9, T, 17, 3) (x, y, confidence per camera view), ...}
    splits/crossmodal_{train,val,test}.txt   one sequence name per line
    ignore_list.txt          sequences to skip (whitespace and ``.json``/``.pkl`` suffixes tolerated)
    wavs/mBR0.wav ...        the music, by music id: ``wavs/`` (EDGE), ``all_musics/`` (Bailando,
                             mint) or ``music/``, found in that order (``music_dir`` names another
                             folder, relative to ``root`` or absolute)

A sequence name such as ``gBR_sBM_cAll_d04_mBR0_ch01`` reads genre ``gBR``, situation ``sBM``
(basic) or ``sFM`` (advanced), camera ``cAll``, dancer ``d04``, music id ``mBR0`` (the 5th
``_``-field) and choreography ``ch01``. Motion is at 60 fps.

The motion is COCO-17 keypoints (skeleton ``coco17``): ``keypoints3d`` by default (scaled to
metres by ``units_scale``), ``keypoints3d_optim``, or one camera view of ``keypoints2d`` (pixels,
the detector confidence in ``meta["confidence"]``); the SMPL parameters are kept in ``meta``
(``smpl_poses``, ``smpl_trans``, ``smpl_scaling``). ``motion="smpl24"`` gives the 24 SMPL joints
(skeleton ``smpl24``, metres in SMPL model scale) by forward kinematics of ``motions/<seq>.pkl``
with the user's SMPL model file ``smpl_model`` (momu does not ship SMPL;
:mod:`momu.data.smpl_model`): FK of ``smpl_poses`` + ``smpl_trans / smpl_scaling``, as AIST++'s
own feature extraction, Bailando and EDGE compute them. Pickles are read with
:mod:`momu.data.safe_pickle`, never ``pickle.load``.

The music starts with the motion (frame 0 = music time 0, as Bailando and EDGE assume); the
audio is cut to the motion's length. Music shorter than the motion by more than
``length_tolerance_seconds`` is an error; within it, the motion is cut to the music.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.common import (
    DataFileError,
    ItemRef,
    LazyClipDataset,
    LoaderConfig,
    MissingDataFileError,
    check_split,
    clean_keypoints,
    load_audio,
    read_lines,
    read_pickle_dict,
    require_root,
    skeleton_shape,
)
from momu.data.smpl_model import SMPLModel, aistpp_joints, load_smpl_model
from momu.data.types import Clip
from momu.features.skeletons import get_skeleton
from momu.registry import DATASETS

__all__ = ["AISTPPConfig", "AISTPPDataset", "GENRES", "parse_sequence_name", "normalize_sequence_name"]

MOTION_KINDS = ("keypoints3d", "keypoints3d_optim", "keypoints2d", "smpl24")

GENRES = {
    "gBR": "break",
    "gPO": "pop",
    "gLO": "lock",
    "gMH": "middle hip-hop",
    "gLH": "LA-style hip-hop",
    "gHO": "house",
    "gWA": "waack",
    "gKR": "krump",
    "gJS": "street jazz",
    "gJB": "ballet jazz",
}
"""AIST genre codes (the first field of a sequence name) and their names."""

_CAMERA = re.compile(r"^c(\d\d|All)$")

MUSIC_DIRS = ("wavs", "all_musics", "music")
"""Music folders under ``root``, in the order they are looked for: EDGE's ``wavs/``, Bailando's and
mint's ``all_musics/``, and ``music/``."""


@dataclass
class AISTPPConfig(LoaderConfig):
    """Options of the ``aistpp`` loader (fields of :class:`~momu.data.common.LoaderConfig` too).

    Attributes:
        split: ``train`` / ``val`` / ``test`` (``splits/crossmodal_<split>.txt``) or ``all``
            (every sequence with a motion file).
        motion: ``keypoints3d`` (default), ``keypoints3d_optim``, ``keypoints2d`` (COCO-17) or
            ``smpl24`` (SMPL joints by forward kinematics; needs ``smpl_model``).
        smpl_model: the user's SMPL model file for ``motion=smpl24`` (``SMPL_MALE.pkl`` — AIST++
            was fitted with the male model —, ``SMPL_NEUTRAL.pkl``, a ``basicmodel_*.pkl`` or an
            ``.npz`` conversion; absolute or relative to the working directory).
        view: camera view index (0 = ``c01``) for ``keypoints2d``.
        music_dir: folder of ``<music id>.wav``, relative to ``root`` or absolute; ``None`` (default)
            finds it among :data:`MUSIC_DIRS`.
        fps: motion frame rate (AIST++: 60).
        units_scale: factor applied to 3D keypoints (AIST++ stores centimetres; 0.01 gives metres).
        min_confidence: 2D keypoints with confidence <= this are treated as missing.
        max_gap: longest run of missing frames that is interpolated (frames).
        load_smpl: put the SMPL parameters of ``motions/<seq>.pkl`` in ``meta`` when that folder exists.
        length_tolerance_seconds: how much shorter than the motion the music may be.
        max_pickle_mb: the largest pickle (and total array data declared in one) that is read, in
            MiB (:mod:`momu.data.safe_pickle` refuses larger ones before allocating).
    """

    split: str = "train"
    motion: str = "keypoints3d"
    smpl_model: str | None = None
    view: int = 0
    music_dir: str | None = None
    fps: float = 60.0
    units_scale: float = 0.01
    min_confidence: float = 0.0
    max_gap: int | None = 60
    load_smpl: bool = True
    length_tolerance_seconds: float = 1.0
    max_pickle_mb: float = 1024.0


def normalize_sequence_name(name: str) -> str:
    """A sequence name as AIST++ lists it: whitespace and ``.json``/``.pkl``/``.wav`` suffixes dropped,
    a camera field (``c01``) replaced by ``cAll``."""
    name = name.strip()
    for suffix in (".json", ".pkl", ".wav", ".mp4"):
        if name.endswith(suffix):
            name = name[: -len(suffix)]
    fields = name.split("_")
    if len(fields) == 6 and _CAMERA.match(fields[2]):
        fields[2] = "cAll"
    return "_".join(fields)


def parse_sequence_name(name: str) -> dict[str, str]:
    """The fields of an AIST++ sequence name.

    >>> parse_sequence_name("gBR_sBM_cAll_d04_mBR0_ch01")["music_id"]
    'mBR0'

    Raises:
        ValueError: not six ``_``-separated fields.
    """
    fields = name.split("_")
    if len(fields) != 6:
        raise ValueError(
            f"{name!r} is not an AIST++ sequence name (expected 6 '_'-fields like gBR_sBM_cAll_d04_mBR0_ch01)"
        )
    genre, situation, camera, dancer, music_id, choreography = fields
    return {
        "genre": genre,
        "situation": situation,
        "camera": camera,
        "dancer": dancer,
        "music_id": music_id,
        "choreography": choreography,
    }


def _array(data: dict[str, Any], key: str, path: Path) -> np.ndarray:
    if key not in data:
        raise DataFileError(path, f"missing key {key!r} (has {sorted(map(str, data))})")
    value = np.asarray(data[key])
    if not np.issubdtype(value.dtype, np.number):
        raise DataFileError(path, f"{key!r} is not numeric (dtype {value.dtype})")
    return value


class AISTPPDataset(LazyClipDataset):
    """AIST++ sequences as :class:`~momu.data.types.Clip` (see the module docstring)."""

    name = "aistpp"

    def __init__(self, cfg: AISTPPConfig) -> None:
        root = require_root(
            cfg.root, self.name, "AIST++ annotations (keypoints3d/, splits/, ignore_list.txt)"
        )
        check_split(cfg.split, self.name)
        if cfg.motion not in MOTION_KINDS:
            raise ValueError(
                f"{self.name}: motion must be one of {', '.join(MOTION_KINDS)}; got {cfg.motion!r}"
            )
        if cfg.fps <= 0:
            raise ValueError(f"{self.name}: fps must be positive, got {cfg.fps}")
        self.smpl: SMPLModel | None = None
        if cfg.motion == "smpl24":
            if not cfg.smpl_model:
                raise ValueError(
                    f"{self.name}: motion=smpl24 needs smpl_model=PATH (dataset.smpl_model), a local SMPL "
                    "model file (SMPL_MALE.pkl, SMPL_NEUTRAL.pkl or an .npz conversion; momu ships none)"
                )
            self.smpl = load_smpl_model(cfg.smpl_model)
            if self.smpl.parents != get_skeleton("smpl24").parents:
                raise DataFileError(
                    self.smpl.path,
                    f"key 'kintree_table': {self.smpl.num_joints} joints whose tree is not SMPL's 24-joint "
                    "body (SMPL-H/SMPL-X files are not SMPL)",
                )
        self.motion_dir = root / {"keypoints2d": "keypoints2d", "smpl24": "motions"}.get(
            cfg.motion, "keypoints3d"
        )
        if not self.motion_dir.is_dir():
            raise FileNotFoundError(f"{self.name}: {self.motion_dir} does not exist")
        if cfg.max_pickle_mb <= 0:
            raise ValueError(f"{self.name}: max_pickle_mb must be > 0, got {cfg.max_pickle_mb}")
        self.max_pickle_bytes = int(cfg.max_pickle_mb * (1 << 20))
        self.smpl_dir = root / "motions"

        ignore_file = root / "ignore_list.txt"
        self.ignored = (
            {normalize_sequence_name(n) for n in read_lines(ignore_file)} if ignore_file.is_file() else set()
        )

        split_of: dict[str, str] = {}
        for split in ("train", "val", "test"):
            split_file = root / "splits" / f"crossmodal_{split}.txt"
            if split_file.is_file():
                for entry in read_lines(split_file):
                    split_of.setdefault(normalize_sequence_name(entry), split)
            elif cfg.split == split:
                raise MissingDataFileError(split_file, f"split file for split={split!r} not found")
        if cfg.split == "all":
            names = sorted({p.stem for p in self.motion_dir.glob("*.pkl")})
        else:
            names = sorted(n for n, s in split_of.items() if s == cfg.split)
        refs = []
        for seq in names:
            if seq in self.ignored:
                continue
            refs.append(ItemRef(seq, self.motion_dir / f"{seq}.pkl", {"split": split_of.get(seq, "none")}))
        # the music folder last: a missing split file or motion folder is the first thing to fix
        self.music_dir = (
            self._music_dir(root, cfg) if cfg.load_audio else root / (cfg.music_dir or MUSIC_DIRS[0])
        )
        super().__init__(cfg, root, refs)
        self.cfg: AISTPPConfig = cfg

    def _music_dir(self, root: Path, cfg: AISTPPConfig) -> Path:
        """``music_dir`` if given (it must exist), else the first of :data:`MUSIC_DIRS` under ``root``."""
        if cfg.music_dir:
            music = Path(cfg.music_dir).expanduser()
            folder = music if music.is_absolute() else root / music
            if not folder.is_dir():
                raise FileNotFoundError(
                    f"{self.name}: music_dir={cfg.music_dir}: folder {folder} not found (the folder of "
                    "<music id>.wav files; or load_audio=false for motion only)"
                )
            return folder
        for name in MUSIC_DIRS:
            if (root / name).is_dir():
                return root / name
        looked = ", ".join(f"{n}/" for n in MUSIC_DIRS)
        raise FileNotFoundError(
            f"{self.name}: no music folder under {root} (looked for {looked}); set music_dir=DIR "
            "(absolute or relative to root), or load_audio=false for motion only"
        )

    # -------------------------------------------------------------------------------- loading
    def _keypoints(self, path: Path) -> tuple[np.ndarray, dict[str, Any]]:
        cfg = self.cfg
        data = read_pickle_dict(path, self.max_pickle_bytes)
        joints, _ = skeleton_shape("coco17")
        meta: dict[str, Any] = {}
        if cfg.motion == "keypoints2d":
            raw = _array(data, "keypoints2d", path)
            if raw.ndim != 4 or raw.shape[-2:] != (joints, 3):
                raise DataFileError(
                    path, f"expected keypoints2d of shape (views, T, {joints}, 3), got {raw.shape}"
                )
            if not 0 <= cfg.view < raw.shape[0]:
                raise DataFileError(path, f"view {cfg.view} out of range: the file has {raw.shape[0]} views")
            view = raw[cfg.view].astype(np.float32)
            conf = view[..., 2]
            missing = ~np.isfinite(conf) | (conf <= cfg.min_confidence)
            motion, filled = clean_keypoints(
                view[..., :2], path, joints=joints, dims=2, max_gap=cfg.max_gap, missing=missing
            )
            meta["confidence"] = np.nan_to_num(conf, nan=0.0)
        else:
            raw = _array(data, cfg.motion, path)
            motion, filled = clean_keypoints(raw, path, joints=joints, dims=3, max_gap=cfg.max_gap)
            motion *= np.float32(cfg.units_scale)
        meta["interpolated_keypoints"] = filled
        return motion, meta

    def _smpl(self, seq: str, frames: int) -> dict[str, Any]:
        path = self.smpl_dir / f"{seq}.pkl"
        data = read_pickle_dict(path, self.max_pickle_bytes)
        poses = _array(data, "smpl_poses", path).astype(np.float32)
        trans = _array(data, "smpl_trans", path).astype(np.float32)
        scaling = _array(data, "smpl_scaling", path).astype(np.float32).reshape(-1)
        poses = poses.reshape(poses.shape[0], -1) if poses.ndim == 3 else poses
        if poses.ndim != 2 or poses.shape[1] != 72:
            raise DataFileError(
                path, f"expected smpl_poses of shape (T, 72) or (T, 24, 3), got {poses.shape}"
            )
        if trans.shape != (poses.shape[0], 3):
            raise DataFileError(
                path, f"expected smpl_trans of shape ({poses.shape[0]}, 3), got {trans.shape}"
            )
        if scaling.size != 1:
            raise DataFileError(path, f"expected one smpl_scaling value, got shape {scaling.shape}")
        if not (np.all(np.isfinite(poses)) and np.all(np.isfinite(trans)) and float(scaling[0]) > 0):
            raise DataFileError(path, "non-finite smpl_poses/smpl_trans or a non-positive smpl_scaling")
        if frames >= 0 and abs(poses.shape[0] - frames) > 1:
            raise DataFileError(
                path, f"SMPL motion has {poses.shape[0]} frames but the keypoints have {frames}"
            )
        return {"smpl_poses": poses, "smpl_trans": trans, "smpl_scaling": float(scaling[0])}

    def load(self, ref: ItemRef) -> Clip:
        cfg = self.cfg
        seq = ref.id
        try:
            fields = parse_sequence_name(seq)
        except ValueError as exc:
            raise DataFileError(ref.path, str(exc)) from None
        if self.smpl is not None:
            smpl = self._smpl(seq, -1)
            motion = aistpp_joints(
                self.smpl, smpl["smpl_poses"], smpl["smpl_trans"], smpl["smpl_scaling"]
            ).astype(np.float32)
            meta: dict[str, Any] = {**smpl, "smpl_model": str(self.smpl.path)}
        else:
            motion, meta = self._keypoints(ref.path)
        meta.update(
            split=ref.extra["split"],
            source=str(ref.path),
            music_id=fields["music_id"],
            situation=fields["situation"],
            dancer=fields["dancer"],
            choreography=fields["choreography"],
            genre_name=GENRES.get(fields["genre"], fields["genre"]),
        )
        if self.smpl is None and cfg.load_smpl and self.smpl_dir.is_dir():
            meta.update(self._smpl(seq, motion.shape[0]))
        audio = None
        sample_rate = None
        if cfg.load_audio:
            wav = self.music_dir / f"{fields['music_id']}.wav"
            motion_seconds = motion.shape[0] / cfg.fps
            audio, sample_rate = load_audio(wav, sample_rate=cfg.sample_rate, duration=motion_seconds)
            audio_seconds = len(audio) / sample_rate
            if audio_seconds < motion_seconds - cfg.length_tolerance_seconds:
                raise DataFileError(
                    wav,
                    f"music lasts {audio_seconds:.2f} s but motion {seq} lasts {motion_seconds:.2f} s: "
                    f"shorter by more than the tolerance of {cfg.length_tolerance_seconds:.2f} s",
                )
            frames = min(motion.shape[0], int(np.floor(audio_seconds * cfg.fps + 1e-6)))
            if frames < motion.shape[0]:
                motion = motion[:frames]
                for key in ("confidence", "smpl_poses", "smpl_trans"):
                    if key in meta:
                        meta[key] = meta[key][:frames]
            meta["audio_source"] = str(wav)
        return Clip(
            id=seq,
            motion=motion,
            fps=float(cfg.fps),
            audio=audio,
            sample_rate=sample_rate,
            skeleton="smpl24" if self.smpl is not None else "coco17",
            style=fields["genre"],
            meta=meta,
        )


@DATASETS.register("aistpp", config=AISTPPConfig)
def build_aistpp(cfg: AISTPPConfig, **_: Any) -> AISTPPDataset:
    """AIST++ from ``cfg.root`` (see :mod:`momu.data.aistpp`)."""
    return AISTPPDataset(cfg)
