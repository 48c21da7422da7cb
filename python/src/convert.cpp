#include "convert.hpp"

#include <cmath>
#include <variant>

namespace saulpy {

const saul::signals::MessageDesc* description_of(const char* type) {
  for (const auto p : saul::signals::kProtocols)
    if (const auto* d = saul::signals::find_named(p, type)) return d;
  return nullptr;
}

FieldView view_of(const saul::signals::MessageDesc* d, const char* field) {
  FieldView f;
  f.name = field;
  if (!d) return f;
  const saul::signals::SignalDesc* found = nullptr;
  for (const auto& s : d->signals) {
    if (std::string_view(s.field) != field) continue;
    if (found) return f;  // several signals share the struct field (multiplexed, as 0x301's value): kept as it is
    found = &s;
  }
  if (!found) return f;
  f.name = found->name;  // the signal's one name, as decode and the DBC say it
  f.unit = found->unit;
  const bool integer = found->kind == saul::signals::Kind::signed_int || found->kind == saul::signals::Kind::unsigned_int;
  if (integer && found->text == saul::signals::Text::raw && (found->scale_num != found->scale_den || found->offset != 0))
    f.scale = found;
  return f;
}

namespace {
std::unordered_map<std::string, std::vector<FieldView>>& unit_registry() {
  static std::unordered_map<std::string, std::vector<FieldView>> r;
  return r;
}
}  // namespace

void register_units(const char* type, const std::vector<FieldView>& views) { unit_registry()[type] = views; }

py::dict units(const std::string& type) {
  const auto it = unit_registry().find(type);
  if (it == unit_registry().end()) throw py::key_error("no message type '" + type + "'");
  py::dict d;
  for (const auto& f : it->second) d[f.name] = f.unit;
  return d;
}

py::dict bus_message_dict(const saul::BusMessage& message) {
  return std::visit([](const auto& m) { return message_dict(m); }, message);
}

py::dict serial_message_dict(const saul::host::SerialMessage& message) {
  return std::visit(
      [&](const auto& outer) -> py::dict {
        using T = std::decay_t<decltype(outer)>;
        if constexpr (std::is_same_v<T, saul::host::CrsfUndecoded>) {
          py::dict d;
          d["type"] = saul::host::name_of(message);
          d["reason"] = saul::to_string(outer.reason);
          const auto payload = outer.frame.payload();
          d["payload"] = py::bytes(reinterpret_cast<const char*>(payload.data()), payload.size());
          return d;
        } else {
          py::dict d = std::visit([](const auto& m) { return message_dict(m); }, inner_message(outer));
          if constexpr (std::is_same_v<T, saul::host::CrsfMessage>) d["address"] = outer.address;
          return d;
        }
      },
      message);
}

py::dict rejected_dict(saul::Reason reason) {
  py::dict d;
  d["type"] = py::none();
  d["reason"] = saul::to_string(reason);
  return d;
}

py::dict counters_dict(const nlohmann::json& counters) {
  py::dict d;
  for (const auto& [k, v] : counters.items()) {
    if (v.is_number_unsigned()) d[py::str(k)] = v.get<std::uint64_t>();
    else if (v.is_number_integer()) d[py::str(k)] = v.get<std::int64_t>();
    else if (v.is_string()) d[py::str(k)] = v.get<std::string>();
  }
  return d;
}

py::object make_array(const char* code, const void* data, std::size_t bytes) {
  static py::object array_type = py::module_::import("array").attr("array");
  py::object a = array_type(code);
  if (bytes > 0)
    a.attr("frombytes")(py::memoryview::from_memory(data, static_cast<py::ssize_t>(bytes)));
  return a;
}

py::object NameCache::get(const char* name) {
  auto it = cache_.find(name);
  if (it != cache_.end()) return it->second;
  py::object s = py::str(name);
  cache_.emplace(name, s);
  return s;
}

namespace {

py::list list_of(const std::vector<py::object>& cached, const std::vector<std::uint16_t>& index) {
  py::list l(index.size());
  for (std::size_t i = 0; i < index.size(); ++i) l[i] = cached[index[i]];
  return l;
}

}  // namespace

py::dict Table::to_python(const char* source_key, const std::vector<py::object>& sources, NameCache& names) const {
  py::dict d;
  std::vector<double> seconds(time_ns_.size());
  for (std::size_t i = 0; i < time_ns_.size(); ++i)
    seconds[i] = time_ns_[i] < 0 ? std::nan("") : static_cast<double>(time_ns_[i]) * 1e-9;
  d["time_s"] = make_array("d", seconds.data(), seconds.size() * sizeof(double));
  d["timestamp_ns"] = make_array("q", time_ns_.data(), time_ns_.size() * sizeof(std::int64_t));
  d[source_key] = list_of(sources, source_);
  for (const Column& c : columns_) {
    switch (c.kind) {
      case Kind::integer: d[c.field] = make_array("q", c.ints.data(), c.ints.size() * sizeof(std::int64_t)); break;
      case Kind::real: d[c.field] = make_array("d", c.reals.data(), c.reals.size() * sizeof(double)); break;
      case Kind::name: {
        py::list l(c.names.size());
        for (std::size_t i = 0; i < c.names.size(); ++i) l[i] = names.get(c.names[i]);
        d[c.field] = l;
        break;
      }
      case Kind::text: {
        py::list l(c.texts.size());
        for (std::size_t i = 0; i < c.texts.size(); ++i) l[i] = py::str(c.texts[i]);
        d[c.field] = l;
        break;
      }
    }
  }
  return d;
}

Table& Tables::at(std::size_t key, const char* type) {
  auto& slot = slots_.at(key);
  if (!slot) {
    slot = std::make_unique<Table>(type);
    order_.push_back(slot.get());
  }
  return *slot;
}

py::dict Tables::to_python(const char* source_key, const std::vector<std::string>& sources) const {
  std::vector<py::object> source_names;
  source_names.reserve(sources.size());
  for (const auto& s : sources) source_names.emplace_back(py::str(s));
  NameCache names;
  py::dict d;
  for (const Table* t : order_) d[t->type()] = t->to_python(source_key, source_names, names);
  return d;
}

}  // namespace saulpy
