// A CaptureReader over CandumpScanner's batches (candump_scan.hpp): the frames and errors of CandumpReader from a
// regular candump file, read in large blocks and parsed in place, for frame-by-frame consumers such as copy_frames()
// (saulctl convert). CandumpReader parses a line at a time through std::getline: on the 1 M-frame log of
// bench/compare it took a third of convert-to-MCAP's first thread.
#pragma once

#include <memory>
#include <string>

#include "saulproto/host/capture/candump_scan.hpp"

namespace saul::host {

class CandumpBatchReader final : public CaptureReader {
 public:
  /// nullptr when `path` is no regular file of uncompressed candump text (read it with open_capture_reader).
  static std::unique_ptr<CandumpBatchReader> open(const std::string& path);
  Status next() override;
  [[nodiscard]] const CanFrame& frame() const override { return batch_.frames[frame_ - 1]; }
  [[nodiscard]] std::string_view interface() const override { return batch_.interfaces[frame_ - 1]; }
  [[nodiscard]] const CaptureError& error() const override { return batch_.corrupt[corrupt_ - 1].error; }
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::candump; }
  [[nodiscard]] std::uint64_t bytes_read() const override { return scanner_.bytes_read(); }
  [[nodiscard]] std::optional<std::uint64_t> bytes_total() const override { return file_->size(); }

 private:
  explicit CandumpBatchReader(std::unique_ptr<CandumpFile> file) : file_(std::move(file)), scanner_(file_->fd()) {}
  std::unique_ptr<CandumpFile> file_;
  CandumpScanner scanner_;
  FrameBatch batch_;
  std::size_t frame_ = 0, corrupt_ = 0;  ///< the next of each in the batch, from 1 once handed out
  bool done_ = false;
};

}  // namespace saul::host
