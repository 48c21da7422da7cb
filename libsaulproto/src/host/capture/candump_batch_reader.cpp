#include "saulproto/host/capture/candump_batch_reader.hpp"

namespace saul::host {

std::unique_ptr<CandumpBatchReader> CandumpBatchReader::open(const std::string& path) {
  auto file = CandumpFile::open(path);
  if (!file) return nullptr;
  return std::unique_ptr<CandumpBatchReader>(new CandumpBatchReader(std::move(file)));
}

CaptureReader::Status CandumpBatchReader::next() {
  for (;;) {
    // In file order: the corrupt lines that came before the next frame, then the frame (for_each_in_order's rule).
    if (corrupt_ < batch_.corrupt.size() && batch_.corrupt[corrupt_].before <= frame_) {
      ++corrupt_;
      return Status::corrupt;
    }
    if (frame_ < batch_.frames.size()) {
      ++frame_;
      return Status::frame;
    }
    if (done_ || !scanner_.next_batch(batch_)) {
      done_ = true;
      batch_.clear();
      frame_ = corrupt_ = 0;
      return Status::end;
    }
    frame_ = corrupt_ = 0;
  }
}

}  // namespace saul::host
