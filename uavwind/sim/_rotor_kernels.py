"""Numba kernels of the multirotor: RotorPy 3.0.0's ``Multirotor`` physics, one environment at a
time, batched by a loop (the same formulas as ``rotorpy/vehicles/multirotor.py``; the tests hold
them to RotorPy's own methods, 1e-12 of each block's scale).

State, one row ``s`` per environment, exactly ``Multirotor._pack_state``'s layout (20 numbers:
position, velocity, attitude quaternion, body rates, wind, rotor speeds), and the parameter
vector ``P`` (:func:`uavwind.sim.multirotor.Multirotor.packed`: the vehicle, its rotors, its
controllers' gains): both are indexed only through the names of ``uavwind.sim._slots``, which
gives every slot and column with its unit. Mode 3 adds three state columns,
``s[S_INTEGRAL]``, the integral of the position error [m s].

Flat-output row ``f`` (modes 2 and 3, ``SE3Control``), 11 numbers: ``x``, ``x_dot``,
``x_ddot``, ``yaw``, ``yaw_dot`` (``_slots``' ``FLAT_*``; the jerk and snap RotorPy's flat
outputs carry are not used by ``SE3Control``); its other outputs go to a row ``aux``
(``_slots``' ``CMD_*``).

One :func:`control_step` is ``Multirotor.step`` with a fixed-step integrator: the command is
mapped to motor speeds from the state at the start of the step and clipped, then held (with
the wind) for ``n_sub`` classical RK4 substeps, and the quaternion is renormalised. The
command is RotorPy's ``cmd_ctatt`` (mode 0), ``cmd_ctbr`` (mode 1), or the motor speeds of
``rotorpy.controllers.quadrotor_control.SE3Control.update`` flying a flat output (mode 2,
position control; :func:`se3_commands` gives all its outputs), or the same law with an
integral term and a thrust cone with vertical priority (mode 3, :func:`_se3i`: PX4's position
controller's structure, PX4 ``MPC_TILTMAX_AIR`` / ``MPC_THR_MIN`` / ``MPC_THR_MAX``), or mode
3 flown with an imperfect state: an attitude estimate off the true attitude by a small world
rotation, a thrust that differs from the commanded by a relative error and a velocity
estimate off by a vector (mode 4, all given
per control step in the flat-output row's ``FLAT_ERR`` columns; :func:`_se3i` with ``err``).

Two loops run a whole flight of control steps here instead of one Python call per step (a
step of a few environments costs microseconds; Python's loop around it cost more):
:func:`fly_flat`, ``Multirotor.fly_reference``'s loop when its wind reads no position (the
winds of every step given), and :func:`fly_rows`, a rollout's segment of held attitude
commands (its wind table's lookup computed in the loop). Each gives the doubles of the
Python loop it replaces (tests/test_position_control.py, tests/test_rollout.py).
"""

import math

import numpy as np
from numba import njit

from ._slots import (AERO, C_D, CMD_ACC, CMD_MOMENT, CMD_Q, CMD_THRUST, CMD_W, FLAT_ACC,
                     FLAT_ERR, FLAT_POS, FLAT_VEL, FLAT_YAW, FLAT_YAW_RATE, G, INERTIA, INERTIA_INV,
                     INTEGRAL_ACC, K_D, K_ETA, K_FLAP, K_H, K_M, K_W, K_Z, KD_ATT, KD_POS, KI_POS,
                     KP_ATT, KP_POS, LAYOUT, MASS, N_CMD, N_FLAT, N_STATE, ROTOR_DIR, ROTOR_POS,
                     S_INTEGRAL, S_POS, S_QUAT, S_RATES, S_ROTORS, S_VEL, S_WIND, SE3_KD_ATT,
                     SE3_KP_ATT, SPEED_MAX, SPEED_MIN, TAN_TILT, TAU_M, THRUST_HIGH, THRUST_LOW,
                     TM_TO_F)

_NB = dict(cache=True, nogil=True, error_model="numpy")


@njit(**_NB)
def compiled_layout():
    """``uavwind.sim._slots.LAYOUT`` as these kernels were compiled with it: numba freezes
    another module's globals into its on-disk cache, which only a change of this file
    renews."""
    return LAYOUT


