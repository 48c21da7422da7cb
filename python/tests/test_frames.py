"""One CAN frame in, one dict out; the Orin's commands out as frames. Golden bytes and values are the worked
examples of docs/protocol.md (sections 3 and 6), written out here by hand."""
import math

import can
import pytest

import saulproto


def frame(text):
    """'400#06FFA4012C0101' -> (id, bytes, extended): an id of 8 hex digits is a 29-bit one, as in candump."""
    ident, data = text.split("#")
    return int(ident, 16), bytes.fromhex(data), len(ident) == 8


@pytest.mark.parametrize("text, want", [
    ("300#E8030CFE", {"type": "velocity_cmd", "speed_mmps": 1000, "steer_mrad": -500}),
    ("301#000700000000C03F", {"type": "pid_gain", "gain": "kp", "sequence": 7, "value": 1.5}),
    ("301#010700000000803E", {"type": "pid_gain", "gain": "ki", "sequence": 7, "value": 0.25}),
    ("302#01", {"type": "mode_cmd", "mode": "balance"}),
    ("303#D007DC05", {"type": "config_cmd", "tilt_limit": 20.0, "max_speed_mmps": 1500}),
    ("400#06FFA4012C0101", {"type": "telemetry_a", "pitch": -2.5, "pid_out": 420, "speed_mmps": 300,
                            "state": "BALANCE"}),
    ("401#B00464FBB09A11", {"type": "telemetry_b", "vesc_l_rpm": 1200, "vesc_r_rpm": -1180, "battery": 39.6,
                            "fault": 0x11}),
    ("402#010703", {"type": "command_ack", "command": 1, "sequence": 7, "result": "rejected_incomplete"}),
    ("00000344#000005DC", {"type": "vesc_set_rpm", "controller_id": 68, "erpm": 1500}),
    ("00000938#FFFFFB50002300FA", {"type": "vesc_status_1", "controller_id": 56, "erpm": -1200, "current": 3.5,
                                   "duty": 0.25}),
])
def test_decode_worked_examples(text, want):
    ident, data, extended = frame(text)
    got = saulproto.decode(ident, data, extended=extended)
    assert got.keys() == want.keys()
    for key, value in want.items():
        if isinstance(value, float):
            assert got[key] == pytest.approx(value, rel=1e-6), key
        else:
            assert got[key] == value, key


def test_kd_float():
    got = saulproto.decode(0x301, bytes.fromhex("02070000CDCC4C3D"))
    assert got["gain"] == "kd" and got["value"] == pytest.approx(0.05, rel=1e-6)


@pytest.mark.parametrize("kwargs, reason", [
    (dict(frame=0x300, data=bytes.fromhex("E8030C")), "wrong_dlc"),
    (dict(frame=0x123, data=b"\x01\x02"), "unknown_id"),
    (dict(frame=0x400, data=b"", remote=True, dlc=7), "remote_frame"),
    (dict(frame=0x302, data=b"\x07"), "out_of_range"),
    (dict(frame=0x20000004, data=bytes(8), error=True), "error_frame"),
])
def test_rejected_frames_say_why(kwargs, reason):
    assert saulproto.decode(**kwargs) == {"type": None, "reason": reason}


def test_a_29_bit_0x300_is_a_vesc_frame():
    got = saulproto.decode(0x300, bytes.fromhex("E8030CFE"), extended=True)
    assert got["type"] == "vesc_set_rpm" and got["controller_id"] == 0


def test_decode_takes_a_python_can_message():
    msg = can.Message(arbitration_id=0x400, data=bytes.fromhex("06FFA4012C0101"), is_extended_id=False)
    assert saulproto.decode(msg)["pitch"] == pytest.approx(-2.5)
    remote = can.Message(arbitration_id=0x400, is_remote_frame=True, dlc=7, is_extended_id=False)
    assert saulproto.decode(remote)["reason"] == "remote_frame"
    vesc = can.Message(arbitration_id=0x1B38, data=bytes.fromhex("0001E240016D0000"), is_extended_id=True)
    got = saulproto.decode(vesc)
    assert got["type"] == "vesc_status_5" and got["tachometer"] == 123456


