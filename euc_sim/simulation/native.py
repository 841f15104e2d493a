"""The planar MuJoCo closed loop without Python per step: the motor PD as a native callback.

:func:`controllers.motor.pd_torque` (the one motor law) is compiled by numba's ``cfunc``
into MuJoCo's control callback ``void(const mjModel*, mjData*)`` and installed with
``mujoco.set_mjcb_control`` for the run only.  ``mj_step(model, data, nstep)`` then runs a
whole block of the rider's delay (n + 1 steps, :class:`controllers.rider.RiderRun`) in C:
at the first callback call of each step (RK4 calls it once per stage; the count per step
is measured on the model, not assumed) the callback records the state, computes M_d from
it and holds it with the block's ankle torque M_h over the step (zero-order hold at dt).
The rider's law stays in Python, once per block.  The velocity-dependent effects
``aerodynamic_drag`` (a force −k ẋ|ẋ| at G) and ``rolling_resistance`` (the moment
−C_rr N R tanh(ẋ/v₀) on the wheel) are evaluated by the callback from the same state and
held over the step, as :class:`euc_sim.simulation.engine._EffectsRow` does in the Python loop.

mjData fields (``qpos``, ``qvel``, ``ctrl``, ``qfrc_applied``, ``xfrc_applied``) are read through offsets in the struct found
at import from a live ``MjData`` (the word holding ``data.qpos.ctypes.data`` etc. from
``data._address``), never hard-coded.  The run's context (counters, indices, motor
settings, buffer addresses) lives in two module arrays whose addresses are compiled in:
like MuJoCo's callback itself it is process-global, so one native run at a time per
process (a lock); a run that finds it taken (threads) takes the Python loop, same result.

Where numba is missing or cannot compile, :func:`native_loop` says so in one line on
stderr and returns ``None``; the caller runs the Python loop.
"""

from __future__ import annotations

import ctypes
import math
import sys
import threading
from typing import Mapping

import numpy as np

from controllers.motor import MotorPD, pd_torque
from controllers.rider import RiderRun
from euc_sim.simulation.errors import FallError

__all__ = ["native_loop", "available", "field_offsets"]

# context slots: _I (int64) and _F (float64)
_I_CALLS, _I_PER, _I_K, _I_ROWS, _I_STATE, _I_MD, _I_MH = range(7)
_I_IX, _I_IG, _I_IR, _I_VX, _I_VG, _I_VR, _I_AM, _I_AA, _I_FALL, _I_DATA = range(7, 17)
_I_EFF, _I_BR, _I_BW, _I_SPIN = range(17, 21)   # effects on; rider, wheel body; wheel spins
_I = np.zeros(24, dtype=np.int64)
_F = np.zeros(24, dtype=np.float64)       # 0..10: MotorPD.law_args(); 11, 12: held M_d, M_h
_F_MD, _F_MH, _F_PHI_MAX, _F_GAM_MAX = 11, 12, 13, 14
_F_KDRAG, _F_ROLL, _F_V0, _F_R = 15, 16, 17, 18   # k (kg/m), C_rr·N·R (N·m), v₀ (m/s), R (m)

_LOCK = threading.Lock()
_CALLBACK = None                          # the compiled cfunc, or False when it cannot be built
_UNUSABLE_REASON = ""


