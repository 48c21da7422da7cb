// Messages to Python objects: one message as a dict, and many messages of one type as columns (array.array for
// numbers, lists of str for names and text). Both walk the fields(visitor) every core message has, and name and
// scale each field from the message's signal description (core/signals*.hpp): a field whose wire integer has a
// scale becomes its physical value under the signal's name (pitch_x100 -1234 -> pitch -12.34, in deg), every other
// field keeps saulctl's JSON key and value (speed_mmps, state 'BALANCE', VESC current_a); units() tells each
// field's unit. CRSF's 0x17 subset frames, whose fields differ frame to frame, keep their fields' names as they are
// (the description's names too).
#pragma once

#include <nlohmann/json.hpp>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "saulproto/core/result.hpp"
#include "saulproto/core/signals.hpp"
#include "saulproto/host/report/serial_decode.hpp"

namespace saulpy {

namespace py = pybind11;

/// How one field of a message type reaches Python.
struct FieldView {
  const char* name = "";  ///< the signal's name (the struct's field name when no one signal has that field)
  const char* unit = "";  ///< "" when the field has none or no description
  const saul::signals::SignalDesc* scale = nullptr;  ///< set: an integer to turn into its physical value
};

/// The description of the message type called `type` (kName), in any protocol; nullptr when there is none.
const saul::signals::MessageDesc* description_of(const char* type);
/// The view of struct field `field` of a message described by d (d may be nullptr).
FieldView view_of(const saul::signals::MessageDesc* d, const char* field);
/// Remembers a type's field names and units for units().
void register_units(const char* type, const std::vector<FieldView>& views);
/// {field: unit} of a message type; KeyError for a type no decoder produces.
py::dict units(const std::string& type);

/// The views of M's fields, in fields() order, computed once.
template <class M>
const std::vector<FieldView>& views() {
  static const std::vector<FieldView> v = [] {
    std::vector<FieldView> out;
    const auto* d = description_of(M::kName);
    M{}.fields([&](const char* key, const auto&) { out.push_back(view_of(d, key)); });
    register_units(M::kName, out);
    return out;
  }();
  return v;
}

/// One field value as a Python object.
template <class T>
py::object to_py(const T& v) {
  if constexpr (std::is_enum_v<T>) {
    return py::str(to_string(v));
  } else if constexpr (std::is_same_v<T, bool>) {
    return py::bool_(v);
  } else if constexpr (std::is_integral_v<T>) {
    return py::int_(v);
  } else if constexpr (std::is_floating_point_v<T>) {
    return py::float_(static_cast<double>(v));
  } else {
    return py::str(static_cast<const char*>(v));
  }
}

/// {"type": kName, field: value, ...}, fields as views<M>() says.
template <class M>
py::dict message_dict(const M& m) {
  py::dict d;
  d["type"] = M::kName;
  if constexpr (requires { M::kVariableLayout; }) {  // fields vary frame to frame (CRSF 0x17): no fixed views
    m.fields([&](const char* key, const auto& value) { d[key] = to_py(value); });
    return d;
  }
  const auto& v = views<M>();
  std::size_t i = 0;
  m.fields([&](const char*, const auto& value) {
    using T = std::decay_t<decltype(value)>;
    const FieldView& f = v[i++];
    if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
      if (f.scale) {
        d[f.name] = saul::signals::raw_to_physical(*f.scale, static_cast<std::int64_t>(value));
        return;
      }
    }
    d[f.name] = to_py(value);
  });
  return d;
}

py::dict bus_message_dict(const saul::BusMessage& message);
py::dict serial_message_dict(const saul::host::SerialMessage& message);

/// The message variant inside one alternative of a SerialMessage: a CrsfMessage's message (it also carries the
/// frame's address), any other alternative itself.
inline const saul::crsf::Message& inner_message(const saul::host::CrsfMessage& m) { return m.message; }
template <class V>
const V& inner_message(const V& v) {
  return v;
}
/// {"type": None, "reason": "wrong_dlc"}
py::dict rejected_dict(saul::Reason reason);

