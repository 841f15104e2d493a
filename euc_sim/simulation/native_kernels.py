"""The numba kernels of the native MuJoCo loops and the one control callback that runs them.

Imported only by :func:`euc_sim.simulation.native_core.build_callback` (it needs numba).
The callback looks its ``mjData`` up in the registry of :mod:`native_core` and runs that
simulation's kernel on its own context (int64 arrays laid out by :mod:`native_layout`),
so simulations on any threads never share state.  The laws are the project's pure
functions compiled: :func:`~euc_sim.controllers.motor.pd_torque`,
:func:`~euc_sim.controllers.rider.delayed_lqr_torque`, :func:`~euc_sim.simulation.effects.held_forces`,
:func:`~euc_sim.simulation.lateral.lateral_force_row` and :func:`~euc_sim.simulation.drift.drift_force_row`.
With ``cog_height_drift``, h_{k+1} is written into the model at the last callback call of
step k, before step k + 1 computes its positions.
"""

from __future__ import annotations

import hashlib
import math
import os
import stat
import sys

import numpy as np

from numba import carray, cfunc, config, njit, types
from numba.core.extending import intrinsic

from euc_sim.controllers import motor as motor_law, rider as rider_law
from euc_sim.controllers.motor import pd_torque
from euc_sim.controllers.rider import delayed_lqr_torque
from euc_sim.simulation import drift, effects, lateral
from euc_sim.simulation import native_layout as lay

__all__ = ["build_callback", "CACHE_DIR", "f64p", "i64p", "address", "held_forces", "lateral_force_row",
           "drift_force_row"]


def _source_hash() -> str:
    """Hash of every source compiled into the kernels (numba watches only this file): the cache folder's name."""
    h = hashlib.sha256()
    for module in (motor_law, rider_law, effects, lateral, drift, lay, sys.modules[__name__]):
        with open(module.__file__, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()[:16]


def _unsafe(path: str) -> str | None:
    """Why ``path`` may not hold code this process loads (numba unpickles its cache), or None:
    it must be a real folder of this user's, not writable by group or others.
    """
    st = os.lstat(path)
    if stat.S_ISLNK(st.st_mode):
        return "it is a symbolic link"
    if not stat.S_ISDIR(st.st_mode):
        return "it is not a folder"
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return f"it belongs to uid {st.st_uid}, not to this user ({os.getuid()})"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"the group or others can write to it (mode {stat.S_IMODE(st.st_mode):o})"
    return None


def _cache_dir() -> str | None:
    """numba's cache folder for these kernels, or None (compile in every process, one line on stderr).

    ``$NUMBA_CACHE_DIR/<hash>`` if set, else ``${XDG_CACHE_HOME:-~/.cache}/euc-sim/numba/<hash>``;
    made with mode 0700 and checked by :func:`_unsafe`.
    """
    if config.CACHE_DIR:
        top = os.path.abspath(config.CACHE_DIR)
        base, parts = os.path.dirname(top), [os.path.basename(top), _source_hash()]
    else:
        xdg = os.environ.get("XDG_CACHE_HOME", "")
        base = xdg if os.path.isabs(xdg) else os.path.join(os.path.expanduser("~"), ".cache")
        parts = ["euc-sim", "numba", _source_hash()]
    path = base
    try:
        if not os.path.isabs(base):
            raise OSError(0, "no home folder to cache in")
        _mkdirs(base)
        for part in parts:
            path = os.path.join(path, part)
            _mkdirs(path)
            why = _unsafe(path)
            if why:
                break
    except OSError as exc:
        why = exc.strerror or str(exc)
    if not why:
        return path
    print(f"euc-sim: warning: not caching compiled kernels in {path}: {why}", file=sys.stderr)
    return None


def _mkdirs(path: str) -> None:
    """Make ``path`` and its missing parents, each with mode 0700."""
    if not os.path.lexists(path):
        _mkdirs(os.path.dirname(path))
        try:
            os.mkdir(path, 0o700)
        except FileExistsError:
            pass


#: Where the compiled kernels are kept between processes (None: nowhere, see :func:`_cache_dir`).
CACHE_DIR = _cache_dir()


def _jit(fn):
    """``njit(cache=True)`` into :data:`CACHE_DIR`; plain ``njit`` where it cannot cache there."""
    if CACHE_DIR is None:
        return njit(fn)
    saved = config.CACHE_DIR
    config.CACHE_DIR = CACHE_DIR
    try:
        compiled = njit(cache=True)(fn)
    except Exception:  # noqa: BLE001 - numba found no usable location
        return njit(fn)
    finally:
        config.CACHE_DIR = saved
    if not compiled._cache.cache_path.startswith(CACHE_DIR + os.sep):    # numba's fallback location
        return njit(fn)
    return compiled


def _pointer_to(element):
    """An intrinsic casting an int64 address to a pointer to ``element``."""
    @intrinsic
    def cast(typingctx, addr):
        sig = types.CPointer(element)(types.int64)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))
        return sig, codegen
    return cast


