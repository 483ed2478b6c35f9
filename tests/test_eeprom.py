import struct
import zlib

import numpy as np
import pytest

from transplanter.machine.eeprom import (
    CRC_OFFSET,
    DATA_SIZE,
    EEPROM_SIZE,
    MAX_PICKUPS,
    EepromError,
    EepromImage,
    Pickup,
)


def paper_image(m_pp: int = 5) -> EepromImage:
    xs = [-0.090, -0.045, 0.0, 0.045, 0.090, -0.090, -0.045, 0.0, 0.045, 0.090][:m_pp]
    pickups = tuple(
        Pickup(approach_xy_m=(x, 0.175), grip_xy_m=(x, 0.215), wrist_deg=90.0 + 7.25 * k)
        for k, x in enumerate(xs)
    )
    return EepromImage(
        pickups=pickups,
        drop_xy_m=(0.0, 0.140),
        drop_wrist_deg=12.34,
        z_up_m=0.100,
        z_low_m=0.032,
        s_low_m_s=0.040,
        s_high_m_s=0.150,
    )


def _with_crc(image: bytearray) -> bytes:
    struct.pack_into("<I", image, CRC_OFFSET, zlib.crc32(image[:DATA_SIZE]))
    return bytes(image)


def test_round_trip_exact_for_representable_values():
    image = paper_image()
    data = image.to_bytes()
    assert len(data) == EEPROM_SIZE
    assert data[:4] == b"TPEE"
    assert data[CRC_OFFSET + 4 :] == b"\xff" * (EEPROM_SIZE - CRC_OFFSET - 4)
    assert EepromImage.from_bytes(data) == image


def test_round_trip_within_quantisation():
    rng = np.random.default_rng(5)
    for _ in range(50):
        m_pp = int(rng.integers(1, MAX_PICKUPS + 1))
        pickups = tuple(
            Pickup(
                approach_xy_m=tuple(rng.uniform(-0.3, 0.3, 2)),
                grip_xy_m=tuple(rng.uniform(-0.3, 0.3, 2)),
                wrist_deg=float(rng.uniform(0, 180)),
            )
            for _ in range(m_pp)
        )
        z_low, z_up = sorted(rng.uniform(0, 0.2, 2))
        image = EepromImage(
            pickups=pickups,
            drop_xy_m=tuple(rng.uniform(-0.3, 0.3, 2)),
            drop_wrist_deg=float(rng.uniform(0, 180)),
            z_up_m=z_up,
            z_low_m=z_low,
            s_low_m_s=float(rng.uniform(0.001, 0.5)),
            s_high_m_s=float(rng.uniform(0.001, 0.5)),
        )
        back = EepromImage.from_bytes(image.to_bytes())
        assert back.m_pp == m_pp
        for a, b in zip(image.pickups, back.pickups, strict=True):
            assert np.allclose(a.approach_xy_m, b.approach_xy_m, atol=0.5e-6, rtol=0)
            assert np.allclose(a.grip_xy_m, b.grip_xy_m, atol=0.5e-6, rtol=0)
            assert abs(a.wrist_deg - b.wrist_deg) <= 0.005 + 1e-12
        assert np.allclose(image.drop_xy_m, back.drop_xy_m, atol=0.5e-6, rtol=0)
        assert abs(image.z_up_m - back.z_up_m) <= 0.5e-6 + 1e-15
        assert abs(image.s_low_m_s - back.s_low_m_s) <= 0.5e-4 + 1e-15
        assert abs(image.s_high_m_s - back.s_high_m_s) <= 0.5e-4 + 1e-15
        # encoding a decoded image is a fixed point
        assert back.to_bytes() == EepromImage.from_bytes(back.to_bytes()).to_bytes()


def test_save_and_load(tmp_path):
    image = paper_image(3)
    path = tmp_path / "eeprom.bin"
    image.save(path)
    assert path.stat().st_size == EEPROM_SIZE
    assert EepromImage.load(path) == image
    image2 = paper_image(7)
    image2.save(path)
    assert EepromImage.load(path) == image2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eeprom.bin"]


