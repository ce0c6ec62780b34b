"""Numba kernels of the multirotor: RotorPy 3.0.0's ``Multirotor`` physics, one environment at a
time, batched by a loop (the same formulas as ``rotorpy/vehicles/multirotor.py``; the tests hold
them to RotorPy's own methods, 1e-12 of each block's scale).

State, one row per environment, exactly ``Multirotor._pack_state``'s layout (20 numbers)::

    s[0:3]   x      position, world frame, z up                          [m]
    s[3:6]   v      velocity over ground, world frame                    [m/s]
    s[6:10]  q      attitude quaternion [i, j, k, w] (scalar last), body -> world
    s[10:13] w      body rates, body frame                               [rad/s]
    s[13:16] wind   wind velocity, world frame (held over a control step) [m/s]
    s[16:20] rotor speeds                                                 [rad/s]

Parameter vector ``P`` (:func:`uavwind.sim.multirotor.Multirotor.packed`)::

    0 mass, 1 g, 2:11 inertia (row-major), 11:20 inverse inertia, 20:23 c_Dx, c_Dy, c_Dz,
    23 k_eta, 24 k_m, 25 k_d, 26 k_z, 27 k_h, 28 k_flap, 29 tau_m, 30 rotor speed min,
    31 rotor speed max, 32:44 rotor positions (4 x 3, body frame), 44:48 rotor directions,
    48:64 thrust-and-moments to rotor forces (4 x 4), 64 k_w, 65 kp_att, 66 kd_att, 67 aero,
    68:71 SE3 kp_pos, 71:74 SE3 kd_pos, 74 SE3 kp_att, 75 SE3 kd_att (``SE3Control``'s gains),
    76:79 ki_pos [1/s^3], 79 tan(max tilt), 80 least collective thrust [N], 81 most thrust [N],
    82 largest integral acceleration |ki I| [m/s^2] (mode 3 only:
    :class:`~uavwind.sim.multirotor.PositionControl`)

Mode 3 adds three state columns: ``s[20:23]`` the integral of the position error [m s].

Flat-output row (mode 2, ``SE3Control``), 11 numbers: ``x`` (3) [m], ``x_dot`` (3) [m/s],
``x_ddot`` (3) [m/s^2], ``yaw`` [rad], ``yaw_dot`` [rad/s] (the jerk and snap RotorPy's flat
outputs carry are not used by ``SE3Control``).

One :func:`control_step` is ``Multirotor.step`` with a fixed-step integrator: the command is
mapped to motor speeds from the state at the start of the step and clipped, then held (with
the wind) for ``n_sub`` classical RK4 substeps, and the quaternion is renormalised. The
command is RotorPy's ``cmd_ctatt`` (mode 0), ``cmd_ctbr`` (mode 1), or the motor speeds of
``rotorpy.controllers.quadrotor_control.SE3Control.update`` flying a flat output (mode 2,
position control; :func:`se3_commands` gives all its outputs), or the same law with an
integral term and a thrust cone with vertical priority (mode 3, :func:`_se3i`: PX4's position
controller's structure, PX4 ``MPC_TILTMAX_AIR`` / ``MPC_THR_MIN`` / ``MPC_THR_MAX``).
"""

import math

import numpy as np
from numba import njit

