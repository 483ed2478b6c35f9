"""The PGF's EEPROM image: the taught pick-and-place data of the paper's Fig. 9.

The image is the Arduino Mega's 4096-byte EEPROM. All fields are little-endian integers:

| offset | type | field | unit |
| --- | --- | --- | --- |
| 0 | 4 bytes | magic ``TPEE`` | |
| 4 | uint16 | layout version (1) | |
| 6 | uint8 | M_pp, number of pickups (1..10) | |
| 7 | uint8 | reserved, 0 | |
| 8 | int32 | Z_up | micrometre |
| 12 | int32 | Z_low | micrometre |
| 16 | uint16 | S_l, low speed | 0.1 mm/s |
| 18 | uint16 | S_h, high speed | 0.1 mm/s |
| 20 | int32 | M_dp x, drop point | micrometre |
| 24 | int32 | M_dp y | micrometre |
| 28 | int16 | M_dep, drop elbow (wrist servo) angle | centidegree |
| 30 | uint16 | reserved, 0 | |
| 32 + 20 k | 20 bytes | pickup k = 0..9 (below); unused slots 0xFF | |
| 232 | uint32 | CRC-32 (zlib) of bytes 0..231 | |
| 236 | | 0xFF (erased) up to 4096; not checked, free for other data | |

Pickup record k: int32 approach x, int32 approach y (M_pdx, M_pady), int32 grip x,
int32 grip y (M_pgdx, M_pgdy) in micrometres, int16 elbow angle M_pep in centidegrees,
uint16 reserved 0.

Values are quantised on writing: positions to 1 um, angles to 0.01 deg, speeds to 0.1 mm/s.
"""

from __future__ import annotations

import math
import os
import stat
import struct
import tempfile
import zlib
from dataclasses import dataclass
from pathlib import Path

from transplanter.errors import TransplanterError
from transplanter.machine.gcode import SERVO_MAX_DEG, valid_servo_angle

EEPROM_SIZE = 4096
MAGIC = b"TPEE"
LAYOUT_VERSION = 1
MAX_PICKUPS = 10
"""Pickup slots in the image: M_pp is 1..MAX_PICKUPS (the scenario's limit too)."""
MAX_ABS_POSITION_M = 1.0
"""Taught points farther than this from the arm origin are refused (a tabletop robot)."""
POSITION_COUNTS_PER_M = 1e6
"""Position fields count micrometres."""
ANGLE_COUNTS_PER_DEG = 100.0
"""Angle fields count centidegrees."""
SPEED_COUNTS_PER_M_S = 1e4
"""Speed fields count 0.1 mm/s."""
MIN_SPEED_M_S = 1.0 / SPEED_COUNTS_PER_M_S
"""Smallest speed the 0.1 mm/s field holds above zero."""
MAX_SPEED_M_S = 0xFFFF / SPEED_COUNTS_PER_M_S
"""Largest speed the uint16 0.1 mm/s field holds (6.5535 m/s)."""

_HEADER = struct.Struct("<4sHBBiiHHiihH")
_PICKUP = struct.Struct("<iiiihH")
_CRC = struct.Struct("<I")
PICKUPS_OFFSET = _HEADER.size
CRC_OFFSET = PICKUPS_OFFSET + MAX_PICKUPS * _PICKUP.size
DATA_SIZE = CRC_OFFSET

assert _HEADER.size == 32 and _PICKUP.size == 20 and CRC_OFFSET == 232


class EepromError(TransplanterError, ValueError):
    """The image cannot be used; the message names why."""


def _check_xy(name: str, xy) -> tuple[float, float]:
    try:
        x, y = (float(v) for v in xy)
    except (TypeError, ValueError) as error:
        raise EepromError(f"{name} must be two numbers (x, y) in metres, got {xy!r}") from error
    for value in (x, y):
        if not math.isfinite(value) or abs(value) > MAX_ABS_POSITION_M:
            raise EepromError(
                f"{name} = ({x}, {y}) m is out of range: each coordinate must be finite and "
                f"within +-{MAX_ABS_POSITION_M} m (positions are in metres, not mm)"
            )
    return (x, y)


def _as_float(name: str, value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError) as error:
        raise EepromError(f"{name} must be a number, got {value!r}") from error


def _check_angle(name: str, value) -> float:
    angle = _as_float(name, value)
    if not valid_servo_angle(angle):
        raise EepromError(
            f"{name} = {value!r} deg is out of range: servo angles are 0-{SERVO_MAX_DEG:g} deg"
        )
    return angle


