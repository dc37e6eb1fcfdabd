"""How a real robot differs from its nominal model: reality profiles and randomization.

A *reality file* (``configs/reality/*.yaml``) gives each perturbation below either one
value (a fixed perturbation: a "reality profile" such as ``default.yaml``) or a
``[low, high]`` range drawn uniformly per episode (domain randomization, as in
``randomize.yaml``)::

    description: one plausible XL430 biped, a little off nominal
    mass_scale: 1.08          # every link's mass and inertia, times
    kp_scale: [0.8, 1.2]      # each servo's position gain, drawn per servo and episode

Per joint values go under ``joints:`` (``biped sysid --per-joint`` writes them); ``centre:
FILE`` puts the ranges around another robot than the nominal one (:func:`centred`: scales
multiply, the rest adds), e.g. one ``biped sysid`` identified; a chain of centres is at most
``MAX_CENTRE_CHAIN`` files long and never comes back to a file (a cycle is refused, naming
the chain).  The keys of :data:`EFFECTS` are effects only the simulated bus simulates.  Every
value, given or centred, must lie within its key's :data:`PLAUSIBLE` range: a real robot
that differs from its model by more is a different robot (and MuJoCo goes numerically
unstable long before a 1e300 armature).

Each simulation gets its own draws from its own seeded stream (:func:`sample`, keyed by
run seed, generation, genome and episode), so results do not depend on how simulations are
batched or distributed.  Physical parameters go into the model (per simulation through
``mujoco.batch``, :func:`apply`): masses, friction, gains, latency (as actuator delay) and
backlash (the width of each backlash joint's range, in a model built with them:
:func:`needs_backlash_joints`); sensor noise acts on what the robot reads.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from sim2real.errors import ConfigError
from sim2real.robot.loading import exists
from sim2real.robot.validation import Node, load_yaml, show, show_name
from sim2real.robot import RobotSpec
from sim2real.robot.timing import control_timing
from sim2real.simulation.model.builder import build_model
from sim2real.simulation.model.parts import CLOSED_PLAY_RAD
from sim2real.simulation.model.robot_model import JointAngles

# name -> (nominal value, meaning with unit)
PERTURBATIONS: dict[str, tuple[float, str]] = {
    "mass_scale": (1.0, "each link's mass and inertia, times (drawn per link)"),
    "com_offset_m": (0.0, "each link's centre of mass moved this far in a random direction [m]"),
    "floor_friction_scale": (1.0, "the floor's sliding friction against the robot, times (every geom's, so "
                                  "that a contact, which takes the larger of its two geoms', sees it)"),
    "kp_scale": (1.0, "each servo's position gain, times (drawn per servo)"),
    "torque_scale": (1.0, "each servo's stall torque, times (drawn per servo)"),
    "damping_scale": (1.0, "each servo's back-EMF damping, times (drawn per servo)"),
    "friction_scale": (1.0, "each servo's Coulomb friction, times (drawn per servo)"),
    "armature_scale": (1.0, "each servo's reflected rotor inertia, times (drawn per servo)"),
    "derivative_ms": (0.0, "the position loop's D term as derivative time Td [ms]: kv = kp Td inside the "
                           "torque limit (an XL430 at D 4000, P 640: 50 firmware loop periods)"),
    "backlash_deg": (0.0, "free play of each joint's gears, full width [deg] (drawn per joint)"),
    "latency_ticks": (0.0, "delay from goal written to goal acted on [control ticks]"),
    "latency_ms": (0.0, "the same delay in milliseconds (as `biped sysid` measures it; adds to latency_ticks)"),
    "joint_noise_deg": (0.0, "standard deviation of the noise on joint readings [deg]"),
    "up_noise": (0.0, "standard deviation of the noise on each up-vector component"),
    "foot_flip": (0.0, "chance that a foot switch reads wrong at a tick"),
    "heading_drift_deg_s": (0.0, "the heading's drift, a gyro's uncorrected bias [deg/s] (drawn per episode; "
                                 "give a range about 0 for either sign)"),
    "gyro_noise_dps": (0.0, "standard deviation of the noise on each gyro rate [deg/s]"),
    "gyro_bias_dps": (0.0, "each gyro rate's bias [deg/s] (drawn per episode and axis; give a range about 0 "
                           "for either sign)"),
    "imu_delay_ms": (0.0, "age of the IMU's readings (up vector, heading, gyro) when the board reports them "
                          "[ms]: its fusion's output period and filter lag"),
}
# Effects only the simulated bus gives its robot: it steps one model in Python and can change
# it between physics steps, which mujoco.batch (evolution, `biped eval`) cannot.  They make the
# robot behind the bus one that the model itself cannot express - what system identification
# and the transfer check must be tested against.  Families after Rhoban BAM's M1-M6 friction
# models (Stribeck, load-dependent) and a supply that sags under current.
EFFECTS: dict[str, tuple[float, str]] = {
    "stribeck_nm": (0.0, "breakaway friction above the Coulomb friction at rest, fading with speed [N m]"),
    "stribeck_rad_s": (0.2, "the speed over which that excess fades (exp(-(v / v_s)^2)) [rad/s]"),
    "load_friction": (0.0, "Coulomb friction added per N m the gears transmit [N m / N m]"),
    "supply_sag": (0.0, "share of every servo's torque limit lost when all servos draw their stall current"),
}
# key -> (low, high) of a plausible value [the key's unit]: wide enough for every range the
# project ships and every value `biped sysid` can fit (identify.SERVO_PARAMETERS, LATENCY),
# also when ranges are centred on such a fit (randomize.yaml around a sysid profile).
PLAUSIBLE: dict[str, tuple[float, float]] = {
    # scales: down to a hundredth (benchmarks.tolerance draws 1 +- 0.9 and more), up to what a
    # sysid fit centred on randomize.yaml's ranges reaches
    "mass_scale": (0.01, 4.0),
    "com_offset_m": (0.0, 0.1),
    "floor_friction_scale": (0.01, 10.0),
    "kp_scale": (0.01, 10.0),
    "torque_scale": (0.01, 10.0),
    "damping_scale": (0.01, 20.0),
    "friction_scale": (0.01, 20.0),
    "armature_scale": (0.01, 20.0),
    "derivative_ms": (0.0, 100.0),
    "backlash_deg": (0.0, 10.0),
    "latency_ticks": (0.0, 10.0),
    "latency_ms": (0.0, 500.0),
    "joint_noise_deg": (0.0, 10.0),
    "up_noise": (0.0, 0.5),
    "foot_flip": (0.0, 0.5),
    "heading_drift_deg_s": (-180.0, 180.0),  # a calibrated gyro drifts < 1 deg/s; a broken one, tested, 90
    # a MEMS gyro's rate noise density is 0.005 (InvenSense MPU-6050) to 0.014 (Bosch BNO055) deg/s/sqrt(Hz)
    # by their datasheets, under 0.5 deg/s rms at a few hundred Hz; its zero-rate offset is +-1 (BNO055) to
    # +-20 deg/s (MPU-6050, uncalibrated).  The bounds are wide enough to test a bad one.
    "gyro_noise_dps": (0.0, 100.0),
    "gyro_bias_dps": (-100.0, 100.0),
    "imu_delay_ms": (0.0, 500.0),
    "stribeck_nm": (0.0, 5.0),
    "stribeck_rad_s": (0.001, 10.0),  # it divides: never 0
    "load_friction": (0.0, 1.0),
    "supply_sag": (0.0, 1.0),  # a share
}
MAX_CENTRE_CHAIN = 8  # reality files, each the centre of the one before
SCALES = ("mass_scale", "floor_friction_scale", "kp_scale", "torque_scale", "damping_scale", "friction_scale",
          "armature_scale")
SIGNED = ("heading_drift_deg_s", "gyro_bias_dps")  # may be negative: a drift either way
PER_SERVO = ("kp_scale", "torque_scale", "damping_scale", "friction_scale", "armature_scale", "backlash_deg")


@dataclass(frozen=True)
class Reality:
    """Each perturbation's ``(low, high)`` range; ``low == high`` is a fixed value."""

    name: str = "nominal"
    description: str = ""
    ranges: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    # joint name -> its own ranges of PER_SERVO keys (a file's ``joints:``), over ``ranges``
    joint_ranges: dict[str, dict[str, tuple[float, float]]] = dataclasses.field(default_factory=dict)
    # ranges around another robot than the nominal one (a file's ``centre:``, see `centred`):
    # that robot, and the ranges as given, before they were moved around it
    centre: "Reality | None" = None
    around: "Reality | None" = None

    def range(self, key: str) -> tuple[float, float]:
        nominal = PERTURBATIONS[key][0] if key in PERTURBATIONS else EFFECTS[key][0]
        return self.ranges.get(key, (nominal, nominal))

    def joint_range(self, joint: str, key: str) -> tuple[float, float]:
        return self.joint_ranges.get(joint, {}).get(key, self.range(key))

    @property
    def effects(self) -> list[str]:
        """The simulated bus's own effects this reality switches on (:data:`EFFECTS`)."""
        return [k for k, (v, _) in EFFECTS.items() if k != "stribeck_rad_s" and self.range(k) != (v, v)]

    def check_batchable(self) -> None:
        """Refuse, naming the key, a reality with effects only the simulated bus simulates."""
        if self.effects:
            raise ConfigError(self.name, self.effects[0], "only the simulated bus simulates this effect "
                              "(`biped dry-run`, `biped excite`); evolution and `biped eval` cannot")

    @property
    def is_nominal(self) -> bool:
        return not self.perturbed

    @property
    def max_latency_s(self) -> tuple[float, float]:
        """The longest latency this reality draws: (control ticks, plus seconds)."""
        return self.range("latency_ticks")[1], self.range("latency_ms")[1] / 1e3

    def scaled(self, intensity: float) -> "Reality":
        """Every range moved toward nominal (or the centre): ``nominal + intensity * (value -
        nominal)``; 0 is the nominal robot (the centre), 1 (or more) this reality itself."""
        if intensity >= 1.0:
            return self

        base = self.centre or NOMINAL  # intensity 0 is the robot the ranges are around

        def toward(key, r, joint=None):
            if key == "stribeck_rad_s":
                return r  # the shape of an effect, not an amount of it
            nominal = base.joint_range(joint, key)[0] if joint else base.range(key)[0]
            return nominal + intensity * (r[0] - nominal), nominal + intensity * (r[1] - nominal)

        ranges = {key: toward(key, r) for key, r in self.ranges.items()}
        joints = {j: {key: toward(key, r, j) for key, r in values.items()} for j, values in self.joint_ranges.items()}
        return Reality(f"{self.name} x{intensity:g}", self.description, ranges, joints, self.centre)

    def only(self, key: str) -> "Reality":
        """This reality with every perturbation but ``key`` at its nominal value."""
        joints = {j: {key: values[key]} for j, values in self.joint_ranges.items() if key in values}
        return Reality(f"{self.name} (only {key})", self.description, {key: self.range(key)}, joints)

    @property
    def perturbed(self) -> list[str]:
        """The perturbations this reality moves off nominal, in :data:`PERTURBATIONS` order."""
        return [k for k, (v, _) in PERTURBATIONS.items()
                if self.range(k) != (v, v) or any(self.joint_range(j, k) != (v, v) for j in self.joint_ranges)]

    def to_dict(self) -> dict[str, Any]:
        if self.around is not None:  # as written: the ranges as given, and the robot they are around
            return {**self.around.to_dict(), "centre": self.centre.to_dict()}
        out: dict[str, Any] = {"description": self.description} if self.description else {}
        as_value = lambda lo, hi: lo if lo == hi else [lo, hi]  # noqa: E731
        for key, (lo, hi) in self.ranges.items():
            out[key] = as_value(lo, hi)
        if self.joint_ranges:
            out["joints"] = {j: {key: as_value(*r) for key, r in values.items()} for j, values in self.joint_ranges.items()}
        return out


