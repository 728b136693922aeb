"""Minimal BVH reader for tests and benchmarks (test support code, not product code).

Reads the joint hierarchy's channel lists and the motion block, and turns each joint's rotation
channels into quaternions (w, x, y, z) with numpy alone. BVH rotation channels listed as
"Zrotation Xrotation Yrotation" mean R = Rz·Rx·Ry (intrinsic, in the listed order), i.e. Blender's
Euler order "YXZ"; angles are in degrees. Joints whose rotation channels are all zero over the clip
(e.g. end joints some exporters write) are kept; callers filter them if they wish.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

# ../shared relative to the project root (tests/python/ -> project root is two levels up).
PROJECT_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MOCAP_DIR = os.path.normpath(os.path.join(PROJECT_ROOT, "..", "shared", "data", "mocap"))


def mocap_path(name: str) -> str:
    """Absolute path of a clip in ../shared/data/mocap (it may not exist on every machine)."""
    return os.path.join(MOCAP_DIR, name)


@dataclass
class Joint:
    name: str
    channels: list[str]          # e.g. ["Zrotation", "Xrotation", "Yrotation"]
    offset: int                  # first column of this joint's channels in the motion block
    rotation_columns: list[int] = field(default_factory=list)  # absolute columns, listed order
    rotation_axes: str = ""      # axis letters in listed order, e.g. "ZXY"

    @property
    def blender_order(self) -> str:
        """Blender Euler order with the same meaning: listed ZXY (R = Rz·Rx·Ry) is Blender 'YXZ'."""
        return self.rotation_axes[::-1]


@dataclass
class Clip:
    joints: list[Joint]
    frame_time: float
    motion: np.ndarray           # (frames, columns) float64

    @property
    def frames(self) -> int:
        return self.motion.shape[0]

    def euler_radians(self, joint: Joint) -> np.ndarray:
        """(frames, 3) angles about (X, Y, Z) in radians, Blender's triple layout."""
        out = np.zeros((self.frames, 3))
        for col, axis in zip(joint.rotation_columns, joint.rotation_axes):
            out[:, "XYZ".index(axis)] = np.radians(self.motion[:, col])
        return out

    def quaternions(self, joint: Joint) -> np.ndarray:
        """(frames, 4) unit quaternions (w, x, y, z), w >= 0 at the first frame, hemisphere-continuous."""
        q = euler_to_quat(self.euler_radians(joint), joint.blender_order)
        return make_hemisphere_continuous(q)

    def rotating_joints(self) -> list[Joint]:
        """Joints with rotation channels that are not identically zero over the clip."""
        return [j for j in self.joints
                if j.rotation_columns and np.any(self.motion[:, j.rotation_columns] != 0.0)]


def read_bvh(path: str) -> Clip:
    with open(path) as f:
        tokens_by_line = [line.split() for line in f]
    joints: list[Joint] = []
    column = 0
    i = 0
    while i < len(tokens_by_line):
        tok = tokens_by_line[i]
        i += 1
        if not tok:
            continue
        if tok[0] in ("ROOT", "JOINT"):
            name = " ".join(tok[1:])
            joints.append(Joint(name=name, channels=[], offset=column))
        elif tok[0] == "CHANNELS":
            count = int(tok[1])
            chans = tok[2:2 + count]
            joint = joints[-1]
            joint.channels = chans
            joint.offset = column
            for k, ch in enumerate(chans):
                if ch.lower().endswith("rotation"):
                    joint.rotation_columns.append(column + k)
                    joint.rotation_axes += ch[0].upper()
            column += count
        elif tok[0] == "MOTION":
            break
    frames = int(tokens_by_line[i][-1])
    frame_time = float(tokens_by_line[i + 1][-1])
    rows = [list(map(float, t)) for t in tokens_by_line[i + 2:i + 2 + frames] if t]
    motion = np.asarray(rows, dtype=np.float64)
    if motion.shape != (frames, column):
        raise ValueError(f"{path}: motion block is {motion.shape}, expected {(frames, column)}")
    return Clip(joints=joints, frame_time=frame_time, motion=motion)


def _axis_quat(axis: str, angle: np.ndarray) -> np.ndarray:
    q = np.zeros(angle.shape + (4,))
    q[..., 0] = np.cos(angle / 2)
    q[..., 1 + "XYZ".index(axis)] = np.sin(angle / 2)
    return q


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (..., 4) arrays in (w, x, y, z)."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def euler_to_quat(angles: np.ndarray, order: str) -> np.ndarray:
    """Blender semantics: order 'XYZ' means R = Rz·Ry·Rx (first letter applied first, fixed axes);
    angles[..., 0..2] are about X, Y, Z whatever the order."""
    angles = np.asarray(angles, dtype=np.float64)
    q = None
    for axis in order:  # applied first → rightmost factor
        r = _axis_quat(axis, angles[..., "XYZ".index(axis)])
        q = r if q is None else quat_multiply(r, q)
    return q


def make_hemisphere_continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs so consecutive quaternions have a non-negative dot product (first has w >= 0)."""
    q = np.array(q, dtype=np.float64)
    if len(q) and q[0, 0] < 0:
        q[0] = -q[0]
    for k in range(1, len(q)):
        if np.dot(q[k], q[k - 1]) < 0:
            q[k] = -q[k]
    return q
