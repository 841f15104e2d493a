"""Replay a recording in the spatial model with MuJoCo's offscreen renderer.

Each frame's pose comes from the recording: C (or E with the Euler angles), the body's
yaw, tilt, pitch and the rider's pitch and lean from G; the wheel's spin is the
travelled distance over R.  Headless rendering needs ``MUJOCO_GL=egl`` or ``osmesa``
(:mod:`euc_sim` sets ``egl`` without a display); videos by ``imageio`` (MP4 with
``imageio-ffmpeg``, GIF with Pillow).
"""

from __future__ import annotations

import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pandas as pd
from tqdm import tqdm

from euc_sim import io
from euc_sim.errors import InputError
from euc_sim.model.parameters import Params, TABLE3

__all__ = ["RenderError", "poses", "render_recording"]


class RenderError(InputError):
    """The recording cannot be replayed or no OpenGL backend is available."""


def _read(path: Path) -> pd.DataFrame:
    if not path.is_file():
        raise RenderError(f"{path}: no such file")
    try:
        df = pd.read_parquet(path) if path.suffix.lower() == ".parquet" else pd.read_csv(path)
    except Exception as exc:  # pandas raises several types for a bad file
        raise RenderError(f"{path}: cannot read ({type(exc).__name__})") from None
    return _checked(df, path)


#: The columns a replay reads, where present.
_POSE_COLUMNS = ("t", "x", "psi", "theta", "gamma", "phi", "C_X", "C_Y", "C_Z", "E_X", "E_Y", "E_Z",
                 "G_X", "G_Y", "G_Z")


def _checked(df: pd.DataFrame, path: Path) -> pd.DataFrame:
    """The recording with its pose columns as finite floats and t increasing; ``RenderError``
    naming the file, the column and the first bad row.
    """
    if len(df) == 0:
        raise RenderError(f"{path}: no data rows (header only)")
    df = df.copy()
    for col in (c for c in _POSE_COLUMNS if c in df.columns):
        values = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            cell = df[col].iloc[bad[0]]
            cell = repr(cell) if isinstance(cell, str) else str(cell)
            raise RenderError(f"{path}: column {col!r} row {bad[0] + 1}: {cell} "
                              f"is not a finite number ({bad.size} such rows)")
        df[col] = values
    if "t" in df.columns and len(df) > 1 and not np.all(np.diff(df["t"].to_numpy()) > 0):
        row = int(np.flatnonzero(np.diff(df["t"].to_numpy()) <= 0)[0]) + 2
        raise RenderError(f"{path}: column 't' row {row}: time must increase")
    return df


def _rot(psi, theta, gamma) -> np.ndarray:
    """Rz(ψ) Rx(ϑ) Ry(γ) for arrays of angles, shape (N, 3, 3)."""
    cz, sz, cx, sx, cy, sy = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta), np.cos(gamma), np.sin(gamma)
    n = np.size(psi)
    Rz = np.zeros((n, 3, 3))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = cz, -sz, sz, cz, 1.0
    Rx = np.zeros((n, 3, 3))
    Rx[:, 0, 0], Rx[:, 1, 1], Rx[:, 1, 2], Rx[:, 2, 1], Rx[:, 2, 2] = 1.0, cx, -sx, sx, cx
    Ry = np.zeros((n, 3, 3))
    Ry[:, 0, 0], Ry[:, 0, 2], Ry[:, 1, 1], Ry[:, 2, 0], Ry[:, 2, 2] = cy, sy, 1.0, -sy, cy
    return Rz @ Rx @ Ry


def poses(df: pd.DataFrame, p: Params = TABLE3, name: str = "recording") -> dict[str, np.ndarray]:
    """Per-sample pose of the spatial model from a recording: ``C`` (N, 3) m, ``R`` (N, 3, 3),
    ``spin``, ``rider_pitch``, ``rider_lean`` (N,) rad; ``RenderError`` naming a missing column.
    """
    for col in ("t", "psi", "theta", "gamma"):
        if col not in df.columns:
            raise RenderError(f"{name}: column {col!r} missing (render needs psi, theta, gamma and C or E)")
    psi, theta, gamma = (df[c].to_numpy(dtype=float) for c in ("psi", "theta", "gamma"))
    R = _rot(psi, theta, gamma)
    if {"C_X", "C_Y", "C_Z"} <= set(df.columns):
        C = df[["C_X", "C_Y", "C_Z"]].to_numpy(dtype=float)
    elif {"E_X", "E_Y", "E_Z"} <= set(df.columns):
        C = df[["E_X", "E_Y", "E_Z"]].to_numpy(dtype=float) - R[:, :, 2] * 0.42
    elif "x" in df.columns:                                   # a planar recording
        C = np.column_stack([df["x"].to_numpy(dtype=float), np.zeros(len(df)), np.full(len(df), p.R)])
    else:
        raise RenderError(f"{name}: column 'C_X' missing (render needs C, E or x)")
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(C[:, :2], axis=0), axis=1))])
    rider_pitch = np.zeros(len(df))
    rider_lean = np.zeros(len(df))
    if {"G_X", "G_Y", "G_Z"} <= set(df.columns):
        G = df[["G_X", "G_Y", "G_Z"]].to_numpy(dtype=float)
        g_body = np.einsum("nji,nj->ni", R, G - C) - np.array([0.0, 0.0, -p.l0])   # A → G, body frame
        rider_pitch = np.arctan2(g_body[:, 0], g_body[:, 2])
        rider_lean = np.arctan2(-g_body[:, 1], np.hypot(g_body[:, 0], g_body[:, 2]))
    if "phi" in df.columns:
        rider_pitch = df["phi"].to_numpy(dtype=float) - gamma
    return {"C": C, "R": R, "spin": dist / p.R - gamma, "rider_pitch": rider_pitch, "rider_lean": rider_lean}