def field_offsets() -> dict[str, int]:
    """Byte offsets in ``mjData`` of the pointers ``qpos``, ``qvel``, ``ctrl``, ``qfrc_applied``,
    ``xfrc_applied``, found on a live MjData.

    Each is the first 8-byte word of the struct equal to the array's address, and must
    agree on a second MjData of another model.
    """
    import mujoco

    found: list[dict[str, int]] = []
    models = [
        '<mujoco><worldbody><body><joint name="a"/><geom size=".1"/></body></worldbody>'
        '<actuator><motor joint="a"/></actuator></mujoco>',
        '<mujoco><worldbody><body><joint name="a" type="slide"/><geom size=".1"/><body>'
        '<joint name="b"/><geom size=".1"/></body></body></worldbody>'
        '<actuator><motor joint="a"/><motor joint="b"/></actuator></mujoco>',
    ]
    for xml in models:
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        targets = {"qpos": d.qpos.ctypes.data, "qvel": d.qvel.ctypes.data, "ctrl": d.ctrl.ctypes.data,
                   "qfrc_applied": d.qfrc_applied.ctypes.data, "xfrc_applied": d.xfrc_applied.ctypes.data}
        base, offs, words = int(d._address), {}, 64
        while len(offs) < len(targets):
            if words > 1 << 20:
                raise RuntimeError(f"mjData pointers not found in its first {words * 8} bytes")
            buf = (ctypes.c_int64 * words).from_address(base)
            w = np.frombuffer(buf, dtype=np.int64)
            for name, addr in targets.items():
                hit = np.flatnonzero(w == addr)
                if name not in offs and hit.size:
                    offs[name] = int(hit[0]) * 8
            words *= 4
        found.append(offs)
    if found[0] != found[1]:
        raise RuntimeError(f"mjData field offsets disagree between two models: {found}")
    return found[0]


def _build():
    """Compile the callback (once per process); ``False`` with a reason when impossible."""
    global _CALLBACK, _UNUSABLE_REASON
    if _CALLBACK is not None:
        return _CALLBACK
    try:
        _CALLBACK = _compile()
    except Exception as exc:  # noqa: BLE001 - any failure means: use the Python loop
        _CALLBACK, _UNUSABLE_REASON = False, f"{type(exc).__name__}: {exc}".splitlines()[0]
    return _CALLBACK


def _compile():
    """numba ``cfunc`` of the motor PD with MuJoCo's control-callback signature."""
    from numba import carray, cfunc, njit, types
    from numba.core.extending import intrinsic

    offs = field_offsets()
    W_QPOS, W_QVEL, W_CTRL = offs["qpos"] // 8, offs["qvel"] // 8, offs["ctrl"] // 8
    W_QFRC, W_XFRC = offs["qfrc_applied"] // 8, offs["xfrc_applied"] // 8
    I_ADDR, F_ADDR = _I.ctypes.data, _F.ctypes.data

    def pointer_to(element):
        """An intrinsic casting an int64 address to a pointer to ``element``."""
        @intrinsic
        def cast(typingctx, addr):
            sig = types.CPointer(element)(types.int64)

            def codegen(context, builder, signature, args):
                return builder.inttoptr(args[0], context.get_value_type(signature.return_type))
            return sig, codegen
        return cast

    f64p, i64p = pointer_to(types.float64), pointer_to(types.int64)

    law = njit(pd_torque)

    @intrinsic
    def address(typingctx, ptr):
        sig = types.int64(ptr)

        def codegen(context, builder, signature, args):
            return builder.ptrtoint(args[0], context.get_value_type(types.int64))
        return sig, codegen

    @cfunc(types.void(types.voidptr, types.CPointer(types.int64)))
    def control(m, d):
        iv = carray(i64p(I_ADDR), 24)
        fv = carray(f64p(F_ADDR), 24)
        if address(d) != iv[16]:                 # another simulation (another thread): not ours
            return
        calls = iv[0]
        iv[0] = calls + 1
        if calls % iv[1] == 0:               # the first call of a control step: fresh state
            k = iv[2]
            if k < iv[3]:
                qpos, qvel = f64p(d[W_QPOS]), f64p(d[W_QVEL])
                g = qpos[iv[8]]
                gd = qvel[iv[11]]
                xd = qvel[iv[10]]
                row = f64p(iv[4] + 48 * k)
                row[0] = qpos[iv[7]]
                row[1] = g
                row[2] = g + qpos[iv[9]]
                row[3] = xd
                row[4] = gd
                row[5] = gd + qvel[iv[12]]
                if iv[15] < 0:                  # the first fall: a bound passed or a non-finite state
                    fine = abs(row[2]) <= fv[13] and abs(g) <= fv[14]
                    for j in range(6):
                        fine = fine and row[j] - row[j] == 0.0
                    if not fine:
                        iv[15] = k
                M_d = law(g, gd, xd, fv[0], fv[1], fv[2], fv[3], fv[4], fv[5], fv[6], fv[7],
                          fv[8], fv[9], fv[10])
                f64p(iv[5])[k] = M_d
                if iv[17]:                      # drag at G and the rolling moment, held over the step
                    xfrc = f64p(d[W_XFRC])
                    xfrc[6 * iv[18]] = -fv[15] * xd * abs(xd)
                    tau = -fv[16] * math.tanh(xd / fv[17])
                    if iv[20]:
                        xfrc[6 * iv[19] + 4] = tau
                    else:                       # the wheel turns at x/R: τ dθ = (τ/R) dx
                        f64p(d[W_QFRC])[iv[10]] = tau / fv[18]
                fv[11] = M_d
                fv[12] = f64p(iv[6])[k]
                iv[2] = k + 1
        ctrl = f64p(d[W_CTRL])
        ctrl[iv[13]] = fv[11]
        ctrl[iv[14]] = fv[12]

    return control