_NB = dict(cache=True, nogil=True, error_model="numpy")


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
    """``Multirotor._s_dot_fn`` for one environment: s, out (20,), u clipped motor speeds (4,)."""
    m = P[0]
    _rotmat(s[6:10], R)
    for i in range(3):
        out[i] = s[3 + i]                                   # x_dot = v
    inv_tau = 1 / P[29]
    for k in range(4):
        out[16 + k] = inv_tau * (u[k] - s[16 + k])          # first-order motors
    q0, q1, q2, q3 = s[6], s[7], s[8], s[9]
    w0, w1, w2 = s[10], s[11], s[12]
    out[6] = 0.5 * (q3 * w0 - q2 * w1 + q1 * w2)            # quaternion rate (raw q)
    out[7] = 0.5 * (q2 * w0 + q3 * w1 - q0 * w2)
    out[8] = 0.5 * (-q1 * w0 + q0 * w1 + q3 * w2)
    out[9] = 0.5 * (-q0 * w0 - q1 * w1 - q2 * w2)
    d0 = s[3] - s[13]
    d1 = s[4] - s[14]
    d2 = s[5] - s[15]
    va0 = R[0, 0] * d0 + R[1, 0] * d1 + R[2, 0] * d2        # body airspeed R^T (v - wind)
    va1 = R[0, 1] * d0 + R[1, 1] * d1 + R[2, 1] * d2
    va2 = R[0, 2] * d0 + R[1, 2] * d1 + R[2, 2] * d2
    aero = P[67] != 0.0
    k_eta, k_m, k_d, k_z, k_h, k_flap = P[23], P[24], P[25], P[26], P[27], P[28]
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
        rx, ry, rz = P[32 + 3 * k], P[33 + 3 * k], P[34 + 3 * k]
        om = s[16 + k]
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
        Mr2 += P[44 + k] * (k_m * om2)                      # rotor yaw torque
    if aero:
        vn = math.sqrt(va0 * va0 + va1 * va1 + va2 * va2)
        F0 = F0 + (-vn * P[20]) * va0                       # quadratic frame drag
        F1 = F1 + (-vn * P[21]) * va1
        F2 = F2 + (-vn * P[22]) * va2
    M0 = M0 + Mr0
    M1 = M1 + Mr1
    M2 = M2 + Mr2
    for i in range(3):                                      # v_dot = (weight + R F) / m
        Fi = R[i, 0] * F0 + R[i, 1] * F1 + R[i, 2] * F2
        out[3 + i] = ((-m * P[1] if i == 2 else 0.0) + Fi) / m
    I = P[2:11]
    Iw0 = I[0] * w0 + I[1] * w1 + I[2] * w2
    Iw1 = I[3] * w0 + I[4] * w1 + I[5] * w2
    Iw2 = I[6] * w0 + I[7] * w1 + I[8] * w2
    g0 = M0 - (w1 * Iw2 - w2 * Iw1)                          # M - w x I w
    g1 = M1 - (w2 * Iw0 - w0 * Iw2)
    g2 = M2 - (w0 * Iw1 - w1 * Iw0)
    Ji = P[11:20]
    out[10] = Ji[0] * g0 + Ji[1] * g1 + Ji[2] * g2
    out[11] = Ji[3] * g0 + Ji[4] * g1 + Ji[5] * g2
    out[12] = Ji[6] * g0 + Ji[7] * g1 + Ji[8] * g2
    for i in range(13, 16):
        out[i] = 0.0                                        # the wind is held


@njit(**_NB)
def _speeds(P, T, M0, M1, M2, u):
    """Collective thrust and body moments -> signed motor speeds ``sign(f) sqrt(|f| / k_eta)``."""
    for k in range(4):
        f = P[48 + 4 * k] * T + P[49 + 4 * k] * M0 + P[50 + 4 * k] * M1 + P[51 + 4 * k] * M2
        sp = f / P[23]
        r = math.sqrt(abs(sp))
        u[k] = -r if sp < 0 else (r if sp > 0 else (0.0 if sp == 0 else sp))


@njit(**_NB)
def _attitude_law(P, s, R, Rd, kp, kd, wz_des):
    """The geometric attitude law ``cmd_ctatt`` and ``SE3Control`` share: from the body
    rotation R and the desired one Rd (3, 3), the error ``e = vee(Rd^T R - R^T Rd) / 2`` and
    the angular acceleration ``a = -kp e - kd (w - (0, 0, wz_des))``, the moments
    ``M = I a + w x (I w)``. Returns ``(M0, M1, M2, a0, a1, a2)``."""
    S = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            a = Rd[0, i] * R[0, j] + Rd[1, i] * R[1, j] + Rd[2, i] * R[2, j]
            b = R[0, i] * Rd[0, j] + R[1, i] * Rd[1, j] + R[2, i] * Rd[2, j]
            S[i, j] = 0.5 * (a - b)
    e0, e1, e2 = -S[1, 2], S[0, 2], -S[0, 1]
    w0, w1, w2 = s[10], s[11], s[12]
    a0 = -kp * e0 - kd * w0
    a1 = -kp * e1 - kd * w1
    a2 = -kp * e2 - kd * (w2 - wz_des)
    I = P[2:11]
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
    _rotmat(s[6:10], R)
    _rotmat(qd, Rd)
    M0, M1, M2, _, _, _ = _attitude_law(P, s, R, Rd, P[65], P[66], 0.0)
    _speeds(P, T, M0, M1, M2, u)