f64p, i64p = _pointer_to(types.float64), _pointer_to(types.int64)


@intrinsic
def address(typingctx, ptr):
    """An intrinsic giving a pointer's address as an int64."""
    sig = types.int64(ptr)

    def codegen(context, builder, signature, args):
        return builder.ptrtoint(args[0], context.get_value_type(types.int64))
    return sig, codegen


_motor = _jit(pd_torque)
_rider_law = _jit(delayed_lqr_torque)
#: :func:`euc_sim.simulation.effects.held_forces` compiled (also the batch's, :mod:`mujoco_batch`).
held_forces = _jit(effects.held_forces)
#: :func:`euc_sim.simulation.lateral.lateral_force_row` and :func:`euc_sim.simulation.drift.drift_force_row` compiled.
lateral_force_row = _jit(lateral.lateral_force_row)
drift_force_row = _jit(drift.drift_force_row)


@_jit
def _rider(c, k, Y, r):
    """The longitudinal rider's applied M_h at step k (:meth:`RiderRun.command`); ``Y`` the
    padded state history, ``r`` the context slot of the rider's block.
    """
    n = c[r + lay.R_N]
    rf = f64p(c[r + lay.R_FLOATS])                 # dt, limit, z, K Φⁿ (6)
    y = Y[k]
    e_v = y[3] - f64p(c[r + lay.R_VREF])[k]
    z = rf[2]
    integral = c[r + lay.R_INTEGRAL] != 0
    if integral:
        rf[2] = z + e_v * rf[0]
    du = f64p(c[r + lay.R_DU])
    history = 0.0
    if n:    # numpy's dot in numba is BLAS's ddot, as numpy's own in RiderRun.command: the same sum
        history = np.dot(carray(f64p(c[r + lay.R_KHIST]), n), carray(f64p(c[r + lay.R_DU] + 8 * k), n))
    u_ref = f64p(c[r + lay.R_UREF])[k + n]
    u = _rider_law(e_v, y[1] - f64p(c[r + lay.R_GREF])[k], y[2] - f64p(c[r + lay.R_PREF])[k], y[4], y[5],
                   z, history, u_ref, carray(f64p(c[r + lay.R_FLOATS] + 24), 6), integral, rf[1])
    du[k + n] = u - u_ref
    return u + f64p(c[r + lay.R_NOISE])[k]


@_jit
def _motor_torque(f, gamma, gamma_dot, speed):
    return _motor(gamma, gamma_dot, speed, f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7], f[8],
                  f[9], f[10])


