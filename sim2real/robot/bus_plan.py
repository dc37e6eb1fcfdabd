"""Which packets an access to many devices takes on a bus of several protocols and control
tables, and what one control tick's packets cost.

A robot may mix servos on one port at one baud rate: AX-12A (protocol 1.0: neither Sync Read
nor Bulk Read), MX-28 with its protocol-1.0 firmware (Bulk Read), X series and MX (2.0) (Sync
Read and Bulk Read).  A device hears only instructions of its own protocol, and a Sync Read or
Sync Write reaches only devices that keep the entry at one address and size.  So reading or
writing one entry (or a span of neighbouring entries) of many devices is planned as a few
*exchanges* - one instruction packet each - grouped by protocol and layout:

    plan_reads(devices, ["present_position"], ids)
    # (Exchange("sync_read", 2.0, ...), Exchange("bulk_read", 1.0, ...), Exchange("read", 1.0, ...), ...)

Reads, per protocol (in the order the protocols first appear among ``ids``): one Sync Read when
every device has it and one layout; else one Bulk Read of the devices that have it (two at
least: a protocol-1.0 Bulk Read cannot read a single device), one Sync Read per layout of the
others that have that, and a Read each for the rest.  Writes: one Sync Write per protocol and
layout (both protocols have it), a Write each for a device without it.

The same plan drives the bus (:class:`~sim2real.hardware.dynamixel.chain.ServoChain`) and
prices a control tick (:func:`tick_exchanges`, :func:`bus_time`), so what a tick is checked
against is the packets the loop sends.  Packet sizes: ROBOTIS e-manual, "Protocol 1.0" and
"Protocol 2.0" (2.0's byte stuffing, rare, left out).  Which instructions a model has is its
profile's ``instructions`` (:meth:`sim2real.robot.profiles.DeviceProfile.has`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Mapping, Sequence

from sim2real.robot.profiles import DeviceProfile
from sim2real.robot.spec import RobotSpec

READ, WRITE = "read", "write"  # one device, one status packet back
SYNC_READ, SYNC_WRITE, BULK_READ = "sync_read", "sync_write", "bulk_read"
BITS_PER_BYTE = 10  # start + 8 data + stop bits
# The host's turnaround, once per exchange that waits for replies [s]: the USB adapter holds
# the last bytes of a reply until its latency timer expires (FTDI application note AN232B-04,
# "Data Throughput, Latency and Handshaking"); start-up warns unless it is set to 1 ms.
TURNAROUND_S = 1e-3
RETURN_DELAY_US = 0.0  # each status packet's Return Delay Time once start-up has set it [us]
# The entries of one control tick, as named in firmware_profiles/ (hardware.dynamixel.registers.Reg)
PRESENT_POSITION, GOAL_POSITION = "present_position", "goal_position"
BOARD_FIRST = "foot_switch_left"
BOARD_LAST = ("up_vector_z", "heading", "gyro_x", "gyro_y", "gyro_z")  # those the board has: its read ends at the last

Item = tuple[int, int, int]  # (id, address, size [bytes])


@dataclass(frozen=True)
class Exchange:
    """One instruction packet and the status packets it brings back."""

    kind: str  # READ, WRITE, SYNC_READ, BULK_READ or SYNC_WRITE
    protocol: float
    items: tuple[Item, ...]  # (id, address, size) of each device it reaches, in order

    @property
    def ids(self) -> tuple[int, ...]:
        return tuple(i for i, _, _ in self.items)

    @property
    def replies(self) -> int:
        """Status packets that come back (a Sync Write gets none)."""
        return 0 if self.kind == SYNC_WRITE else len(self.items)

    def out_bytes(self) -> int:
        """The instruction packet's bytes: 10 + parameters in protocol 2.0 (header 4, ID, length 2,
        instruction, CRC 2), 6 + parameters in 1.0 (header 2, ID, length, instruction, checksum)."""
        n, size = len(self.items), self.items[0][2]
        two = self.protocol == 2.0
        params = {READ: 4 if two else 2, WRITE: (2 if two else 1) + size,
                  SYNC_READ: 4 + n, BULK_READ: 5 * n if two else 1 + 3 * n,
                  SYNC_WRITE: (4 if two else 2) + n * (1 + size)}[self.kind]
        return (10 if two else 6) + params

    def in_bytes(self) -> int:
        """The status packets' bytes: 11 + data each in protocol 2.0, 6 + data in 1.0."""
        overhead = 11 if self.protocol == 2.0 else 6
        if self.kind == SYNC_WRITE:
            return 0
        if self.kind == WRITE:
            return overhead
        return sum(overhead + size for _, _, size in self.items)

    def describe(self) -> str:
        """``sync read (2.0) of servos 1-6, 4 bytes at 132`` and the like."""
        sizes = {(a, s) for _, a, s in self.items}
        where = (f"{self.items[0][2]} bytes at {self.items[0][1]}" if len(sizes) == 1
                 else "each its own address")
        who = "servo" + ("s " if len(self.items) > 1 else " ") + id_list(self.ids)
        return f"{self.kind.replace('_', ' ')} (protocol {self.protocol:.1f}) of {who}, {where}"