@njit(**_NB)
def _rotmat(q, R):
    """scipy ``Rotation.from_quat(q).as_matrix()`` (normalising), written into R (3, 3)."""
    nrm = math.sqrt((q[0] * q[0] + q[1] * q[1] + q[2] * q[2]) + q[3] * q[3])
    x = q[0] / nrm
    y = q[1] / nrm
    z = q[2] / nrm
    w = q[3] / nrm
    x2 = x * x
    y2 = y * y
    z2 = z * z
    w2 = w * w
    xy = x * y
    zw = z * w
    xz = x * z
    yw = y * w
    yz = y * z
    xw = x * w
    R[0, 0] = x2 - y2 - z2 + w2
    R[1, 0] = 2 * (xy + zw)
    R[2, 0] = 2 * (xz - yw)
    R[0, 1] = 2 * (xy - zw)
    R[1, 1] = - x2 + y2 - z2 + w2
    R[2, 1] = 2 * (yz + xw)
    R[0, 2] = 2 * (xz + yw)
    R[1, 2] = 2 * (yz - xw)
    R[2, 2] = - x2 - y2 + z2 + w2


@njit(**_NB)
def _sdot(P, s, u, out, R):
    """``Multirotor._s_dot_fn`` for one environment: s, out (20,) (``uavwind.sim._slots``'
    columns), u clipped motor speeds (4,)."""
    m = P[MASS]
    _rotmat(s[S_QUAT], R)
    for i in range(3):
        out[S_POS.start + i] = s[S_VEL.start + i]           # x_dot = v
    inv_tau = 1 / P[TAU_M]
    speeds = s[S_ROTORS]
    for k in range(4):
        out[S_ROTORS.start + k] = inv_tau * (u[k] - speeds[k])  # first-order motors
    q = s[S_QUAT]
    w = s[S_RATES]
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    w0, w1, w2 = w[0], w[1], w[2]
    q_dot = out[S_QUAT]
    q_dot[0] = 0.5 * (q3 * w0 - q2 * w1 + q1 * w2)          # quaternion rate (raw q)
    q_dot[1] = 0.5 * (q2 * w0 + q3 * w1 - q0 * w2)
    q_dot[2] = 0.5 * (-q1 * w0 + q0 * w1 + q3 * w2)
    q_dot[3] = 0.5 * (-q0 * w0 - q1 * w1 - q2 * w2)
    v = s[S_VEL]
    wind = s[S_WIND]
    d0 = v[0] - wind[0]
    d1 = v[1] - wind[1]
    d2 = v[2] - wind[2]
    va0 = R[0, 0] * d0 + R[1, 0] * d1 + R[2, 0] * d2        # body airspeed R^T (v - wind)
    va1 = R[0, 1] * d0 + R[1, 1] * d1 + R[2, 1] * d2
    va2 = R[0, 2] * d0 + R[1, 2] * d1 + R[2, 2] * d2
    aero = P[AERO] != 0.0
    k_eta, k_m, k_d, k_z, k_h, k_flap = P[K_ETA], P[K_M], P[K_D], P[K_Z], P[K_H], P[K_FLAP]
    rotor_pos = P[ROTOR_POS]                                # 4 x 3, row k rotor k's x, y, z
    rotor_dir = P[ROTOR_DIR]
    F0 = 0.0
    F1 = 0.0
    F2 = 0.0
    M0 = 0.0
    M1 = 0.0
    M2 = 0.0
    Mr0 = 0.0
    Mr1 = 0.0
    Mr2 = 0.0
    for k in range(4):
        rx, ry, rz = rotor_pos[3 * k], rotor_pos[3 * k + 1], rotor_pos[3 * k + 2]
        om = speeds[k]
        om2 = om * om
        Tz = k_eta * om2
        Hx = 0.0
        Hy = 0.0
        Mf0 = 0.0
        Mf1 = 0.0
        if aero:
            la0 = va0 + (-w2 * ry + w1 * rz)                # local airspeed va + w x r_k
            la1 = va1 + (w2 * rx - w0 * rz)
            la2 = va2 + (-w1 * rx + w0 * ry)
            Tz = Tz + k_h * (la0 * la0 + la1 * la1)          # translational lift
            Hx = -om * (k_d * la0)                          # rotor drag (H-force)
            Hy = -om * (k_d * la1)
            Tz = Tz + -om * (k_z * la2)
            kf = -k_flap * om                               # flapping moment
            Mf0 = kf * la1
            Mf1 = kf * -la0
        F0 += Hx
        F1 += Hy
        F2 += Tz
        M0 += ry * Tz - rz * Hy                             # r_k x F_k
        M1 += rz * Hx - rx * Tz
        M2 += rx * Hy - ry * Hx
        Mr0 += Mf0
        Mr1 += Mf1
        Mr2 += rotor_dir[k] * (k_m * om2)                   # rotor yaw torque
    if aero:
        vn = math.sqrt(va0 * va0 + va1 * va1 + va2 * va2)
        c_d = P[C_D]
        F0 = F0 + (-vn * c_d[0]) * va0                      # quadratic frame drag
        F1 = F1 + (-vn * c_d[1]) * va1
        F2 = F2 + (-vn * c_d[2]) * va2
    M0 = M0 + Mr0
    M1 = M1 + Mr1
    M2 = M2 + Mr2
    for i in range(3):                                      # v_dot = (weight + R F) / m
        Fi = R[i, 0] * F0 + R[i, 1] * F1 + R[i, 2] * F2
        out[S_VEL.start + i] = ((-m * P[G] if i == 2 else 0.0) + Fi) / m
    I = P[INERTIA]
    Iw0 = I[0] * w0 + I[1] * w1 + I[2] * w2
    Iw1 = I[3] * w0 + I[4] * w1 + I[5] * w2
    Iw2 = I[6] * w0 + I[7] * w1 + I[8] * w2
    g0 = M0 - (w1 * Iw2 - w2 * Iw1)                          # M - w x I w
    g1 = M1 - (w2 * Iw0 - w0 * Iw2)
    g2 = M2 - (w0 * Iw1 - w1 * Iw0)
    Ji = P[INERTIA_INV]
    w_dot = out[S_RATES]
    w_dot[0] = Ji[0] * g0 + Ji[1] * g1 + Ji[2] * g2
    w_dot[1] = Ji[3] * g0 + Ji[4] * g1 + Ji[5] * g2
    w_dot[2] = Ji[6] * g0 + Ji[7] * g1 + Ji[8] * g2
    for i in range(S_WIND.start, S_WIND.stop):
        out[i] = 0.0                                        # the wind is held


