"""saulproto: the SAUL-TEE robot's wire protocol for Python, on libsaulproto (C++, through pybind11).

Decode one CAN frame (or a python-can ``can.Message``) into physical values::

    saulproto.decode(0x400, bytes.fromhex("06FFA4012C0101"))
    # {'type': 'telemetry_a', 'pitch': -2.5, 'pid_out': 420, 'speed_mmps': 300, 'state': 'BALANCE'}
    saulproto.units("telemetry_a")
    # {'pitch': 'deg', 'pid_out': 'permille', 'speed_mmps': 'mm/s', 'state': ''}

Encode the Orin's commands into ``can.Message`` objects python-can sends (``raw=True``: ``(id, bytes)``)::

    bus.send(saulproto.encode_velocity(speed_mmps=300, steer_mrad=0))

Read any capture file saulctl reads, in batches decoded in C++::

    for batch in saulproto.read_capture("run.log"):
        telemetry = batch.tables.get("telemetry_a")   # {'time_s': array('d'), 'pitch': array('d'), ...}

Decode serial links live: ``saulproto.StreamDecoder("interboard" | "crsf" | "pride").push(data)``.

Measure the balance loop's tuning from a loop trace, a CSV or a CAN capture (``saulctl tune report --json``'s
figures: step response, spectra, oscillation, saturation, loop timing; docs/tuning.md)::

    saulproto.tune_report("run.trace")["step"]["overshoot_pct"]

Fields come from the messages' signal descriptions (libsaulproto core/signals*.hpp): a wire integer with a scale
becomes its physical value under the signal's name (``pitch_x100`` -250 -> ``pitch`` -2.5 deg, ``battery_mv`` ->
``battery`` in V, ``tilt_limit_x100`` -> ``tilt_limit`` in deg); every other field keeps the name and value
``saulctl decode --json`` gives it (``speed_mmps``, ``state`` 'BALANCE', VESC ``current``). ``units(type)`` gives
each field's unit. docs/python.md has a bus loop and an analysis of a log.
"""

from ._saulproto import CaptureBatches, StreamDecoder
from . import _saulproto

__all__ = [
    "decode", "encode_velocity", "encode_mode", "encode_pid_set", "encode_config", "read_capture", "messages",
    "load", "Batch", "StreamDecoder", "units", "tune_report",
]

units = _saulproto.units


def decode(frame, data=None, *, extended=False, remote=False, error=False, dlc=None):
    """Decodes one CAN frame into a dict: {'type': 'telemetry_a', 'pitch': -2.5, ...}; a frame that is not a
    valid SAUL or VESC frame gives {'type': None, 'reason': 'wrong_dlc'} (unknown_id, remote_frame, ...).

    ``frame`` is either a python-can ``can.Message`` (its arbitration_id, data and flags are used) or the frame's
    id, with ``data`` its payload bytes."""
    if data is None and hasattr(frame, "arbitration_id"):
        return _saulproto.decode_frame(frame.arbitration_id, bytes(frame.data), bool(frame.is_extended_id),
                                       bool(frame.is_remote_frame), bool(frame.is_error_frame),
                                       frame.dlc if frame.is_remote_frame else None)
    return _saulproto.decode_frame(frame, bytes(data or b""), extended, remote, error, dlc)


def _message(frame, raw):
    if raw:
        return frame
    import can  # python-can (Debian: python3-can)
    ident, data = frame
    return can.Message(arbitration_id=ident, data=data, is_extended_id=False)


def encode_velocity(speed_mmps, steer_mrad, *, raw=False):
    """0x300: speed in mm/s (+ forward), steer in mrad (+ left), each an int16. Send it at 20 Hz: BALANCE falls back
    to RC after 500 ms without one."""
    return _message(_saulproto.encode_velocity(speed_mmps, steer_mrad), raw)


def encode_mode(mode, *, raw=False):
    """0x302: 'off', 'balance', 'manual', 'estop' (or 0..3). Balance and manual need an armed robot."""
    return _message(_saulproto.encode_mode(mode), raw)


def encode_pid_set(kp, ki, kd, *, sequence, raw=False):
    """0x301 x 3: one tuning set (Kp, Ki, Kd, finite and >= 0), all three with the same sequence number (0..255, a new
    one per set). Send the three back to back: BALANCE applies them together, within 100 ms, and answers once
    (0x402)."""
    return [_message(f, raw) for f in _saulproto.encode_pid_set(kp, ki, kd, sequence)]