NOMINAL = Reality()


def _unit(key: str) -> str:
    """The unit in a key's name, for messages ("deg" for ``backlash_deg``; "" for a scale)."""
    for suffix, unit in (("_deg_s", "deg/s"), ("_dps", "deg/s"), ("_deg", "deg"), ("_ms", "ms"), ("_nm", "N m"), ("_m", "m"),
                         ("_rad_s", "rad/s"), ("_ticks", "ticks")):
        if key.endswith(suffix):
            return unit
    return ""


def _value_or_range(key: str, item: Node) -> tuple[float, float]:
    if isinstance(item.value, list):
        lo, hi = item.pair()
    else:
        lo = hi = item.number()
    if lo < 0 and key not in SIGNED:
        raise item.error(f"must not be negative, got {show(item.value)}")
    if key in SCALES and lo == 0:
        raise item.error("a scale must be > 0")
    if key == "foot_flip" and hi > 1:
        raise item.error(f"is a probability (0-1), got {show(item.value)}")
    lo_ok, hi_ok = PLAUSIBLE[key]
    if lo < lo_ok or hi > hi_ok:
        unit = f" {_unit(key)}" if _unit(key) else ""
        raise item.error(f"must be within the plausible {lo_ok:g} to {hi_ok:g}{unit}, got {show(item.value)}")
    return float(lo), float(hi)


