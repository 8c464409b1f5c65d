"""Export of generated motion: BVH (through ``upc-pymotion``) and plain ``.npz`` files.

* :func:`rigid_motion` — :mod:`momu.export.rigid`: one length per bone for the whole motion, each
  bone in its direction: what the BVH holds, and what ``momu generate`` writes to every file;
* :func:`write_bvh` / :func:`read_bvh` — :mod:`momu.export.bvh`, hierarchy and rotations from
  :mod:`momu.export.rig`;
* :func:`write_motion_npz` / :func:`read_motion_npz` — :mod:`momu.export.npz`.
"""

from momu.export.bvh import BvhMotion, read_bvh, write_bvh
from momu.export.npz import MotionFile, read_motion_npz, write_motion_npz
from momu.export.rig import BvhRig, build_rig
from momu.export.rigid import fit_bone_lengths, rigid_motion

__all__ = [
    "BvhMotion",
    "BvhRig",
    "MotionFile",
    "build_rig",
    "fit_bone_lengths",
    "read_bvh",
    "read_motion_npz",
    "rigid_motion",
    "write_bvh",
    "write_motion_npz",
]
