"""The bus interface and its errors.

Values cross this interface as unsigned integers of the register's size, exactly as on
the wire; :class:`~sim2real.hardware.dynamixel.chain.ServoChain` decodes signs and names.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Iterable

from sim2real.errors import BipedError

# Protocol 2.0 status error numbers (bits 0-6), e-manual "Status Packet".
ERROR_NUMBERS = {1: "result fail", 2: "instruction error", 3: "CRC error", 4: "data range error",
                 5: "data length error", 6: "data limit error", 7: "access error"}
ALERT_BIT = 0x80
# Hardware Error Status bits (X series, address 70).
HARDWARE_ERRORS = {0: "input voltage", 2: "overheating", 3: "motor encoder", 4: "electrical shock", 5: "overload"}


class CommunicationError(BipedError):
    """A servo did not answer (after retries), or its answer was corrupt (``corrupt``: a
    reply came but failed its CRC or checksum - noise or a baud mismatch, not a silent servo)."""

    def __init__(self, ids: Iterable[int], what: str, corrupt: bool = False):
        self.ids = tuple(ids)
        self.what = what
        self.corrupt = corrupt
        who = ", ".join(str(i) for i in self.ids)
        super().__init__(f"servo{'s' if len(self.ids) > 1 else ''} {who}: {what}" if self.ids else what)


class ServoError(BipedError):
    """A servo reported an error in its status packet (or its alert bit is set)."""

    def __init__(self, dxl_id: int, error: int, detail: str = "", value: int | None = None):
        self.id = dxl_id
        self.error = error
        self.value = value  # the data that came with the status, if it was a read
        self.alert = bool(error & ALERT_BIT)
        number = error & 0x7F
        parts = []
        if number:
            parts.append(ERROR_NUMBERS.get(number, f"error {number}"))
        if self.alert:
            parts.append("hardware alert")
        if detail:
            parts.append(detail)
        super().__init__(f"servo {dxl_id}: {', '.join(parts) or 'error'}")


def decode_hardware_error(status: int) -> str:
    """Hardware Error Status bits in words."""
    names = [name for bit, name in HARDWARE_ERRORS.items() if status & (1 << bit)]
    return ", ".join(names) or "none"


class Bus(ABC):
    """A chain of Dynamixel devices on one port.  Values are unsigned ints of ``size`` bytes."""

    protocol: float = 2.0

    def open(self) -> None:
        """Open the port (idempotent)."""

    def close(self) -> None:
        """Close the port (idempotent)."""

    def __enter__(self) -> "Bus":
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @abstractmethod
    def ping(self, dxl_id: int) -> int:
        """The device's model number."""

    @abstractmethod
    def read(self, dxl_id: int, address: int, size: int) -> int: ...

    @abstractmethod
    def write(self, dxl_id: int, address: int, size: int, value: int) -> None: ...

    @abstractmethod
    def sync_read(self, ids: list[int], address: int, size: int) -> dict[int, int]:
        """Every listed device's value.  Raises :class:`CommunicationError` naming every device
        that did not answer, and :class:`ServoError` for a status with an error byte (the
        alert bit included, which the SDK's group classes drop)."""

    @abstractmethod
    def sync_write(self, address: int, size: int, values: dict[int, int]) -> None: ...

    def bulk_read(self, requests: list[tuple[int, int, int]]) -> dict[int, int]:
        """(id, address, size) per device; the default reads them one by one."""
        return {dxl_id: self.read(dxl_id, address, size) for dxl_id, address, size in requests}

    @abstractmethod
    def reboot(self, dxl_id: int) -> None: ...