@njit(**_NB)
def _speeds(P, T, M0, M1, M2, u):
    """Collective thrust and body moments -> signed motor speeds ``sign(f) sqrt(|f| / k_eta)``."""
    A = P[TM_TO_F]                                          # 4 x 4, row k rotor k's force
    for k in range(4):
        f = A[4 * k] * T + A[4 * k + 1] * M0 + A[4 * k + 2] * M1 + A[4 * k + 3] * M2
        sp = f / P[K_ETA]
        r = math.sqrt(abs(sp))
        u[k] = -r if sp < 0 else (r if sp > 0 else (0.0 if sp == 0 else sp))


@njit(**_NB)
def _attitude_law(P, s, R, Rd, kp, kd, wz_des):
    """The geometric attitude law ``cmd_ctatt`` and ``SE3Control`` share: from the body
    rotation R and the desired one Rd (3, 3), the error ``e = vee(Rd^T R - R^T Rd) / 2`` and
    the angular acceleration ``a = -kp e - kd (w - (0, 0, wz_des))``, the moments
    ``M = I a + w x (I w)``. Returns ``(M0, M1, M2, a0, a1, a2)``."""
    skew = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            a = Rd[0, i] * R[0, j] + Rd[1, i] * R[1, j] + Rd[2, i] * R[2, j]
            b = R[0, i] * Rd[0, j] + R[1, i] * Rd[1, j] + R[2, i] * Rd[2, j]
            skew[i, j] = 0.5 * (a - b)
    e0, e1, e2 = -skew[1, 2], skew[0, 2], -skew[0, 1]
    w = s[S_RATES]
    w0, w1, w2 = w[0], w[1], w[2]
    a0 = -kp * e0 - kd * w0
    a1 = -kp * e1 - kd * w1
    a2 = -kp * e2 - kd * (w2 - wz_des)
    I = P[INERTIA]
    Iw0 = I[0] * w0 + I[1] * w1 + I[2] * w2
    Iw1 = I[3] * w0 + I[4] * w1 + I[5] * w2
    Iw2 = I[6] * w0 + I[7] * w1 + I[8] * w2
    M0 = I[0] * a0 + I[1] * a1 + I[2] * a2 + (w1 * Iw2 - w2 * Iw1)
    M1 = I[3] * a0 + I[4] * a1 + I[5] * a2 + (w2 * Iw0 - w0 * Iw2)
    M2 = I[6] * a0 + I[7] * a1 + I[8] * a2 + (w0 * Iw1 - w1 * Iw0)
    return M0, M1, M2, a0, a1, a2


@njit(**_NB)
def _cmd_ctatt(P, s, T, qd, u, R, Rd):
    """``cmd_ctatt``: collective thrust T [N] and attitude qd -> unclipped motor speeds u."""
    _rotmat(s[S_QUAT], R)
    _rotmat(qd, Rd)
    M0, M1, M2, _, _, _ = _attitude_law(P, s, R, Rd, P[KP_ATT], P[KD_ATT], 0.0)
    _speeds(P, T, M0, M1, M2, u)