def available() -> bool:
    """Whether the native callback compiles here (compiles it on first call)."""
    return bool(_build())


def native_loop(stepper, motor: MotorPD, run: RiderRun, dt: float, N: int, y0: tuple,
                bounds: Mapping[str, float], raise_fall,
                progress=None, drag: tuple[float, float] = (0.0, 0.0)) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`euc_sim.simulation.engine._closed_loop` for a MuJoCo stepper without per-step effects.

    Same states (N+1, 6) and torques (N+1, 2); ``None`` (and one line on stderr) when the
    callback cannot be built, ``None`` silently when another thread's native run holds it:
    the caller then runs the Python loop.  ``raise_fall(t, y,
    phi_max, gam_max)`` raises at the first recorded state outside ``bounds``, as the
    Python loop does; the ``FallError`` carries ``partial``, the states and torques of
    steps 0 … k − 1, as the Python loop's does.  ``progress(t)``: the simulated time, s,
    at every rider block.  ``drag``: (k, C_rr·N·R), the ``aerodynamic_drag`` coefficient,
    kg/m, and the ``rolling_resistance`` moment's scale, N·m (0, 0: neither).
    """
    callback = _build()
    if not callback:
        print(f"euc-sim: native closed loop unavailable ({_UNUSABLE_REASON}); using the Python loop",
              file=sys.stderr)
        return None
    if not _LOCK.acquire(blocking=False):     # another thread's native run holds the callback
        return None
    try:
        return _run(callback, stepper, motor, run, dt, N, y0, bounds, raise_fall, progress, drag)
    finally:
        _LOCK.release()


def _run(callback, stepper, motor, run, dt, N, y0, bounds, raise_fall, progress=None, drag=(0.0, 0.0)):
    """:func:`native_loop` with the callback built and the lock held."""
    import mujoco

    m, d = stepper.m, stepper.d
    n = run.n
    P = np.empty((N + 1 + n, 6))              # padded state history: the rider's delay buffer
    P[:n] = y0
    M_d = np.zeros(N + 1)
    M_h = np.zeros(N + 1)
    _I[:] = 0
    _I[[_I_IX, _I_IG, _I_IR, _I_VX, _I_VG, _I_VR, _I_AM, _I_AA]] = (
        stepper.ix, stepper.ig, stepper.ir, stepper.vx, stepper.vg, stepper.vr,
        stepper.a_motor, stepper.a_ankle)
    _I[_I_DATA] = d._address
    _F[:] = 0.0
    _F[:11] = motor.law_args()
    _F[_F_PHI_MAX], _F[_F_GAM_MAX] = bounds["phi"], bounds["gamma"]
    from euc_sim.simulation.effects import SIGN_SPEED

    _F[_F_KDRAG], _F[_F_ROLL], _F[_F_V0], _F[_F_R] = drag[0], drag[1], SIGN_SPEED, stepper.p.R
    _I[[_I_BR, _I_BW, _I_SPIN]] = stepper.b_rider, stepper.b_wheel, int(stepper.spin)
    previous = mujoco.get_mjcb_control()
    mujoco.set_mjcb_control(callback.ctypes)
    try:
        _I[_I_PER] = _calls_per_step(m, d)
        _I[_I_EFF] = int(bool(drag[0] or drag[1]))
        _I[_I_CALLS] = _I[_I_K] = 0
        _I[_I_FALL] = -1
        _I[_I_ROWS] = N + 1
        _I[_I_STATE], _I[_I_MD], _I[_I_MH] = P[n:].ctypes.data, M_d.ctypes.data, M_h.ctypes.data
        phi_max, gam_max = bounds["phi"], bounds["gamma"]
        for k0 in range(0, N + 1, n + 1):
            block = min(n + 1, N + 1 - k0)
            if progress is not None:
                progress(k0 * dt)
            P[n + k0] = y0 if k0 == 0 else stepper.state()   # the callback records it again
            M_h[k0:k0 + block] = run.commands(k0, P[k0:k0 + block])[1]
            steps = block if k0 + block <= N else block - 1
            if steps:
                mujoco.mj_step(m, d, nstep=steps)
            if _I[_I_FALL] >= 0:
                k = int(_I[_I_FALL])
                try:
                    _check_falls(P[n + k:n + k + 1], k, dt, phi_max, gam_max, raise_fall)
                except FallError as exc:          # the states and torques of steps 0 … k − 1
                    exc.partial = (P[n:n + k].copy(), np.column_stack([M_d[:k], M_h[:k]]))
                    raise
    finally:
        mujoco.set_mjcb_control(previous)
    # the last state: after the last step, read as the Python stepper reads it
    y = stepper.state()
    P[n + N] = y
    P[n] = y0                                 # as given, not as read back from qpos
    try:
        _check_falls(P[n + N:n + N + 1], N, dt, phi_max, gam_max, raise_fall)
    except FallError as exc:
        exc.partial = (P[n:n + N].copy(), np.column_stack([M_d[:N], M_h[:N]]))
        raise
    M_d[N] = motor.torque(y[1], y[4], y[3])
    return P[n:], np.column_stack([M_d, M_h])


def _calls_per_step(m, d) -> int:
    """Callback calls per ``mj_step`` of this model (4 for RK4), counted on a copy of ``d``."""
    import mujoco

    probe = mujoco.MjData(m)
    mujoco.mj_copyData(probe, m, d)
    _I[_I_PER], _I[_I_CALLS], _I[_I_ROWS], _I[_I_FALL], _I[_I_DATA] = 1, 0, 0, -1, probe._address
    mujoco.mj_step(m, probe)
    calls = int(_I[_I_CALLS])
    _I[_I_DATA] = d._address
    if calls < 1:
        raise RuntimeError("the control callback was not called by mj_step")
    return calls


def _check_falls(rows: np.ndarray, k0: int, dt: float, phi_max: float, gam_max: float, raise_fall) -> None:
    """Raise at the first row with |φ| > φ_max, |γ| > γ_max or a non-finite value."""
    ok = (np.abs(rows[:, 2]) <= phi_max) & (np.abs(rows[:, 1]) <= gam_max) & np.isfinite(rows).all(axis=1)
    if not ok.all():
        j = int(np.argmin(ok))
        raise_fall((k0 + j) * dt, tuple(rows[j].tolist()), phi_max, gam_max)
