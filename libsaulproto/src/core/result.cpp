#include "saulproto/core/result.hpp"

namespace saul {

const char* to_string(Reason reason) noexcept {
  switch (reason) {
    case Reason::ok: return "ok";
    case Reason::wrong_dlc: return "wrong_dlc";
    case Reason::extended_id: return "extended_id";
    case Reason::standard_id: return "standard_id";
    case Reason::remote_frame: return "remote_frame";
    case Reason::error_frame: return "error_frame";
    case Reason::unknown_id: return "unknown_id";
    case Reason::invalid_frame: return "invalid_frame";
    case Reason::out_of_range: return "out_of_range";
    case Reason::not_finite: return "not_finite";
    case Reason::negative: return "negative";
    case Reason::buffer_too_small: return "buffer_too_small";
    case Reason::bad_crc: return "bad_crc";
    case Reason::bad_length: return "bad_length";
    case Reason::unknown_type: return "unknown_type";
    case Reason::truncated: return "truncated";
    case Reason::syntax: return "syntax";
    case Reason::unknown_command: return "unknown_command";
    case Reason::missing_argument: return "missing_argument";
    case Reason::extra_argument: return "extra_argument";
    case Reason::not_a_number: return "not_a_number";
  }
  return "unknown_reason";
}

}  // namespace saul