@njit(**_NB)
def _cmd_ctbr(P, s, T, wd, u):
    """``cmd_ctbr``: collective thrust T [N] and body rates wd -> unclipped motor speeds u."""
    kw = P[K_W]
    w = s[S_RATES]
    a0 = -kw * (w[0] - wd[0])
    a1 = -kw * (w[1] - wd[1])
    a2 = -kw * (w[2] - wd[2])
    I = P[INERTIA]
    _speeds(P, T, I[0] * a0 + I[1] * a1 + I[2] * a2, I[3] * a0 + I[4] * a1 + I[5] * a2,
            I[6] * a0 + I[7] * a1 + I[8] * a2, u)


@njit(**_NB)
def _quat_from_matrix(M, q):
    """scipy ``Rotation.from_matrix(M).as_quat()`` for an orthonormal M (Shepperd's method,
    the branch of the largest of the diagonal and the trace, then normalised), into q (4,)."""
    tr = M[0, 0] + M[1, 1] + M[2, 2]
    c = 0
    best = M[0, 0]
    if M[1, 1] > best:
        c = 1
        best = M[1, 1]
    if M[2, 2] > best:
        c = 2
        best = M[2, 2]
    if tr > best:
        c = 3
    if c == 0:
        q[0] = 1 - tr + 2 * M[0, 0]
        q[1] = M[1, 0] + M[0, 1]
        q[2] = M[2, 0] + M[0, 2]
        q[3] = M[2, 1] - M[1, 2]
    elif c == 1:
        q[0] = M[1, 0] + M[0, 1]
        q[1] = 1 - tr + 2 * M[1, 1]
        q[2] = M[2, 1] + M[1, 2]
        q[3] = M[0, 2] - M[2, 0]
    elif c == 2:
        q[0] = M[2, 0] + M[0, 2]
        q[1] = M[2, 1] + M[1, 2]
        q[2] = 1 - tr + 2 * M[2, 2]
        q[3] = M[1, 0] - M[0, 1]
    else:
        q[0] = M[2, 1] - M[1, 2]
        q[1] = M[0, 2] - M[2, 0]
        q[2] = M[1, 0] - M[0, 1]
        q[3] = 1 + tr
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        q[i] = q[i] / n


@njit(**_NB)
def _se3(P, s, f, u, R, Rd, aux):
    """``SE3Control.update`` for one environment: the state row s (20,) and the flat-output row
    f (11,) = ``x`` (3), ``x_dot`` (3), ``x_ddot`` (3), ``yaw``, ``yaw_dot`` -> the unclipped
    motor speeds u (4,) and, in aux (14,), ``cmd_thrust`` [N], ``cmd_moment`` (3) [N m],
    ``cmd_q`` (4), ``cmd_acc`` (3) [m/s^2] (``F_des / m``) and ``cmd_w`` (3) [rad/s]; R and
    Rd (3, 3) are scratch (Rd ends as the desired attitude)."""
    m = P[MASS]
    g = P[G]
    kp = P[KP_POS]
    kd = P[KD_POS]
    x = s[S_POS]
    v = s[S_VEL]
    x_ref = f[FLAT_POS]
    v_ref = f[FLAT_VEL]
    a_ref = f[FLAT_ACC]
    F0 = m * ((-(kp[0] * (x[0] - x_ref[0])) - kd[0] * (v[0] - v_ref[0])) + a_ref[0])
    F1 = m * ((-(kp[1] * (x[1] - x_ref[1])) - kd[1] * (v[1] - v_ref[1])) + a_ref[1])
    F2 = m * (((-(kp[2] * (x[2] - x_ref[2])) - kd[2] * (v[2] - v_ref[2])) + a_ref[2]) + g)
    _se3_force(P, s, f, F0, F1, F2, u, R, Rd, aux, False, False)


@njit(**_NB)
def _yaw_share(P, T, M0, M1, M2):
    """The largest share ``c`` in [0, 1] of the yaw moment ``M2`` [N m] with which every
    rotor's force for ``(T, M0, M1, c M2)`` lies within the rotors' range (``k_eta`` times
    the square of the speed range); 0 when none does (then the clipping takes its course).
    A multirotor makes yaw moments weakly (through its rotors' drag torque), and a large
    frame's yaw inertia grows with the square of its arms: a flight controller gives up yaw
    before roll, pitch and thrust (PX4's mixer does)."""
    lo = P[K_ETA] * P[SPEED_MIN] * P[SPEED_MIN]
    hi = P[K_ETA] * P[SPEED_MAX] * P[SPEED_MAX]
    A = P[TM_TO_F]
    c_lo = 0.0
    c_hi = 1.0
    for k in range(4):
        base = A[4 * k] * T + A[4 * k + 1] * M0 + A[4 * k + 2] * M1
        slope = A[4 * k + 3] * M2
        if slope == 0.0:
            if base < lo or base > hi:
                return 0.0
            continue
        a = (lo - base) / slope
        b = (hi - base) / slope
        if a > b:
            a, b = b, a
        c_lo = max(c_lo, a)
        c_hi = min(c_hi, b)
    if c_hi < c_lo or c_hi < 0.0:
        return 0.0
    return c_hi


