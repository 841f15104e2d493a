"""The layout of a native run's context: the slots of its int64 and float64 arrays.

Filled by :mod:`native_core`, read by :mod:`native_kernels`.  Int slots: the common
``C_*``, then ``P_*`` (planar) or ``S_*`` (spatial) with a rider block of ``R_*`` offsets;
a slot named for an array holds its address.  Float slots (at ``C_FLOATS``): the motor
law's settings, the held controls from ``F_HELD``, then the ``F_*``; a rider block's own
floats (``R_FLOATS``): dt, torque limit, z, K Φⁿ (6, zero-padded).
"""

KIND_PLANAR, KIND_SPATIAL, KIND_COUNT = 1, 2, 3
# common int slots: kind, callback calls, calls per step, next row k, rows, first fall (−1), floats, actuators
C_KIND, C_CALLS, C_PER, C_K, C_ROWS, C_FALL, C_FLOATS, C_NACT, C_ACT = range(9)   # C_ACT .. C_ACT + 3
# a rider block (controllers.rider.RiderRun): offsets from its first slot
R_VREF, R_GREF, R_PREF, R_UREF, R_NOISE, R_DU, R_KHIST, R_INTEGRAL, R_N, R_FLOATS = range(10)
# planar: state indices, padded history, torques, rider block (its R_* slots: 21 … 30)
P_IX, P_IG, P_IR, P_VX, P_VG, P_VR, P_HIST, P_MD, P_MH, P_RIDER = range(12, 22)
# planar held forces (effects.held_forces): on (0/1), F(t) on the grid (0: none), rider and
# wheel bodies, whether the wheel spins (the moment on it, else τ/R on x)
P_EFF, P_PUSH, P_BR, P_BW, P_SPIN = range(31, 36)
# planar lateral_dynamics and cog_height_drift: the tilt table (N, 5: sin ϑ, cos ϑ, ϑ̇, ψ̇, ψ̈) and the
# height table (N + 1, 3: h, ḣ, ḧ), 0: none; word offsets of body_ipos and site_pos in mjModel, the site G (−1: none)
P_LAT, P_DRIFT, P_W_BIPOS, P_W_SPOS, P_SITE_G = range(36, 41)
# spatial: qpos/qvel addresses, output rows, history, plan, path, lateral rider, fall kind, rider block
(S_RQ, S_RV, S_IP, S_IL, S_IT, S_VP, S_VL, S_VT, S_OUT, S_HIST, S_PLAN, S_PX, S_PY, S_PH, S_PK, S_PN, S_PI,
 S_ND, S_KP, S_KH, S_ZHIST, S_UHIST, S_K, S_FALL_KIND, S_RIDER) = range(12, 37)
C_SIZE = 48
# float slots: the motor law's settings (MotorPD.law_args) 0 … 10, then
F_HELD = 11                                        # the held controls, 11 … 14
(F_PHI_MAX, F_GAM_MAX, F_TILT, F_DT, F_LAT_LIM, F_G, F_XS, F_ZINT, F_UBAR, F_UBAR1, F_ABAR, F_XDOT, F_PSI,
 F_H, F_L0, F_EH, F_FALL_VALUE, F_KDRAG, F_CRR, F_NLOAD, F_R) = range(15, 36)
# lateral_dynamics' scale (lat_scale) and Table 3's mw, m0, m, h0, l0, h, R, g, Jw, J0, J (11, in this order,
# effects.lateral_force_row's); cog_height_drift reads m and l0 from there
F_LSCALE = 36
F_TABLE3 = 37                                      # 37 … 47
F_SIZE = 48
