"""What a Dynamixel's status packet and Hardware Error Status say, in words.

Protocol 2.0 status: bit 7 of the error byte is the hardware alert (some Hardware Error
Status bit is set; the servo dropped its torque), bits 0-6 an error number.  Source: ROBOTIS
e-manual, "Protocol 2.0 - Status Packet", and the X series control table, address 70.
"""

from __future__ import annotations

from sim2real.hardware.bus import ServoError

RESULT_FAIL = 1
INSTRUCTION_ERROR = 2
CRC_ERROR = 3
DATA_RANGE_ERROR = 4  # a value outside the entry's range
DATA_LENGTH_ERROR = 5  # fewer bytes than the entry holds
DATA_LIMIT_ERROR = 6  # e.g. a goal outside the position limits
ACCESS_ERROR = 7  # read-only entry, or EEPROM while torque is on
ERROR_NUMBERS = {RESULT_FAIL: "result fail", INSTRUCTION_ERROR: "instruction error", CRC_ERROR: "CRC error",
                 DATA_RANGE_ERROR: "data range error", DATA_LENGTH_ERROR: "data length error",
                 DATA_LIMIT_ERROR: "data limit error", ACCESS_ERROR: "access error"}
ALERT_BIT = 0x80
ERROR_NUMBER_MASK = 0x7F

# Hardware Error Status bits (X series, address 70).
OVERLOAD_BIT = 1 << 5
HARDWARE_ERRORS = {0: "input voltage", 2: "overheating", 3: "motor encoder", 4: "electrical shock", 5: "overload"}


def decode_hardware_error(status: int) -> str:
    """Hardware Error Status bits in words ("none" for 0)."""
    names = [name for bit, name in HARDWARE_ERRORS.items() if status & (1 << bit)]
    return ", ".join(names) or "none"


def status_error(dxl_id: int, error: int, value: int | None = None) -> ServoError:
    """The :class:`ServoError` for a status packet's error byte (``value``: the data that came
    with it, if the instruction was a read)."""
    number = error & ERROR_NUMBER_MASK
    alert = bool(error & ALERT_BIT)
    reasons = [ERROR_NUMBERS.get(number, f"error {number}")] if number else []
    if alert:
        reasons.append("hardware alert")
    return ServoError(dxl_id, error, reasons, alert=alert, value=value)