def _check_plausible(reality: "Reality", source: str) -> None:
    """Every range of ``reality`` (ranges centred on another robot) within :data:`PLAUSIBLE`."""
    rows = [(key, r) for key, r in reality.ranges.items()]
    rows += [(f"joints.{show(j)}.{key}", r) for j, values in reality.joint_ranges.items() for key, r in values.items()]
    for where, (lo, hi) in rows:
        key = where.rsplit(".", 1)[-1]
        lo_ok, hi_ok = PLAUSIBLE[key]
        if lo < lo_ok or hi > hi_ok:
            unit = f" {_unit(key)}" if _unit(key) else ""
            raise ConfigError(source, where, f"around its centre {reality.centre.name if reality.centre else ''} "
                              f"this is {lo:g} to {hi:g}{unit}, outside the plausible {lo_ok:g} to {hi_ok:g}{unit}")


def parse_reality(doc: Any, source: str, name: str = "inline", *, chain: tuple[str, ...] = ()) -> Reality:
    """A reality file's contents: each key of :data:`PERTURBATIONS` a value or a range, and
    optionally ``joints:``, per joint name values of :data:`PER_SERVO` keys that override the
    robot-wide ones (what ``biped sysid --per-joint`` writes).  ``chain``: the files whose
    ``centre:`` led here (a cycle through them is refused)."""
    node = Node(doc if doc is not None else {}, source)
    node.mapping(optional=("description", "joints", "centre", *PERTURBATIONS, *EFFECTS))
    ranges: dict[str, tuple[float, float]] = {}
    joints: dict[str, dict[str, tuple[float, float]]] = {}
    for key, item in node.items():
        if key == "centre":
            continue
        if key == "joints":
            for joint, values in item.items():
                values.mapping(optional=PER_SERVO)
                joints[joint] = {k: _value_or_range(k, v) for k, v in values.items()}
        elif key != "description":
            ranges[key] = _value_or_range(key, item)
    description = node.get("description").string() if node.has("description") else ""
    reality = Reality(name, description, ranges, joints)
    if node.has("centre"):
        item = node["centre"]
        if not isinstance(item.value, (str, dict)):
            raise item.error("must be a reality file's name or path (fixed values), or its contents")
        target = item.value
        if isinstance(target, str) and not Path(target).is_absolute() and source != "<inline reality>":
            beside = Path(source).parent / target  # as an include is read: from the naming file's folder
            if exists(beside):
                target = str(beside)
        try:
            centre = load_reality(target, chain=(*chain, source))
        except FileNotFoundError as exc:
            raise item.error(str(exc)) from None
        reality = centred(reality, centre)
        _check_plausible(reality, source)
    return reality