@njit(**_NB)
def _cmd_ctbr(P, s, T, wd, u):
    """``cmd_ctbr``: collective thrust T [N] and body rates wd -> unclipped motor speeds u."""
    kw = P[64]
    a0 = -kw * (s[10] - wd[0])
    a1 = -kw * (s[11] - wd[1])
    a2 = -kw * (s[12] - wd[2])
    I = P[2:11]
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
    m = P[0]
    g = P[1]
    F0 = m * ((-(P[68] * (s[0] - f[0])) - P[71] * (s[3] - f[3])) + f[6])
    F1 = m * ((-(P[69] * (s[1] - f[1])) - P[72] * (s[4] - f[4])) + f[7])
    F2 = m * (((-(P[70] * (s[2] - f[2])) - P[73] * (s[5] - f[5])) + f[8]) + g)
    _se3_force(P, s, f, F0, F1, F2, u, R, Rd, aux, False)


@njit(**_NB)
def _yaw_share(P, T, M0, M1, M2):
    """The largest share ``c`` in [0, 1] of the yaw moment ``M2`` [N m] with which every
    rotor's force for ``(T, M0, M1, c M2)`` lies within the rotors' range (``k_eta`` times
    the square of the speed range); 0 when none does (then the clipping takes its course).
    A multirotor makes yaw moments weakly (through its rotors' drag torque), and a large
    frame's yaw inertia grows with the square of its arms: a flight controller gives up yaw
    before roll, pitch and thrust (PX4's mixer does)."""
    lo = P[23] * P[30] * P[30]
    hi = P[23] * P[31] * P[31]
    c_lo = 0.0
    c_hi = 1.0
    for k in range(4):
        base = P[48 + 4 * k] * T + P[49 + 4 * k] * M0 + P[50 + 4 * k] * M1
        slope = P[51 + 4 * k] * M2
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
def _se3i(P, s, f, h, u, R, Rd, aux):
    """SE3 with an integral term and a thrust cone (mode 3), for one environment.

    The desired force is SE3's plus ``-m ki I``, ``I = s[20:23]`` the integral of the
    position error [m s]; then, as PX4's position controller limits its thrust set-point
    with vertical priority, its vertical part is held within [least, most] collective
    thrust and its horizontal part shortened to stay within the tilt cone
    ``|F_h| <= F_z tan(max tilt)`` and within the most thrust. The integral advances by
    ``h`` [s] of position error unless the force was limited (conditional integration, the
    anti-windup), each axis clipped so that ``|ki I|`` stays within its bound."""
    m = P[0]
    g = P[1]
    e0 = s[0] - f[0]
    e1 = s[1] - f[1]
    e2 = s[2] - f[2]
    F0 = m * (-P[68] * e0 - P[71] * (s[3] - f[3]) - P[76] * s[20] + f[6])
    F1 = m * (-P[69] * e1 - P[72] * (s[4] - f[4]) - P[77] * s[21] + f[7])
    F2 = m * (-P[70] * e2 - P[73] * (s[5] - f[5]) - P[78] * s[22] + f[8] + g)
    limited = False
    lo, hi = P[80], P[81]
    if F2 < lo:
        F2 = lo
        limited = True
    elif F2 > hi:
        F2 = hi
        limited = True
    fh = math.sqrt(F0 * F0 + F1 * F1)
    fh_max = min(F2 * P[79], math.sqrt(max(hi * hi - F2 * F2, 0.0)))
    if fh > fh_max:
        c = fh_max / fh
        F0 = F0 * c
        F1 = F1 * c
        limited = True
    if not limited:
        for k in range(3):
            ki = P[76 + k]
            if ki > 0.0:
                lim = P[82] / ki
                v = s[20 + k] + h * (s[k] - f[k])
                s[20 + k] = min(max(v, -lim), lim)
    _se3_force(P, s, f, F0, F1, F2, u, R, Rd, aux, True)


@njit(**_NB)
def _se3_force(P, s, f, F0, F1, F2, u, R, Rd, aux, yaw_last):
    """The rest of ``SE3Control.update`` from the desired force ``F`` [N] (world frame): the
    desired attitude (body z along ``F``, yaw ``f[9]``), the collective thrust ``F . b3``,
    the attitude law and the motor speeds u; aux as :func:`_se3`. With ``yaw_last`` the yaw
    moment is shortened first when the rotors cannot make all four (:func:`_yaw_share`)."""
    m = P[0]
    _rotmat(s[6:10], R)
    u1 = F0 * R[0, 2] + F1 * R[1, 2] + F2 * R[2, 2]          # F_des . b3
    nF = math.sqrt(F0 * F0 + F1 * F1 + F2 * F2)
    b30 = F0 / nF
    b31 = F1 / nF
    b32 = F2 / nF
    c0 = math.cos(f[9])
    c1 = math.sin(f[9])
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
    M0, M1, M2, a0, a1, a2 = _attitude_law(P, s, R, Rd, P[74], P[75], f[10])
    if yaw_last:
        M2 = M2 * _yaw_share(P, u1, M0, M1, M2)
    _speeds(P, u1, M0, M1, M2, u)
    aux[0] = u1
    aux[1] = M0
    aux[2] = M1
    aux[3] = M2
    _quat_from_matrix(Rd, aux[4:8])
    aux[8] = F0 / m
    aux[9] = F1 / m
    aux[10] = F2 / m
    aux[11] = a0
    aux[12] = a1
    aux[13] = a2