def test_save_failure_leaves_old_file_and_no_temp(tmp_path, monkeypatch):
    path = tmp_path / "eeprom.bin"
    paper_image(2).save(path)
    before = path.read_bytes()

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr("transplanter.machine.eeprom.os.replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        paper_image(4).save(path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eeprom.bin"]


@pytest.mark.parametrize("size", [0, 100, DATA_SIZE, EEPROM_SIZE - 1, EEPROM_SIZE + 1])
def test_wrong_size_refused(size):
    data = (paper_image().to_bytes() + b"\xff")[:size]
    with pytest.raises(EepromError, match="truncated|too long"):
        EepromImage.from_bytes(data)


def test_erased_eeprom_has_bad_magic():
    with pytest.raises(EepromError, match="bad magic"):
        EepromImage.from_bytes(b"\xff" * EEPROM_SIZE)


def test_bad_magic():
    image = bytearray(paper_image().to_bytes())
    image[0:4] = b"XXXX"
    with pytest.raises(EepromError, match="bad magic"):
        EepromImage.from_bytes(_with_crc(image))


def test_unsupported_version():
    image = bytearray(paper_image().to_bytes())
    struct.pack_into("<H", image, 4, 2)
    with pytest.raises(EepromError, match="unsupported layout version 2"):
        EepromImage.from_bytes(_with_crc(image))


def test_crc_mismatch_names_expected_and_found():
    image = bytearray(paper_image().to_bytes())
    struct.pack_into("<I", image, CRC_OFFSET, 0xDEADBEEF)
    expected = zlib.crc32(image[:DATA_SIZE])
    with pytest.raises(EepromError, match="CRC mismatch") as info:
        EepromImage.from_bytes(bytes(image))
    assert f"0x{expected:08x}" in str(info.value) and "0xdeadbeef" in str(info.value)


@pytest.mark.parametrize("m_pp", [0, MAX_PICKUPS + 1, 255])
def test_m_pp_out_of_range_in_image(m_pp):
    image = bytearray(paper_image().to_bytes())
    image[6] = m_pp
    with pytest.raises(EepromError, match=f"M_pp = {m_pp} is out of range"):
        EepromImage.from_bytes(_with_crc(image))


def test_values_out_of_range_in_image():
    image = bytearray(paper_image().to_bytes())
    struct.pack_into("<h", image, 28, -500)  # drop elbow -5 deg
    with pytest.raises(EepromError, match="drop_wrist_deg"):
        EepromImage.from_bytes(_with_crc(image))
    image = bytearray(paper_image().to_bytes())
    struct.pack_into("<H", image, 16, 0)  # S_l = 0
    with pytest.raises(EepromError, match="s_low_m_s"):
        EepromImage.from_bytes(_with_crc(image))
    image = bytearray(paper_image().to_bytes())
    struct.pack_into("<i", image, 32, 2_000_000)  # approach x of pickup 0 = 2 m
    with pytest.raises(EepromError, match="approach_xy_m"):
        EepromImage.from_bytes(_with_crc(image))