def reality_dir() -> Path:
    from sim2real.robot.paths import data_root

    return data_root() / "configs" / "reality"


def load_reality(name_or_path: str | Path | dict | Reality | None, *, chain: tuple[str, ...] = ()) -> Reality:
    """A reality file by name (``configs/reality/<name>.yaml``) or path; a mapping is taken
    as the file's contents; ``None`` or ``"nominal"`` is the nominal robot.  ``chain``: the
    files whose ``centre:`` led here, outermost first (see :func:`parse_reality`)."""
    if isinstance(name_or_path, Reality):
        return name_or_path
    if name_or_path is None or name_or_path == "nominal":
        return NOMINAL
    if isinstance(name_or_path, dict):
        source = "<inline reality>"
    else:
        path = Path(name_or_path)
        if not exists(path):
            candidate = reality_dir() / f"{name_or_path}.yaml"
            if not exists(candidate):
                known = ", ".join(sorted(p.stem for p in reality_dir().glob("*.yaml")))
                raise FileNotFoundError(f"unknown reality profile {show_name(str(name_or_path))} (known: nominal, {known}; "
                                        "or a path)")
            path = candidate
        source = str(path)
    files = [c for c in chain if c != "<inline reality>"]
    if chain and not isinstance(name_or_path, dict):
        if any(_same_file(path, c) for c in files):
            loop = " -> ".join((*files, source))
            raise ConfigError(chain[-1], "centre", f"a cycle of centres: {loop}")
    if len(chain) >= MAX_CENTRE_CHAIN:
        raise ConfigError(chain[-1], "centre", f"more than {MAX_CENTRE_CHAIN} reality files each the centre of the "
                          f"one before ({' -> '.join(chain[:3])} -> ...)")
    if isinstance(name_or_path, dict):
        return parse_reality(name_or_path, source, chain=chain)
    return parse_reality(load_yaml(path), source, path.stem, chain=chain)