@njit(**_NB)
def control_step(P, S, T, C, mode, n_sub, h, clipped):
    """Advance every environment by one control step of ``n_sub * h`` [s], in place.

    ``S`` (n, 20) states, wind columns already set for this step; ``T`` (n,) collective
    thrust [N]; ``C`` (n, 4) attitude quaternions (``mode`` 0, ``cmd_ctatt``), (n, 3) body
    rates (``mode`` 1, ``cmd_ctbr``) or (n, 11) flat-output rows (``mode`` 2, ``SE3Control``:
    then ``T`` is an output, the commanded collective thrust ``cmd_thrust`` of the step;
    ``mode`` 3, the same law with an integral term and a thrust cone, :func:`_se3i`: then
    ``S`` is (n, 23), its last three columns the integral of the position error);
    ``clipped`` (n,) counts the steps in which a motor command was clipped to the motors'
    range.
    """
    n = S.shape[0]
    R = np.empty((3, 3))
    Rd = np.empty((3, 3))
    u = np.empty(4)
    k1 = np.empty(20)
    k2 = np.empty(20)
    k3 = np.empty(20)
    k4 = np.empty(20)
    tmp = np.empty(20)
    aux = np.empty(14)
    for i in range(n):
        s = S[i]
        if mode == 0:
            _cmd_ctatt(P, s, T[i], C[i], u, R, Rd)
        elif mode == 1:
            _cmd_ctbr(P, s, T[i], C[i], u)
        elif mode == 2:
            _se3(P, s, C[i], u, R, Rd, aux)
            T[i] = aux[0]
        else:
            _se3i(P, s, C[i], n_sub * h, u, R, Rd, aux)
            T[i] = aux[0]
        hit = False
        for k in range(4):                                   # np.clip(cmd, min, max)
            c = min(max(u[k], P[30]), P[31])
            if c != u[k]:
                hit = True
            u[k] = c
        if hit:
            clipped[i] += 1
        for _ in range(n_sub):
            _sdot(P, s, u, k1, R)
            for j in range(20):
                tmp[j] = s[j] + (0.5 * h) * k1[j]
            _sdot(P, tmp, u, k2, R)
            for j in range(20):
                tmp[j] = s[j] + (0.5 * h) * k2[j]
            _sdot(P, tmp, u, k3, R)
            for j in range(20):
                tmp[j] = s[j] + h * k3[j]
            _sdot(P, tmp, u, k4, R)
            for j in range(20):
                s[j] = s[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        qn = math.sqrt(s[6] * s[6] + s[7] * s[7] + s[8] * s[8] + s[9] * s[9])
        for j in range(6, 10):
            s[j] = s[j] / qn


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
    (:func:`_se3i`) at the states S (n, 23), without advancing the integral."""
    n = S.shape[0]
    u = np.empty((n, 4))
    aux = np.empty((n, 14))
    R = np.empty((3, 3))
    Rd = np.empty((3, 3))
    s = np.empty(S.shape[1])
    for i in range(n):
        s[:] = S[i]
        _se3i(P, s, F[i], 0.0, u[i], R, Rd, aux[i])
    return u, aux[:, 0].copy()


@njit(**_NB)
def se3_commands(P, S, F):
    """``SE3Control.update`` for a batch: states S (n, 20), flat-output rows F (n, 11) ->
    ``(cmd_motor_speeds (n, 4) [rad/s] (unclipped), cmd_thrust (n,) [N], cmd_moment (n, 3)
    [N m], cmd_q (n, 4) [i, j, k, w], cmd_acc (n, 3) [m/s^2], cmd_w (n, 3) [rad/s])``."""
    n = S.shape[0]
    u = np.empty((n, 4))
    aux = np.empty((n, 14))
    R = np.empty((3, 3))
    Rd = np.empty((3, 3))
    for i in range(n):
        _se3(P, S[i], F[i], u[i], R, Rd, aux[i])
    return u, aux[:, 0].copy(), aux[:, 1:4].copy(), aux[:, 4:8].copy(), aux[:, 8:11].copy(), \
        aux[:, 11:14].copy()