def render_recording(recording, out, *, fps: float = 30.0, width: int = 640, height: int = 480,
                     frame_time: float | None = None, progress: bool = True) -> int:
    """Render ``recording`` (CSV or Parquet) to ``out``: .mp4, .gif, or .png for one frame.

    Parameters
    ----------
    fps : float
        Frames per second of a video.
    width, height : int
        Frame size, pixels.
    frame_time : float, optional
        With ``.png``: the frame's time, s (default: the middle).
    progress : bool
        A progress bar on stderr.

    Returns the number of frames written; ``RenderError`` for a bad recording or size, or
    when no OpenGL backend can be created.
    """
    import mujoco

    from euc_sim.model.spatial import EucSpatial  # deferred: loads mujoco (0.1 s)

    recording, out = Path(recording), Path(out)
    if not (16 <= width <= 4096 and 16 <= height <= 4096):
        raise RenderError(f"frame size must be 16-4096 pixels, got {width} x {height}")
    io.check_writable(out)             # before the rendering, not after it
    df = _read(recording)
    pose = poses(df, TABLE3, str(recording))
    t = df["t"].to_numpy(dtype=float)
    if out.suffix.lower() == ".png":
        ft = float(t[len(t) // 2]) if frame_time is None else frame_time
        if not (t[0] <= ft <= t[-1]):
            raise RenderError(f"--time {ft!r} s is outside the recording ({t[0]:g}-{t[-1]:g} s)")
        frames_at = [int(np.searchsorted(t, ft))]
    else:
        frames_at = np.unique(np.searchsorted(t, np.arange(t[0], t[-1], 1.0 / fps))).tolist()
    sim = EucSpatial(TABLE3)
    m, d = sim.model, sim.data
    m.vis.global_.offwidth, m.vis.global_.offheight = max(width, 640), max(height, 480)
    try:
        renderer = mujoco.Renderer(m, height, width)
    except Exception as exc:   # no display, no EGL/OSMesa: MuJoCo raises several types
        raise RenderError(f"no OpenGL backend for offscreen rendering ({type(exc).__name__}: "
                          f"{str(exc).splitlines()[0] if str(exc) else ''}); set MUJOCO_GL=egl "
                          "(Debian: libegl1 libegl-mesa0) or MUJOCO_GL=osmesa (libosmesa6)") from None
    cam = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "follow")
    a = sim.qadr
    quat = np.empty(4)
    frames = []
    bar = tqdm(total=len(frames_at), desc=f"render {out.name}", unit="frame", file=sys.stderr,
               disable=not progress or len(frames_at) < 2)
    try:
        for i in frames_at:
            d.qpos[a["root"]:a["root"] + 3] = pose["C"][i]
            mujoco.mju_mat2Quat(quat, pose["R"][i].ravel())
            d.qpos[a["root"] + 3:a["root"] + 7] = quat
            d.qpos[a["wheel_spin"]] = pose["spin"][i]
            d.qpos[a["rider_pitch"]] = pose["rider_pitch"][i]
            d.qpos[a["rider_lean"]] = pose["rider_lean"][i]
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_camlight(m, d)
            renderer.update_scene(d, camera=cam)
            frames.append(renderer.render().copy())
            bar.update()
    finally:
        bar.close()
        renderer.close()
    _write_frames(out, frames, fps, io)
    return len(frames)


def _write_frames(out: Path, frames, fps: float, io) -> None:
    suffix = out.suffix.lower()

    def write(tmp: Path) -> None:
        try:
            if suffix == ".png":
                iio.imwrite(tmp, frames[0], extension=".png")
            elif suffix == ".gif":
                iio.imwrite(tmp, np.stack(frames), extension=".gif", duration=1000.0 / fps, loop=0)
            else:
                iio.imwrite(tmp, np.stack(frames), extension=".mp4", fps=fps, codec="libx264",
                            macro_block_size=8)
        except OSError as exc:         # the encoder (ffmpeg, a pipe) failed: say which file
            raise RenderError(f"{out}: the {suffix} encoder failed ({type(exc).__name__}: "
                              f"{str(exc).splitlines()[0] if str(exc) else ''})") from None

    io.atomic_write(out, write)
