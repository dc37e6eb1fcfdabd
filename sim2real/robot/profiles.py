"""Servo and sensor-board firmware profiles: the data in ``firmware_profiles/*.yaml``.

A profile is what the e-manual says about one Dynamixel model (or our foot-sensor
board): its model number and protocol, the control-table entries the project uses,
its position resolution, its motor's stall torque and no-load speed, and its default
gains with their conversion to physical units.  This module only reads and checks
the data (every physical quantity within a plausible range, :data:`MOTOR_RANGES` and the
bounds beside it; divisors > 0; register defaults that fit their bytes);
:mod:`sim2real.robot.servo_model` turns it into physics.

    profile = load_profile("XL430-W250-T")
    profile.register("goal_position").address      # 116
    profile.motor.stall_torque_nm                   # 1.4 [N m]
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from sim2real.robot.paths import profiles_dir
from sim2real.robot.validation import Node, load_yaml, show

# Plausible ranges of a profile's physical quantities, checked on reading with the key named:
# any Dynamixel from the XL330 (0.52 N m, 18 g) to the largest Dynamixel-P (44.7 N m, 855 g),
# with room to spare.  (low, high, unit); a low of 0 is exclusive where the value divides.
MOTOR_RANGES: dict[str, tuple[float, float, str]] = {
    "nominal_voltage_v": (3.0, 48.0, "V"),
    "stall_torque_nm": (0.0, 100.0, "N m"),  # > 0
    "stall_current_a": (0.0, 30.0, "A"),  # > 0
    "no_load_speed_rpm": (0.0, 1000.0, "rpm"),  # > 0
    "no_load_current_a": (0.0, 10.0, "A"),
    "gear_ratio": (1.0, 5000.0, ""),
    "armature_kgm2": (0.0, 1.0, "kg m^2"),
    "viscous_friction_nms": (0.0, 10.0, "N m s/rad"),
    "coulomb_friction_nm": (0.0, 100.0, "N m"),  # and below stall_torque_nm
}
_POSITIVE_MOTOR = ("stall_torque_nm", "stall_current_a", "no_load_speed_rpm")
MASS_KG = (0.001, 5.0)  # a device's mass [kg], > 0
GAIN_MAX = 2.0**20  # a gain's table value or divisor (registers are at most 32 bit; shipped: <= 65536)
_DIVISORS = ("p_divisor", "i_divisor", "d_divisor", "pwm_limit", "torque_limit")  # > 0: they divide
UNIT_MAX = 100.0  # a unit's size (velocity_unit_rpm, load_unit_percent, voltage_unit_v, LSBs), > 0
TICK_LIMIT = 2**31  # position ticks are within (-2^31, 2^31)
RESOLUTION = (2, 2**20)  # encoder ticks a revolution
BAUD_RANGE = (9600, 10_500_000)  # [bit/s], as a robot's bus.baud
# The instructions each protocol defines, by the names a profile's ``instructions`` lists (ROBOTIS
# e-manual, "Protocol 1.0" and "Protocol 2.0" instruction tables).  Which of them a model answers
# is the model's own (protocol 1.0: Reboot on MX firmware v40+ and X, Bulk Read on MX only).
INSTRUCTIONS: dict[float, tuple[str, ...]] = {
    1.0: ("ping", "read", "write", "reg_write", "action", "factory_reset", "reboot", "sync_write", "bulk_read"),
    2.0: ("ping", "read", "write", "reg_write", "action", "factory_reset", "reboot", "clear", "sync_read",
          "sync_write", "bulk_read", "bulk_write", "fast_sync_read", "fast_bulk_read"),
}
_BASIC_INSTRUCTIONS = ("ping", "read", "write")  # every device on a bus answers these
# What a profile that lists no instructions is taken to answer besides those: what every model of
# its protocol has (protocol 1.0: Sync Write for all, Bulk Read on MX only - e-manual "Protocol
# 1.0"; DynamixelSDK protocol1_packet_handler.bulkReadTx: "Available only on Dynamixel MX / X series").
UNLISTED_INSTRUCTIONS: dict[float, tuple[str, ...]] = {
    1.0: ("sync_write",), 2.0: ("sync_read", "sync_write", "bulk_read", "bulk_write")}


@dataclass(frozen=True)
class Register:
    """One control-table entry."""

    name: str
    address: int
    size: int  # [bytes]
    signed: bool
    access: str  # "R" or "RW"
    area: str  # "EEPROM" or "RAM"
    unit: str | None  # physical size of one LSB, e.g. "0.229 rpm"; None for codes
    default: int = 0
    encoding: str | None = None  # e.g. "sign_magnitude_bit10" (AX-12A speed and load)
    range: tuple[int, int] | None = None  # the e-manual's Range column: writes outside it are refused


@dataclass(frozen=True)
class PositionSpec:
    """Encoder resolution and position range of a servo."""

    resolution: int  # ticks a revolution (or over range_deg)
    min_tick: int
    max_tick: int
    center_tick: int
    range_deg: float  # angle covered by min_tick..max_tick+1 [deg]

    @property
    def rad_per_tick(self) -> float:
        return math.radians(self.range_deg) / (self.max_tick - self.min_tick + 1)

    @property
    def range_rad(self) -> tuple[float, float]:
        """Reachable angles relative to the centre tick [rad]."""
        return (
            (self.min_tick - self.center_tick) * self.rad_per_tick,
            (self.max_tick - self.center_tick) * self.rad_per_tick,
        )


@dataclass(frozen=True)
class MotorSpec:
    """DC motor and gearbox at the nominal voltage, referred to the output shaft."""

    nominal_voltage_v: float
    stall_torque_nm: float
    stall_current_a: float
    no_load_speed_rpm: float
    no_load_current_a: float
    gear_ratio: float
    armature_kgm2: float  # reflected rotor inertia [kg m^2]
    viscous_friction_nms: float  # [N m s/rad]
    coulomb_friction_nm: float  # [N m]
    sources: dict[str, str] = field(default_factory=dict)

    @property
    def no_load_speed_rad_s(self) -> float:
        return self.no_load_speed_rpm * 2.0 * math.pi / 60.0


@dataclass(frozen=True)
class GainSpec:
    """Default position-loop gains as table values (``type`` is ``pid`` or ``compliance``)."""

    type: str
    values: dict[str, float]
    source: str = ""


@dataclass(frozen=True)
class DeviceProfile:
    """One device model on a Dynamixel bus: a servo or the foot-sensor board."""

    model: str
    kind: str  # "servo" or "sensor_board"
    model_number: int
    protocol: float  # 1.0 or 2.0
    mass_kg: float
    source: str
    path: Path
    control_table: dict[str, Register]
    position: PositionSpec | None = None
    motor: MotorSpec | None = None
    gains: GainSpec | None = None
    units: dict[str, float] = field(default_factory=dict)  # velocity_unit_rpm, ...; a board's up_vector_unit
    variants: tuple[str, ...] = ()
    sensors: dict[str, Any] = field(default_factory=dict)
    baud_rates: tuple[int, ...] = ()  # [bit/s] the rates it can be set to (empty: not listed)
    instructions: tuple[str, ...] = ()  # what its firmware answers, names of INSTRUCTIONS (empty: not listed)

    def has(self, instruction: str) -> bool:
        """Whether the firmware answers ``instruction`` (a name in :data:`INSTRUCTIONS`): as the
        profile lists, else as every model of its protocol does (:data:`UNLISTED_INSTRUCTIONS`)."""
        if self.instructions:
            return instruction in self.instructions
        return instruction in _BASIC_INSTRUCTIONS + UNLISTED_INSTRUCTIONS[self.protocol]

    def register(self, name: str) -> Register:
        try:
            return self.control_table[name]
        except KeyError:
            raise KeyError(f"{self.model} has no control-table entry {name!r}") from None

    @property
    def is_servo(self) -> bool:
        return self.kind == "servo"


_SERVO_KEYS = ("position", "motor", "gains")
_UNIT_KEYS = ("velocity_unit_rpm", "load_unit_percent", "voltage_unit_v")


def _read_register(node: Node) -> Register:
    node.mapping(
        required=("name", "address", "size", "signed", "access", "area", "unit"),
        optional=("default", "encoding", "range"),
    )
    size = node["size"].integer()
    if size not in (1, 2, 4):
        raise node.error(f"must be 1, 2 or 4 bytes, got {size}", key="size")
    unit = node["unit"].value
    signed = node["signed"].boolean()
    bits = 8 * size  # a value must fit its bytes (the mock and simulated buses store it so)
    fits = dict(lo=-(2 ** (bits - 1)), hi=2 ** (bits - 1) - 1) if signed else dict(lo=0, hi=2**bits - 1)
    return Register(
        name=node["name"].string(),
        address=node["address"].integer(0, 0xFFFF),
        size=size,
        signed=signed,
        access=node["access"].string(("R", "RW")),
        area=node["area"].string(("EEPROM", "RAM")),
        unit=None if unit is None else str(unit),
        default=node.get("default", 0).integer(**fits),
        encoding=node["encoding"].string() if node.has("encoding") else None,
        range=_register_range(node["range"], fits) if node.has("range") else None,
    )


def _lsb(node: Node) -> float:
    """The physical size of one LSB: a number, or a fraction written ``1/N`` (``1/16384``: Q14)."""
    value = node.value
    if isinstance(value, str) and value.count("/") == 1:
        num, den = (part.strip() for part in value.split("/"))
        if num.isdigit() and den.isdigit() and int(num) > 0 and int(den) > 0:
            return int(num) / int(den)
    if isinstance(value, (int, float)) and not isinstance(value, bool) and 0 < value <= UNIT_MAX:
        return float(value)
    raise node.error(f"must be a positive number (at most {UNIT_MAX:g}) or a fraction like 1/16384, got {show(value)}")


def _register_range(node: Node, fits: dict[str, int]) -> tuple[int, int]:
    items = node.list()
    if len(items) != 2 or items[0].integer(**fits) > items[1].integer(**fits):
        raise node.error(f"must be [min, max], got {show(node.value)}")
    return items[0].integer(), items[1].integer()


def _read_instructions(node: Node, protocol: float) -> tuple[str, ...]:
    """The instructions a model answers: names its protocol defines, each once, ping/read/write among them."""
    known = INSTRUCTIONS[protocol]
    names = tuple(item.string(known) for item in node.list(min_len=1))
    if len(set(names)) != len(names):
        raise node.error(f"lists an instruction twice: {show(list(names))}")
    missing = [name for name in _BASIC_INSTRUCTIONS if name not in names]
    if missing:
        raise node.error(f"must list {', '.join(missing)} (every device answers them)")
    return names


def parse_profile(doc: Any, path: Path) -> DeviceProfile:
    """Validate one profile document (already loaded from YAML)."""
    root = Node(doc, str(path))
    if not root.has("kind"):
        raise root.error("missing required key 'kind' (servo or sensor_board)", key="kind")
    kind = root["kind"].string(("servo", "sensor_board"))
    common = ("model", "kind", "model_number", "protocol", "mass_kg", "source", "control_table")
    if kind == "servo":
        root.mapping(required=common + _SERVO_KEYS, optional=_UNIT_KEYS + ("variants", "baud_rates", "instructions"))
    else:
        root.mapping(required=common + ("sensors",), optional=("variants", "baud_rates", "instructions"))

    table: dict[str, Register] = {}
    for entry in root["control_table"].list(min_len=1):
        reg = _read_register(entry)
        if reg.name in table:
            raise entry.error(f"duplicate control-table entry {show(reg.name)}", key="name")
        table[reg.name] = reg
    for needed in ("model_number", "id", "return_delay_time"):
        if needed not in table:
            raise root.error(f"control table lacks {needed!r}", key="control_table")

    protocol = root["protocol"].number()
    if protocol not in (1.0, 2.0):
        raise root.error(f"must be 1.0 or 2.0, got {protocol}", key="protocol")
    if protocol == 1.0:  # a protocol-1.0 packet carries the address in one byte
        for i, reg in enumerate(table.values()):
            if reg.address + reg.size > 256:
                raise root.error(f"{reg.name} (address {reg.address}, {reg.size} bytes) is beyond address 255, "
                                 "which protocol 1.0 cannot reach", key=f"control_table[{i}].address")
    profile = dict(
        model=root["model"].string(),
        kind=kind,
        model_number=root["model_number"].integer(0, 0xFFFF),
        protocol=protocol,
        mass_kg=root["mass_kg"].number(*MASS_KG, unit="kg"),
        source=root["source"].string(),
        path=Path(path),
        control_table=table,
        variants=tuple(v.string() for v in root.get("variants", []).list()),
        baud_rates=tuple(sorted({b.integer(*BAUD_RANGE) for b in root.get("baud_rates", []).list()})),
        instructions=_read_instructions(root["instructions"], protocol) if root.has("instructions") else (),
    )
    if kind == "sensor_board":
        sensors = root["sensors"]
        up_unit = _lsb(sensors["up_vector_unit"]) if sensors.has("up_vector_unit") else None
        for axis in "xyz":
            reg = table.get(f"up_vector_{axis}")
            if reg is not None and (up_unit is None or reg.unit is None or _lsb(Node(reg.unit, str(path))) != up_unit):
                raise sensors.error(f"up_vector_unit ({sensors.get('up_vector_unit').value}) must be given and be "
                                    f"up_vector_{axis}'s unit ({reg.unit})", key="up_vector_unit")
        units = {"up_vector_unit": up_unit} if up_unit is not None else {}
        # optional sensors: a board without them serves controllers that do not read them
        for unit_key, registers, unit in (("heading_unit", ("heading",), "rad"),
                                          ("gyro_unit", ("gyro_x", "gyro_y", "gyro_z"), "rad/s")):
            present = [r for r in registers if r in table]
            if not present:
                continue
            if len(present) < len(registers):
                raise root.error(f"control_table has {', '.join(present)} but not "
                                 f"{', '.join(r for r in registers if r not in table)}: give all or none")
            lsb = _lsb(sensors[unit_key]) if sensors.has(unit_key) else None
            for name in registers:
                reg = table[name]
                if lsb is None or reg.unit is None or _lsb(Node(reg.unit, str(path))) != lsb:
                    raise sensors.error(f"{unit_key} ({sensors.get(unit_key).value}) must be given and be "
                                        f"{name}'s unit ({reg.unit}) [{unit}]", key=unit_key)
            units[unit_key] = lsb
        return DeviceProfile(**profile, sensors=dict(sensors.free_mapping()), units=units)

    pos = root["position"].mapping(
        required=("resolution", "min_tick", "max_tick", "center_tick", "range_deg")
    )
    ticks = dict(lo=1 - TICK_LIMIT, hi=TICK_LIMIT - 1)
    position = PositionSpec(
        resolution=pos["resolution"].integer(*RESOLUTION),
        min_tick=pos["min_tick"].integer(**ticks),
        max_tick=pos["max_tick"].integer(**ticks),
        center_tick=pos["center_tick"].integer(**ticks),
        range_deg=pos["range_deg"].number(positive=True, hi=360.0, unit="deg"),
    )
    if position.max_tick <= position.min_tick:  # rad_per_tick divides by their difference
        raise pos.error("must be above min_tick", key="max_tick")
    if not position.min_tick <= position.center_tick <= position.max_tick:
        raise pos.error("center_tick must lie between min_tick and max_tick", key="center_tick")

    mot = root["motor"]
    numeric = [f for f in MotorSpec.__dataclass_fields__ if f != "sources"]
    mot.mapping(required=numeric, optional=("sources",))
    motor = MotorSpec(
        **{f: mot[f].number(lo=None if f in _POSITIVE_MOTOR else MOTOR_RANGES[f][0], hi=MOTOR_RANGES[f][1],
                            positive=f in _POSITIVE_MOTOR, unit=MOTOR_RANGES[f][2]) for f in numeric},
        sources={str(k): str(v) for k, v in (mot.get("sources", {}).value or {}).items()},
    )
    if motor.coulomb_friction_nm >= motor.stall_torque_nm:
        raise mot.error("must be below stall_torque_nm", key="coulomb_friction_nm")
    # the servo model's back-EMF damping, (stall - coulomb) / no-load speed, includes the viscous part
    if motor.viscous_friction_nms > (motor.stall_torque_nm - motor.coulomb_friction_nm) / motor.no_load_speed_rad_s:
        raise mot.error("is too large to reach no_load_speed_rpm with stall_torque_nm", key="viscous_friction_nms")

    g = root["gains"]
    if not g.has("type"):
        raise g.error("missing required key 'type' (pid or compliance)", key="type")
    gtype = g["type"].string(("pid", "compliance"))
    values = {k: n.number(lo=None if k in _DIVISORS else 0.0, hi=GAIN_MAX, positive=k in _DIVISORS)
              for k, n in g.items() if k not in ("type", "source")}
    need = (
        ("position_p", "p_divisor", "pwm_limit")
        if gtype == "pid"
        else ("cw_compliance_slope", "ccw_compliance_slope", "torque_limit")
    )
    for key in need:
        if key not in values:
            raise g.error(f"missing required key {key!r} for {gtype} gains", key=key)
    if gtype == "compliance" and values["cw_compliance_slope"] + values["ccw_compliance_slope"] <= 0:
        raise g.error("the compliance slopes divide: give at least one > 0", key="cw_compliance_slope")
    gains = GainSpec(type=gtype, values=values, source=str(g.get("source", "").value))
    units = {k: root[k].number(positive=True, hi=UNIT_MAX) for k in _UNIT_KEYS if root.has(k)}
    return DeviceProfile(**profile, position=position, motor=motor, gains=gains, units=units)


@lru_cache(maxsize=None)
def _profiles_in(folder: Path) -> dict[str, DeviceProfile]:
    by_name: dict[str, DeviceProfile] = {}
    for path in sorted(folder.glob("*.yaml")):
        profile = parse_profile(load_yaml(path), path)
        for name in (profile.model, *profile.variants, path.stem):
            by_name[name.upper()] = profile
    return by_name


def available_profiles(folder: Path | None = None) -> list[str]:
    """Model names of every profile in ``firmware_profiles/``."""
    return sorted({p.model for p in _profiles_in(folder or profiles_dir()).values()})


def supported_baud_rates(folder: Path | None = None) -> tuple[int, ...]:
    """Every baud rate some profile in ``firmware_profiles/`` can be set to [bit/s]."""
    return tuple(sorted({b for p in _profiles_in(folder or profiles_dir()).values() for b in p.baud_rates}))


def load_profile(name: str, folder: Path | None = None) -> DeviceProfile:
    """The profile for a model name (``"XL430-W250-T"``), a variant or a file stem."""
    profiles = _profiles_in(folder or profiles_dir())
    try:
        return profiles[name.upper()]
    except KeyError:
        known = ", ".join(available_profiles(folder))
        raise KeyError(f"unknown servo profile {show(name)} (known: {known})") from None
