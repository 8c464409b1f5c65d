"""Slow pure-Python transcriptions of the field's reference metric loops (METRICS.md §1.1–1.4).

Written from the specification's per-frame loops, for tests only: momu's vectorised code must equal them.
"""

from __future__ import annotations

import numpy as np

SMPL_NAMES = [
    "root", "lhip", "rhip", "belly", "lknee", "rknee", "spine", "lankle", "rankle", "chest", "ltoes", "rtoes",
    "neck", "linshoulder", "rinshoulder", "head", "lshoulder", "rshoulder", "lelbow", "relbow", "lwrist",
    "rwrist", "lhand", "rhand",
]  # fmt: skip


def _avg_velocity(positions, i, joint, w, ft, axes):
    cw = 0
    acc = np.zeros(len(positions[0][joint]))
    for k in range(-w, w + 1):
        if i + k - 1 < 0 or i + k >= len(positions):
            continue
        acc += positions[i + k][joint] - positions[i + k - 1][joint]
        cw += 1
    return np.linalg.norm(np.array([acc[a] for a in axes]) / (cw * ft))


def _avg_acceleration(positions, i, joint, w, ft, buggy):
    cw = 0
    acc = np.zeros(len(positions[0][joint]))
    for k in range(-w, w + 1):
        if i + k - 1 < 0 or i + k + 1 >= len(positions):
            continue
        v2 = (positions[i + k + 1][joint] - positions[i + k][joint]) / ft
        if buggy:
            v1 = positions[i + k][joint] - positions[i + k - 1][joint] / ft
        else:
            v1 = (positions[i + k][joint] - positions[i + k - 1][joint]) / ft
        acc += (v2 - v1) / ft
        cw += 1
    return np.linalg.norm(acc / cw)


def reference_kinetic(positions, ft=1.0 / 60, up="y", w=2, buggy=True):
    horiz, vert = ((0, 2), (1,)) if up == "y" else ((0, 1), (2,))
    out = []
    n = len(positions)
    for j in range(positions.shape[1]):
        ke_h = 0
        ke_v = 0
        ee = 0.0
        for i in range(1, n):
            ke_h += _avg_velocity(positions, i, j, w, ft, horiz) ** 2
            ke_v += _avg_velocity(positions, i, j, w, ft, vert) ** 2
            ee += _avg_acceleration(positions, i, j, w, ft, buggy)
        out.extend([ke_h / (n - 1.0), ke_v / (n - 1.0), ee / (n - 1.0)])
    return np.array(out, dtype=np.float32)


_HL = float(np.linalg.norm(np.array([1.99113488e-01, 2.36807942e-01, -1.80702247e-02])
                           - np.array([4.54445392e-01, 2.21158922e-01, -4.10167128e-02])))  # fmt: skip
_SW = float(np.linalg.norm(np.array([1.99113488e-01, 2.36807942e-01, -1.80702247e-02])
                           - np.array([-1.91692337e-01, 2.36928746e-01, -1.23055102e-02])))  # fmt: skip
_HW = float(np.linalg.norm(np.array([5.64076714e-02, -3.23069185e-01, 1.09197125e-02])
                           - np.array([-6.24834076e-02, -3.31302464e-01, 1.50412619e-02])))  # fmt: skip