@njit(**_NB)
def _se3i(P, s, f, h, u, R, Rd, aux, err):
    """SE3 with an integral term and a thrust cone (mode 3), for one environment; with
    ``err`` (mode 4) flown on the imperfect state of ``f[FLAT_ERR]``: its velocity read off by
    the last three columns [m/s], the attitude and thrust as :func:`_se3_force` says.

    The desired force is SE3's plus ``-m ki I``, ``I = s[S_INTEGRAL]`` the integral of the
    position error [m s]; then, as PX4's position controller limits its thrust set-point
    with vertical priority, its vertical part is held within [least, most] collective
    thrust and its horizontal part shortened to stay within the tilt cone
    ``|F_h| <= F_z tan(max tilt)`` and within the most thrust. The integral advances by
    ``h`` [s] of position error unless the force was limited (conditional integration, the
    anti-windup), each axis clipped so that ``|ki I|`` stays within its bound."""
    m = P[MASS]
    g = P[G]
    kp = P[KP_POS]
    kd = P[KD_POS]
    ki = P[KI_POS]
    x = s[S_POS]
    v = s[S_VEL]
    integral = s[S_INTEGRAL]
    x_ref = f[FLAT_POS]
    v_ref = f[FLAT_VEL]
    a_ref = f[FLAT_ACC]
    e0 = x[0] - x_ref[0]
    e1 = x[1] - x_ref[1]
    e2 = x[2] - x_ref[2]
    d0 = v[0] - v_ref[0]
    d1 = v[1] - v_ref[1]
    d2 = v[2] - v_ref[2]
    if err:  # the velocity as estimated
        d0 = d0 + f[FLAT_ERR.start + 3]
        d1 = d1 + f[FLAT_ERR.start + 4]
        d2 = d2 + f[FLAT_ERR.start + 5]
    F0 = m * (-kp[0] * e0 - kd[0] * d0 - ki[0] * integral[0] + a_ref[0])
    F1 = m * (-kp[1] * e1 - kd[1] * d1 - ki[1] * integral[1] + a_ref[1])
    F2 = m * (-kp[2] * e2 - kd[2] * d2 - ki[2] * integral[2] + a_ref[2] + g)
    limited = False
    lo, hi = P[THRUST_LOW], P[THRUST_HIGH]
    if F2 < lo:
        F2 = lo
        limited = True
    elif F2 > hi:
        F2 = hi
        limited = True
    fh = math.sqrt(F0 * F0 + F1 * F1)
    fh_max = min(F2 * P[TAN_TILT], math.sqrt(max(hi * hi - F2 * F2, 0.0)))
    if fh > fh_max:
        c = fh_max / fh
        F0 = F0 * c
        F1 = F1 * c
        limited = True
    if not limited:
        for k in range(3):
            if ki[k] > 0.0:
                lim = P[INTEGRAL_ACC] / ki[k]
                i_k = integral[k] + h * (x[k] - x_ref[k])
                integral[k] = min(max(i_k, -lim), lim)
    _se3_force(P, s, f, F0, F1, F2, u, R, Rd, aux, True, err)


@njit(**_NB)
def _tilt_error(R, ex, ey):
    """R (3, 3) replaced, in place, by ``E R`` with ``E`` the rotation by the rotation vector
    ``(ex, ey, 0)`` [rad] (world frame, Rodrigues' formula): an attitude estimate tilted off
    the true attitude."""
    th = math.sqrt(ex * ex + ey * ey)
    if th == 0.0:
        return
    kx = ex / th
    ky = ey / th
    c = math.cos(th)
    sn = math.sin(th)
    v = 1.0 - c
    E00 = c + kx * kx * v
    E01 = kx * ky * v
    E02 = ky * sn
    E10 = kx * ky * v
    E11 = c + ky * ky * v
    E12 = -kx * sn
    E20 = -ky * sn
    E21 = kx * sn
    E22 = c
    for j in range(3):
        a0 = R[0, j]
        a1 = R[1, j]
        a2 = R[2, j]
        R[0, j] = E00 * a0 + E01 * a1 + E02 * a2
        R[1, j] = E10 * a0 + E11 * a1 + E12 * a2
        R[2, j] = E20 * a0 + E21 * a1 + E22 * a2


