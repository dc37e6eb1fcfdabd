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

Drawing from the ranges, and putting the draws into a model, is :mod:`.randomize`'s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sim2real.errors import ConfigError
from sim2real.robot.loading import exists
from sim2real.robot.validation import Node, load_yaml, show, show_name


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
        path = reality_path(name_or_path)
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


def reality_path(name_or_path: str | Path) -> Path:
    """The file of the reality profile ``name_or_path``: that path, else ``configs/reality/<name>.yaml``."""
    path = Path(name_or_path)
    if exists(path):
        return path
    candidate = reality_dir() / f"{name_or_path}.yaml"
    if not exists(candidate):
        known = ", ".join(sorted(p.stem for p in reality_dir().glob("*.yaml")))
        raise FileNotFoundError(f"unknown reality profile {show_name(str(name_or_path))} (known: nominal, {known}; "
                                "or a path)")
    return candidate


def _same_file(path: Path, other: str) -> bool:
    try:
        return path.resolve() == Path(other).resolve() or path.samefile(other)
    except OSError:
        return False


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
