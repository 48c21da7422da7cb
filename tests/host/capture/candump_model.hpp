// The reference the candump reader is checked against: a log read line by line with std::getline and each line
// that starts with '(' given to parse_candump_line (comments and blank lines skipped, as canplayer does). Nothing
// of the reader's buffering, fast path or batches: what those must give. It holds a line of any length (the reader
// reports one longer than kMaxCandumpLine by its length instead).
#pragma once

#include <cstdint>
#include <istream>
#include <string>

#include "saulproto/host/capture/candump.hpp"

namespace saul::host::test {

class CandumpLineModel final : public RecordCaptureReader {
 public:
  explicit CandumpLineModel(std::istream& in) : in_(in) {}
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::candump; }

 private:
  Status next() override {
    while (std::getline(in_, line_)) {
      ++line_number_;
      if (line_.empty() || line_[0] != '(') continue;
      if (parse_candump_line(line_, current_, error_)) {
        frame_ = current_.frame;
        name_ = current_.interface;
        return Status::frame;
      }
      error_.kind = PositionKind::line;
      error_.position = line_number_;
      error_.recovery = Recovery::next_line;
      return Status::corrupt;
    }
    return Status::end;
  }

  std::istream& in_;
  std::string line_;
  CandumpLine current_;
  std::uint64_t line_number_ = 0;
};

}  // namespace saul::host::test