def test_every_single_bit_flip_in_data_region_detected():
    data = paper_image().to_bytes()
    undetected = []
    for bit in range((DATA_SIZE + 4) * 8):  # data region and the CRC itself
        corrupt = bytearray(data)
        corrupt[bit // 8] ^= 1 << (bit % 8)
        try:
            EepromImage.from_bytes(bytes(corrupt))
        except EepromError:
            continue
        undetected.append(bit)
    assert undetected == []


def test_flip_in_free_area_is_ignored():
    data = bytearray(paper_image().to_bytes())
    data[3000] ^= 0x10
    assert EepromImage.from_bytes(bytes(data)) == paper_image()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"pickups": ()}, "M_pp = 0"),
        ({"pickups": (paper_image().pickups[0],) * 11}, "M_pp = 11"),
        ({"pickups": ("not a pickup",)}, "must be a Pickup"),
        ({"drop_xy_m": (0.0, 140.0)}, "not mm"),
        ({"drop_xy_m": (0.0,)}, "two numbers"),
        ({"drop_xy_m": (float("nan"), 0.1)}, "drop_xy_m"),
        ({"drop_wrist_deg": 181}, "0-180"),
        ({"z_low_m": 0.2}, "above z_up_m"),
        ({"z_up_m": -0.01}, "z_up_m"),
        ({"s_low_m_s": 40.0}, "not mm/s"),
        ({"s_high_m_s": 0.0}, "s_high_m_s"),
        ({"s_high_m_s": "fast"}, "must be a number"),
    ],
)
def test_constructor_validation(change, match):
    base = paper_image()
    fields = {
        "pickups": base.pickups,
        "drop_xy_m": base.drop_xy_m,
        "drop_wrist_deg": base.drop_wrist_deg,
        "z_up_m": base.z_up_m,
        "z_low_m": base.z_low_m,
        "s_low_m_s": base.s_low_m_s,
        "s_high_m_s": base.s_high_m_s,
    }
    fields.update(change)
    with pytest.raises(EepromError, match=match):
        EepromImage(**fields)


def test_pickup_validation():
    with pytest.raises(EepromError, match="wrist_deg"):
        Pickup((0.0, 0.175), (0.0, 0.215), -1.0)
    with pytest.raises(EepromError, match="grip_xy_m"):
        Pickup((0.0, 0.175), (0.0, 215.0), 90.0)
    pickup = Pickup([0, 0.175], np.array([0.0, 0.215]), 90)
    assert pickup.approach_xy_m == (0.0, 0.175) and isinstance(pickup.grip_xy_m, tuple)


def test_load_refuses_missing_special_and_wrong_size_files_naming_the_path(tmp_path):
    """Issue row 17: a missing file raised a bare FileNotFoundError; /dev/zero or a FIFO
    would read forever or hang. Only a regular file of the image's size is read."""
    import os
    import threading

    missing = tmp_path / "nope.bin"
    with pytest.raises(EepromError, match=r"cannot open EEPROM image .*nope\.bin"):
        EepromImage.load(missing)
    with pytest.raises(EepromError, match="is not a regular file"):
        EepromImage.load(tmp_path)  # a directory
    if os.path.exists("/dev/zero"):
        with pytest.raises(EepromError, match=r"'/dev/zero' is not a regular file"):
            EepromImage.load("/dev/zero")
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    outcome = []

    def load_fifo():
        try:
            EepromImage.load(fifo)
        except EepromError as error:
            outcome.append(str(error))

    worker = threading.Thread(target=load_fifo, daemon=True)
    worker.start()
    worker.join(5.0)
    assert not worker.is_alive(), "loading a FIFO hung"
    assert outcome and "is not a regular file" in outcome[0]
    short = tmp_path / "short.bin"
    short.write_bytes(paper_image().to_bytes()[:100])
    with pytest.raises(EepromError, match=r"short\.bin' is 100 bytes, expected exactly 4096"):
        EepromImage.load(short)


@pytest.mark.parametrize("offset", [7, 30, 31, 32 + 18, 32 + 20 + 19])
def test_reserved_bytes_must_be_zero(offset):
    image = bytearray(paper_image(5).to_bytes())
    image[offset] = 0x5A
    crc_offset = 232
    struct.pack_into("<I", image, crc_offset, zlib.crc32(bytes(image[:crc_offset])))
    with pytest.raises(EepromError, match="reserved field .* must be 0"):
        EepromImage.from_bytes(bytes(image))


def test_reserved_bytes_of_unused_slots_are_not_checked():
    image = bytearray(paper_image(2).to_bytes())
    assert image[32 + 2 * 20 + 18 : 32 + 2 * 20 + 20] == b"\xff\xff"  # slot 2 unused, erased
    assert EepromImage.from_bytes(bytes(image)) == paper_image(2)
