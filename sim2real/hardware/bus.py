"""The bus interface and its errors: protocol-free.

Values cross this interface as unsigned integers of the register's size, exactly as on
the wire; :class:`~sim2real.hardware.dynamixel.chain.ServoChain` decodes signs and names.
A vendor package (:mod:`sim2real.hardware.dynamixel`) implements :class:`Bus` and turns its
status codes into :class:`ServoError`; ``tests/test_bus_contract.py`` holds every
implementation to the same contract.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Iterable, Sequence

from sim2real.errors import BipedError


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
    """A servo reported an error in its status (or its hardware alert is set).

    ``error`` is the raw status code, ``reasons`` what it says in words (the vendor package
    decodes it), ``alert`` whether the servo has a latched hardware error, ``value`` the data
    that came with the status, if it was a read."""

    def __init__(self, dxl_id: int, error: int, reasons: Sequence[str] = (), *, alert: bool = False,
                 value: int | None = None):
        self.id = dxl_id
        self.error = error
        self.reasons = tuple(reasons)
        self.alert = alert
        self.value = value
        super().__init__(f"servo {dxl_id}: {', '.join(self.reasons) or 'error'}")


class Bus(ABC):
    """A chain of devices (servos, a sensor board) on one port, each answering by its ID.
    Values are unsigned ints of ``size`` bytes at a control-table ``address``.

    The devices may speak different protocols and keep an entry at different addresses: a
    sync read, bulk read or sync write is one instruction, which reaches only devices of one
    protocol whose firmware has it (and, for the sync ones, one address and size).  Asked to
    reach others, a bus raises ``ValueError`` naming them
    (:func:`sim2real.robot.bus_plan.check_group`) and sends nothing; the chain above plans
    its accesses so that this never happens (:mod:`sim2real.robot.bus_plan`)."""

    baud: int | None = None  # [bit/s] the port's rate, where there is a wire

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
        """The device's model number.  Raises :class:`CommunicationError` if it does not answer."""

    @abstractmethod
    def read(self, dxl_id: int, address: int, size: int) -> int:
        """``size`` bytes from ``address``.  Raises :class:`CommunicationError` if the device
        does not answer, :class:`ServoError` if its status carries an error (``value`` holds
        the data that came with it)."""

    @abstractmethod
    def write(self, dxl_id: int, address: int, size: int, value: int) -> None:
        """``value`` to ``address``, as the device's firmware takes it: :class:`ServoError` if
        it refuses (the value is then not applied), :class:`CommunicationError` if it is silent."""

    @abstractmethod
    def sync_read(self, ids: list[int], address: int, size: int) -> dict[int, int]:
        """Every listed device's value.  Raises :class:`CommunicationError` naming every device
        that did not answer, and :class:`ServoError` for a status with an error (the hardware
        alert included, which the Dynamixel SDK's group classes drop)."""

    @abstractmethod
    def bulk_read(self, items: dict[int, tuple[int, int]]) -> dict[int, int]:
        """Each listed device's ``size`` bytes at its own ``address`` (``items``: id -> (address,
        size)) in one instruction, with the errors of :meth:`sync_read`."""

    @abstractmethod
    def sync_write(self, address: int, size: int, values: dict[int, int]) -> None:
        """One instruction for every device in ``values``, without replies: a device applies
        its value under the same rules as :meth:`write`, and one that refuses it (a goal
        outside its position limits, say) keeps its old value silently, as on the wire."""

    @abstractmethod
    def reboot(self, dxl_id: int) -> None:
        """Restart the device: clears a latched hardware error, torque off."""
