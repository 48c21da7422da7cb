// The serial links' streaming decoders (inter-board UART, CRSF, Pride) for bytes read live from a port: push bytes
// as they come, get the messages they complete. One class over the host's SerialStreamDecoder, which runs the
// core's decoder of the protocol and keeps its counters.
#include <string>
#include <vector>

#include "convert.hpp"
#include "saulproto/host/report/serial_decode.hpp"

namespace saulpy {
namespace {

using saul::host::SerialMessage;
using saul::host::SerialProtocol;

class StreamDecoder {
 public:
  explicit StreamDecoder(const std::string& protocol) : decoder_(parse(protocol)) {}

  py::list push(const py::bytes& data) {
    std::vector<SerialMessage> found;
    {
      const std::string_view bytes = data;  // a view of the bytes object, kept alive by the caller
      py::gil_scoped_release release;
      decoder_.push({reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()},
                    [&](const SerialMessage& m) { found.push_back(m); });
    }
    return to_list(found);
  }

  py::list finish() {
    std::vector<SerialMessage> found;
    decoder_.finish([&](const SerialMessage& m) { found.push_back(m); });
    return to_list(found);
  }

  [[nodiscard]] py::dict counters() const {
    return counters_dict(decoder_.counters_json());
  }

  [[nodiscard]] std::string protocol() const { return std::string(saul::host::to_string(decoder_.protocol())); }

 private:
  static SerialProtocol parse(const std::string& name) {
    const auto p = saul::host::serial_protocol_from_name(name);
    if (!p || *p == SerialProtocol::raw)
      throw py::value_error("protocol must be 'interboard', 'crsf' or 'pride', not '" + name + "'");
    return *p;
  }
  static py::list to_list(const std::vector<SerialMessage>& found) {
    py::list l(found.size());
    for (std::size_t i = 0; i < found.size(); ++i) l[i] = serial_message_dict(found[i]);
    return l;
  }

  saul::host::SerialStreamDecoder decoder_;
};

}  // namespace

void bind_streams(py::module_& m) {
  py::class_<StreamDecoder>(m, "StreamDecoder",
                            "Streaming decoder of one serial link: 'interboard' (IO <-> BALANCE UART), 'crsf' (RC "
                            "receiver) or 'pride' (Pride ES controller).")
      .def(py::init<const std::string&>(), py::arg("protocol"))
      .def("push", &StreamDecoder::push, py::arg("data"),
           "Feeds bytes; returns the messages they complete, one dict each (an undecodable CRSF frame as "
           "{'type': 'crsf_0x..', 'reason': ..., 'payload': bytes}).")
      .def("finish", &StreamDecoder::finish,
           "End of input: gives up an unfinished frame (CRSF rescans what followed it); returns messages found.")
      .def_property_readonly("counters", &StreamDecoder::counters,
                             "What the decoder has seen: frames, crc_errors, bytes_skipped, ... (the protocol's own).")
      .def_property_readonly("protocol", &StreamDecoder::protocol);
}

}  // namespace saulpy
