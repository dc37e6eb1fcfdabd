"""Randomization: the perturbations of a reality file (:mod:`.file`) drawn and put into models.

Each simulation gets its own draws from its own seeded stream (:func:`sample`, keyed by
run seed, generation, genome and episode), so results do not depend on how simulations are
batched or distributed.  Physical parameters go into the model (per simulation through
``mujoco.batch``, :func:`apply`): masses, friction, gains, latency (as actuator delay) and
backlash (the width of each backlash joint's range, in a model built with them:
:func:`needs_backlash_joints`); sensor noise acts on what the robot reads.

    model, draw = perturbed_model(robot, load_reality("default"), seed=3)   # one robot of a file
    draws = sample(reality, keys, model, n_ticks, tick_s)                    # (n, ...) for a batch
    apply(fields, model, draws, rows)                                        # into a batch's fields
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import mujoco
import numpy as np

from sim2real.errors import ConfigError
from sim2real.robot import RobotSpec
from sim2real.robot.timing import control_timing
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.parts import CLOSED_PLAY_RAD
from sim2real.simulation.model.robot_model import JointAngles
from sim2real.simulation.reality.file import Reality


@dataclass(frozen=True)
class Perturbation:
    """One draw per simulation: arrays with the simulations on the first axis.

    Body arrays cover every body of the model, actuator arrays every actuator (= every
    joint, in robot order); noise is drawn ahead for ``n_ticks`` ticks.
    """

    mass_scale: np.ndarray  # (n, nbody)
    com_offset: np.ndarray  # (n, nbody, 3) [m]
    floor_friction_scale: np.ndarray  # (n,)
    kp_scale: np.ndarray  # (n, nu)
    torque_scale: np.ndarray  # (n, nu)
    damping_scale: np.ndarray  # (n, nu)
    friction_scale: np.ndarray  # (n, nu)
    armature_scale: np.ndarray  # (n, nu)
    derivative_s: np.ndarray  # (n,)
    backlash_rad: np.ndarray  # (n, nu)
    latency_s: np.ndarray  # (n,)
    joint_noise_sd_rad: np.ndarray  # (n,)
    up_noise_sd: np.ndarray  # (n,)
    foot_flip_p: np.ndarray  # (n,)
    joint_noise_rad: np.ndarray  # (n, n_ticks, nu)
    up_noise: np.ndarray  # (n, n_ticks, 3)
    foot_flip: np.ndarray  # (n, n_ticks, 2) bool
    heading_drift_rad_s: np.ndarray  # (n,)
    gyro_noise_sd_rad_s: np.ndarray  # (n,)
    gyro_noise_rad_s: np.ndarray  # (n, n_ticks, 3)
    gyro_bias_rad_s: np.ndarray  # (n, 3)
    imu_delay_s: np.ndarray  # (n,)

    def __len__(self) -> int:
        return len(self.latency_s)

    def rows(self, index: np.ndarray | slice) -> "Perturbation":
        return Perturbation(*(getattr(self, f.name)[index] for f in dataclasses.fields(self)))

    @staticmethod
    def stack(parts: "list[Perturbation]") -> "Perturbation":
        """The simulations of ``parts`` one after another."""
        return Perturbation(*(np.concatenate([getattr(p, f.name) for p in parts])
                              for f in dataclasses.fields(Perturbation)))


def sample(reality: Reality, keys: np.ndarray, model: mujoco.MjModel, n_ticks: int,
           tick_s: float) -> Perturbation:
    """Draw one perturbation per row of ``keys`` (integers; each row seeds its own stream)."""
    keys = np.atleast_2d(np.asarray(keys, dtype=np.int64))
    nbody, nu = model.nbody, model.nu
    actuators = [model.actuator(i).name for i in range(nu)]
    joint_columns = []
    for joint in reality.joint_ranges:
        if joint not in actuators:
            raise ConfigError(reality.name, f"joints.{joint}", f"not a servo joint of this robot "
                              f"(its joints: {', '.join(actuators)})")
        joint_columns.append((joint, actuators.index(joint)))
    out: dict[str, list] = {f.name: [] for f in dataclasses.fields(Perturbation)}
    for key in keys:
        rng = np.random.default_rng([int(k) for k in key])

        def draw(name, *shape):
            lo, hi = reality.range(name)
            return np.full(shape, lo) if lo == hi else rng.uniform(lo, hi, shape)

        direction = rng.normal(size=(nbody, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        out["mass_scale"].append(draw("mass_scale", nbody))
        out["com_offset"].append(direction * draw("com_offset_m", nbody)[:, None])
        out["floor_friction_scale"].append(draw("floor_friction_scale"))
        for name in ("kp_scale", "torque_scale", "damping_scale", "friction_scale"):
            out[name].append(draw(name, nu))
        out["backlash_rad"].append(np.radians(draw("backlash_deg", nu)))
        out["latency_s"].append(draw("latency_ticks") * tick_s)
        joint_sd, up_sd, flip = np.radians(draw("joint_noise_deg")), draw("up_noise"), draw("foot_flip")
        out["joint_noise_sd_rad"].append(joint_sd)
        out["up_noise_sd"].append(up_sd)
        out["foot_flip_p"].append(flip)
        out["joint_noise_rad"].append(rng.normal(0.0, 1.0, (n_ticks, nu)) * joint_sd)
        out["up_noise"].append(rng.normal(0.0, 1.0, (n_ticks, 3)) * up_sd)
        out["foot_flip"].append(rng.random((n_ticks, 2)) < flip)
        # drawn last: the perturbations added later leave the earlier ones' draws as they were
        out["armature_scale"].append(draw("armature_scale", nu))
        out["derivative_s"].append(draw("derivative_ms") / 1e3)
        out["latency_s"][-1] += draw("latency_ms") / 1e3
        out["heading_drift_rad_s"].append(np.radians(draw("heading_drift_deg_s")))
        for joint, index in joint_columns:  # a joint's own values: drawn last, as above
            for key, (lo, hi) in reality.joint_ranges[joint].items():
                value = lo if lo == hi else rng.uniform(lo, hi)
                field_name, unit = ("backlash_rad", np.radians) if key == "backlash_deg" else (key, float)
                out[field_name][-1][index] = unit(value)
        # the gyro's, after everything else: realities without a gyro draw as they did before it
        gyro_sd = np.radians(draw("gyro_noise_dps"))
        out["gyro_noise_sd_rad_s"].append(gyro_sd)
        out["gyro_noise_rad_s"].append(rng.normal(0.0, 1.0, (n_ticks, 3)) * gyro_sd if gyro_sd else
                                       np.zeros((n_ticks, 3)))
        out["gyro_bias_rad_s"].append(np.radians(draw("gyro_bias_dps", 3)))
        out["imu_delay_s"].append(draw("imu_delay_ms") / 1e3)  # last of all, as the gyro's
    return Perturbation(**{k: np.array(v) for k, v in out.items()})


def needs_backlash_joints(reality: Reality) -> bool:
    """Whether a model for this reality needs backlash joints (``build_model(backlash=...)``):
    only then, so that a reality without backlash runs the nominal model at its speed."""
    return reality.range("backlash_deg")[1] > 0


def latency_capacity_s(reality: Reality, tick_s: float) -> float:
    """Actuator history a model needs for this reality's longest latency [s]."""
    ticks, seconds = reality.max_latency_s
    return ticks * tick_s + seconds


