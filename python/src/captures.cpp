// Reading capture files from Python in batches: any format saulctl reads (open_capture tells them apart by their
// content), every CAN frame through decode_bus_frame and every serial byte through the link's stream decoder, in
// C++ with the GIL released; Python receives per batch either one table (columns) per message type, or a list of
// one dict per message.
#include <pybind11/stl.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "convert.hpp"
#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/serial_decode.hpp"

namespace saulpy {
namespace {

using saul::host::CaptureReader;
using saul::host::SerialCaptureReader;
using saul::host::SerialChunk;
using saul::host::SerialMessage;
using saul::host::SerialProtocol;

constexpr std::size_t kMaxCorruptKept = 1000;

/// Table keys: BusMessage alternatives take 0..31, serial messages 32 + 16 * protocol + alternative.
constexpr std::size_t kSerialKeyBase = 32;
static_assert(std::variant_size_v<saul::BusMessage> <= kSerialKeyBase);

std::size_t serial_key(const SerialMessage& m) {
  return std::visit(
      [&](const auto& outer) -> std::size_t {
        using T = std::decay_t<decltype(outer)>;
        if constexpr (std::is_same_v<T, saul::host::CrsfUndecoded>) {
          return Tables::kSlots;  // not a table: counted as rejected
        } else {
          static_assert(std::variant_size_v<std::decay_t<decltype(inner_message(outer))>> <= 16);
          return kSerialKeyBase + 16 * m.index() + inner_message(outer).index();
        }
      },
      m);
}

/// Calls f(message) with the message struct itself: a BusMessage alternative, or the inner alternative of a
/// SerialMessage (undecoded CRSF frames never get here).
template <class F>
void visit_leaf(const saul::BusMessage& message, F&& f) {
  std::visit(f, message);
}
template <class F>
void visit_leaf(const SerialMessage& message, F&& f) {
  std::visit(
      [&](const auto& outer) {
        if constexpr (!std::is_same_v<std::decay_t<decltype(outer)>, saul::host::CrsfUndecoded>) std::visit(f, inner_message(outer));
      },
      message);
}

/// A message of either kind with its time and source, for the one-dict-per-message view.
struct Row {
  std::variant<saul::BusMessage, SerialMessage> message;
  std::optional<std::uint64_t> timestamp_ns;
  std::uint16_t source = 0;
};

class CaptureBatches {
 public:
  CaptureBatches(const std::string& path, std::size_t batch_size, std::optional<std::string> format,
                 std::optional<std::string> protocol, std::uint64_t samplerate_hz)
      : path_(path), batch_size_(std::max<std::size_t>(batch_size, 1)) {
    std::optional<saul::host::CaptureFormat> f;
    if (format) {
      f = saul::host::capture_format_from_name(*format);
      if (!f) throw py::value_error("unknown capture format '" + *format + "'");
    }
    saul::host::SerialReadOptions options;
    if (protocol) {
      options.protocol = saul::host::serial_protocol_from_name(*protocol);
      if (!options.protocol) throw py::value_error("unknown serial protocol '" + *protocol + "'");
    }
    options.samplerate_hz = samplerate_hz;
    try {
      auto opened = saul::host::open_capture(path, options, f);
      format_ = opened.format;
      frames_ = std::move(opened.frames);
      chunks_ = std::move(opened.chunks);
    } catch (const saul::host::CaptureOpenError& e) {
      throw py::value_error(e.what());
    }
    if (chunks_) serial_.emplace(options.protocol);
  }

  /// The next batch as {"tables": {type: {column: values}}, plus the batch's counts}, or None at the end.
  py::object next_tables() {
    Tables tables;
    Counts counts;
    {
      py::gil_scoped_release release;
      read([&](const auto& message, std::size_t key, std::optional<std::uint64_t> t, std::uint16_t source) {
        visit_leaf(message, [&](const auto& m) { tables.at(key, m.kName).add(m, t, source); });
      }, counts);
    }
    if (counts.empty()) return py::none();
    py::dict d = counts.to_python(*this);
    d["tables"] = tables.to_python(source_key(), sources_);
    return d;
  }

  /// The next batch as {"messages": [dict, ...], ...counts}, or None at the end. Each dict is the message's
  /// fields with "type", "time_s" (None without a timestamp) and "interface" (CAN) or "link" (serial).
  py::object next_messages() {
    std::vector<Row> rows;
    Counts counts;
    {
      py::gil_scoped_release release;
      read([&](const auto& message, std::size_t, std::optional<std::uint64_t> t, std::uint16_t source) {
        rows.push_back(Row{message, t, source});
      }, counts);
    }
    if (counts.empty()) return py::none();
    std::vector<py::object> names;
    for (const auto& s : sources_) names.emplace_back(py::str(s));
    py::list list(rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      py::dict d = std::visit(
          [](const auto& m) -> py::dict {
            if constexpr (std::is_same_v<std::decay_t<decltype(m)>, saul::BusMessage>) return bus_message_dict(m);
            else return serial_message_dict(m);
          },
          r.message);
      d["time_s"] = r.timestamp_ns ? py::object(py::float_(static_cast<double>(*r.timestamp_ns) * 1e-9)) : py::none();
      d[source_key()] = names[r.source];
      list[i] = d;
    }
    py::dict d = counts.to_python(*this);
    d["messages"] = list;
    return d;
  }

  [[nodiscard]] std::string format() const { return std::string(saul::host::to_string(format_)); }

