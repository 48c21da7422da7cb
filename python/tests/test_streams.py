"""The serial links' stream decoders, fed the worked examples of docs/protocol.md (sections 2, 7 and 8) in pieces,
with noise, as bytes arrive from a port."""
import pytest

import saulproto

INTERBOARD = {  # docs/protocol.md section 2
    "AA 05 01 F4 01 06 FF 01 0F": {"type": "rc_cmd", "throttle": 500, "steer": -250, "flags": 1},
    "AA 05 02 D2 04 C8 FF 01 14": {"type": "sensor", "tof_mm": 1234, "baro_delta_pa": -56, "nfc_present": 1},
    "AA 01 03 05 6A": {"type": "fault", "flags": 5},
    "AA 05 10 2E FB 2C 01 01 51": {"type": "state", "pitch": pytest.approx(-12.34), "pid_out": 300, "error_state": 1},
    "AA 04 11 02 FF 80 00 4B": {"type": "led_cmd", "pattern": 2, "r": 255, "g": 128, "b": 0},
    "AA 03 12 03 F4 01 27": {"type": "buzzer", "tone_id": 3, "duration_ms": 500},
}


def test_interboard_byte_by_byte_with_noise():
    d = saulproto.StreamDecoder("interboard")
    stream = b"\x00\xAA\x07" + b"".join(bytes.fromhex(h) for h in INTERBOARD)
    got = []
    for i in range(len(stream)):
        got += d.push(stream[i:i + 1])
    assert got == list(INTERBOARD.values())
    c = d.counters
    assert c["frames"] == 6 and c["bytes_skipped"] == 3
    assert d.protocol == "interboard"


def test_interboard_bad_crc_is_counted_and_the_next_frame_found():
    d = saulproto.StreamDecoder("interboard")
    bad = bytearray.fromhex("AA 01 03 05 6A")
    bad[-1] ^= 0xFF
    got = d.push(bytes(bad) + bytes.fromhex("AA 01 03 05 6A"))
    assert got == [{"type": "fault", "flags": 5}]
    assert d.counters["crc_errors"] == 1


CRSF_T4 = "C8 0A 08 00 A8 00 7B 00 05 DC 4B 29"        # battery 16.8 V, 12.3 A, 1500 mAh, 75 %
CRSF_T5 = "C8 08 1E 03 E8 F8 30 3D 5C 0A"              # attitude 0.1, -0.2, 1.5708 rad
CRSF_T6 = "C8 07 21 41 43 52 4F 00 80"                 # flight mode "ACRO"
CRSF_T1 = "C8 18 16 E0 03 1F F8 C0 07 3E F0 81 0F 7C E0 03 1F F8 C0 07 3E F0 81 0F 7C AD"  # 16 x 992


def test_crsf_worked_examples():
    d = saulproto.StreamDecoder("crsf")
    got = d.push(bytes.fromhex(CRSF_T4 + CRSF_T5 + CRSF_T6 + CRSF_T1))
    assert [m["type"] for m in got] == ["battery_sensor", "attitude", "flight_mode", "rc_channels"]
    assert [m["address"] for m in got] == [0xC8] * 4
    battery, attitude, mode, rc = got
    assert battery["voltage"] == pytest.approx(16.8) and battery["current"] == pytest.approx(12.3)
    assert battery["capacity_mah"] == 1500 and battery["remaining_pct"] == 75
    assert saulproto.units("battery_sensor")["voltage"] == "V"
    assert (attitude["pitch"], attitude["roll"], attitude["yaw"]) == pytest.approx((0.1, -0.2, 1.5708))
    assert mode["mode"] == "ACRO"
    # 992 ticks = 1500 us (the receivers' integer formula gives 1500; the linear scale of the description 1500.77)
    assert all(abs(rc[f"ch{i}"] - 1500) < 1 for i in range(1, 17))
    assert saulproto.units("rc_channels")["ch1"] == "us"


def test_crsf_unknown_type_with_a_good_crc_is_reported_undecoded():
    # type 0x3A, payload 01 02; 6A = CRC-8/DVB-S2 (poly 0xD5, init 0) of 3A 01 02, worked out bitwise offline.
    d = saulproto.StreamDecoder("crsf")
    (m,) = d.push(bytes.fromhex("C8 04 3A 01 02 6A"))
    assert m == {"type": "crsf_0x3A", "reason": "unknown_type", "payload": b"\x01\x02"}


def test_crsf_finish_gives_up_a_partial_frame():
    d = saulproto.StreamDecoder("crsf")
    t4 = bytes.fromhex(CRSF_T4)
    assert d.push(t4[:5]) == []
    assert d.finish() == []
    assert d.counters["incomplete"] == 1


def test_pride_both_directions():
    d = saulproto.StreamDecoder("pride")
    got = d.push(bytes.fromhex("FE 54 07 32 00 74  4A 01 02 64 00 4E  FE 54 0E 9C CE 35"))
    assert got == [
        {"type": "vcu_command", "speed_level": 7, "forward_back": 50, "left_right": 0},
        {"type": "controller_status", "error_byte": 2, "battery_charge": 100, "unknown": 0},
        {"type": "vcu_command", "speed_level": 14, "forward_back": -100, "left_right": -50},
    ]
    bad = d.push(bytes.fromhex("FE 54 07 32 00 75"))
    assert bad == [] and d.counters["crc_errors"] == 1  # Pride: a bad checksum


def test_unknown_protocol():
    for name in ("raw", "uart", ""):
        with pytest.raises(ValueError):
            saulproto.StreamDecoder(name)


def test_crsf_address_and_subset_frame():
    # T7's heartbeat broadcast (address 0x00; the CRC covers TYPE and payload only), then the 0x17 subset frame
    # of tests/unit/test_crsf.cpp: CH5..CH7 at 11 bits = 1000, 1024, 2047 -> value / 2 + 988 us.
    d = saulproto.StreamDecoder("crsf")
    got = d.push(bytes.fromhex("00 04 0B 00 C8 ED" + "C8 08 17 24 E8 03 E0 FF 01 03"))
    assert [(m["type"], m["address"]) for m in got] == [("heartbeat", 0), ("rc_channels_subset", 0xC8)]
    subset = got[1]
    assert subset["first_channel"] == 5 and subset["resolution_bits"] == 11
    assert (subset["ch5"], subset["ch6"], subset["ch7"]) == (1488.0, 1500.0, 2011.5)
