"""Serving an emulated chain of Dynamixel devices on a pseudo-terminal.

    chain = EmulatedChain(MockBus(robot).devices)
    with PtyServer(chain) as server:
        DynamixelBus(server.port, 1_000_000, robot) ...

Each device is a :class:`~sim2real.hardware.mock.MockDevice` (control table from its profile,
firmware rules for EEPROM and torque, motion toward the goal).  Broadcast instructions get
no status; a silent device never answers; a sync or bulk read is answered by each device in
turn.  (Physics-backed servos and wire timing are the simulated bus's business.)
"""

from __future__ import annotations

import contextlib
import os
import random
import select
import threading
import time
import tty
from typing import Callable, Iterator

from sim2real.hardware.dynamixel.errors import (
    DATA_LENGTH_ERROR,
    ERROR_NUMBER_MASK,
    INSTRUCTION_ERROR,
)
from sim2real.hardware.dynamixel.registers import Reg
from sim2real.hardware.mock import MockDevice
from sim2real.simulation.simbus import protocol1 as p1
from sim2real.simulation.simbus import protocol2 as p2
from sim2real.simulation.simbus.mixed import MixedParser


class EmulatedChain:
    """Devices behind a wire.  ``advance`` moves them on before each instruction and while
    none arrives (default: each servo toward its goal at its no-load speed; a
    :class:`PhysicsChain` passes its own, which returns True while it is still behind the
    clock: the serving loop then comes back to it at once instead of waiting for the wire)."""

    def __init__(self, devices: dict[int, MockDevice], clock: Callable[[], float] = time.monotonic,
                 advance: Callable[[], bool | None] | None = None):
        if not devices:
            raise ValueError("an emulated chain needs at least one device")
        self.devices = devices
        self._custom_advance = advance
        self.protocol = next(iter(devices.values())).profile.protocol
        self.protocols = {d.profile.protocol for d in devices.values()}  # both: one port for servos of each
        self.silent: set[int] = set()
        self.registered: dict[int, tuple[int, bytes]] = {}  # REG_WRITE held for ACTION
        self.clock = clock
        self._last = clock()
        self.heard_at = clock()  # the last instruction packet, for the servos' Bus Watchdog
        self.lock = threading.Lock()

    def _advance(self) -> bool:
        if self._custom_advance is not None:
            return bool(self._custom_advance())
        now = self.clock()
        dt, self._last = now - self._last, now
        for device in self.devices.values():
            device.advance(dt)
        return False

    def tick(self) -> bool:
        """Move the devices on while no instruction arrives (the simulated bus keeps its
        physics in step with the wall clock this way, on the serving thread); True while
        they are still behind it.  A servo whose
        Bus Watchdog expires stops first (:meth:`MockDevice.watch`): checked here only, when
        the wire has been idle, so that the simulator's own stall never trips it."""
        with self.lock:
            silent_s = self.clock() - self.heard_at
            for device in self.devices.values():
                device.watch(silent_s)
            return self._advance()

    def parser(self):
        if len(self.protocols) > 1:
            return MixedParser()
        return p2.Parser() if self.protocol == 2.0 else p1.Parser()

    def checksum_error(self, dxl_id: int) -> bytes:
        """The status the addressed servo sends back for a packet whose checksum (1.0) or CRC
        (2.0) was wrong; nothing from a broadcast, a missing or a silent ID."""
        if dxl_id not in self.devices or dxl_id in self.silent:
            return b""
        if self.devices[dxl_id].profile.protocol == 1.0:
            return p1.status(dxl_id, p1.CHECKSUM_ERROR)
        return p2.status(dxl_id, p2.CRC_ERROR)

    def handle(self, dxl_id: int, inst: int, params: bytes, protocol: float | None = None) -> bytes:
        """Replies (status packets, concatenated) to one instruction packet of ``protocol``
        (default: the chain's own; a :class:`MixedParser` tags each packet with its own)."""
        protocol = self.protocol if protocol is None else protocol
        with self.lock, self._heard_by(protocol):
            # every servo on the wire hears every packet; the e-manual's watchdog counts "all the
            # Instruction Packet" and does not say whether another ID's feed it: here they do
            self.heard_at = self.clock()
            self._advance()
            if protocol == 1.0:
                return self._handle_p1(dxl_id, inst, params)
            if inst in (p2.SYNC_READ, p2.BULK_READ, p2.FAST_SYNC_READ, p2.FAST_BULK_READ):
                wanted = _read_targets(inst, params)
                if inst in (p2.SYNC_READ, p2.BULK_READ):  # each device answers in turn
                    return b"".join(self._read(i, address, size) for i, address, size in wanted)
                replies = []  # one packet for all
                for i, address, size in wanted:
                    if i in self.devices and i not in self.silent:
                        value, error = self.devices[i].read(address, size)
                        replies.append((i, error, value.to_bytes(size, "little")))
                return p2.fast_status(replies) if replies else b""
            if inst == p2.BULK_WRITE:  # [id, address, length, data] for each device, no status
                k = 0
                while k + 5 <= len(params):
                    target = params[k]
                    address = int.from_bytes(params[k + 1:k + 3], "little")
                    size = int.from_bytes(params[k + 3:k + 5], "little")
                    data = params[k + 5:k + 5 + size]
                    if target in self.devices and target not in self.silent and len(data) == size:
                        self.devices[target].write(address, size, int.from_bytes(data, "little"))
                    k += 5 + size
                return b""
            if inst == p2.SYNC_WRITE:
                address, size = int.from_bytes(params[0:2], "little"), int.from_bytes(params[2:4], "little")
                for k in range(4, len(params) - size, 1 + size):
                    device = self.devices.get(params[k])
                    if device is not None and params[k] not in self.silent:
                        device.write(address, size, int.from_bytes(params[k + 1:k + 1 + size], "little"))
                return b""
            if inst == p2.ACTION:  # broadcast or not: apply what REG_WRITE held
                targets = list(self.registered) if dxl_id == p2.BROADCAST else [dxl_id]
                for target in targets:
                    held = self.registered.pop(target, None)
                    if held is not None and target in self.devices:
                        address, data = held
                        self.devices[target].write(address, len(data), int.from_bytes(data, "little"))
                if dxl_id == p2.BROADCAST or dxl_id not in self.devices or dxl_id in self.silent:
                    return b""
                return p2.status(dxl_id, self.devices[dxl_id].alert())
            if dxl_id == p2.BROADCAST:
                if inst == p2.PING:  # every device answers, in ID order
                    return b"".join(self._ping(i) for i in sorted(self.devices) if i not in self.silent)
                return b""
            device = self.devices.get(dxl_id)
            if device is None or dxl_id in self.silent:
                return b""
            if inst == p2.PING:
                return self._ping(dxl_id)
            if inst == p2.READ:
                if len(params) != 4:
                    return p2.status(dxl_id, DATA_LENGTH_ERROR)
                return self._read(dxl_id, int.from_bytes(params[0:2], "little"), int.from_bytes(params[2:4], "little"))
            if inst == p2.WRITE:
                address, data = int.from_bytes(params[0:2], "little"), params[2:]
                return p2.status(dxl_id, device.write(address, len(data), int.from_bytes(data, "little")))
            if inst == p2.REG_WRITE:  # held until ACTION
                self.registered[dxl_id] = (int.from_bytes(params[0:2], "little"), params[2:])
                return p2.status(dxl_id, device.alert())
            if inst == p2.REBOOT:
                device.reboot()
                return p2.status(dxl_id, 0)
            if inst == p2.FACTORY_RESET:
                device.factory_reset(keep_id=params[:1] in (b"\x01", b"\x02"))
                return p2.status(dxl_id, 0)
            return p2.status(dxl_id, INSTRUCTION_ERROR)

    @contextlib.contextmanager
    def _heard_by(self, protocol: float) -> Iterator[None]:
        """While a packet of ``protocol`` is handled: a device of the other protocol cannot parse
        it, so for this packet it is as silent as a disconnected one (it neither answers nor
        applies anything)."""
        deaf = {i for i, d in self.devices.items() if d.profile.protocol != protocol}
        if not deaf:
            yield
            return
        silent = self.silent
        self.silent = silent | deaf
        try:
            yield
        finally:
            self.silent = silent

    def _handle_p1(self, dxl_id: int, inst: int, params: bytes) -> bytes:
        if inst == p1.BULK_READ:  # each device whose firmware has it answers in turn (e-manual, Protocol 1.0)
            replies = []
            for k in range(1, len(params) - 2, 3):
                size, target, address = params[k], params[k + 1], params[k + 2]
                device = self.devices.get(target)
                if device is not None and target not in self.silent and device.profile.has("bulk_read"):
                    value, _ = device.read(address, size)
                    replies.append(p1.status(target, 0, value.to_bytes(size, "little")))
            return b"".join(replies)
        if inst == p1.SYNC_WRITE:
            address, size = params[0], params[1]
            for k in range(2, len(params) - size, 1 + size):
                device = self.devices.get(params[k])
                if device is not None and params[k] not in self.silent:
                    device.write(address, size, int.from_bytes(params[k + 1:k + 1 + size], "little"))
            return b""
        device = self.devices.get(dxl_id)
        if dxl_id == p1.BROADCAST or device is None or dxl_id in self.silent:
            return b""
        if inst == p1.PING:
            return p1.status(dxl_id, 0)
        if inst == p1.READ and len(params) == 2:
            value, _ = device.read(params[0], params[1])
            return p1.status(dxl_id, 0, value.to_bytes(params[1], "little"))
        if inst == p1.WRITE and len(params) >= 2:
            error = device.write(params[0], len(params) - 1, int.from_bytes(params[1:], "little"))
            return p1.status(dxl_id, p1.RANGE_ERROR if error & ERROR_NUMBER_MASK else 0)
        return p1.status(dxl_id, p1.INSTRUCTION_ERROR)

    def _ping(self, dxl_id: int) -> bytes:
        device = self.devices[dxl_id]
        return p2.status(dxl_id, device.alert(), device.get_named(Reg.MODEL_NUMBER).to_bytes(2, "little")
                         + bytes([device.get_named(Reg.FIRMWARE_VERSION)]))

    def _read(self, dxl_id: int, address: int, size: int) -> bytes:
        device = self.devices.get(dxl_id)
        if device is None or dxl_id in self.silent:
            return b""
        value, error = device.read(address, size)
        return p2.status(dxl_id, error, value.to_bytes(size, "little"))