  /// Per serial link: protocol, whether it was guessed, and the decoder's counters (empty for CAN captures).
  [[nodiscard]] py::list links() const {
    py::list l;
    if (!serial_) return l;
    for (const auto& link : serial_->links()) {
      py::dict d;
      d["link"] = link.name;
      d["protocol"] = std::string(saul::host::to_string(link.protocol));
      d["guessed"] = link.guessed;
      d["counters"] = counters_dict(link.counters_json);
      l.append(d);
    }
    return l;
  }

 private:
  struct Counts {
    std::uint64_t records = 0;  ///< CAN frames or serial chunks read
    std::uint64_t messages = 0;
    std::map<std::string, std::uint64_t> rejected;  ///< by reason
    std::uint64_t corrupt = 0;
    std::vector<std::string> corrupt_text;
    [[nodiscard]] bool empty() const { return records == 0 && corrupt == 0 && messages == 0; }
    py::dict to_python(const CaptureBatches& self) const {
      py::dict d;
      d[self.chunks_ ? "chunks" : "frames"] = records;
      d["messages"] = messages;
      d["rejected"] = rejected;
      d["corrupt"] = corrupt;
      d["corrupt_records"] = corrupt_text;
      return d;
    }
  };

  [[nodiscard]] const char* source_key() const { return chunks_ ? "link" : "interface"; }

  std::uint16_t source_index(std::string_view name) {
    if (last_source_ < sources_.size() && sources_[last_source_] == name) return last_source_;
    auto it = std::find(sources_.begin(), sources_.end(), name);
    if (it == sources_.end()) {
      if (sources_.size() >= 0xFFFF) throw std::runtime_error("more than 65535 interfaces or links");
      sources_.emplace_back(name);
      it = sources_.end() - 1;
    }
    last_source_ = static_cast<std::uint16_t>(it - sources_.begin());
    return last_source_;
  }

  void corrupt(Counts& counts, const saul::host::CaptureError& error) {
    ++counts.corrupt;
    if (counts.corrupt_text.size() < kMaxCorruptKept)
      counts.corrupt_text.push_back(saul::host::format_capture_error(path_, error));
  }

  // Reads until the batch holds batch_size_ messages (or records) or the file ends; calls
  // sink(message, table key, timestamp, source) for each message.
  template <class Sink>
  void read(Sink&& sink, Counts& counts) {
    if (frames_) {  // the reader's batches (next_batch), each taken up to where the Python batch is full
      while (counts.messages < batch_size_ && counts.records + counts.corrupt < 4 * batch_size_) {
        if (frame_ == batch_.frames.size() && corrupt_ == batch_.corrupt.size()) {
          frame_ = corrupt_ = 0;
          if (!frames_->next_batch(batch_)) break;
        }
        if (corrupt_ < batch_.corrupt.size() && batch_.corrupt[corrupt_].before == frame_) {
          corrupt(counts, batch_.corrupt[corrupt_++].error);
          continue;
        }
        ++counts.records;
        const saul::CanFrame& f = batch_.frames[frame_];
        const auto r = saul::decode_bus_frame(f);
        if (!r) {
          ++counts.rejected[saul::to_string(r.reason())];
        } else {
          ++counts.messages;
          sink(saul::BusMessage(r.value()), r.value().index(), f.timestamp_ns, source_index(batch_.interfaces[frame_]));
        }
        ++frame_;
      }
      return;
    }
    if (!chunks_ || finished_) return;
    auto on_message = [&](const SerialChunk& chunk, SerialProtocol, const SerialMessage& m) {
      const std::size_t key = serial_key(m);
      if (key >= Tables::kSlots) {
        ++counts.rejected[saul::to_string(std::get<saul::host::CrsfUndecoded>(m).reason)];
        return;
      }
      ++counts.messages;
      sink(m, key, chunk.timestamp_ns, source_index(chunk.link));
    };
    while (counts.messages < batch_size_ && counts.records + counts.corrupt < 4 * batch_size_) {
      const auto status = chunks_->next();
      if (status == SerialCaptureReader::Status::end) {
        serial_->finish(on_message);
        finished_ = true;
        break;
      }
      if (status == SerialCaptureReader::Status::corrupt) {
        corrupt(counts, chunks_->error());
        continue;
      }
      ++counts.records;
      serial_->add(chunks_->chunk(), on_message);
    }
  }

  std::string path_;
  std::size_t batch_size_;
  saul::host::CaptureFormat format_ = saul::host::CaptureFormat::candump;
  std::unique_ptr<CaptureReader> frames_;
  saul::host::FrameBatch batch_;
  std::size_t frame_ = 0, corrupt_ = 0;  // what read() took of batch_
  std::unique_ptr<SerialCaptureReader> chunks_;
  std::optional<saul::host::SerialCaptureDecoder> serial_;
  bool finished_ = false;
  std::vector<std::string> sources_;
  std::uint16_t last_source_ = 0;
};

}  // namespace

void bind_captures(py::module_& m) {
  py::class_<CaptureBatches>(m, "CaptureBatches",
                             "Reads a capture file in batches (saulproto.read_capture and saulproto.messages wrap it).")
      .def(py::init<const std::string&, std::size_t, std::optional<std::string>, std::optional<std::string>,
                    std::uint64_t>(),
           py::arg("path"), py::arg("batch_size") = 100000, py::arg("format") = py::none(),
           py::arg("protocol") = py::none(), py::arg("samplerate_hz") = 0)
      .def("next_tables", &CaptureBatches::next_tables)
      .def("next_messages", &CaptureBatches::next_messages)
      .def_property_readonly("format", &CaptureBatches::format)
      .def("links", &CaptureBatches::links);
}

}  // namespace saulpy