class _RefManual:
    """Per-frame transcription of the reference's ManualFeatures (METRICS.md §1.2)."""

    def __init__(self, positions, tpf=1 / 120.0):
        self.positions = positions
        self.t = 1
        self.tpf = tpf

    def pos(self, j):
        if j == "y_unit":
            return np.array([0, 1, 0])
        if j == "minus_y_unit":
            return np.array([0, -1, 0])
        if j == "zero":
            return np.array([0, 0, 0])
        if j == "y_min":
            return np.array([0, min([y for (_, y, _) in self.positions[self.t]]), 0])
        return np.array(self.positions[self.t][SMPL_NAMES.index(j)])

    def prev(self, j):
        return np.array(self.positions[self.t - 1][SMPL_NAMES.index(j)])

    def move(self, j1, j2, j3, j4, th):
        v = self.pos(j3) - self.pos(j1) - (self.prev(j3) - self.prev(j1))
        d = self.pos(j2) - self.pos(j1)
        return np.dot(v, d) / np.linalg.norm(d) / self.tpf > th

    def nmove(self, j1, j2, j3, j4, th):
        v = self.pos(j4) - self.pos(j1) - (self.prev(j4) - self.prev(j1))
        d = np.cross(self.pos(j3) - self.pos(j1), self.pos(j2) - self.pos(j1))
        return np.dot(v, d) / np.linalg.norm(d) / self.tpf > th

    def plane(self, a, b, c, p, th):
        a, b, c, p = (self.pos(j) for j in (a, b, c, p))
        cross = np.cross(c - a, b - a)
        return np.dot(cross, p - a) / np.linalg.norm(cross) > th

    def nplane(self, n1, n2, a, p, th):
        n1, n2, a, p = (self.pos(j) for j in (n1, n2, a, p))
        normal = n2 - n1
        return np.dot(normal, p - a) / np.linalg.norm(normal) > th

    def angle(self, j1, j2, k1, k2, rng):
        j = self.pos(j2) - self.pos(j1)
        k = self.pos(k2) - self.pos(k1)
        angle = np.degrees(np.arccos(np.dot(j, k) / (np.linalg.norm(j) * np.linalg.norm(k))))
        return bool(angle > rng[0] and angle < rng[1])

    def fast(self, j, th):
        return np.linalg.norm(self.pos(j) - self.prev(j)) / self.tpf > th


def reference_manual(positions, tpf=1 / 120.0):
    f = _RefManual(positions, tpf)
    hl, sw, hw = _HL, _SW, _HW
    rows = []
    with np.errstate(all="ignore"):
        for _ in range(1, positions.shape[0]):
            rows.append([
                f.nmove("neck", "rhip", "lhip", "rwrist", 1.8 * hl),
                f.nmove("neck", "lhip", "rhip", "lwrist", 1.8 * hl),
                f.nplane("chest", "neck", "neck", "rwrist", 0.2 * hl),
                f.nplane("chest", "neck", "neck", "lwrist", 0.2 * hl),
                f.move("belly", "chest", "chest", "rwrist", 1.8 * hl),
                f.move("belly", "chest", "chest", "lwrist", 1.8 * hl),
                f.angle("relbow", "rshoulder", "relbow", "rwrist", [0, 110]),
                f.angle("lelbow", "lshoulder", "lelbow", "lwrist", [0, 110]),
                f.nplane("lshoulder", "rshoulder", "lwrist", "rwrist", 2.5 * sw),
                f.move("lwrist", "rwrist", "rwrist", "lwrist", 1.4 * hl),
                f.move("rwrist", "root", "lwrist", "root", 1.4 * hl),
                f.move("lwrist", "root", "rwrist", "root", 1.4 * hl),
                f.fast("rwrist", 2.5 * hl),
                f.fast("lwrist", 2.5 * hl),
                f.plane("root", "lhip", "ltoes", "rankle", 0.38 * hl),
                f.plane("root", "rhip", "rtoes", "lankle", 0.38 * hl),
                f.nplane("zero", "y_unit", "y_min", "rankle", 1.2 * hl),
                f.nplane("zero", "y_unit", "y_min", "lankle", 1.2 * hl),
                f.nplane("lhip", "rhip", "lankle", "rankle", 2.1 * hw),
                f.angle("rknee", "rhip", "rknee", "rankle", [0, 110]),
                f.angle("lknee", "lhip", "lknee", "lankle", [0, 110]),
                f.fast("rankle", 2.5 * hl),
                f.fast("lankle", 2.5 * hl),
                f.angle("neck", "root", "rshoulder", "relbow", [25, 180]),
                f.angle("neck", "root", "lshoulder", "lelbow", [25, 180]),
                f.angle("neck", "root", "rhip", "rknee", [50, 180]),
                f.angle("neck", "root", "lhip", "lknee", [50, 180]),
                f.plane("rankle", "neck", "lankle", "root", 0.5 * hl),
                f.angle("neck", "root", "zero", "y_unit", [70, 110]),
                f.nplane("zero", "minus_y_unit", "y_min", "rwrist", -1.2 * hl),
                f.nplane("zero", "minus_y_unit", "y_min", "lwrist", -1.2 * hl),
                f.fast("root", 2.3 * hl),
            ])  # fmt: skip
            f.t += 1
    return np.array(rows, dtype=np.float32).mean(axis=0)


