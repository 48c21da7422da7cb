// _saulproto: the C++ half of the Python package saulproto (python/saulproto/__init__.py is the other half and the
// documented interface). One frame decoded into a dict, the Orin's commands encoded into (id, bytes), and the
// batch reader, stream decoders and tuning report bound in captures.cpp, streams.cpp and tune.cpp.
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <variant>

#include "convert.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/saul_can.hpp"

namespace saulpy {

void bind_captures(py::module_& m);
void bind_streams(py::module_& m);
void bind_tune(py::module_& m);

namespace {

namespace sc = saul::saulcan;

py::dict decode_frame(std::uint32_t id, const py::bytes& data, bool extended, bool remote, bool error,
                      std::optional<unsigned> dlc) {
  const std::string_view bytes = data;
  if (bytes.size() > saul::CanFrame::kMaxDlc) throw py::value_error("a classic CAN frame holds at most 8 bytes");
  saul::CanFrame f;
  f.id = id;
  f.extended = extended;
  f.remote = remote;
  f.error = error;
  f.dlc = static_cast<std::uint8_t>(dlc ? std::min(*dlc, 15U) : bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = static_cast<std::uint8_t>(bytes[i]);
  const auto r = saul::decode_bus_frame(f);
  return r ? bus_message_dict(r.value()) : rejected_dict(r.reason());
}

py::tuple frame_tuple(const saul::CanFrame& f) {
  const auto p = f.payload();
  return py::make_tuple(f.id, py::bytes(reinterpret_cast<const char*>(p.data()), p.size()));
}

template <class T>
T checked(long long v, const char* what) {
  if (v < std::numeric_limits<T>::min() || v > std::numeric_limits<T>::max())
    throw py::value_error(std::string(what) + " is outside " + std::to_string(std::numeric_limits<T>::min()) + ".." +
                          std::to_string(std::numeric_limits<T>::max()));
  return static_cast<T>(v);
}

py::tuple encode_velocity(long long speed_mmps, long long steer_mrad) {
  sc::VelocityCmd m;
  m.speed_mmps = checked<std::int16_t>(speed_mmps, "speed_mmps");
  m.steer_mrad = checked<std::int16_t>(steer_mrad, "steer_mrad");
  return frame_tuple(sc::encode(m));
}

py::tuple encode_mode(const py::object& mode) {
  sc::ModeCmd m;
  if (py::isinstance<py::str>(mode)) {
    const auto name = mode.cast<std::string>();
    bool found = false;
    for (std::uint8_t v = 0; v <= static_cast<std::uint8_t>(sc::Mode::estop); ++v) {
      if (name == sc::to_string(static_cast<sc::Mode>(v))) {
        m.mode = static_cast<sc::Mode>(v);
        found = true;
      }
    }
    if (!found) throw py::value_error("mode must be 'off', 'balance', 'manual' or 'estop', not '" + name + "'");
  } else {
    const auto v = mode.cast<long long>();
    if (v < 0 || v > static_cast<long long>(sc::Mode::estop)) throw py::value_error("mode must be 0..3");
    m.mode = static_cast<sc::Mode>(v);
  }
  return frame_tuple(sc::encode(m));
}

py::list encode_pid_set(double kp, double ki, double kd, long long sequence) {
  const auto seq = checked<std::uint8_t>(sequence, "sequence");
  py::list frames;
  const double gains[3] = {kp, ki, kd};
  for (std::uint8_t i = 0; i < 3; ++i) {
    const float g = static_cast<float>(gains[i]);
    if (!std::isfinite(g) || g < 0.0F)
      throw py::value_error("gains must be finite and not negative (BALANCE rejects the whole set otherwise)");
    frames.append(frame_tuple(sc::encode(sc::PidGain{static_cast<sc::Gain>(i), seq, g})));
  }
  return frames;
}

py::tuple encode_config(long long tilt_limit_x100, long long max_speed_mmps) {
  sc::ConfigCmd m;
  m.tilt_limit_x100 = checked<std::uint16_t>(tilt_limit_x100, "tilt_limit_x100");
  if (m.tilt_limit_x100 < sc::ConfigCmd::kMinTiltX100 || m.tilt_limit_x100 > sc::ConfigCmd::kMaxTiltX100)
    throw py::value_error("tilt_limit_x100 must be 500..2500 (5.00 to 25.00 degrees); BALANCE rejects others");
  m.max_speed_mmps = checked<std::uint16_t>(max_speed_mmps, "max_speed_mmps");
  return frame_tuple(sc::encode(m));
}

template <class Variant, std::size_t... I>
void register_types(std::index_sequence<I...>) {
  (views<std::variant_alternative_t<I, Variant>>(), ...);
}
template <class Variant>
void register_types() {
  register_types<Variant>(std::make_index_sequence<std::variant_size_v<Variant>>());
}

}  // namespace
}  // namespace saulpy

PYBIND11_MODULE(_saulproto, m) {
  using namespace saulpy;
  m.doc() = "C++ part of saulproto (libsaulproto through pybind11); use the package saulproto.";
  m.def("decode_frame", &decode_frame, py::arg("id"), py::arg("data"), py::arg("extended") = false,
        py::arg("remote") = false, py::arg("error") = false, py::arg("dlc") = py::none(),
        "Decodes one CAN frame: {'type': name, field: value, ...}, or {'type': None, 'reason': why}.");
  m.def("encode_velocity", &encode_velocity, py::arg("speed_mmps"), py::arg("steer_mrad"));
  m.def("encode_mode", &encode_mode, py::arg("mode"));
  m.def("encode_pid_set", &encode_pid_set, py::arg("kp"), py::arg("ki"), py::arg("kd"), py::arg("sequence"));
  m.def("encode_config", &encode_config, py::arg("tilt_limit_x100"), py::arg("max_speed_mmps"));
  register_types<saul::BusMessage>();
  register_types<saul::interboard::Message>();
  register_types<saul::crsf::Message>();
  register_types<saul::pride::Message>();
  m.def("units", &units, py::arg("type"),
        "{field: unit} of a message type as decode() and read_capture() name its fields ('' for none).");
  bind_captures(m);
  bind_streams(m);
  bind_tune(m);
}