@_jit
def _hold_forces(qfrc, xfrc, c, f, k, x_dot):
    """Set the held forces of step k from ẋ at its start: F_x at G, the rolling moment on ``wheel`` or τ/R on x."""
    push = c[lay.P_PUSH]
    F, tau = held_forces(x_dot, f[lay.F_KDRAG], f[lay.F_CRR], f[lay.F_NLOAD], f[lay.F_R],
                         f64p(push)[k] if push != 0 else 0.0)
    xfrc[6 * c[lay.P_BR]] = F
    if c[lay.P_SPIN] != 0:
        xfrc[6 * c[lay.P_BW] + 4] = tau
    else:
        qfrc[c[lay.P_VX]] = 0.0 + tau / f[lay.F_R]


@_jit
def _hold_generalized(qfrc, c, f, k, row):
    """Add the held generalised forces of ``lateral_dynamics`` and ``cog_height_drift`` for step k
    (Q = lat_scale Q_lat + Q_h, paper coordinates) into ``qfrc_applied``.
    """
    Q0, Q1, Q2 = 0.0, 0.0, 0.0
    lat, dr = c[lay.P_LAT], c[lay.P_DRIFT]
    p = lay.F_TABLE3
    if lat != 0:
        T = f64p(lat + 40 * k)                  # sin ϑ, cos ϑ, ϑ̇, ψ̇, ψ̈ of step k
        r0, r1, r2 = lateral_force_row(
            f[p], f[p + 1], f[p + 2], f[p + 3], f[p + 4], f[p + 5], f[p + 6], f[p + 7], f[p + 8], f[p + 9],
            f[p + 10], math.sin(row[1]), math.cos(row[1]), math.sin(row[2]), math.cos(row[2]), row[3], row[4],
            row[5], T[0], T[1], T[2], T[3], T[4])
        s = f[lay.F_LSCALE]
        Q0, Q1, Q2 = s * r0, s * r1, s * r2
    if dr != 0:
        H = f64p(dr + 24 * k)                   # h, ḣ, ḧ of step k
        d0, d1, d2 = drift_force_row(f[p + 2], f[p + 4], H[0], H[1], H[2], row[1], row[2], row[5])
        if lat != 0:
            Q0, Q1, Q2 = Q0 + d0, Q1 + d1, Q2 + d2
        else:
            Q0, Q1, Q2 = d0, d1, d2
    Q_x = qfrc[c[lay.P_VX]] if c[lay.P_SPIN] == 0 else 0.0      # τ/R from _hold_forces
    qfrc[c[lay.P_VX]] = Q0 + Q_x
    qfrc[c[lay.P_VG]] = Q1 + Q2
    qfrc[c[lay.P_VR]] = Q2


@_jit
def _move_g(model, c, w_bipos, w_spos):
    """Write the next step's h into ``body_ipos`` of ``rider`` and ``site_pos`` of G."""
    k = c[lay.C_K]
    if k >= c[lay.C_ROWS]:
        return
    h = f64p(c[lay.P_DRIFT] + 24 * k)[0]
    f64p(model[w_bipos])[3 * c[lay.P_BR] + 2] = h
    if c[lay.P_SITE_G] >= 0:
        f64p(model[w_spos])[3 * c[lay.P_SITE_G] + 2] = h