def _read_targets(inst: int, params: bytes) -> list[tuple[int, int, int]]:
    """(id, address, size) of each device a sync or bulk read (fast or not) asks."""
    if inst in (p2.SYNC_READ, p2.FAST_SYNC_READ):  # address, size, then the IDs
        address, size = int.from_bytes(params[0:2], "little"), int.from_bytes(params[2:4], "little")
        return [(i, address, size) for i in params[4:]]
    return [(params[k], int.from_bytes(params[k + 1:k + 3], "little"), int.from_bytes(params[k + 3:k + 5], "little"))
            for k in range(0, len(params) - 4, 5)]  # id, address, size for each


STALL_S = 0.05  # a serving loop held up this long [s] makes replies late enough to count as lost (0.1 s)


class PtyServer:
    """Serves an :class:`EmulatedChain` on a new pseudo-terminal; ``port`` is its path.

    ``drop_rate`` and ``corrupt_rate`` lose replies or flip one of their bytes, at random
    (seeded).  With ``baud``, replies keep the wire's pace: each status packet leaves the
    device's Return Delay Time and the time its bytes take at that baud (10 bits a byte) after
    the request was heard, the time spent answering included; without it they leave at once.
    Between instructions the chain is ticked every ``idle_s`` (at once while it is behind).  One thread does all of it: a second thread stepping the physics would hold
    Python's GIL for milliseconds and make replies late.

    ``stalls`` lists each time the serving loop was held up longer than :data:`STALL_S`
    (when, since the start [s], and how long [s]): a runtime that reports lost communication
    then was let down by this computer, not by its loop.
    """

    def __init__(self, chain: EmulatedChain, baud: int | None = None, drop_rate: float = 0.0,
                 corrupt_rate: float = 0.0, seed: int = 0, idle_s: float = 0.002):
        self.chain = chain
        self.baud = baud
        self.idle_s = idle_s
        # faults on the wire: a reply lost, or one of its bytes flipped (its CRC then fails)
        self.drop_rate, self.corrupt_rate = drop_rate, corrupt_rate
        self._rng = random.Random(seed)
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.port = os.ttyname(slave)
        self._slave = slave
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self.stalls: list[tuple[float, float]] = []  # (since the start, length) [s]; appended by the serving thread

    def __enter__(self) -> "PtyServer":
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass

    def _serve(self) -> None:
        parser = self.chain.parser()
        start = last = time.monotonic()
        behind = False  # the devices lag the clock (after a stall): catch up between instructions
        while not self._stop.is_set():
            now = time.monotonic()
            if now - last > STALL_S + self.idle_s:
                self.stalls.append((last - start, now - last))
            last = now
            ready, _, _ = select.select([self.master], [], [], 0.0 if behind else self.idle_s)
            if not ready:
                behind = self.chain.tick()
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            heard = time.monotonic()  # the request's last byte, near enough: replies are paced from here
            packets = parser.feed(data)
            for dxl_id in parser.bad_crc_ids:  # the addressed servo says so
                os.write(self.master, self.chain.checksum_error(dxl_id))
            parser.bad_crc_ids.clear()
            for packet in packets:  # (id, instruction, params), and the protocol on a mixed chain
                reply = self.chain.handle(*packet)
                if reply and self.drop_rate and self._rng.random() < self.drop_rate:
                    continue
                if reply and self.corrupt_rate and self._rng.random() < self.corrupt_rate:
                    k = self._rng.randrange(len(reply))
                    reply = reply[:k] + bytes([reply[k] ^ 0x5A]) + reply[k + 1:]
                if reply:
                    if self.baud:
                        heard = self._pace(reply, heard)
                    os.write(self.master, reply)

    def _pace(self, reply: bytes, since: float) -> float:
        """Sleep until the replies would have left the wire, counted from ``since`` (the
        request heard, or the previous reply sent) [s, monotonic]: bytes at the baud plus each
        replying device's Return Delay Time (2 us units).  Time this side already spent (the
        physics, a stall) counts toward it instead of adding to it - a servo answers on its
        own clock, not after the host's.  Returns when the replies left."""
        delay = len(reply) * 10.0 / self.baud
        for dxl_id, *_ in self.chain.parser().feed(reply):
            device = self.chain.devices.get(dxl_id)
            if device is not None and Reg.RETURN_DELAY_TIME in device.profile.control_table:
                delay += 2e-6 * device.get_named(Reg.RETURN_DELAY_TIME)
        due = since + delay
        wait = due - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        return max(due, time.monotonic())