def id_list(ids: Iterable[int]) -> str:
    """``1-6, 9, 21-22``: IDs with their runs joined."""
    ids = sorted(set(ids))
    runs: list[list[int]] = []
    for i in ids:
        if runs and i == runs[-1][-1] + 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    return ", ".join(f"{r[0]}-{r[-1]}" if len(r) > 2 else ", ".join(map(str, r)) for r in runs)


def span(profile: DeviceProfile, names: Sequence[str]) -> tuple[int, int]:
    """(address, size) of the bytes ``names`` cover on a device; ``ValueError`` unless they lie
    next to each other (``KeyError`` for an entry the device lacks)."""
    regs = [profile.register(name) for name in names]
    start = min(r.address for r in regs)
    size = max(r.address + r.size for r in regs) - start
    if size != sum(r.size for r in regs):
        raise ValueError(f"{', '.join(names)} do not lie next to each other on {profile.model}: read them one by one")
    return start, size


def _by_protocol(devices: Mapping[int, DeviceProfile], ids: Sequence[int]) -> dict[float, list[int]]:
    groups: dict[float, list[int]] = {}
    for i in ids:
        groups.setdefault(devices[i].protocol, []).append(i)
    return groups


def _by_layout(items: Iterable[Item]) -> dict[tuple[int, int], list[Item]]:
    groups: dict[tuple[int, int], list[Item]] = {}
    for item in items:
        groups.setdefault(item[1:], []).append(item)
    return groups


def plan_reads(devices: Mapping[int, DeviceProfile], names: Sequence[str],
               ids: Sequence[int] | None = None) -> tuple[Exchange, ...]:
    """The exchanges that read the span of ``names`` from every device in ``ids`` (default: all
    of ``devices``), grouped as the module docstring says."""
    ids = list(devices) if ids is None else list(ids)
    plan: list[Exchange] = []
    for protocol, members in _by_protocol(devices, ids).items():
        items = [(i, *span(devices[i], names)) for i in members]
        layouts = _by_layout(items)
        if len(layouts) == 1 and all(devices[i].has(SYNC_READ) for i in members):
            plan.append(Exchange(SYNC_READ, protocol, tuple(items)))
            continue
        bulk = [item for item in items if devices[item[0]].has(BULK_READ)]
        if len(bulk) >= 2:
            plan.append(Exchange(BULK_READ, protocol, tuple(bulk)))
        rest = [item for item in items if item not in bulk or len(bulk) < 2]
        for group in _by_layout(item for item in rest if devices[item[0]].has(SYNC_READ)).values():
            plan.append(Exchange(SYNC_READ, protocol, tuple(group)))
        plan += [Exchange(READ, protocol, (item,)) for item in rest if not devices[item[0]].has(SYNC_READ)]
    return tuple(plan)


