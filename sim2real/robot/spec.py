"""What a robot is: a frozen :class:`RobotSpec` (read from ``configs/robots/*.yaml`` by
:mod:`sim2real.robot.loading`).

A robot is either a biped of the project's box tree - trunk, pelvis (the root, seed 000's
"waist"), and per leg thigh, shank and foot - with a configurable set of hinge joints at the
waist, hips, knees and ankles, whose config gives the segment sizes [m] and masses [kg] (or,
for the human character, anthropometric measures they are scaled from); or a user's MJCF or
URDF model (:class:`ModelSource`) whose joints the config maps onto roles - legs, arms, neck -
with a ``sign`` each (anatomical angle = sign * model angle).  Either way the config gives the
joints with their ranges, and for a servo robot each joint's Dynamixel (ID, model, direction,
zero offset), the sensor board and the bus.  Mass, height and leg length (:attr:`RobotSpec.physique`)
are the box tree's, or, for a robot from a model file, measured on its compiled model by the
simulation, which hands them to the spec (:attr:`RobotSpec.measured`): nothing here needs MuJoCo.

Joint angles are anatomical and mirrored between the sides, so the same angle means the
same motion on either side (a symmetric controller relies on it): :mod:`sim2real.robot.anatomy`.

    robot = load_robot("xl430_biped")          # or a path, or "human:female_50"
    robot.joint("right_knee").range_rad
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from sim2real.robot.profiles import DeviceProfile

SIDES = ("left", "right", "center")
LOCATIONS = ("waist", "hip", "knee", "ankle", "toe", "shoulder", "elbow", "wrist", "neck")
CENTER_LOCATIONS = ("waist", "neck")  # on the body's midline: side center; every other location is sided
LEG_LOCATIONS = ("hip", "knee", "ankle", "toe")  # what a stance leg is made of
ARM_LOCATIONS = ("shoulder", "elbow", "wrist")  # what an arm is made of
BOX_LOCATIONS = ("waist", "hip", "knee", "ankle")  # where the box tree has joints (model files: any location)
AXES = ("yaw", "roll", "pitch")
DEFAULT_ROBOT = "xl430_biped"
GRAVITY = 9.81  # [m/s^2], as in the MuJoCo model (its default)
# A foot switch closes when its sole carries this share of the body weight: the sensor
# board's threshold (``sensor_board.contact_share`` in a robot config), which evolution,
# the simulated bus and compare all read; robots without a board (simulation-only) use it too.
DEFAULT_CONTACT_SHARE = 0.05
BOX_ROOT_BODY = "pelvis"  # the floating root of a box robot (seed 000's "waist"), named so in its model

# Plausible ranges of a robot config's physical quantities, checked on reading with the key
# named (:mod:`sim2real.robot.loading`): wide enough for anything from a 20 cm hobby-servo
# biped to the human character's largest preset (2.5 m, 300 kg), narrow enough that MuJoCo
# never meets a 1000 m trunk or a 1e-300 kg foot (a singular inertia, or mjMINVAL).
SEGMENT_SIZE_M = (0.002, 1.5)  # each side of a segment's box, each foot dimension, hip_spacing [m]
SEGMENT_MASS_KG = (0.005, 200.0)  # each segment (trunk, pelvis, one thigh, shank or foot) [kg]
JOINT_ANGLE_DEG = (-360.0, 360.0)  # range_deg, home_deg, zero_offset_deg [deg]: at most a turn either way
PD_KP = (0.0, 10_000.0)  # pd_gains.kp, > 0 [1/s^2] (the human's 300: ~17 rad/s)
PD_KD = (0.0, 1_000.0)  # pd_gains.kd, > 0 [1/s]
MAX_TORQUE_NM = (0.0, 5_000.0)  # pd_gains.max_torque_nm, > 0 [N m]
MAX_TORQUE_NM_PER_KG = (0.0, 50.0)  # pd_gains.max_torque_nm_per_kg, > 0 [N m/kg] (the human's 4.08)
NO_LOAD_SPEED_FROUDE = (0.0, 100.0)  # pd_gains.no_load_speed_froude, > 0 [1] (the XL430 on the biped's leg: 0.94)
STIFFNESS_MGL = (0.0, 1_000.0)  # pd_gains.stiffness_mgl, > 0 [m g L per rad] (the XL430 on the biped: 2.0)
CONTROL_TICK_S = (0.001, 1.0)  # control_tick_s [s]: the controller format's tick_s range
PHYSICS_DT_S = (0.0002, 0.02)  # physics_dt_s [s]: MuJoCo's timestep


@dataclass(frozen=True)
class Box:
    """A box-shaped segment: size along x (forward), y (left), z (up) [m] and mass [kg]."""

    size: tuple[float, float, float]
    mass: float


@dataclass(frozen=True)
class Foot:
    length: float  # heel to toe [m]
    width: float  # [m]
    thickness: float  # sole plate [m]
    ankle_height: float  # ankle axis above the sole [m]
    heel: float  # ankle axis in front of the heel [m]
    mass: float  # [kg]


@dataclass(frozen=True)
class Body:
    trunk: Box
    pelvis: Box
    hip_spacing: float  # lateral distance between the hip joints [m]
    thigh: Box  # size[2] is the hip-to-knee length
    shank: Box  # size[2] is the knee-to-ankle length
    foot: Foot

    @property
    def leg_length(self) -> float:
        """Hip joint to sole with straight legs [m]."""
        return self.thigh.size[2] + self.shank.size[2] + self.foot.ankle_height

    @property
    def height(self) -> float:
        """Sole to top of the trunk, standing straight [m] (hips at the pelvis' bottom)."""
        return self.leg_length + self.pelvis.size[2] + self.trunk.size[2]

    @property
    def mass(self) -> float:
        """Total mass [kg]."""
        legs = 2 * (self.thigh.mass + self.shank.mass + self.foot.mass)
        return self.trunk.mass + self.pelvis.mass + legs


@dataclass(frozen=True)
class Physique:
    """A robot's size, measured on its compiled model (for a robot from an MJCF or URDF)."""

    mass: float  # [kg]
    height: float  # sole to the top of the highest part, at the model's zero pose [m]
    leg_length: float  # hip joint to sole, legs straight [m]


@dataclass(frozen=True)
class ModelFoot:
    body: str  # the model's body the foot is
    geoms: tuple[str, ...] = ()  # its sole's collision geoms (empty: every collision geom of the body)


@dataclass(frozen=True)
class ModelSource:
    """A robot described by a MuJoCo model file (MJCF or URDF) rather than the box tree."""

    path: Path  # the MJCF or URDF file
    package_dirs: tuple[Path, ...]  # where a URDF's package:// meshes are looked for
    root: str  # the body that floats (its centre of mass is what the fall test watches)
    imu_body: str  # the body the sensor board's IMU sits on: the torso
    imu_pos: tuple[float, float, float]  # [m] in that body's frame; the IMU's axes are the body's
    feet: dict[str, ModelFoot]  # side -> foot
    hands: dict[str, str]  # side -> body (arms' end effectors), maybe empty
    inertias: str = "as_given"  # or "from_geometry": each body's inertia from its collision geometry
    drop_visuals: bool = True  # the geoms that only show are not loaded (nor their meshes)
    # the way the robot faces in the file (sim2real.robot.anatomy.FORWARDS); the model builder
    # turns it about z to face +x, and the IMU's axes with it
    forward: str = "+x"


@dataclass(frozen=True)
class ServoMap:
    """How a joint angle maps onto its servo: ``servo = direction * joint + zero_offset``."""

    id: int
    profile: DeviceProfile
    direction: int  # +1 or -1
    zero_offset_rad: float  # servo angle (from its centre tick) at joint angle 0 [rad]


@dataclass(frozen=True)
class Joint:
    name: str
    side: str  # left | right | center
    location: str  # one of LOCATIONS
    axis: str  # yaw | roll | pitch
    range_rad: tuple[float, float]
    home_rad: float
    servo: ServoMap | None = None
    sign: int = 1  # a model robot's joint: anatomical angle = sign * the model joint's angle
    # among joints of one side, location and axis, its order along the chain from the root (a
    # spine's second pitch joint is 1): a model robot's; every box robot joint is 0
    index: int = 0

    @property
    def slot(self) -> tuple[str, str, int]:
        """(location, axis, index): what a joint is on either side (its twin has the same)."""
        return (self.location, self.axis, self.index)

    @property
    def center_rad(self) -> float:
        return 0.5 * (self.range_rad[0] + self.range_rad[1])


@dataclass(frozen=True)
class PDGains:
    """Seed 000's eq. 2: torque = I (kp (target - q) - kd qdot), I the joint's inertia."""

    kp: float  # [1/s^2]
    kd: float  # [1/s]
    # [N m]; None for a robot from a model file capped in proportion to its mass, which is
    # known only once the model is measured: then max_torque_nm_per_kg holds the cap
    max_torque_nm: float | None
    max_torque_nm_per_kg: float | None = None  # [N m/kg]
    # [1] the no-load speed in Froude units, w0 sqrt(leg / g): torque falls linearly with joint speed from the
    # cap to zero at w0, and a goal moves at most w0 a second, as a servo's does; None: neither limit
    no_load_speed_froude: float | None = None
    # [m g L per rad] every joint's stiffness this many times the body's weight times its leg length a
    # radian, as a servo's is the same on every joint (the XL430 biped's: 2.0), in place of kp x I, which
    # makes an ankle carrying the whole body 6-7 times stiffer than a hip; the damping keeps eq. 2's
    # damping ratio kd / (2 sqrt(kp)); None: eq. 2's gains
    stiffness_mgl: float | None = None


@dataclass(frozen=True)
class SensorBoard:
    id: int
    profile: DeviceProfile
    contact_share: float = DEFAULT_CONTACT_SHARE  # a foot switch closes at this share of the body weight


@dataclass(frozen=True)
class BusSettings:
    port: str
    baud: int  # [bit/s]


@dataclass(frozen=True)
class RobotSpec:
    name: str
    description: str
    source: str  # file it was read from (and preset, if any)
    body: Body | None  # the box tree; None for a robot from a model file
    joints: tuple[Joint, ...]
    control_sets: dict[str, tuple[str, ...]]
    bus: BusSettings | None = None
    sensor_board: SensorBoard | None = None
    pd: PDGains | None = None  # set for a PD-actuated character (seed 000's, seed 002's), None for servos
    control_tick_s: float | None = None  # overrides the derived tick when set
    physics_dt_s: float | None = None  # MuJoCo's timestep [s]; None: timing.PHYSICS_DT_S
    anthropometry: dict[str, float] = field(default_factory=dict)
    model: ModelSource | None = None  # a robot from an MJCF or URDF file (then body is None)
    # a model robot's mass, height and leg length as the simulation measured them on its compiled
    # model (sim2real.simulation.model.physique.measured); None until then, and for a box robot
    measured: Physique | None = None

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(f"robot {self.name} has no joint {name!r}")

    @property
    def root_body(self) -> str:
        """The model's floating root body, whose centre of mass the fall test watches."""
        return self.model.root if self.model is not None else BOX_ROOT_BODY

    @property
    def physique(self) -> Physique:
        """Mass, height and leg length: the box tree's, or those measured on the compiled model
        of a robot from a model file (:attr:`measured`; RuntimeError naming the robot if it
        never was, which takes MuJoCo)."""
        if self.body is not None:
            return Physique(self.body.mass, self.body.height, self.body.leg_length)
        if self.measured is None:
            raise RuntimeError(
                f"robot {self.name} is described by a MuJoCo model ({self.model.path}): its mass, height and leg "
                "length are measured on the compiled model, and this robot was loaded without that (it takes "
                "MuJoCo: pip install mujoco; then sim2real.simulation.model.physique.measured(robot) or "
                "load_measured(name))")
        return self.measured

    @property
    def mass(self) -> float:
        """Total mass [kg]."""
        return self.physique.mass

    @property
    def leg_length(self) -> float:
        """Hip joint to sole with straight legs [m]."""
        return self.physique.leg_length

    @property
    def height(self) -> float:
        """Sole to the top, standing straight [m]."""
        return self.physique.height

    @property
    def pd_torque_cap_nm(self) -> float:
        """A PD robot's torque limit on every joint [N m]: the config's ``max_torque_nm``, or
        its ``max_torque_nm_per_kg`` times the mass (a model robot's measured on its model)."""
        if self.pd is None:
            raise ValueError(f"robot {self.name} is driven by servos: its torque limits are their stall torques")
        if self.pd.max_torque_nm is not None:
            return self.pd.max_torque_nm
        return self.pd.max_torque_nm_per_kg * self.mass

    @property
    def pd_no_load_speed_rad_s(self) -> float:
        """A PD robot's no-load joint speed [rad/s]: ``no_load_speed_froude`` times sqrt(g / leg
        length), so that bodies of every size move alike in Froude-scaled time; inf without one."""
        if self.pd is None or self.pd.no_load_speed_froude is None:
            return math.inf
        return self.pd.no_load_speed_froude * math.sqrt(GRAVITY / self.leg_length)

    @property
    def is_servo_robot(self) -> bool:
        return self.pd is None

    @property
    def contact_share(self) -> float:
        """Share of the body weight on a sole at which its foot switch closes."""
        return self.sensor_board.contact_share if self.sensor_board else DEFAULT_CONTACT_SHARE

    @property
    def foot_contact_n(self) -> float:
        """Sole force at which a foot switch closes [N]: what evolution, the simulated bus
        and compare all compare a foot's touch sensor with."""
        return self.contact_share * self.mass * GRAVITY

    @property
    def devices(self) -> dict[int, str]:
        """Every device on the bus by ID: ``{4: "joint 'right_knee' (XL430-W250-T)", ...}``."""
        out = {j.servo.id: f"joint {j.name!r} ({j.servo.profile.model})" for j in self.joints if j.servo}
        if self.sensor_board is not None:
            out[self.sensor_board.id] = f"the sensor board ({self.sensor_board.profile.model})"
        return out

    @property
    def baud_rates(self) -> tuple[int, ...] | None:
        """The baud rates every device on the bus can be set to [bit/s], from their profiles
        (None when no profile lists its rates)."""
        return common_baud_rates(self.joints, self.sensor_board)


def common_baud_rates(joints: tuple[Joint, ...], board: SensorBoard | None) -> tuple[int, ...] | None:
    """The baud rates every listed device can be set to (None: no profile lists any)."""
    profiles = [j.servo.profile for j in joints if j.servo] + ([board.profile] if board else [])
    listed = [set(p.baud_rates) for p in profiles if p.baud_rates]
    return tuple(sorted(set.intersection(*listed))) if listed else None