/// A flat JSON object of counters (SerialStreamDecoder::counters_json) as a dict: numbers as int, text as str.
py::dict counters_dict(const nlohmann::json& counters);

/// array.array(code) holding a copy of `bytes` bytes at `data` (one memcpy).
py::object make_array(const char* code, const void* data, std::size_t bytes);

/// Builds lists of str from C strings that live as long as the program (enum names), each made once.
class NameCache {
 public:
  py::object get(const char* name);

 private:
  std::unordered_map<const char*, py::object> cache_;
};

/// The columns of one message type in one batch.
class Table {
 public:
  explicit Table(const char* type) : type_(type) {}

  template <class M>
  void add(const M& m, std::optional<std::uint64_t> timestamp_ns, std::uint16_t source) {
    time_ns_.push_back(timestamp_ns ? static_cast<std::int64_t>(*timestamp_ns) : -1);
    source_.push_back(source);
    const auto& v = views<M>();
    std::size_t i = 0;
    m.fields([&](const char*, const auto& value) {
      using T = std::decay_t<decltype(value)>;
      if (!shaped_) {
        const FieldView& f = v[i];
        columns_.push_back(Column{f.name, f.scale && std::is_integral_v<T> ? Kind::real : kind_of<T>(), f.scale,
                                  {}, {}, {}, {}});
      }
      Column& c = columns_[i++];
      if constexpr (std::is_enum_v<T>) {
        c.names.push_back(to_string(value));
      } else if constexpr (std::is_integral_v<T>) {
        if (c.scale) c.reals.push_back(saul::signals::raw_to_physical(*c.scale, static_cast<std::int64_t>(value)));
        else c.ints.push_back(static_cast<std::int64_t>(value));
      } else if constexpr (std::is_floating_point_v<T>) {
        c.reals.push_back(static_cast<double>(value));
      } else {
        c.texts.emplace_back(static_cast<const char*>(value));
      }
    });
    shaped_ = true;
  }

  [[nodiscard]] const char* type() const { return type_; }
  [[nodiscard]] std::size_t rows() const { return time_ns_.size(); }
  /// {"time_s": array('d'), "timestamp_ns": array('q'), <source_key>: [str], field: column, ...}
  py::dict to_python(const char* source_key, const std::vector<py::object>& sources, NameCache& names) const;

 private:
  enum class Kind : std::uint8_t { integer, real, name, text };
  struct Column {
    const char* field;
    Kind kind;
    const saul::signals::SignalDesc* scale;
    std::vector<std::int64_t> ints;
    std::vector<double> reals;
    std::vector<const char*> names;
    std::vector<std::string> texts;
  };
  template <class T>
  static constexpr Kind kind_of() {
    if constexpr (std::is_enum_v<T>) return Kind::name;
    else if constexpr (std::is_integral_v<T>) return Kind::integer;
    else if constexpr (std::is_floating_point_v<T>) return Kind::real;
    else return Kind::text;
  }

  const char* type_;
  std::vector<std::int64_t> time_ns_;  // -1: no timestamp
  std::vector<std::uint16_t> source_;  // index into the batch's interface or link names
  std::vector<Column> columns_;
  bool shaped_ = false;
};

/// The tables of one batch, one per message type, in order of first appearance. Types are told apart by a small
/// key (the variant index, see captures.cpp).
class Tables {
 public:
  static constexpr std::size_t kSlots = 128;
  Table& at(std::size_t key, const char* type);
  [[nodiscard]] bool empty() const { return order_.empty(); }
  py::dict to_python(const char* source_key, const std::vector<std::string>& sources) const;

 private:
  std::vector<std::unique_ptr<Table>> slots_ = std::vector<std::unique_ptr<Table>>(kSlots);
  std::vector<Table*> order_;
};

}  // namespace saulpy
