"""Capture files in batches: counts and values checked against the files themselves (read here with plain Python,
independent of libsaulproto), against the hand-written faults of captures/glitches.log, and against the
inter-board and Pride sample stories (captures/make_uart_vcd.py)."""
import array
import math
import struct

import can
import pytest

import saulproto


def candump_frames(path):
    """(time_s, id, data) of every frame line of a candump log, parsed here with str methods."""
    out = []
    for line in path.read_text().splitlines():
        if not line.startswith("("):
            continue
        stamp, _, rest = line.partition(") ")
        ident, _, data = rest.split(" ")[1].partition("#")
        out.append((float(stamp[1:]), int(ident, 16), bytes.fromhex(data)))
    return out


def test_robot_bus_log_tables(captures):
    path = captures / "robot_bus.log"
    frames = candump_frames(path)
    b = saulproto.load(path)
    assert b.frames == len(frames) == b.messages and b.rejected == {} and b.corrupt == 0
    tele = [(t, d) for t, i, d in frames if i == 0x400]
    ta = b["telemetry_a"]
    assert len(ta["time_s"]) == len(tele)
    assert isinstance(ta["pitch"], array.array) and isinstance(ta["speed_mmps"], array.array)
    for row, (t, d) in enumerate(tele):
        pitch, pid, speed, state = struct.unpack("<hhhB", d)
        assert ta["time_s"][row] == pytest.approx(t, abs=1e-6)
        assert ta["timestamp_ns"][row] == round(t * 1e6) * 1000
        assert ta["pitch"][row] == pytest.approx(pitch / 100)
        assert (ta["pid_out"][row], ta["speed_mmps"][row]) == (pid, speed)
        assert ta["state"][row] == ["OFF", "BALANCE", "MANUAL", "ESTOP", "TILT_CUTOFF", "FAULT"][state]
        assert ta["interface"][row] == "can0"
    battery = [struct.unpack("<hhHB", d)[2] / 1000 for _, i, d in frames if i == 0x401]
    assert list(b["telemetry_b"]["battery"]) == pytest.approx(battery)
    vesc = [d for _, i, d in frames if i >> 8 == 9 and i & 0xFF == 68]
    s1 = b["vesc_status_1"]
    mine = [k for k, c in enumerate(s1["controller_id"]) if c == 68]
    assert [s1["erpm"][k] for k in mine] == [struct.unpack(">i", d[:4])[0] for d in vesc]


def test_batches_add_up_to_the_whole(captures):
    path = captures / "robot_bus.log"
    whole = saulproto.load(path)
    batches = list(saulproto.read_capture(path, batch_size=7))
    assert len(batches) == math.ceil(whole.messages / 7)
    assert all(b.messages == 7 for b in batches[:-1])
    assert sum(b.frames for b in batches) == whole.frames
    pitch = array.array("d")
    for b in batches:
        if "telemetry_a" in b:
            pitch.extend(b["telemetry_a"]["pitch"])
    assert pitch == whole["telemetry_a"]["pitch"]


def test_messages_one_dict_each(captures):
    path = captures / "robot_bus.log"
    msgs = list(saulproto.messages(path, batch_size=50))
    frames = candump_frames(path)
    assert len(msgs) == len(frames)
    first = msgs[0]
    assert first["type"] == "telemetry_a" and first["interface"] == "can0"
    assert first["time_s"] == pytest.approx(frames[0][0], abs=1e-6)
    assert [m["type"] for m in msgs].count("velocity_cmd") == sum(1 for _, i, _ in frames if i == 0x300)


def test_faults_counted_by_reason(captures):
    # glitches.log, written by hand: a wrong DLC, an unknown id, a remote frame, an error frame, an out-of-range
    # mode, a bad hex id and a missing ')' (corrupt lines 8 and 11), a 29-bit 0x300 (a VESC frame), a valid ack.
    b = saulproto.load(captures / "glitches.log")
    assert b.rejected == {"wrong_dlc": 1, "unknown_id": 1, "remote_frame": 1, "error_frame": 1, "out_of_range": 1}
    assert b.corrupt == 2
    assert b.corrupt_records[0].endswith("glitches.log:8:27: id is not hexadecimal (line skipped)")
    assert b.corrupt_records[1].endswith("glitches.log:11:1: timestamp has no closing ')' (line skipped)")
    assert sorted(b.tables) == ["command_ack", "telemetry_b", "velocity_cmd", "vesc_set_rpm"]


def test_other_formats_read_the_same(captures, tmp_path):
    # python-can writes the robot bus as ASC and BLF; ASC is read back by saulproto with the same values.
    asc = tmp_path / "bus.asc"
    with can.ASCWriter(str(asc)) as w:
        for t, ident, data in candump_frames(captures / "robot_bus.log"):
            w.on_message_received(can.Message(timestamp=t, arbitration_id=ident, data=data,
                                              is_extended_id=ident > 0x7FF, channel=0))
    from_asc = saulproto.load(asc)
    from_log = saulproto.load(captures / "robot_bus.log")
    assert from_asc.frames == from_log.frames
    assert list(from_asc["telemetry_a"]["pitch"]) == list(from_log["telemetry_a"]["pitch"])
    assert list(from_asc["vesc_status_1"]["erpm"]) == list(from_log["vesc_status_1"]["erpm"])


def test_serial_log(captures):
    # interboard_uart.serial: the six worked examples of docs/protocol.md section 2, with noise and a bad CRC.
    b = saulproto.load(captures / "interboard_uart.serial")
    assert b.messages == 6 and b.chunks > 0
    assert list(b.tables) == ["rc_cmd", "state", "sensor", "fault", "led_cmd", "buzzer"]
    assert b["state"]["pitch"][0] == pytest.approx(-12.34)
    assert (b["state"]["pid_out"][0], b["state"]["error_state"][0]) == (300, 1)
    assert b["rc_cmd"]["throttle"][0] == 500 and b["buzzer"]["duration_ms"][0] == 500
    assert b["state"]["link"][0] == "serial:/dev/ttyUSB0@460800:8N1"
    assert saulproto.units("state")["pitch"] == "deg"


def test_sigrok_export_with_protocol_and_samplerate(captures):
    msgs = list(saulproto.messages(captures / "pride_uart.sigrok.txt", protocol="pride", samplerate_hz=1_000_000))
    assert len(msgs) == 8
    assert msgs[-1] == {"type": "controller_status", "error_byte": 2, "battery_charge": 100, "unknown": 0,
                        "time_s": pytest.approx(0.018658, abs=1e-6), "link": "uart-1"}
    reader = saulproto.CaptureBatches(str(captures / "pride_uart.sigrok.txt"), 100, None, "pride", 1_000_000)
    assert reader.format == "sigrok"
    while reader.next_tables() is not None:
        pass
    (link,) = reader.links()
    assert link["protocol"] == "pride" and link["counters"]["frames"] == 8 and link["counters"]["uart_errors"] == 1


def test_bad_input():
    with pytest.raises(ValueError):
        list(saulproto.read_capture("/nonexistent/file.log"))
    with pytest.raises(ValueError):
        list(saulproto.read_capture(__file__, format="nosuchformat"))