def plan_writes(devices: Mapping[int, DeviceProfile], name: str,
                ids: Sequence[int] | None = None) -> tuple[Exchange, ...]:
    """The exchanges that write entry ``name`` of every device in ``ids``: a Sync Write per
    protocol and layout, a Write each for a device without Sync Write."""
    ids = list(devices) if ids is None else list(ids)
    plan: list[Exchange] = []
    for protocol, members in _by_protocol(devices, ids).items():
        items = [(i, *span(devices[i], [name])) for i in members]
        for group in _by_layout(item for item in items if devices[item[0]].has(SYNC_WRITE)).values():
            plan.append(Exchange(SYNC_WRITE, protocol, tuple(group)))
        plan += [Exchange(WRITE, protocol, (item,)) for item in items if not devices[item[0]].has(SYNC_WRITE)]
    return tuple(plan)


def board_span(profile: DeviceProfile) -> tuple[int, int]:
    """(address, size) of the sensor board's one read a tick: from the left foot switch to the
    last of up-vector, heading and angular rates that the board has."""
    first = profile.register(BOARD_FIRST).address
    last = max((profile.register(name) for name in BOARD_LAST if name in profile.control_table),
               key=lambda reg: reg.address)
    return first, last.address + last.size - first


def check_group(kind: str, devices: Mapping[int, DeviceProfile], items: Sequence[Item]) -> None:
    """``ValueError`` unless one ``kind`` instruction (SYNC_READ, BULK_READ, SYNC_WRITE) can
    reach every device of ``items``: one protocol, the instruction in every device's firmware,
    one address and size for a sync one, two devices at least for a protocol-1.0 Bulk Read.
    What the mock and the SDK buses both refuse, so that a plan that is wrong fails on both."""
    known = [i for i, _, _ in items if i in devices]
    protocols = sorted({devices[i].protocol for i in known})
    name = kind.replace("_", " ")
    if len(protocols) > 1:
        by = _by_protocol(devices, known)
        raise ValueError(f"one {name} cannot reach servos of protocols " + " and ".join(
            f"{p:.1f} ({id_list(by[p])})" for p in protocols) + ": one instruction per protocol")
    lacking = [i for i in known if not devices[i].has(kind)]
    if lacking:
        models = sorted({devices[i].model for i in lacking})
        raise ValueError(f"servo{'s' if len(lacking) > 1 else ''} {id_list(lacking)} ({', '.join(models)}, protocol "
                         f"{devices[lacking[0]].protocol:.1f}) {'have' if len(lacking) > 1 else 'has'} no {name} "
                         "instruction")
    if kind != BULK_READ and len(_by_layout(items)) > 1:
        raise ValueError(f"one {name} needs one address and size on every servo; servos {id_list(known)} differ")
    if kind == BULK_READ and protocols == [1.0] and len(items) < 2:
        raise ValueError("a protocol-1.0 bulk read cannot read a single servo (e-manual, Protocol 1.0): read it")


@dataclass(frozen=True)
class BusTime:
    """What one control tick's exchanges take on the wire at ``baud`` [bit/s]."""

    exchanges: tuple[Exchange, ...]
    baud: int
    return_delay_us: float = RETURN_DELAY_US

    @property
    def bytes(self) -> int:
        return sum(e.out_bytes() + e.in_bytes() for e in self.exchanges)

    @property
    def packets(self) -> int:
        """Instruction packets sent a tick."""
        return len(self.exchanges)

    @property
    def wire_s(self) -> float:
        """Every byte at the baud rate, 10 bits each [s]."""
        return self.bytes * BITS_PER_BYTE / self.baud

    @property
    def return_delay_s(self) -> float:
        """Every status packet's Return Delay Time [s]."""
        return sum(e.replies for e in self.exchanges) * self.return_delay_us * 1e-6

    @property
    def turnaround_s(self) -> float:
        """The host's latency, once per exchange that waits for replies [s]."""
        return sum(1 for e in self.exchanges if e.replies) * TURNAROUND_S

    @property
    def total_s(self) -> float:
        return self.wire_s + self.return_delay_s + self.turnaround_s

    def describe(self) -> str:
        """The sum in words, and its exchanges."""
        waits = sum(1 for e in self.exchanges if e.replies)
        return (f"{self.packets} packets, {self.bytes} bytes at {self.baud} baud = {self.wire_s * 1e3:.2f} ms, "
                f"+ {waits} x {TURNAROUND_S * 1e3:g} ms turnaround"
                + (f" + {self.return_delay_s * 1e3:.2f} ms return delay" if self.return_delay_s else "")
                + f" = {self.total_s * 1e3:.2f} ms: " + "; ".join(e.describe() for e in self.exchanges))


