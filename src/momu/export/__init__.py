"""Export of generated motion: BVH (through ``upc-pymotion``) and plain ``.npz`` files.

* :func:`write_bvh` / :func:`read_bvh` — :mod:`momu.export.bvh`, hierarchy and rotations from
  :mod:`momu.export.rig`;
* :func:`write_motion_npz` / :func:`read_motion_npz` — :mod:`momu.export.npz`.
"""

from momu.export.bvh import BvhMotion, read_bvh, write_bvh
from momu.export.npz import MotionFile, read_motion_npz, write_motion_npz
from momu.export.rig import BvhRig, build_rig

__all__ = [
    "BvhMotion",
    "BvhRig",
    "MotionFile",
    "build_rig",
    "read_bvh",
    "read_motion_npz",
    "write_bvh",
    "write_motion_npz",
]