def encode_config(tilt_limit_x100, max_speed_mmps, *, raw=False):
    """0x303: tilt limit in degrees x 100 (500..2500) and maximum speed in mm/s."""
    return _message(_saulproto.encode_config(tilt_limit_x100, max_speed_mmps), raw)


class Batch:
    """One batch of a capture: ``tables`` maps each message type seen ('telemetry_a', 'vesc_status_1', 'state', ...)
    to its columns: 'time_s' (array of float, NaN without a timestamp), 'timestamp_ns' (array of int, -1 without),
    'interface' (CAN) or 'link' (serial) as a list of str, then one column per field (array('q') for integers,
    array('d') for floats, list of str for names). ``frames`` (CAN) or ``chunks`` (serial) records were read,
    ``messages`` decoded; ``rejected`` counts frames that did not decode by reason; ``corrupt`` counts unreadable
    records (``corrupt_records``: the first 1000 described as saulctl does)."""

    __slots__ = ("tables", "frames", "chunks", "messages", "rejected", "corrupt", "corrupt_records")

    def __init__(self, d):
        self.tables = d["tables"]
        self.frames = d.get("frames", 0)
        self.chunks = d.get("chunks", 0)
        self.messages = d["messages"]
        self.rejected = d["rejected"]
        self.corrupt = d["corrupt"]
        self.corrupt_records = d["corrupt_records"]

    def __getitem__(self, message_type):
        return self.tables[message_type]

    def __contains__(self, message_type):
        return message_type in self.tables

    def __repr__(self):
        sizes = ", ".join(f"{k}: {len(v['time_s'])}" for k, v in self.tables.items())
        return f"<saulproto.Batch {self.messages} messages ({sizes}), rejected {self.rejected}, corrupt {self.corrupt}>"


def _reader(path, batch_size, format, protocol, samplerate_hz):
    return CaptureBatches(str(path), batch_size, format, protocol, samplerate_hz)


def read_capture(path, batch_size=100_000, *, format=None, protocol=None, samplerate_hz=0):
    """Yields the capture's messages as ``Batch`` objects of up to batch_size messages, columns per message type.

    Any format saulctl reads, told by its content: candump, pcap, pcapng, ASC (CAN: every frame through the SAUL and
    VESC decoders), saulctl's serial log, sigrok-cli and PulseView exports (serial: each link through its stream
    decoder; ``protocol`` names the protocol of files that do not say it, else it is guessed; ``samplerate_hz``
    turns sample numbers into time). ``format`` forces a format by name ('candump', 'pcap', 'serial', ...)."""
    reader = _reader(path, batch_size, format, protocol, samplerate_hz)
    while True:
        d = reader.next_tables()
        if d is None:
            return
        yield Batch(d)


def messages(path, batch_size=10_000, *, format=None, protocol=None, samplerate_hz=0):
    """Yields every decoded message of a capture as a dict: its fields, 'type', 'time_s' and 'interface' (CAN) or
    'link' (serial). Slower than read_capture (one dict per message), simpler for scripts."""
    reader = _reader(path, batch_size, format, protocol, samplerate_hz)
    while True:
        d = reader.next_messages()
        if d is None:
            return
        yield from d["messages"]


def load(path, **options):
    """The whole capture as one Batch: every batch of read_capture joined (columns extended in order)."""
    total = {"tables": {}, "frames": 0, "chunks": 0, "messages": 0, "rejected": {}, "corrupt": 0,
             "corrupt_records": []}
    for b in read_capture(path, **options):
        for name, table in b.tables.items():
            into = total["tables"].get(name)
            if into is None:
                total["tables"][name] = table
            else:
                for column, values in table.items():
                    into[column].extend(values)
        for key in ("frames", "chunks", "messages", "corrupt"):
            total[key] += getattr(b, key)
        for reason, n in b.rejected.items():
            total["rejected"][reason] = total["rejected"].get(reason, 0) + n
        total["corrupt_records"].extend(b.corrupt_records)
    return Batch(total)


def tune_report(path):
    """The balance loop's tuning figures from a loop trace (``saulctl tune record``), a CSV with time_s,
    setpoint_deg and pitch_deg columns, or a CAN capture (its 10 Hz telemetry): the dict ``saulctl tune report
    --json`` prints (docs/tuning.md lists its keys). Raises ValueError naming the file and why when it cannot be
    analysed at all; rows or records left out are listed under 'problems'."""
    import json
    return json.loads(_saulproto.tune_report_json(str(path)))