def reference_avg_distance(feature_list):
    """Bailando ``calculate_avg_distance``: Python-loop sum of norms over i < j."""
    feature_list = np.stack(feature_list)
    n = feature_list.shape[0]
    dist = 0
    for i in range(n):
        for j in range(i + 1, n):
            dist += np.linalg.norm(feature_list[i] - feature_list[j])
    dist /= (n * n - n) / 2
    return dist


def reference_calc_fid(kps_gen, kps_gt):
    """Bailando ``calc_fid`` (with scipy's deprecated ``sqrtm(disp=False)``, as the reference calls it)."""
    import warnings

    from scipy import linalg

    mu1, mu2 = np.mean(kps_gen, axis=0), np.mean(kps_gt, axis=0)
    sigma1, sigma2 = np.cov(kps_gen, rowvar=False), np.cov(kps_gt, rowvar=False)
    diff = mu1 - mu2
    eps = 1e-5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        covmean, _ = linalg.sqrtm(sigma1.dot(sigma2), disp=False)
        if not np.isfinite(covmean).all():
            offset = np.eye(sigma1.shape[0]) * eps
            covmean = linalg.sqrtm((sigma1 + offset).dot(sigma2 + offset))
    if np.iscomplexobj(covmean):
        if not np.allclose(np.diagonal(covmean).imag, 0, atol=1e-3):
            covmean = covmean.real
    tr_covmean = np.trace(covmean)
    return diff.dot(diff) + np.trace(sigma1) + np.trace(sigma2) - 2 * tr_covmean


def reference_normalize(feat, feat2):
    """Bailando ``normalize(gt, pred)``."""
    mean = feat.mean(axis=0)
    std = feat.std(axis=0)
    return (feat - mean) / (std + 1e-10), (feat2 - mean) / (std + 1e-10)


def reference_mint_fid(real, gen):
    """mint ``calculate_frechet_feature_distance(real, gen)`` (PR #41), with ``sqrtm(disp=False)``."""
    import warnings

    from scipy import linalg

    real, gen = np.stack(real), np.stack(gen)
    mean = np.mean(real, axis=0)
    std = np.std(real, axis=0) + 1e-10
    real, gen = (real - mean) / std, (gen - mean) / std
    mu1, sigma1 = np.mean(real, axis=0), np.cov(real, rowvar=False)
    mu2, sigma2 = np.mean(gen, axis=0), np.cov(gen, rowvar=False)
    diff = mu1 - mu2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        covmean, _ = linalg.sqrtm(sigma1.dot(sigma2), disp=False)
        if not np.isfinite(covmean).all():
            offset = np.eye(sigma1.shape[0]) * 1e-6
            covmean = linalg.sqrtm((sigma1 + offset).dot(sigma2 + offset))
    if np.iscomplexobj(covmean):
        if not np.allclose(np.diagonal(covmean).imag, 0, atol=1e-3):
            raise ValueError("Imaginary component")
        covmean = covmean.real
    return diff.dot(diff) + np.trace(sigma1) + np.trace(sigma2) - 2 * np.trace(covmean)