@njit(**_NB)
def _se3_force(P, s, f, F0, F1, F2, u, R, Rd, aux, yaw_last, err):
    """The rest of ``SE3Control.update`` from the desired force ``F`` [N] (world frame): the
    desired attitude (body z along ``F``, yaw ``f[FLAT_YAW]``), the collective thrust ``F . b3``,
    the attitude law and the motor speeds u; aux as :func:`_se3`. With ``yaw_last`` the yaw
    moment is shortened first when the rotors cannot make all four (:func:`_yaw_share`).
    With ``err`` (mode 4) the law reads the attitude estimate ``E R``, ``E`` the rotation of
    ``f[FLAT_ERR]``'s first two columns (:func:`_tilt_error`; the body rates are read true),
    and the rotors make ``1 + f[FLAT_ERR][2]`` times the commanded thrust (``aux`` keeps the
    commanded)."""
    m = P[MASS]
    _rotmat(s[S_QUAT], R)
    if err:
        _tilt_error(R, f[FLAT_ERR.start], f[FLAT_ERR.start + 1])
    u1 = F0 * R[0, 2] + F1 * R[1, 2] + F2 * R[2, 2]          # F_des . b3
    nF = math.sqrt(F0 * F0 + F1 * F1 + F2 * F2)
    b30 = F0 / nF
    b31 = F1 / nF
    b32 = F2 / nF
    c0 = math.cos(f[FLAT_YAW])
    c1 = math.sin(f[FLAT_YAW])
    x0 = b31 * 0.0 - b32 * c1                                # b3_des x c1_des
    x1 = b32 * c0 - b30 * 0.0
    x2 = b30 * c1 - b31 * c0
    nx = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    b20 = x0 / nx
    b21 = x1 / nx
    b22 = x2 / nx
    Rd[0, 0] = b21 * b32 - b22 * b31                         # b1_des = b2_des x b3_des
    Rd[1, 0] = b22 * b30 - b20 * b32
    Rd[2, 0] = b20 * b31 - b21 * b30
    Rd[0, 1] = b20
    Rd[1, 1] = b21
    Rd[2, 1] = b22
    Rd[0, 2] = b30
    Rd[1, 2] = b31
    Rd[2, 2] = b32
    M0, M1, M2, a0, a1, a2 = _attitude_law(P, s, R, Rd, P[SE3_KP_ATT], P[SE3_KD_ATT],
                                             f[FLAT_YAW_RATE])
    if yaw_last:
        M2 = M2 * _yaw_share(P, u1, M0, M1, M2)
    if err:
        _speeds(P, u1 * (1.0 + f[FLAT_ERR.start + 2]), M0, M1, M2, u)
    else:
        _speeds(P, u1, M0, M1, M2, u)
    aux[CMD_THRUST] = u1
    moment = aux[CMD_MOMENT]
    moment[0] = M0
    moment[1] = M1
    moment[2] = M2
    _quat_from_matrix(Rd, aux[CMD_Q])
    acc = aux[CMD_ACC]
    acc[0] = F0 / m
    acc[1] = F1 / m
    acc[2] = F2 / m
    cmd_w = aux[CMD_W]
    cmd_w[0] = a0
    cmd_w[1] = a1
    cmd_w[2] = a2