def servo_profiles(robot: RobotSpec) -> tuple[dict[int, DeviceProfile], list[int]]:
    """The robot's servos by ID, and their IDs in joint order."""
    ids = [j.servo.id for j in robot.joints if j.servo is not None]
    return {j.servo.id: j.servo.profile for j in robot.joints if j.servo is not None}, ids


def bus_devices(robot: RobotSpec) -> dict[int, DeviceProfile]:
    """Every device on the robot's bus by ID: its servos and its sensor board."""
    devices, _ = servo_profiles(robot)
    if robot.sensor_board is not None:
        devices[robot.sensor_board.id] = robot.sensor_board.profile
    return devices


def tick_exchanges(robot: RobotSpec, motion: Sequence[str] = ()) -> tuple[Exchange, ...]:
    """One control tick's exchanges: read every present position, read the sensor board, write
    every goal - and, with ``motion`` (entries next to each other, e.g. present load and
    velocity for a traced excitation), read those too.  Empty for a robot without servos."""
    devices, ids = servo_profiles(robot)
    if not ids:
        return ()
    plan = list(plan_reads(devices, [PRESENT_POSITION], ids))
    board = robot.sensor_board
    if board is not None:
        plan.append(Exchange(READ, board.profile.protocol, ((board.id, *board_span(board.profile)),)))
    if motion:
        try:
            plan += plan_reads(devices, list(motion), ids)
        except ValueError:  # not next to each other somewhere: one read each (hardware.readings does so)
            for name in motion:
                plan += plan_reads(devices, [name], ids)
    plan += plan_writes(devices, GOAL_POSITION, ids)
    return tuple(plan)


def bus_time(robot: RobotSpec, baud: int | None = None, motion: Sequence[str] = ()) -> BusTime | None:
    """One control tick's bus time at ``baud`` (default: the robot's); None without a bus."""
    if robot.bus is None:
        return None
    return BusTime(tick_exchanges(robot, motion), baud or robot.bus.baud)


def tick_problem(robot: RobotSpec, tick_s: float, baud: int | None = None, motion: Sequence[str] = ()) -> str | None:
    """Why ``robot``'s bus cannot serve a control tick of ``tick_s`` [s] (its reads, the
    board's and its writes take longer), naming the exchanges and the numbers; None if it can."""
    time = bus_time(robot, baud, motion)
    if time is None or time.total_s <= tick_s + 1e-12:
        return None
    slowest = max(time.exchanges, key=lambda e: (e.out_bytes() + e.in_bytes()) * BITS_PER_BYTE / time.baud
                  + (TURNAROUND_S if e.replies else 0.0))
    return (f"one control tick's bus traffic takes {time.total_s * 1e3:.2f} ms, longer than the {tick_s * 1e3:.3g} ms "
            f"tick ({time.describe()}); the slowest is the {slowest.describe()}: raise the baud rate, or use servos "
            "with sync or bulk read, or a longer tick")


def baud_problem(devices: Mapping[int, DeviceProfile], baud: int) -> str | None:
    """Why some of ``devices`` (by ID) cannot be set to ``baud`` [bit/s], naming those devices
    by model and protocol and the rates each model can take; None if all can."""
    wrong = [i for i, p in devices.items() if p.baud_rates and baud not in p.baud_rates]
    if not wrong:
        return None
    models: dict[str, list[int]] = {}
    for i in wrong:
        models.setdefault(devices[i].model, []).append(i)
    listed = [set(p.baud_rates) for p in devices.values() if p.baud_rates]
    common = sorted(set.intersection(*listed))
    return ("; ".join(f"{model} (protocol {devices[ids[0]].protocol:.1f}, IDs {id_list(ids)}) cannot be set to {baud} "
                      f"baud, only to {', '.join(map(str, devices[ids[0]].baud_rates))}" for model, ids in models.items())
            + (f"; every device on the bus can take {', '.join(map(str, common))}" if common else
               "; no baud rate suits every device on the bus: put them on two ports, or replace some"))