def apply(fields: dict[str, np.ndarray], nominal: mujoco.MjModel, p: Perturbation,
          rows: np.ndarray | slice) -> None:
    """Write ``p`` into per-simulation model fields (``fields[name]`` is ``(n, ...)``, as
    ``Batch.expand`` returns or a model's array with a leading axis), rows ``rows``.

    The caller runs ``set_const`` afterwards (masses and armatures feed derived constants).
    """
    angles = JointAngles.of(nominal)
    if not angles.has_play and np.any(p.backlash_rad > 0):
        raise ValueError("backlash drawn for a model without backlash joints: build it with "
                         "build_model(..., backlash=needs_backlash_joints(reality))")
    fields["body_mass"][rows] = nominal.body_mass * p.mass_scale
    fields["body_inertia"][rows] = nominal.body_inertia * p.mass_scale[..., None]
    fields["body_ipos"][rows] = nominal.body_ipos + p.com_offset
    # every geom's sliding friction, the floor's and the soles' alike: a contact takes the larger
    # of its two geoms' (equal priority), so a floor made slicker alone changed nothing below
    # the soles' own 1.0 - two thirds of randomize.yaml's draws did nothing until this was seen
    friction = np.array(fields["geom_friction"][rows])
    friction[..., 0] = nominal.geom_friction[:, 0] * p.floor_friction_scale[:, None]
    fields["geom_friction"][rows] = friction
    gain = np.array(fields["actuator_gainprm"][rows])
    bias = np.array(fields["actuator_biasprm"][rows])
    kp = nominal.actuator_gainprm[:, 0] * p.kp_scale
    gain[:, :, 0] = kp
    bias[:, :, 1] = -kp
    # kv of PD robots scales alike; the D term (biasprm[2] = -kv) adds kp Td
    bias[:, :, 2] = nominal.actuator_biasprm[:, 2] * p.kp_scale - kp * p.derivative_s[:, None]
    fields["actuator_gainprm"][rows], fields["actuator_biasprm"][rows] = gain, bias
    fields["actuator_forcerange"][rows] = nominal.actuator_forcerange * p.torque_scale[..., None]
    dofs = angles.servo_dof
    damping = np.array(fields["dof_damping"][rows])
    frictionloss = np.array(fields["dof_frictionloss"][rows])
    damping[:, dofs] = nominal.dof_damping[dofs] * p.damping_scale
    frictionloss[:, dofs] = nominal.dof_frictionloss[dofs] * p.friction_scale
    fields["dof_damping"][rows], fields["dof_frictionloss"][rows] = damping, frictionloss
    armature = np.array(fields["dof_armature"][rows])
    armature[:, dofs] = nominal.dof_armature[dofs] * p.armature_scale
    fields["dof_armature"][rows] = armature
    fields["actuator_delay"][rows] = np.repeat(p.latency_s[:, None], nominal.nu, axis=1)
    if angles.has_play:
        limits = np.array(fields["jnt_range"][rows])
        half = np.maximum(p.backlash_rad, CLOSED_PLAY_RAD) / 2  # (n, nu), in actuator order as play_joint
        limits[:, angles.play_joint, 0], limits[:, angles.play_joint, 1] = -half, half
        fields["jnt_range"][rows] = limits


