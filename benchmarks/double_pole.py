"""Double pole balancing (Wieland 1991), as in NEAT's experiments, vectorized over carts.

Two poles (half-lengths 0.5 m and 0.05 m, masses 0.1 kg and 0.01 kg) hinged on a 1 kg
cart on a 4.8 m track; the force is +-10 N scaled by the network's output.  The equations
are those of NEAT's C++ ``CartPole::step`` (Wieland's, with pole-hinge friction 2e-6),
integrated by 4th-order Runge-Kutta in 0.01 s steps, two steps a control step (as NEAT's
``performAction``).  A cart fails when it leaves the track or a pole leans past 36 deg.

Arrays are ``(n, 6)``: x [m], x' [m/s], theta1 [rad], theta1' [rad/s], theta2, theta2'.
"""

from __future__ import annotations

import math

import numpy as np

GRAVITY = -9.8  # [m/s^2]
CART_MASS = 1.0  # [kg]
POLE_MASS = (0.1, 0.01)  # [kg]
POLE_HALF_LENGTH = (0.5, 0.05)  # [m]
FORCE_MAG = 10.0  # [N]
HINGE_FRICTION = 0.000002
TAU = 0.01  # RK4 step [s]
SUBSTEPS = 2  # RK4 steps a control step
TRACK_LIMIT = 2.4  # [m]
ANGLE_LIMIT = 0.628329  # 36 deg [rad]
START_ANGLE = 0.07  # the long pole starts at ~4 deg (NEAT's pole2 experiments) [rad]


def derivatives(state: np.ndarray, force: np.ndarray) -> np.ndarray:
    """d(state)/dt for states (n, 6) under forces (n,) [N]."""
    xdot = state[:, 1]
    accel_terms = []
    masses = []
    poles = []
    for k, (m, l) in enumerate(zip(POLE_MASS, POLE_HALF_LENGTH)):
        theta, omega = state[:, 2 + 2 * k], state[:, 3 + 2 * k]
        cos, sin = np.cos(theta), np.sin(theta)
        gsin = GRAVITY * sin
        ml = l * m
        temp = HINGE_FRICTION * omega / ml
        accel_terms.append(ml * omega * omega * sin + 0.75 * m * cos * (temp + gsin))
        masses.append(m * (1.0 - 0.75 * cos * cos))
        poles.append((cos, gsin, temp, l))
    xacc = (force + accel_terms[0] + accel_terms[1]) / (masses[0] + masses[1] + CART_MASS)
    out = np.empty_like(state)
    out[:, 0] = xdot
    out[:, 1] = xacc
    for k, (cos, gsin, temp, l) in enumerate(poles):
        out[:, 2 + 2 * k] = state[:, 3 + 2 * k]
        out[:, 3 + 2 * k] = -0.75 * (xacc * cos + gsin + temp) / l
    return out


def rk4(state: np.ndarray, force: np.ndarray, dt: float = TAU) -> np.ndarray:
    k1 = derivatives(state, force)
    k2 = derivatives(state + 0.5 * dt * k1, force)
    k3 = derivatives(state + 0.5 * dt * k2, force)
    k4 = derivatives(state + dt * k3, force)
    return state + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def control_step(state: np.ndarray, output: np.ndarray) -> np.ndarray:
    """Apply network outputs in [0, 1] as forces for one control step."""
    force = (output - 0.5) * 2.0 * FORCE_MAG
    for _ in range(SUBSTEPS):
        state = rk4(state, force)
    return state


def failed(state: np.ndarray) -> np.ndarray:
    return ((np.abs(state[:, 0]) > TRACK_LIMIT) | (np.abs(state[:, 2]) > ANGLE_LIMIT)
            | (np.abs(state[:, 4]) > ANGLE_LIMIT))


def start_states(n: int) -> np.ndarray:
    state = np.zeros((n, 6))
    state[:, 2] = START_ANGLE
    return state


def observe(state: np.ndarray, velocities: bool) -> np.ndarray:
    """Network inputs, scaled as in NEAT (positions / 4.8, angles / 0.52, rates / 2)."""
    if velocities:
        return state / np.array([4.8, 2.0, 0.52, 2.0, 0.52, 2.0])
    return state[:, [0, 2, 4]] / np.array([4.8, 0.52, 0.52])


def generalization_starts() -> np.ndarray:
    """The 625 start states of Gruau et al.: x, x', theta1, theta1' each at 5 levels."""
    levels = np.array([0.05, 0.25, 0.5, 0.75, 0.95])
    grid = np.array(np.meshgrid(levels, levels, levels, levels, indexing="ij")).reshape(4, -1).T
    state = np.zeros((len(grid), 6))
    state[:, 0] = grid[:, 0] * 4.32 - 2.16
    state[:, 1] = grid[:, 1] * 2.70 - 1.35
    state[:, 2] = grid[:, 2] * 0.12566304 - 0.06283152
    state[:, 3] = grid[:, 3] * 0.30019504 - 0.15009752
    return state


# -- one cart in plain floats: the long tail of an evaluation, where numpy's per-call cost
#    would dominate (one survivor balancing for 100,000 steps) -------------------------------
def _derivatives_scalar(s: list[float], force: float) -> list[float]:
    x_dot, t1, w1, t2, w2 = s[1], s[2], s[3], s[4], s[5]
    (m1, m2), (l1, l2) = POLE_MASS, POLE_HALF_LENGTH
    c1, s1, c2, s2 = math.cos(t1), math.sin(t1), math.cos(t2), math.sin(t2)
    g1, g2 = GRAVITY * s1, GRAVITY * s2
    ml1, ml2 = l1 * m1, l2 * m2
    tmp1, tmp2 = HINGE_FRICTION * w1 / ml1, HINGE_FRICTION * w2 / ml2
    f1 = ml1 * w1 * w1 * s1 + 0.75 * m1 * c1 * (tmp1 + g1)
    f2 = ml2 * w2 * w2 * s2 + 0.75 * m2 * c2 * (tmp2 + g2)
    mi1, mi2 = m1 * (1.0 - 0.75 * c1 * c1), m2 * (1.0 - 0.75 * c2 * c2)
    acc = (force + f1 + f2) / (mi1 + mi2 + CART_MASS)
    return [x_dot, acc, w1, -0.75 * (acc * c1 + g1 + tmp1) / l1, w2, -0.75 * (acc * c2 + g2 + tmp2) / l2]


def control_step_scalar(state: list[float], output: float) -> list[float]:
    """:func:`control_step` for one cart as a list of 6 floats."""
    force = (output - 0.5) * 2.0 * FORCE_MAG
    dt = TAU
    for _ in range(SUBSTEPS):
        k1 = _derivatives_scalar(state, force)
        k2 = _derivatives_scalar([s + 0.5 * dt * k for s, k in zip(state, k1)], force)
        k3 = _derivatives_scalar([s + 0.5 * dt * k for s, k in zip(state, k2)], force)
        k4 = _derivatives_scalar([s + dt * k for s, k in zip(state, k3)], force)
        state = [s + dt / 6.0 * (a + 2 * b + 2 * c + d) for s, a, b, c, d in zip(state, k1, k2, k3, k4)]
    return state


def failed_scalar(s: list[float]) -> bool:
    return abs(s[0]) > TRACK_LIMIT or abs(s[2]) > ANGLE_LIMIT or abs(s[4]) > ANGLE_LIMIT
