"""Procedural dance motion: key poses on beats, eased in between, posed by rigid forward kinematics.

Pipeline for one clip (all vectorised over frames):

1. :func:`choose_keys`: draw moves from the style's vocabulary until every beat has a key pose
   (random amplitude per move, random left/right mirroring), plus the root's yaw and floor
   position accumulated from each key's ``turn`` / ``step`` increments.
2. :func:`beat_phase` + :func:`ease_keys`: every control moves from one key to the next over one
   (jittered) beat, starting sharply on the beat and decelerating into the next key, so velocity is
   zero and direction changes exactly at the motion beats (MoMu §3.2 kinematic beats; HarmoGAN
   Eq. 3 velocity extrema). Through a musical break the dancer hits a pose on the break's first
   downbeat and flows slowly, in one eased move, to the pose of the next section: no kinematic beat
   where the music has no attack.
3. :func:`segment_rotations`: controls -> one global rotation per body segment.
4. :func:`pose`: per-bone rotations -> :func:`momu.features.skeletons.forward_kinematics` (bone
   lengths exactly constant), root lifted so the lowest foot joint touches the floor (y = 0).
5. :func:`project`: pinhole projection to image pixels for 2D skeletons.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from momu.data.synth.styles import CONTROLS, INCREMENTS, NEUTRAL, Style
from momu.features.skeletons import Skeleton, forward_kinematics

__all__ = [
    "Camera",
    "CameraConfig",
    "choose_keys",
    "beat_phase",
    "ease_keys",
    "segment_rotations",
    "pose",
    "project",
    "smooth_noise",
]

_CTRL = {c: i for i, c in enumerate(CONTROLS)}
_LIMB_SEGMENTS = frozenset(
    f"{s}_{p}" for s in ("l", "r") for p in ("upper_arm", "forearm", "hand", "thigh", "shin")
)
_FOOT_SEGMENTS = frozenset({"l_shin", "r_shin", "l_foot", "r_foot"})


@dataclass
class CameraConfig:
    """Pinhole camera of 2D skeletons (``openpose14``), facing the dancer's rest orientation (looking
    along -Z from +Z); the ``camera`` node of :class:`~momu.data.synth.dataset.SynthConfig`.

    The dancer stands at the origin; a 1.7 m dancer at the default 5 m is about 370 px tall.

    Attributes:
        width, height: image size in pixels (OpenPose convention: origin top-left, v down).
        focal_px: focal length in pixels.
        distance: camera position on the +Z axis, metres from the floor origin.
        height_m: camera height above the floor, metres (the principal point's height).
    """

    width: int = 1280
    height: int = 720
    focal_px: float = 1100.0
    distance: float = 5.0
    height_m: float = 1.0


Camera = CameraConfig
"""The camera :func:`project` takes (the same class as :class:`CameraConfig`)."""


def _mirror_key(key: Mapping[str, float]) -> dict[str, float]:
    out: dict[str, float] = {}
    for name, value in key.items():
        if name.startswith("l_"):
            out["r_" + name[2:]] = value
        elif name.startswith("r_"):
            out["l_" + name[2:]] = value
        elif name in ("lean_side", "twist", "turn", "step_x"):
            out[name] = -value
        else:
            out[name] = value
    return out


def choose_keys(
    style: Style,
    num_keys: int,
    rng: np.random.Generator,
    *,
    amplitude_range: Sequence[float] = (0.75, 1.25),
    radius: float = 1.0,
    moves_out: list[dict[str, Any]] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Key poses for ``num_keys`` consecutive beats.

    With ``moves_out`` given, one record per drawn move is appended to it: ``name``, ``mirrored``
    (left/right swapped), ``first_key`` and ``num_keys`` (the key indices it covers, cut at
    ``num_keys``) and ``turn`` (its summed yaw increments in radians, after mirroring; positive =
    towards the dancer's left). The draws are the same with or without it.

    Returns:
        ``poses``: ``(num_keys, len(CONTROLS))`` control values in radians;
        ``root``: ``(num_keys, 3)`` columns yaw (radians), x, z (metres) of the root on the floor.
        Steps that would leave the disc of ``radius`` metres are reflected back (``radius <= 0``
        keeps the dancer in place).
    """
    lo, hi = float(amplitude_range[0]), float(amplitude_range[1])
    weights = np.array([m.weight for m in style.moves], dtype=np.float64)
    weights /= weights.sum()
    neutral = np.array([NEUTRAL.get(c, 0.0) for c in CONTROLS])
    poses = np.empty((num_keys, len(CONTROLS)))
    incs = np.zeros((num_keys, len(INCREMENTS)))
    k = 0
    while k < num_keys:
        move = style.moves[int(rng.choice(len(style.moves), p=weights))]
        amp = rng.uniform(lo, hi)
        mirrored = rng.random() < 0.5
        first, turn = k, 0.0
        for key in move.keys:
            if k >= num_keys:
                break
            key = _mirror_key(key) if mirrored else key
            target = neutral.copy()
            for name, value in key.items():
                if name in _CTRL:
                    target[_CTRL[name]] = value
            poses[k] = neutral + amp * (target - neutral)
            incs[k] = [key.get(n, 0.0) for n in INCREMENTS]
            incs[k, 1:] *= amp
            turn += incs[k, 0]
            k += 1
        if moves_out is not None:
            moves_out.append(
                {
                    "name": move.name,
                    "mirrored": bool(mirrored),
                    "first_key": first,
                    "num_keys": k - first,
                    "turn": float(turn),
                }
            )
    root = np.zeros((num_keys, 3))
    yaw, pos = 0.0, np.zeros(2)
    for i in range(num_keys):
        dx, dz = incs[i, 1], incs[i, 2]
        c, s = np.cos(yaw), np.sin(yaw)
        step = np.array([c * dx + s * dz, -s * dx + c * dz])  # R_y(yaw) applied to (dx, 0, dz)
        if radius <= 0:
            step[:] = 0.0
        elif np.hypot(*(pos + step)) > radius:
            step = -step
        pos = pos + step
        yaw += incs[i, 0]
        root[i] = (yaw, pos[0], pos[1])
    return poses, root


def beat_phase(times: np.ndarray, beat_times: np.ndarray) -> np.ndarray:
    """Continuous beat index at ``times``: ``k`` exactly at ``beat_times[k]``, linear in between.

    ``beat_times`` must be increasing (at least two); beyond its ends the phase is extrapolated
    with the first / last interval. Returns ``(T,)`` float64 phases in beats.
    """
    b = np.asarray(beat_times, dtype=np.float64)
    if b.ndim != 1 or b.size < 2 or np.any(np.diff(b) <= 0):
        raise ValueError("beat_times must be an increasing 1-D array of at least two times")
    t = np.asarray(times, dtype=np.float64)
    idx = np.arange(b.size, dtype=np.float64)
    phase = np.interp(t, b, idx)
    before, after = t < b[0], t > b[-1]
    phase[before] = (t[before] - b[0]) / (b[1] - b[0])
    phase[after] = b.size - 1 + (t[after] - b[-1]) / (b[-1] - b[-2])
    return phase


def ease_keys(
    keys: np.ndarray,
    phase: np.ndarray,
    key_phases: np.ndarray | None = None,
    *,
    attack: float = 1.0,
    release: float = 1.0,
) -> np.ndarray:
    """Eased interpolation of ``keys`` (``(K, C)``) placed at ``key_phases``, sampled at ``phase``.

    ``key_phases`` (``(K,)`` increasing, default ``0, 1, ..., K - 1``) are the phases (in beats) at
    which each key pose is reached. Between keys ``k`` and ``k + 1`` the value is
    ``key_k + (key_{k+1} - key_k) w(u)`` with ``u`` the fraction of the way from ``key_phases[k]`` to
    ``key_phases[k + 1]`` and ``w`` the regularised incomplete beta function ``I_u(attack + 1,
    release + 1)``: the speed profile is ``∝ u^attack (1 - u)^release``, zero at every key (a
    velocity minimum and a change of direction on each key). ``attack = release = 1`` is smoothstep;
    ``attack < 1`` makes every move start sharply on its key, like a dancer's hit on the beat.
    Phases outside the keys' range are clamped. Returns ``(T, C)``.
    """
    if attack <= 0 or release <= 0:
        raise ValueError(f"attack and release must be > 0, got {attack} and {release}")
    keys = np.asarray(keys, dtype=np.float64)
    n = keys.shape[0]
    kp = np.arange(n, dtype=np.float64) if key_phases is None else np.asarray(key_phases, dtype=np.float64)
    if kp.shape != (n,) or n < 2 or np.any(np.diff(kp) <= 0):
        raise ValueError("need at least two keys at strictly increasing key_phases")
    p = np.clip(np.asarray(phase, dtype=np.float64), kp[0], kp[-1])
    k = np.clip(np.searchsorted(kp, p, side="right") - 1, 0, n - 2)
    u = np.clip((p - kp[k]) / (kp[k + 1] - kp[k]), 0.0, 1.0)
    from scipy.special import betainc  # here: scipy.special takes 0.3 s to import

    w = betainc(attack + 1.0, release + 1.0, u)[:, None]
    return keys[k] + (keys[k + 1] - keys[k]) * w


def smooth_noise(
    rng: np.random.Generator, shape: tuple[int, int], std: float, sigma_frames: float
) -> np.ndarray:
    """Gaussian-smoothed white noise of the given per-sample ``std`` along axis 0."""
    if std <= 0:
        return np.zeros(shape)
    raw = rng.standard_normal(shape)
    if sigma_frames > 0:
        from scipy.ndimage import gaussian_filter1d  # here: scipy.ndimage takes 0.3 s to import

        raw = gaussian_filter1d(raw, sigma_frames, axis=0, mode="reflect")
        raw /= max(float(raw.std()), 1e-12)
    return raw * std


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    """``(T, 3, 3)`` rotations by ``angle`` (radians) about x (0), y (1) or z (2), right-handed."""
    a = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[..., axis, axis] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def segment_rotations(controls: np.ndarray, yaw: np.ndarray) -> dict[str, np.ndarray]:
    """Global rotation ``(T, 3, 3)`` of every body segment from controls ``(T, C)`` and yaw ``(T,)``.

    Limbs are expressed relative to a hanging (straight down) rest direction; see
    :func:`pose` for how each bone's rest offset is aligned to it.
    """
    c = {name: controls[:, i] for i, name in enumerate(CONTROLS)}
    r_yaw = _rot(1, yaw)
    pelvis = r_yaw @ _rot(0, 0.2 * c["lean_fwd"])
    abdomen = (
        r_yaw @ _rot(1, 0.5 * c["twist"]) @ _rot(0, 0.6 * c["lean_fwd"]) @ _rot(2, -0.6 * c["lean_side"])
    )
    chest = r_yaw @ _rot(1, c["twist"]) @ _rot(0, c["lean_fwd"]) @ _rot(2, -c["lean_side"])
    seg = {"pelvis": pelvis, "abdomen": abdomen, "chest": chest, "head": chest @ _rot(0, c["nod"])}
    for side, sign in (("l", 1.0), ("r", -1.0)):
        seg[f"{side}_clavicle"] = chest
        upper = chest @ _rot(2, sign * c[f"{side}_sh_abd"]) @ _rot(0, -c[f"{side}_sh_flex"])
        fore = upper @ _rot(0, -c[f"{side}_elbow"])
        thigh = pelvis @ _rot(2, sign * c[f"{side}_hip_abd"]) @ _rot(0, -c[f"{side}_hip_flex"])
        seg.update(
            {
                f"{side}_upper_arm": upper,
                f"{side}_forearm": fore,
                f"{side}_hand": fore,
                f"{side}_thigh": thigh,
                f"{side}_shin": thigh @ _rot(0, c[f"{side}_knee"]),
                f"{side}_foot": r_yaw,
            }
        )
    return seg


def _align_down(v: np.ndarray) -> np.ndarray:
    """Smallest rotation taking direction ``v`` to straight down ``(0, -1, 0)``."""
    a = v / np.linalg.norm(v)
    b = np.array([0.0, -1.0, 0.0])
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(a @ b)
    if s < 1e-9:
        return np.eye(3) if c > 0 else np.diag([-1.0, -1.0, 1.0])  # pi about z
    k = axis / s
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * kx + (1 - c) * (kx @ kx)


def pose(
    skeleton: Skeleton,
    segments: Mapping[str, np.ndarray],
    root_xz: np.ndarray,
    *,
    floor_softness: float = 0.01,
) -> np.ndarray:
    """Joint positions ``(T, J, 3)`` in metres (Y up) of ``skeleton`` posed by segment rotations.

    Each limb bone's rest offset is first rotated to hang straight down (so T-pose and A-pose rest
    skeletons dance alike), then by its segment's rotation. The root is placed at ``root_xz``
    (``(T, 2)``, floor coordinates) and lifted so the lowest shin/foot joint is on the floor. With
    ``floor_softness`` > 0 (metres) the lift uses a soft minimum over the foot joints, so the body
    does not jerk when the support foot changes (feet then hover at most ``softness * log(n)``).
    """
    t = root_xz.shape[0]
    rots = np.empty((t, skeleton.num_joints, 3, 3))
    rots[:, skeleton.root] = np.eye(3)
    for j, seg in enumerate(skeleton.segments):
        if seg == "root":
            continue
        rot = segments[seg]
        if seg in _LIMB_SEGMENTS:
            rot = rot @ _align_down(np.asarray(skeleton.offsets[j], dtype=np.float64))
        rots[:, j] = rot
    root = np.zeros((t, 3))
    root[:, 0], root[:, 2] = root_xz[:, 0], root_xz[:, 1]
    pos = forward_kinematics(skeleton, rots, root)
    feet = [j for j, s in enumerate(skeleton.segments) if s in _FOOT_SEGMENTS]
    heights = pos[:, feet, 1]
    lowest = heights.min(axis=1, keepdims=True)
    if floor_softness > 0:  # smooth weight transfer: a soft minimum, <= the lowest foot
        lowest = lowest - floor_softness * np.log(
            np.exp(-(heights - lowest) / floor_softness).sum(axis=1, keepdims=True)
        )
    pos[..., 1] -= lowest
    return pos


def project(positions: np.ndarray, camera: Camera) -> np.ndarray:
    """Perspective projection of ``(T, J, 3)`` metres to ``(T, J, 2)`` image pixels ``(u, v)``.

    ``u = W/2 + f X / (d - Z)``, ``v = H/2 - f (Y - h) / (d - Z)``: the dancer's left (+X) is on the
    image's right (the dancer faces the camera), v grows downwards.
    """
    depth = camera.distance - positions[..., 2]
    if np.any(depth < 0.5):
        raise ValueError("a joint came within 0.5 m of the camera; increase camera.distance")
    u = camera.width / 2 + camera.focal_px * positions[..., 0] / depth
    v = camera.height / 2 - camera.focal_px * (positions[..., 1] - camera.height_m) / depth
    return np.stack([u, v], axis=-1)
