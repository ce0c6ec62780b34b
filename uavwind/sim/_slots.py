"""The multirotor's packed layouts: this module owns them, and every reader and writer of
them indexes through its names.

The numba kernels (``uavwind.sim._rotor_kernels``) read a vehicle from one flat parameter
vector ``P`` (``uavwind.sim._rotor_layout._packed`` writes it, through these names) and each
environment's state from a row ``s`` of a state array ``S`` (RotorPy 3.0.0's
``Multirotor._pack_state`` layout, then the integral of a
:class:`~uavwind.sim.rotor_params.PositionControl`). A single slot is an ``int``; a block of
slots is a ``slice`` (``P[INERTIA]``, ``S[:, S_WIND]``; in a kernel ``S_ROTORS.start + k``).
Numba freezes module-level ints and slices into compiled code as constants, so the kernels
index by name at no cost. Units in brackets, as RotorPy's and python-control's comments give
them; ``[-]`` a pure number. 3 x 3 and 4 x 4 blocks are row-major.

Two more rows the kernels pack: the flat output that mode 2 and 3 follow (RotorPy's
``flat_output``, without the jerk and snap that ``SE3Control`` does not use) and the
outputs of ``SE3Control.update`` besides the motor speeds (RotorPy's ``control_input``
keys).

Numba's on-disk cache is keyed on the kernels' own source file (a hash of its bytes), not on
this one: a kernel cached before a slot here moved would keep the old number. So
:data:`LAYOUT` (every number here) is compiled into the kernels too, and
``uavwind.sim._rotor_layout._kernels`` refuses kernels whose copy differs (then delete
``uavwind/sim/__pycache__/_rotor_kernels*.nbi`` and ``.nbc``, and they compile afresh).
"""

# -- the parameter vector P (one vehicle) ---------------------------------------------- #
MASS = 0                   # vehicle mass m [kg]
G = 1                      # gravitational acceleration g, RotorPy's [m/s^2]
INERTIA = slice(2, 11)     # inertia tensor I about the centre of mass, body frame, 3 x 3 [kg m^2]
INERTIA_INV = slice(11, 20)  # its inverse I^-1, 3 x 3 [1/(kg m^2)]
C_D = slice(20, 23)        # frame drag coefficients c_Dx, c_Dy, c_Dz, body axes [N/(m/s)^2]
K_ETA = 23                 # rotor thrust coefficient k_eta [N/(rad/s)^2]
K_M = 24                   # rotor yaw moment coefficient k_m [N m/(rad/s)^2]
K_D = 25                   # rotor drag (H-force) coefficient k_d [N/(rad m/s^2)]
K_Z = 26                   # induced inflow coefficient k_z [N/(rad m/s^2)]
K_H = 27                   # translational lift coefficient k_h [N/(m/s)^2]
K_FLAP = 28                # flapping moment coefficient k_flap [N m/(rad m/s^2)]
TAU_M = 29                 # motor time constant tau_m [s]
SPEED_MIN = 30             # least rotor speed [rad/s]
SPEED_MAX = 31             # most rotor speed [rad/s]
ROTOR_POS = slice(32, 44)  # rotor positions, 4 x 3: row k is rotor k's x, y, z, body frame [m]
ROTOR_DIR = slice(44, 48)  # rotor spin directions, +1 or -1 (the sign of its yaw moment) [-]
TM_TO_F = slice(48, 64)    # collective thrust and moments to rotor forces, 4 x 4: row k gives
#                            rotor k's thrust [N] from (T [N], M_x, M_y, M_z [N m]): [-], [1/m]
K_W = 64                   # body rate gain k_w of cmd_ctbr [1/s]
KP_ATT = 65                # attitude gain kp_att of cmd_ctatt [1/s^2]
KD_ATT = 66                # body rate gain kd_att of cmd_ctatt [1/s]
AERO = 67                  # 1.0: the rotor and frame aerodynamics act; 0.0: they do not [-]
KP_POS = slice(68, 71)     # SE3Control's position gains kp_pos on x, y, z [1/s^2]
KD_POS = slice(71, 74)     # SE3Control's velocity gains kd_pos on x, y, z [1/s]
SE3_KP_ATT = 74            # SE3Control's attitude gain kp_att [1/s^2]
SE3_KD_ATT = 75            # SE3Control's body rate gain kd_att [1/s]
KI_POS = slice(76, 79)     # PositionControl's integral gains ki on x, y, z (mode 3) [1/s^3]
TAN_TILT = 79              # tangent of PositionControl's largest tilt (mode 3) [-]
THRUST_LOW = 80            # PositionControl's least collective thrust (mode 3) [N]
THRUST_HIGH = 81           # PositionControl's most collective thrust (mode 3) [N]
INTEGRAL_ACC = 82          # PositionControl's bound on |ki I| per axis (mode 3) [m/s^2]
N_PARAMS = 83              # length of P

# -- the state row s (one environment) ------------------------------------------------- #
S_POS = slice(0, 3)        # position x, world frame, z up [m]
S_VEL = slice(3, 6)        # velocity over ground v, world frame [m/s]
S_QUAT = slice(6, 10)      # attitude quaternion q [i, j, k, w] (scalar last), body -> world [-]
S_RATES = slice(10, 13)    # body rates w, body frame [rad/s]
S_WIND = slice(13, 16)     # wind velocity, world frame (held over a control step) [m/s]
S_ROTORS = slice(16, 20)   # rotor speeds [rad/s]
N_STATE = 20               # RotorPy's state length
S_INTEGRAL = slice(20, 23)  # integral of the position error, PositionControl only (mode 3) [m s]
N_STATE_PI = 23            # state length under PositionControl

# -- the flat-output row f (one control step of a reference flight) -------------------- #
FLAT_POS = slice(0, 3)     # reference position x, world frame [m]
FLAT_VEL = slice(3, 6)     # reference velocity x_dot, world frame [m/s]
FLAT_ACC = slice(6, 9)     # reference acceleration x_ddot, world frame [m/s^2]
FLAT_YAW = 9               # reference yaw [rad]
FLAT_YAW_RATE = 10         # reference yaw rate yaw_dot [rad/s]
N_FLAT = 11                # length of f
FLAT_ERR = slice(11, 17)   # mode 4 only: the attitude estimate's error, a rotation about world x
#                            and y [rad]; the thrust's relative error (made / commanded - 1) [-];
#                            the velocity estimate's error, world x, y, z [m/s]
N_FLAT_ERR = 17            # length of f in mode 4

# -- SE3Control's outputs besides the motor speeds (aux, one environment) -------------- #
CMD_THRUST = 0             # commanded collective thrust cmd_thrust [N]
CMD_MOMENT = slice(1, 4)   # commanded body moments cmd_moment, body frame [N m]
CMD_Q = slice(4, 8)        # desired attitude cmd_q [i, j, k, w] (scalar last) [-]
CMD_ACC = slice(8, 11)     # desired acceleration cmd_acc = F_des / m, world frame [m/s^2]
CMD_W = slice(11, 14)      # cmd_w = -kp_att e - kd_att (w - w_des), body frame: RotorPy calls
#                            it body rates [rad/s] (it is the attitude law's angular acceleration)
N_CMD = 14                 # length of aux


def _numbers():
    """Every number above, in the order written (an int, or a block's start and stop)."""
    out = []
    for name, v in list(globals().items()):
        if name.isupper():
            out += [v.start, v.stop] if isinstance(v, slice) else [v]
    return tuple(out)


#: Every number of the layouts, as this file gives them (the kernels compile a copy).
LAYOUT = _numbers()