@dataclass(frozen=True)
class Pickup:
    """One taught pickup: approach (via) point, grip point, and the wrist servo angle."""

    approach_xy_m: tuple[float, float]
    grip_xy_m: tuple[float, float]
    wrist_deg: float

    def __post_init__(self):
        object.__setattr__(self, "approach_xy_m", _check_xy("approach_xy_m", self.approach_xy_m))
        object.__setattr__(self, "grip_xy_m", _check_xy("grip_xy_m", self.grip_xy_m))
        object.__setattr__(self, "wrist_deg", _check_angle("wrist_deg", self.wrist_deg))


@dataclass(frozen=True)
class EepromImage:
    """Everything the PGF reads at start: M_pp pickups, drop point, Z levels, speeds."""

    pickups: tuple[Pickup, ...]
    drop_xy_m: tuple[float, float]
    drop_wrist_deg: float
    z_up_m: float
    z_low_m: float
    s_low_m_s: float
    s_high_m_s: float

    def __post_init__(self):
        pickups = tuple(self.pickups)
        if not 1 <= len(pickups) <= MAX_PICKUPS:
            raise EepromError(
                f"M_pp = {len(pickups)} pickups is out of range: teach 1 to {MAX_PICKUPS}"
            )
        for index, pickup in enumerate(pickups):
            if not isinstance(pickup, Pickup):
                raise EepromError(f"pickups[{index}] must be a Pickup, got {pickup!r}")
        object.__setattr__(self, "pickups", pickups)
        object.__setattr__(self, "drop_xy_m", _check_xy("drop_xy_m", self.drop_xy_m))
        object.__setattr__(
            self, "drop_wrist_deg", _check_angle("drop_wrist_deg", self.drop_wrist_deg)
        )
        for name in ("z_up_m", "z_low_m"):
            value = _as_float(name, getattr(self, name))
            if not (math.isfinite(value) and 0.0 <= value <= MAX_ABS_POSITION_M):
                raise EepromError(f"{name} = {value} m is out of range: 0 to {MAX_ABS_POSITION_M}")
            object.__setattr__(self, name, value)
        if self.z_low_m > self.z_up_m:
            raise EepromError(
                f"z_low_m = {self.z_low_m} m is above z_up_m = {self.z_up_m} m; swap them"
            )
        for name in ("s_low_m_s", "s_high_m_s"):
            value = _as_float(name, getattr(self, name))
            if not (math.isfinite(value) and MIN_SPEED_M_S <= value <= MAX_SPEED_M_S):
                raise EepromError(
                    f"{name} = {value} m/s is out of range: speeds are >= {MIN_SPEED_M_S} and <= "
                    f"{MAX_SPEED_M_S} m/s (speeds are in m/s, not mm/s)"
                )
            object.__setattr__(self, name, value)

    @property
    def m_pp(self) -> int:
        """Number of pickups (the paper's M_pp)."""
        return len(self.pickups)

    def to_bytes(self) -> bytes:
        """The 4096-byte EEPROM image (layout in the module docstring)."""
        image = bytearray(b"\xff" * EEPROM_SIZE)
        _HEADER.pack_into(
            image,
            0,
            MAGIC,
            LAYOUT_VERSION,
            self.m_pp,
            0,
            _um(self.z_up_m),
            _um(self.z_low_m),
            _decimm_s(self.s_low_m_s),
            _decimm_s(self.s_high_m_s),
            _um(self.drop_xy_m[0]),
            _um(self.drop_xy_m[1]),
            _centideg(self.drop_wrist_deg),
            0,
        )
        for index, pickup in enumerate(self.pickups):
            _PICKUP.pack_into(
                image,
                PICKUPS_OFFSET + index * _PICKUP.size,
                _um(pickup.approach_xy_m[0]),
                _um(pickup.approach_xy_m[1]),
                _um(pickup.grip_xy_m[0]),
                _um(pickup.grip_xy_m[1]),
                _centideg(pickup.wrist_deg),
                0,
            )
        _CRC.pack_into(image, CRC_OFFSET, zlib.crc32(image[:DATA_SIZE]))
        return bytes(image)

    @classmethod
    def from_bytes(cls, data: bytes) -> EepromImage:
        """Decode an image; EepromError names what is wrong with a bad one."""
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise EepromError(f"an EEPROM image is bytes, got {type(data).__name__}")
        data = bytes(data)
        if len(data) != EEPROM_SIZE:
            kind = "truncated" if len(data) < EEPROM_SIZE else "too long"
            raise EepromError(
                f"EEPROM image is {kind}: {len(data)} bytes, expected exactly {EEPROM_SIZE}"
            )
        header = _HEADER.unpack_from(data, 0)
        magic, version, m_pp = header[0], header[1], header[2]
        if magic != MAGIC:
            raise EepromError(
                f"bad magic {magic!r}, expected {MAGIC!r}: this is not a transplanter image "
                "(or the EEPROM was never written)"
            )
        if version != LAYOUT_VERSION:
            raise EepromError(
                f"unsupported layout version {version}; this firmware reads version "
                f"{LAYOUT_VERSION}"
            )
        (stored_crc,) = _CRC.unpack_from(data, CRC_OFFSET)
        computed_crc = zlib.crc32(data[:DATA_SIZE])
        if stored_crc != computed_crc:
            raise EepromError(
                f"CRC mismatch: expected 0x{computed_crc:08x} (computed over bytes "
                f"0..{DATA_SIZE - 1}), found 0x{stored_crc:08x}; the image is corrupt, "
                "re-teach or restore it"
            )
        if not 1 <= m_pp <= MAX_PICKUPS:
            raise EepromError(f"M_pp = {m_pp} is out of range 1..{MAX_PICKUPS}")
        _, _, _, reserved7, z_up, z_low, s_low, s_high, drop_x, drop_y, drop_wrist, reserved30 = (
            header
        )
        for offset, value in ((7, reserved7), (30, reserved30)):
            if value != 0:
                raise EepromError(
                    f"reserved field at byte {offset} is {value:#x}, must be 0: the image was "
                    "written by another layout or is corrupt"
                )
        pickups = []
        for index in range(m_pp):
            record_offset = PICKUPS_OFFSET + index * _PICKUP.size
            ax, ay, gx, gy, wrist, reserved = _PICKUP.unpack_from(data, record_offset)
            if reserved != 0:
                raise EepromError(
                    f"pickup {index}: reserved field at byte {record_offset + _PICKUP.size - 2} "
                    f"is {reserved:#x}, must be 0"
                )
            pickups.append(
                Pickup(
                    approach_xy_m=(ax / POSITION_COUNTS_PER_M, ay / POSITION_COUNTS_PER_M),
                    grip_xy_m=(gx / POSITION_COUNTS_PER_M, gy / POSITION_COUNTS_PER_M),
                    wrist_deg=wrist / ANGLE_COUNTS_PER_DEG,
                )
            )
        return cls(
            pickups=tuple(pickups),
            drop_xy_m=(drop_x / POSITION_COUNTS_PER_M, drop_y / POSITION_COUNTS_PER_M),
            drop_wrist_deg=drop_wrist / ANGLE_COUNTS_PER_DEG,
            z_up_m=z_up / POSITION_COUNTS_PER_M,
            z_low_m=z_low / POSITION_COUNTS_PER_M,
            s_low_m_s=s_low / SPEED_COUNTS_PER_M_S,
            s_high_m_s=s_high / SPEED_COUNTS_PER_M_S,
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> EepromImage:
        """Read an image file written by ``save``; EepromError (naming the path) if it is
        missing, unreadable, not a regular file or not exactly EEPROM_SIZE bytes.

        The file is opened with O_NONBLOCK and checked with fstat before any read, so a FIFO
        or a device (/dev/zero) is refused instead of hanging or reading forever.
        """
        shown = os.fspath(path)
        try:
            fd = os.open(shown, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        except OSError as error:
            raise EepromError(
                f"cannot open EEPROM image {shown!r}: {error.strerror or error}"
            ) from None
        try:
            info = os.fstat(fd)
            if not stat.S_ISREG(info.st_mode):
                raise EepromError(f"EEPROM image {shown!r} is not a regular file")
            if info.st_size != EEPROM_SIZE:
                raise EepromError(
                    f"EEPROM image {shown!r} is {info.st_size} bytes, expected exactly "
                    f"{EEPROM_SIZE}"
                )
            chunks, size = [], 0
            while size <= EEPROM_SIZE:
                chunk = os.read(fd, EEPROM_SIZE + 1 - size)
                if not chunk:
                    break
                chunks.append(chunk)
                size += len(chunk)
        except OSError as error:
            raise EepromError(
                f"cannot read EEPROM image {shown!r}: {error.strerror or error}"
            ) from None
        finally:
            os.close(fd)
        try:
            return cls.from_bytes(b"".join(chunks))
        except EepromError as error:
            raise EepromError(f"EEPROM image {shown!r}: {error}") from None

    def save(self, path: str | os.PathLike) -> None:
        """Write the image atomically (temp file in the same folder, then os.replace)."""
        target = Path(path)
        data = self.to_bytes()
        handle, temp_name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.")
        try:
            with os.fdopen(handle, "wb") as temp_file:
                temp_file.write(data)
                temp_file.flush()
                os.fsync(temp_file.fileno())
            os.replace(temp_name, target)
        except BaseException:
            if os.path.exists(temp_name):
                os.unlink(temp_name)
            raise


def _um(value_m: float) -> int:
    return int(round(value_m * POSITION_COUNTS_PER_M))


def _centideg(value_deg: float) -> int:
    return int(round(value_deg * ANGLE_COUNTS_PER_DEG))


def _decimm_s(value_m_s: float) -> int:
    return int(round(value_m_s * SPEED_COUNTS_PER_M_S))