PERTURBED_FIELDS = ("body_mass", "body_inertia", "body_ipos", "geom_friction", "actuator_gainprm",
                    "actuator_biasprm", "actuator_forcerange", "dof_damping", "dof_frictionloss", "dof_armature",
                    "actuator_delay", "jnt_range")


def apply_to_model(model: mujoco.MjModel, nominal: mujoco.MjModel, p: Perturbation) -> None:
    """Perturb one model in place with the first row of ``p`` (for a single simulation)."""
    fields = {name: getattr(model, name)[None] for name in PERTURBED_FIELDS}
    apply(fields, nominal, p.rows(slice(0, 1)), slice(0, 1))
    mujoco.mj_setConst(model, mujoco.MjData(model))


def perturbed_model(robot: RobotSpec, reality: Reality, seed: int = 0,
                    suspended: bool = False) -> tuple[mujoco.MjModel, Perturbation]:
    """One robot of ``reality``: its model (sized for its latency, with backlash joints if it
    draws play; hung by the pelvis if ``suspended``) perturbed by the draw of key ``[seed]``,
    and that draw (its noise levels act on readings).  The simulated bus and ``compare`` build
    theirs here, so that the same profile and seed are the same robot in both."""
    tick_s = control_timing(robot).tick_s
    model = build_model(robot, latency_capacity_s(reality, tick_s), backlash=needs_backlash_joints(reality),
                        suspended=suspended)
    perturbation = sample(reality, np.array([[seed]]), model, 0, tick_s)
    apply_to_model(model, copy.copy(model), perturbation)
    return model, perturbation