@njit(**_NB)
def control_step(P, S, T, C, mode, n_sub, h, clipped):
    """Advance every environment by one control step of ``n_sub * h`` [s], in place.

    ``S`` (n, 20) states, wind columns already set for this step; ``T`` (n,) collective
    thrust [N]; ``C`` (n, 4) attitude quaternions (``mode`` 0, ``cmd_ctatt``), (n, 3) body
    rates (``mode`` 1, ``cmd_ctbr``) or (n, 11) flat-output rows (``mode`` 2, ``SE3Control``:
    then ``T`` is an output, the commanded collective thrust ``cmd_thrust`` of the step;
    ``mode`` 3, the same law with an integral term and a thrust cone, :func:`_se3i`: then
    ``S`` is (n, 23), its last three columns the integral of the position error; ``mode`` 4,
    mode 3 on an imperfect state, ``C`` (n, 17) with the errors in ``FLAT_ERR``);
    ``clipped`` (n,) counts the steps in which a motor command was clipped to the motors'
    range.
    """
    n = S.shape[0]
    R = np.empty((3, 3))
    Rd = np.empty((3, 3))
    u = np.empty(4)
    k1 = np.empty(N_STATE)
    k2 = np.empty(N_STATE)
    k3 = np.empty(N_STATE)
    k4 = np.empty(N_STATE)
    tmp = np.empty(N_STATE)
    aux = np.empty(N_CMD)
    for i in range(n):
        s = S[i]
        if mode == 0:
            _cmd_ctatt(P, s, T[i], C[i], u, R, Rd)
        elif mode == 1:
            _cmd_ctbr(P, s, T[i], C[i], u)
        elif mode == 2:
            _se3(P, s, C[i], u, R, Rd, aux)
            T[i] = aux[CMD_THRUST]
        else:
            _se3i(P, s, C[i], n_sub * h, u, R, Rd, aux, mode == 4)
            T[i] = aux[CMD_THRUST]
        hit = False
        for k in range(4):                                   # np.clip(cmd, min, max)
            c = min(max(u[k], P[SPEED_MIN]), P[SPEED_MAX])
            if c != u[k]:
                hit = True
            u[k] = c
        if hit:
            clipped[i] += 1
        for _ in range(n_sub):
            _sdot(P, s, u, k1, R)
            for j in range(N_STATE):
                tmp[j] = s[j] + (0.5 * h) * k1[j]
            _sdot(P, tmp, u, k2, R)
            for j in range(N_STATE):
                tmp[j] = s[j] + (0.5 * h) * k2[j]
            _sdot(P, tmp, u, k3, R)
            for j in range(N_STATE):
                tmp[j] = s[j] + h * k3[j]
            _sdot(P, tmp, u, k4, R)
            for j in range(N_STATE):
                s[j] = s[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        q = s[S_QUAT]
        qn = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        for j in range(4):
            q[j] = q[j] / qn


@njit(**_NB)
def fly_flat(P, S, F, E, W, mode, n_sub, h, per, T, clipped, positions, before, states,
             commands, record):
    """Fly every environment through the flat-output rows ``F`` (n_ctrl + 1, N_FLAT), one
    :func:`control_step` each (modes 2-4), in place: ``Multirotor.fly_reference``'s loop for a
    wind that reads no position, its winds given per step, ``W`` (n_ctrl, n, 3) [m/s].

    ``E`` (n, n_ctrl, 6), mode 4 only, each step's state errors (copied into the row's
    ``FLAT_ERR`` columns); ``per`` control steps make a sample. After each sample's last step
    its positions go to ``positions`` (n, n_samples, 3) and, with ``record``, the state
    before that step to ``before``, after it to ``states`` (n, n_samples, n_state) and the
    commanded thrust to ``commands`` (n, n_samples). ``T`` (n,) ends as the last step's
    command. Returns ``(status, k, i)``: 0 when every step was flown; else the flight stopped
    after step ``k`` because environment ``i`` (the first) became non-finite (1) or went
    below z = 0 (2), each checked after every step, the non-finite first."""
    n = S.shape[0]
    width = N_FLAT + (FLAT_ERR.stop - FLAT_ERR.start) if mode == 4 else N_FLAT
    C = np.empty((n, width))
    n_ctrl = F.shape[0] - 1
    for k in range(n_ctrl):
        for i in range(n):
            for c in range(N_FLAT):
                C[i, c] = F[k, c]
            if mode == 4:
                for c in range(FLAT_ERR.stop - FLAT_ERR.start):
                    C[i, FLAT_ERR.start + c] = E[i, k, c]
            for c in range(3):
                S[i, S_WIND.start + c] = W[k, i, c]
        last = (k + 1) % per == 0
        j = (k + 1) // per - 1
        if record and last:
            before[:, j] = S
        control_step(P, S, T, C, mode, n_sub, h, clipped)
        for i in range(n):
            for c in range(S.shape[1]):
                if not math.isfinite(S[i, c]):
                    return 1, k, i
        for i in range(n):
            if S[i, S_POS.start + 2] < 0.0:
                return 2, k, i
        if last:
            for i in range(n):
                for c in range(3):
                    positions[i, j, c] = S[i, S_POS.start + c]
            if record:
                states[:, j] = S
                commands[:, j] = T
    return 0, n_ctrl, 0


@njit(**_NB)
def fly_rows(P, S, T, C, Tk, Ck, n_sub, h, per, k0, n_steps, base, sh, ref, height, floor,
             alpha, tb, env_tb, table, added, env, positions, clipped):
    """Fly rows ``S`` (n, 20) for ``n_steps`` control steps of attitude commands (mode 0), in
    place: ``uavwind.sim.rollout.Rollout``'s multirotor loop, each step's wind computed here
    as its wind table's lookup computes it (the same operations in the same order, so the
    same doubles).

    Commands: ``T`` (n,) [N] and ``C`` (n, 4) held, or, where ``Tk`` (n, n_steps) and ``Ck``
    (n, n_steps, 4) have columns, each step's own (state errors). Wind of step ``k`` (the
    table's step ``k0 + k``): ``base`` (n, 3) [m/s]; rows ``sh`` a shear, ``ref[a] * pow(max(z,
    floor[a]) / height[a], alpha[a])`` with the C library's ``pow`` (``wind.libm_pow``'s);
    rows ``tb`` the table's ``table[k0 + k, env_tb[a]]``; then, if ``added`` has steps,
    ``+ added[k0 + k, env[i]]`` (gusts added to every row). After each sample's last step
    the positions go to ``positions`` (n, n_steps // per, 3)."""
    n = S.shape[0]
    Tn = T.copy()
    Cn = C.copy()
    varying = Tk.shape[1] > 0
    w0 = S_WIND.start
    for k in range(n_steps):
        kk = k0 + k
        for i in range(n):
            for c in range(3):
                S[i, w0 + c] = base[i, c]
        for a in range(sh.size):
            i = sh[a]
            z = S[i, S_POS.start + 2]
            if not z >= floor[a]:  # np.maximum's: the floor, or a NaN height kept
                z = floor[a] if z == z else z
            f = math.pow(z / height[a], alpha[a])
            for c in range(3):
                S[i, w0 + c] = ref[a, c] * f
        for a in range(tb.size):
            for c in range(3):
                S[tb[a], w0 + c] = table[kk, env_tb[a], c]
        if added.shape[0] > 0:
            for i in range(n):
                for c in range(3):
                    S[i, w0 + c] = S[i, w0 + c] + added[kk, env[i], c]
        if varying:
            for i in range(n):
                Tn[i] = Tk[i, k]
                for c in range(4):
                    Cn[i, c] = Ck[i, k, c]
        control_step(P, S, Tn, Cn, 0, n_sub, h, clipped)
        if (k + 1) % per == 0:
            j = (k + 1) // per - 1
            for i in range(n):
                for c in range(3):
                    positions[i, j, c] = S[i, S_POS.start + c]


@njit(**_NB)
def state_derivative(P, S, U):
    """``Multirotor._s_dot_fn`` for a batch (n, 20) with clipped motor speeds U (n, 4)."""
    out = np.empty_like(S)
    R = np.empty((3, 3))
    for i in range(S.shape[0]):
        _sdot(P, S[i], U[i], out[i], R)
    return out


@njit(**_NB)
def motor_commands(P, S, T, C, mode):
    """Unclipped motor speeds (n, 4) of ``cmd_ctatt`` (``mode`` 0) or ``cmd_ctbr`` (1)."""
    n = S.shape[0]
    out = np.empty((n, 4))
    R = np.empty((3, 3))
    Rd = np.empty((3, 3))
    for i in range(n):
        if mode == 0:
            _cmd_ctatt(P, S[i], T[i], C[i], out[i], R, Rd)
        else:
            _cmd_ctbr(P, S[i], T[i], C[i], out[i])
    return out


@njit(**_NB)
def se3i_commands(P, S, F):
    """The motor speeds (n, 4) [rad/s] (unclipped) and collective thrusts (n,) [N] of mode 3
    (:func:`_se3i`) at the states S (n, 23), without advancing the integral; mode 4 when the
    rows F carry the errors (``FLAT_ERR``: F (n, 17))."""
    err = F.shape[1] > N_FLAT
    n = S.shape[0]
    u = np.empty((n, 4))
    aux = np.empty((n, N_CMD))
    R = np.empty((3, 3))
    Rd = np.empty((3, 3))
    s = np.empty(S.shape[1])
    for i in range(n):
        s[:] = S[i]
        _se3i(P, s, F[i], 0.0, u[i], R, Rd, aux[i], err)
    return u, aux[:, CMD_THRUST].copy()


@njit(**_NB)
def se3_commands(P, S, F):
    """``SE3Control.update`` for a batch: states S (n, 20), flat-output rows F (n, 11) ->
    ``(cmd_motor_speeds (n, 4) [rad/s] (unclipped), cmd_thrust (n,) [N], cmd_moment (n, 3)
    [N m], cmd_q (n, 4) [i, j, k, w], cmd_acc (n, 3) [m/s^2], cmd_w (n, 3) [rad/s])``."""
    n = S.shape[0]
    u = np.empty((n, 4))
    aux = np.empty((n, N_CMD))
    R = np.empty((3, 3))
    Rd = np.empty((3, 3))
    for i in range(n):
        _se3(P, S[i], F[i], u[i], R, Rd, aux[i])
    return (u, aux[:, CMD_THRUST].copy(), aux[:, CMD_MOMENT].copy(), aux[:, CMD_Q].copy(),
            aux[:, CMD_ACC].copy(), aux[:, CMD_W].copy())