def test_units_name_the_physical_fields():
    assert saulproto.units("telemetry_a") == {"pitch": "deg", "pid_out": "permille", "speed_mmps": "mm/s", "state": ""}
    assert saulproto.units("telemetry_b")["battery"] == "V"
    assert saulproto.units("config_cmd")["tilt_limit"] == "deg"
    assert saulproto.units("vesc_status_1")["current"] == "A"
    # every key decode() gives has a unit entry
    assert set(saulproto.decode(0x401, bytes.fromhex("B00464FBB09A11"))) - {"type"} == set(saulproto.units("telemetry_b"))
    with pytest.raises(KeyError):
        saulproto.units("no_such_message")


def test_a_frame_longer_than_8_bytes_is_refused():
    with pytest.raises(ValueError):
        saulproto.decode(0x300, bytes(9))


# ---- encoding -------------------------------------------------------------------------------------------------

def test_encode_worked_examples():
    assert saulproto.encode_velocity(1000, -500, raw=True) == (0x300, bytes.fromhex("E8030CFE"))
    assert saulproto.encode_mode("balance", raw=True) == (0x302, b"\x01")
    assert saulproto.encode_mode(3, raw=True) == (0x302, b"\x03")
    assert saulproto.encode_config(2000, 1500, raw=True) == (0x303, bytes.fromhex("D007DC05"))
    assert saulproto.encode_pid_set(1.5, 0.25, 0.05, sequence=7, raw=True) == [
        (0x301, bytes.fromhex("000700000000C03F")),
        (0x301, bytes.fromhex("010700000000803E")),
        (0x301, bytes.fromhex("02070000CDCC4C3D")),
    ]


def test_encoders_make_python_can_messages():
    msg = saulproto.encode_velocity(speed_mmps=300, steer_mrad=-100)
    assert isinstance(msg, can.Message)
    assert (msg.arbitration_id, msg.is_extended_id, msg.dlc, bytes(msg.data)) == (0x300, False, 4, bytes.fromhex("2C019CFF"))
    msgs = saulproto.encode_pid_set(2.0, 0.0, 0.5, sequence=200)
    assert [m.dlc for m in msgs] == [8, 8, 8] and all(m.data[1] == 200 for m in msgs)


@pytest.mark.parametrize("call", [
    lambda: saulproto.encode_velocity(40000, 0),
    lambda: saulproto.encode_velocity(0, -32769),
    lambda: saulproto.encode_mode("fly"),
    lambda: saulproto.encode_mode(4),
    lambda: saulproto.encode_config(2501, 1000),   # above 25.00 degrees: BALANCE would refuse it
    lambda: saulproto.encode_config(499, 1000),
    lambda: saulproto.encode_config(2000, 70000),
    lambda: saulproto.encode_pid_set(1.0, -0.1, 0.0, sequence=1),
    lambda: saulproto.encode_pid_set(1.0, math.nan, 0.0, sequence=1),
    lambda: saulproto.encode_pid_set(1.0, 0.1, 0.0, sequence=256),
])
def test_encoders_refuse_what_balance_would_reject(call):
    with pytest.raises(ValueError):
        call()


def test_encode_then_decode():
    for ident, data in [saulproto.encode_velocity(-32768, 32767, raw=True), saulproto.encode_mode("estop", raw=True),
                        saulproto.encode_config(500, 0, raw=True)]:
        assert saulproto.decode(ident, data)["type"] is not None
    ident, data = saulproto.encode_velocity(-32768, 32767, raw=True)
    assert saulproto.decode(ident, data) == {"type": "velocity_cmd", "speed_mmps": -32768, "steer_mrad": 32767}