@_jit
def planar_step(qpos, qvel, qfrc, xfrc, c, f):
    """One control step of the planar loop (:func:`euc_sim.simulation.native.native_loop`)."""
    k = c[lay.C_K]
    if k >= c[lay.C_ROWS]:
        return
    n = c[lay.P_RIDER + lay.R_N]
    Y = carray(f64p(c[lay.P_HIST]), (c[lay.C_ROWS] + n, 6))
    row = Y[k + n]
    if k > 0:                                     # row 0 is y0 as given
        g = qpos[c[lay.P_IG]]
        gd = qvel[c[lay.P_VG]]
        row[0] = qpos[c[lay.P_IX]]
        row[1] = g
        row[2] = g + qpos[c[lay.P_IR]]
        row[3] = qvel[c[lay.P_VX]]
        row[4] = gd
        row[5] = gd + qvel[c[lay.P_VR]]
    if c[lay.C_FALL] < 0:                          # the first fall: a bound passed or a non-finite state
        fine = abs(row[2]) <= f[lay.F_PHI_MAX] and abs(row[1]) <= f[lay.F_GAM_MAX]
        for j in range(6):
            fine = fine and row[j] - row[j] == 0.0
        if not fine:
            c[lay.C_FALL] = k
    M_d = _motor_torque(f, row[1], row[4], row[3])
    M_h = _rider(c, k, Y, lay.P_RIDER)
    if c[lay.P_EFF] != 0 and k + 1 < c[lay.C_ROWS]:    # not at the last row: no step follows it
        _hold_forces(qfrc, xfrc, c, f, k, row[3])
        if c[lay.P_LAT] != 0 or c[lay.P_DRIFT] != 0:
            _hold_generalized(qfrc, c, f, k, row)
    f64p(c[lay.P_MD])[k] = M_d
    f64p(c[lay.P_MH])[k] = M_h
    f[lay.F_HELD] = M_d
    f[lay.F_HELD + 1] = M_h
    c[lay.C_K] = k + 1


@_jit
def _nearest(c, X, Y):
    """(e_y, path heading, κ) of the nearest path point, searched forward (``spatial._Tracker``)."""
    Xs, Ys = f64p(c[lay.S_PX]), f64p(c[lay.S_PY])
    i, last = c[lay.S_PI], c[lay.S_PN] - 1
    d = (Xs[i] - X) ** 2 + (Ys[i] - Y) ** 2
    while i < last:
        d1 = (Xs[i + 1] - X) ** 2 + (Ys[i + 1] - Y) ** 2
        if d1 > d:
            break
        i, d = i + 1, d1
    c[lay.S_PI] = i
    h = f64p(c[lay.S_PH])[i]
    e_y = -math.sin(h) * (X - Xs[i]) + math.cos(h) * (Y - Ys[i])
    return e_y, h, f64p(c[lay.S_PK])[i]


@_jit
def _lateral(c, f, k, z):
    """(M_lean, M_twist) at step k from the lateral state z (``spatial._ride``'s law)."""
    lim = f[lay.F_LAT_LIM]
    nd = c[lay.S_ND]
    if nd:
        zh = carray(f64p(c[lay.S_ZHIST]), (c[lay.C_ROWS], 11))
        for j in range(11):
            zh[k, j] = z[j]
        zs = zh[max(k - nd, 0)]
        KP, KH, uh = f64p(c[lay.S_KP]), f64p(c[lay.S_KH]), f64p(c[lay.S_UHIST])
        u0 = _lateral_row(KP, zs, KH, uh, 0, k, nd, lim)
        u1 = _lateral_row(KP, zs, KH, uh, 1, k, nd, lim)
        ab = f[lay.F_ABAR]
        f[lay.F_UBAR] += ab * (u0 - f[lay.F_UBAR])
        f[lay.F_UBAR + 1] += ab * (u1 - f[lay.F_UBAR + 1])
        uh[2 * (k + nd)] = u0 - f[lay.F_UBAR]
        uh[2 * (k + nd) + 1] = u1 - f[lay.F_UBAR + 1]
        return u0, u1
    K = f64p(c[lay.S_K])
    acc0, acc1 = 0.0, 0.0
    for j in range(11):
        acc0 += K[j] * z[j]
    for j in range(11):
        acc1 += K[11 + j] * z[j]
    return max(-lim, min(lim, -acc0)), max(-lim, min(lim, -acc1))


@_jit
def _lateral_row(KP, zs, KH, uh, a, k, nd, lim):
    """Input a of the predicting lateral rider: −(K Φⁿ z_{k−n} + Σ K Φ^{n−1−i} Γ u_{k−n+i}), limited."""
    acc = 0.0
    for j in range(11):
        acc += KP[11 * a + j] * zs[j]
    hist = 0.0
    for j in range(2 * nd):
        hist += KH[2 * nd * a + j] * uh[2 * k + j]
    return max(-lim, min(lim, -(acc + hist)))


