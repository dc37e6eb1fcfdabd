"""Start-up of a Dynamixel chain: is the bus the robot the config describes, and the writes
that make it safe to drive.

Pings every configured device and checks its model number (every problem in one error),
refuses servos with a latched hardware error, then - torque off, since EEPROM is locked while
it is on - sets Return Delay Time 0, position mode, position limits from the joint ranges
(the firmware then refuses any goal outside them) and the Bus Watchdog.  Warns if the USB
adapter's latency timer is not 1 ms.  Source of the entries and units: the X series e-manual.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from sim2real.controller.mapping import ServoMapping
from sim2real.errors import BipedError
from sim2real.hardware.bus import CommunicationError
from sim2real.hardware.dynamixel.chain import ServoChain
from sim2real.hardware.dynamixel.errors import decode_hardware_error
from sim2real.hardware.dynamixel.registers import POSITION_MODE, Reg
from sim2real.robot.bus_plan import RETURN_DELAY_US  # the bus time the tick is checked against assumes it
from sim2real.robot.timing import WATCHDOG_MS, WATCHDOG_UNIT_MS  # the tick's bounds are checked against it too

RETURN_DELAY_UNIT_US = 2.0  # Return Delay Time's unit (e-Manual, every X and MX series: 2 us a step)


class StartupError(BipedError):
    """The bus does not hold the robot the config describes."""


def start_up(chain: ServoChain, mapping: ServoMapping, *, attempts: int, patience_s: float,
             warn: Callable[[str], None] = print) -> None:
    """Check and configure every device of ``chain`` (see the module docstring); each call
    to a device is tried ``attempts`` times and for ``patience_s`` seconds [s] at least.
    Raises :class:`StartupError` before any servo has torque."""
    problems = []
    for dxl_id, profile in chain.devices.items():
        try:
            model = chain.ping(dxl_id, attempts, patience_s)
        except CommunicationError as exc:
            problems.append(f"ID {dxl_id} ({profile.model}) "
                            + ("answers only with corrupt packets (wrong baud rate, or noise on the wire?)"
                               if exc.corrupt else "does not answer"))
            continue
        if model != profile.model_number:
            problems.append(f"ID {dxl_id} is model number {model}, the config expects {profile.model} "
                            f"({profile.model_number})")
    if problems:
        raise StartupError("the bus does not match the robot config: " + "; ".join(problems))
    errors = []
    for dxl_id in chain.servo_ids:
        if Reg.HARDWARE_ERROR_STATUS in chain.devices[dxl_id].control_table:
            status = chain.hardware_error(dxl_id, attempts, patience_s)
            if status:
                errors.append(f"ID {dxl_id}: {decode_hardware_error(status)}")
    if errors:
        raise StartupError("hardware errors latched (power-cycle or REBOOT the servo): " + "; ".join(errors))
    chain.torque(False, attempts=attempts, patience_s=patience_s)  # EEPROM settings need torque off
    for k, dxl_id in enumerate(chain.servo_ids):
        table = chain.devices[dxl_id].control_table
        settings = [(Reg.RETURN_DELAY_TIME, round(RETURN_DELAY_US / RETURN_DELAY_UNIT_US))]
        if Reg.OPERATING_MODE in table:
            settings.append((Reg.OPERATING_MODE, POSITION_MODE))
        if Reg.MIN_POSITION_LIMIT in table:
            settings += [(Reg.MIN_POSITION_LIMIT, int(mapping.tick_low[k])),
                         (Reg.MAX_POSITION_LIMIT, int(mapping.tick_high[k]))]
        if Reg.BUS_WATCHDOG in table:  # 0 first: clears a tripped watchdog
            settings += [(Reg.BUS_WATCHDOG, 0), (Reg.BUS_WATCHDOG, WATCHDOG_MS // WATCHDOG_UNIT_MS)]
        for name, value in settings:
            chain.write(dxl_id, name, value, attempts, patience_s)
    latency = usb_latency_timer_ms(getattr(chain.bus, "port_name", None))
    if latency is not None and latency != 1:
        warn(f"warning: the USB adapter's latency timer is {latency} ms; set it to 1 ms "
             f"(echo 1 > /sys/bus/usb-serial/devices/<tty>/latency_timer)")


def usb_latency_timer_ms(port: str | None) -> int | None:
    """The FTDI latency timer of a /dev/ttyUSB* port (Linux sysfs) [ms], or None."""
    if not port:
        return None
    path = Path("/sys/bus/usb-serial/devices") / Path(port).name / "latency_timer"
    try:
        return int(path.read_text().strip())
    except (OSError, ValueError):
        return None
