"""A line link to a controller over pyserial (a serial port, a pseudo-terminal, or any
`serial.serial_for_url` address such as socket://host:port).

A reader thread splits the incoming bytes into lines (at any of `reply_ends`, a trailing CR
dropped) and queues events: ("line", text), ("garbage", repr of the bytes) for a line with
bytes that are not printable ASCII, ("disconnected", reason) when the device goes away.
Writes are serialised by a lock, so `stop()` may write from another thread during a move.
"""
from __future__ import annotations

import queue
import termios
import threading

import serial

from core.robot.driver import RobotFault

LINE, GARBAGE, DISCONNECTED = "line", "garbage", "disconnected"
MAX_LINE = 4096          # bytes; a longer run without a line end is garbage


class LineLink:
    def __init__(self, port: str, baudrate: int = 115200, *, reply_ends: str = "\n", send_end: str = "\n"):
        self.port = port
        self.baudrate = baudrate
        self._ends = set(reply_ends.encode("latin-1"))
        self._send_end = send_end
        self._serial = None
        self._events: queue.Queue = queue.Queue()
        self._write_lock = threading.Lock()
        self._reader: threading.Thread | None = None
        self._closing = threading.Event()
        self.lost: str | None = None        # why the link went away (None while it is up)

    @property
    def is_open(self) -> bool:
        return self._serial is not None and self.lost is None

    def open(self) -> None:
        try:
            self._serial = serial.serial_for_url(self.port, baudrate=self.baudrate, timeout=0.05,
                                                 write_timeout=2.0)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise RobotFault(f"cannot open the port ({exc})", source=self.port,
                             hint="Check the cable, the port name and that no other program uses it.") from None
        self._closing.clear()
        self.lost = None
        self._reader = threading.Thread(target=self._read_loop, name=f"robot-link {self.port}", daemon=True)
        self._reader.start()

    def close(self) -> None:
        self._closing.set()
        ser, self._serial = self._serial, None
        if ser is not None:
            try:
                ser.cancel_read()
            except Exception:       # noqa: BLE001 - closing must never fail
                pass
        if self._reader is not None:
            self._reader.join(timeout=2.0)
            self._reader = None
        if ser is not None:
            try:
                ser.close()
            except Exception:       # noqa: BLE001
                pass

    def write(self, text: str, *, end: bool = True) -> None:
        """Send `text` (latin-1: one byte per character, so real-time bytes pass as they are),
        followed by the line end unless `end` is False."""
        data = (text + (self._send_end if end else "")).encode("latin-1")
        with self._write_lock:
            ser = self._serial
            if ser is None or self.lost is not None:
                raise RobotFault(f"the connection is lost ({self.lost or 'not open'})", source=self.port,
                                 hint="Check the cable, reconnect, then resume the run.")
            try:
                ser.write(data)
                ser.flush()
            except (serial.SerialException, OSError, termios.error) as exc:   # tcdrain on a dropped line: EIO
                self.lost = self.lost or str(exc)
                raise RobotFault(f"the connection is lost ({exc})", source=self.port,
                                 hint="Check the cable, reconnect, then resume the run.") from None

    def get(self, timeout: float) -> tuple[str, str] | None:
        """The next event, or None after `timeout` seconds."""
        try:
            return self._events.get(timeout=max(timeout, 0.0))
        except queue.Empty:
            return None

    def discard_pending(self) -> list[tuple[str, str]]:
        """Drop and return the events received so far."""
        out = []
        while True:
            try:
                out.append(self._events.get_nowait())
            except queue.Empty:
                return out

    def _read_loop(self) -> None:
        buf = bytearray()
        ser = self._serial
        while not self._closing.is_set():
            try:
                data = ser.read(max(1, ser.in_waiting))
            except (serial.SerialException, OSError, TypeError, AttributeError) as exc:
                if not self._closing.is_set():
                    self.lost = str(exc) or type(exc).__name__
                    self._events.put((DISCONNECTED, self.lost))
                return
            for byte in data:
                if byte in self._ends:
                    self._emit(bytes(buf))
                    buf.clear()
                else:
                    buf.append(byte)
            if len(buf) > MAX_LINE:
                self._events.put((GARBAGE, repr(bytes(buf[:40]))))
                buf.clear()

    def _emit(self, raw: bytes) -> None:
        raw = raw.rstrip(b"\r")
        if not raw:
            return
        if all(32 <= b < 127 or b == 9 for b in raw):
            self._events.put((LINE, raw.decode("ascii")))
        else:
            self._events.put((GARBAGE, repr(raw[:40])))