@_jit
def _pose(qp, rq, ip, il, f, out):
    """Rotation (row-major 9) into ``R`` and the sites C, E, G into the row (``spatial._pose``)."""
    w, x, y, z = qp[rq + 3], qp[rq + 4], qp[rq + 5], qp[rq + 6]
    R = (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
         2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
         2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))
    h, l0, e_h = f[lay.F_H], f[lay.F_L0], f[lay.F_EH]
    sp_, cp_, sl, cl = math.sin(qp[ip]), math.cos(qp[ip]), math.sin(qp[il]), math.cos(qp[il])
    gb0, gb1, gb2 = h * cl * sp_, -h * sl, h * cl * cp_ - l0
    for i in range(3):
        C = qp[rq + i]
        out[17 + i] = C
        out[20 + i] = C + R[3 * i + 2] * e_h
        out[23 + i] = C + R[3 * i] * gb0 + R[3 * i + 1] * gb1 + R[3 * i + 2] * gb2
    return R


@_jit
def _fall_3d(c, f, k, theta, phi, gamma):
    """Record the first fall at step k: its kind (``spatial._fall``'s order) and value."""
    if not (math.isfinite(theta) and math.isfinite(phi) and math.isfinite(gamma)):
        kind, value = 0, math.nan
    elif abs(theta) > f[lay.F_TILT]:
        kind, value = 1, theta
    elif abs(phi) > f[lay.F_PHI_MAX]:
        kind, value = 2, phi
    else:
        kind, value = 3, gamma
    c[lay.C_FALL], c[lay.S_FALL_KIND], f[lay.F_FALL_VALUE] = k, kind, value


@_jit
def spatial_step(qp, qv, c, f):
    """One control step of the 3-D loop (:func:`euc_sim.simulation.native_spatial.native_ride`)."""
    k = c[lay.C_K]
    if k >= c[lay.C_ROWS] or c[lay.C_FALL] >= 0:
        return
    rq, rv, dt = c[lay.S_RQ], c[lay.S_RV], f[lay.F_DT]
    if k > 0:                                     # the travelled distance: trapezoid over the last step
        psi0 = f[lay.F_PSI]
        f[lay.F_XS] += dt * 0.5 * (f[lay.F_XDOT] + (math.cos(psi0) * qv[rv] + math.sin(psi0) * qv[rv + 1]))
    out = carray(f64p(c[lay.S_OUT]), (c[lay.C_ROWS], 26))[k]
    R = _pose(qp, rq, c[lay.S_IP], c[lay.S_IL], f, out)
    psi = math.atan2(-R[1], R[4])
    theta = math.asin(max(-1.0, min(1.0, R[7])))
    gamma = math.atan2(-R[6], R[8])
    wl0, wl1, wl2 = qv[rv + 3], qv[rv + 4], qv[rv + 5]
    wx = R[0] * wl0 + R[1] * wl1 + R[2] * wl2
    wy = R[3] * wl0 + R[4] * wl1 + R[5] * wl2
    wz = R[6] * wl0 + R[7] * wl1 + R[8] * wl2
    cp, sp, ct, st = math.cos(psi), math.sin(psi), math.cos(theta), math.sin(theta)
    gamma_d = (-sp * wx + cp * wy) / ct
    theta_d = cp * wx + sp * wy
    psi_d = wz - gamma_d * st
    vX, vY = qv[rv], qv[rv + 1]
    x_dot = cp * vX + sp * vY
    phi, phi_d = gamma + qp[c[lay.S_IP]], gamma_d + qv[c[lay.S_VP]]
    if not (abs(theta) <= f[lay.F_TILT] and abs(phi) <= f[lay.F_PHI_MAX] and abs(gamma) <= f[lay.F_GAM_MAX]):
        _fall_3d(c, f, k, theta, phi, gamma)
        return
    n = c[lay.S_RIDER + lay.R_N]
    Y = carray(f64p(c[lay.S_HIST]), (c[lay.C_ROWS] + n, 6))
    x_s = f[lay.F_XS]
    Y[k + n, 0], Y[k + n, 1], Y[k + n, 2] = x_s, gamma, phi
    Y[k + n, 3], Y[k + n, 4], Y[k + n, 5] = x_dot, gamma_d, phi_d
    M_d = _motor_torque(f, gamma, gamma_d, x_dot)
    M_h = _rider(c, k, Y, lay.S_RIDER)
    e_y, h_p, kap = _nearest(c, qp[rq], qp[rq + 1])
    a = psi - h_p + math.pi
    z = (e_y, a % (2.0 * math.pi) - math.pi, theta + math.atan(x_dot * x_dot * kap / f[lay.F_G]),
         qp[c[lay.S_IL]], qp[c[lay.S_IT]], -math.sin(h_p) * vX + math.cos(h_p) * vY, theta_d,
         psi_d - x_dot * kap, qv[c[lay.S_VL]], qv[c[lay.S_VT]], f[lay.F_ZINT])
    u_l, u_t = _lateral(c, f, k, z)
    row = (k * dt, x_s, gamma, phi, x_dot, gamma_d, phi_d, M_d, M_h, f64p(c[lay.S_PLAN])[k], psi,
           theta, psi_d, theta_d, u_l, u_t, e_y)
    for j in range(17):
        out[j] = row[j]
    f[lay.F_ZINT] += e_y * dt
    f[lay.F_XDOT], f[lay.F_PSI] = x_dot, psi
    f[lay.F_HELD], f[lay.F_HELD + 1], f[lay.F_HELD + 2], f[lay.F_HELD + 3] = M_d, M_h, u_l, u_t
    c[lay.C_K] = k + 1