def _same_file(path: Path, other: str) -> bool:
    try:
        return path.resolve() == Path(other).resolve() or path.samefile(other)
    except OSError:
        return False


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


def centred(ranges: Reality, centre: Reality) -> Reality:
    """``ranges`` (e.g. ``randomize.yaml``) around the robot ``centre`` (fixed values, e.g. what
    ``biped sysid`` identified) instead of around the nominal model: a scale's range is
    multiplied by the centre's value, any other range is shifted by it (the ranges are
    deviations from the robot; the identified robot becomes the one they deviate from).
    Per-joint values of the centre give per-joint ranges.  A reality file says the same with
    ``centre: FILE``; scaled toward intensity 0 (evolution's ramp), the ranges shrink to the
    centre, not to the nominal model."""
    fixed = [k for k, (lo, hi) in centre.ranges.items() if lo != hi]
    fixed += [f"joints.{j}.{k}" for j, v in centre.joint_ranges.items() for k, (lo, hi) in v.items() if lo != hi]
    if fixed:
        raise ConfigError(centre.name, fixed[0], "a centre for randomization must be fixed values (a profile such "
                          "as `biped sysid` writes), not ranges")

    def around(key: str, r: tuple[float, float], c: float) -> tuple[float, float]:
        return (r[0] * c, r[1] * c) if key in SCALES else (r[0] + c, r[1] + c)

    keys = set(ranges.ranges) | set(centre.ranges)
    out = {k: around(k, ranges.range(k), centre.range(k)[0]) if k in centre.ranges else ranges.range(k) for k in keys}
    joints = {j: {k: around(k, ranges.joint_range(j, k), c) for k, (c, _) in values.items()}
              for j, values in centre.joint_ranges.items()}
    for j, values in ranges.joint_ranges.items():
        for k, r in values.items():
            joints.setdefault(j, {}).setdefault(k, around(k, r, centre.range(k)[0]) if k in centre.ranges else r)
    return Reality(f"{ranges.name} around {centre.name}", ranges.description, dict(sorted(out.items())), joints,
                   centre, ranges)