def build_callback(w_qpos: int, w_qvel: int, w_ctrl: int, w_qfrc: int, w_xfrc: int, w_bipos: int,
                   w_spos: int, registry_address: int, slots: int):
    """The cfunc ``void(const mjModel*, mjData*)``: find ``d`` in the registry, run its kernel.

    ``w_*``: word offsets of the ``mjData`` (``mjModel`` for ``w_bipos``, ``w_spos``) fields.
    The kernel runs at the first of the ``c[C_PER]`` calls of each step; every call writes
    the held controls.
    """
    @cfunc(types.void(types.CPointer(types.int64), types.CPointer(types.int64)))
    def control(m, d):
        reg = carray(i64p(registry_address), 2 * slots)
        me = address(d)
        for s in range(slots):
            if reg[2 * s] == me:
                c = carray(i64p(reg[2 * s + 1]), lay.C_SIZE)
                calls = c[lay.C_CALLS]
                c[lay.C_CALLS] = calls + 1
                kind = c[lay.C_KIND]
                if kind == lay.KIND_COUNT:
                    return
                f = carray(f64p(c[lay.C_FLOATS]), lay.F_SIZE)
                if calls % c[lay.C_PER] == 0:
                    qpos, qvel = f64p(d[w_qpos]), f64p(d[w_qvel])
                    if kind == lay.KIND_PLANAR:
                        planar_step(qpos, qvel, f64p(d[w_qfrc]), f64p(d[w_xfrc]), c, f)
                    else:
                        spatial_step(qpos, qvel, c, f)
                if kind == lay.KIND_PLANAR and c[lay.P_DRIFT] != 0 and calls % c[lay.C_PER] == c[lay.C_PER] - 1:
                    _move_g(m, c, w_bipos, w_spos)
                ctrl = f64p(d[w_ctrl])
                for a in range(c[lay.C_NACT]):
                    ctrl[c[lay.C_ACT + a]] = f[lay.F_HELD + a]
                return

    return control
