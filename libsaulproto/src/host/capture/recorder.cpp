#include "saulproto/host/capture/recorder.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "saulproto/core/quantity.hpp"
#include "capture_io.hpp"

namespace saul::host {
namespace {

// Written in 1 MiB writes, not the stream's 8 KiB: fewer calls, and the kernel keeps the file's pages in large
// folios, which are quicker to read back (a pcapng file written 8 KiB at a time decoded ~7 % slower).
constexpr std::size_t kBuffer = std::size_t{1} << 20;

}  // namespace

std::string numbered_path(const std::string& path, unsigned index) {
  const std::size_t slash = path.find_last_of('/');
  const std::size_t base = slash == std::string::npos ? 0 : slash + 1;
  const std::size_t dot = path.find_last_of('.');
  const bool has_ext = dot != std::string::npos && dot > base;  // ".hidden" has no extension
  if (!has_ext) return fmt::format("{}-{:03}", path, index);
  return fmt::format("{}-{:03}{}", path.substr(0, dot), index, path.substr(dot));
}

std::uint64_t parse_size(const std::string& text) {
  if (const auto bytes = quantity::parse(text, {"iB", "B"}, 1024.0)) return *bytes;
  throw std::invalid_argument(fmt::format("bad size '{}' (use e.g. 100M, 1.5G, 64k)", text));
}

// ---- the files of both writers --------------------------------------------------------------------------------

template <class Writer>
bool RotatingFiles<Writer>::due(std::optional<std::uint64_t> timestamp_ns) {
  if (!rotation_.enabled() || items_in_file_ == 0) return false;  // never leave a file empty
  if (rotation_.max_bytes > 0 && bytes_in_file() >= rotation_.max_bytes) return true;
  return rotation_.max_duration_ns > 0 && file_start_ns_ && timestamp_ns && *timestamp_ns >= *file_start_ns_ &&
         *timestamp_ns - *file_start_ns_ >= rotation_.max_duration_ns;
}

template <class Writer>
RotatingFiles<Writer>::RotatingFiles(const std::string& path, RotationOptions rotation,
                                     std::function<void(const std::string&)> on_new_file, MakeWriter make,
                                     Compression packing, bool append)
    : rotation_(rotation),
      path_(path),
      on_new_file_(std::move(on_new_file)),
      make_(std::move(make)),
      packing_(packing),
      append_(append),
      buffer_(std::make_unique<char[]>(kBuffer)) {
  open(0);
  // without rotation no other file is made: `make` may hold references its caller's scope ends (open_mcap_writer)
  if (!rotation_.enabled()) make_ = nullptr;
}

template <class Writer>
RotatingFiles<Writer>::~RotatingFiles() {
  try {
    close();
  } catch (...) {  // call close() to see errors
  }
}

template <class Writer>
std::uint64_t RotatingFiles<Writer>::bytes_in_file() {
  const auto p = file_->tellp();  // file_ is made by the constructor; -1 once closed
  return p < 0 ? 0 : static_cast<std::uint64_t>(p);
}

template <class Writer>
void RotatingFiles<Writer>::close_current() {
  detail::close_with_file(
      [&] {
        inner_->close();
        if (packer_) packer_->finish();
      },
      *file_, current_path_);
  if (rotation_.compress == Compression::none) return;
  // std::async's future waits for its thread when destroyed: the destructor waits for every file closed
  compressed_ = std::async(std::launch::async, [before = std::move(compressed_), path = current_path_,
                                                compression = rotation_.compress]() mutable {
    std::string failure = before.valid() ? before.get() : std::string();
    try {
      compress_file(path, compression);
    } catch (const std::runtime_error& e) {
      if (failure.empty()) failure = e.what();
    }
    return failure;
  });
  if (!closed_) return;
  current_path_ += std::string(file_suffix(rotation_.compress));  // the last file's final name
  if (const std::string failure = compressed_.get(); !failure.empty()) throw std::runtime_error(failure);
}

template <class Writer>
void RotatingFiles<Writer>::open(unsigned index) {
  index_ = index;
  current_path_ = rotation_.enabled() ? numbered_path(path_, index) : path_;
  file_ = std::make_unique<std::ofstream>();
  file_->rdbuf()->pubsetbuf(buffer_.get(), kBuffer);
  // "-" (never a numbered path) is opened again by its name, /dev/stdout
  const auto mode = std::ios::binary | (append_ ? std::ios::app : std::ios::out | std::ios::trunc);
  file_->open(current_path_ == "-" ? "/dev/stdout" : current_path_.c_str(), mode);
  if (!*file_) throw CaptureOpenError(fmt::format("cannot create '{}': {}", current_path_, std::strerror(errno)));
  if (packing_ != Compression::none) {
    packer_ = make_compressing_buf(*file_->rdbuf(), packing_);
    packed_ = std::make_unique<std::ostream>(packer_.get());
  }
  inner_ = make_(packed_ ? *packed_ : *file_);
  items_in_file_ = 0;
  file_start_ns_.reset();
  if (on_new_file_) on_new_file_(current_path_);
}

template <class Writer>
void RotatingFiles<Writer>::write_item(std::optional<std::uint64_t> timestamp_ns,
                                       const std::function<void(Writer&)>& write) {
  if (!closed_ && due(timestamp_ns)) {  // after close() the format writer refuses the write
    close_current();
    open(index_ + 1);
  }
  detail::naming_file(current_path_, [&] { write(*inner_); });
  if (!file_start_ns_) file_start_ns_ = timestamp_ns;
  ++items_in_file_;
}

template <class Writer>
void RotatingFiles<Writer>::flush() {
  if (closed_) return;
  detail::naming_file(current_path_, [&] { inner_->flush(); });
}

template <class Writer>
void RotatingFiles<Writer>::close() {
  if (closed_) return;
  closed_ = true;
  close_current();
}

template class RotatingFiles<CaptureWriter>;
template class RotatingFiles<SerialCaptureWriter>;

namespace {
/// `make`, or the format's own writer; throws CaptureOpenError for a format of serial bytes (before any file is made).
RotatingCaptureWriter::MakeWriter can_writer(const std::string& path, CaptureFormat format,
                                             RotatingCaptureWriter::MakeWriter make) {
  if (holds_serial_bytes(format))
    throw CaptureOpenError(fmt::format("cannot write CAN frames to '{}' as {}: that format holds serial bytes", path,
                                       to_string(format)));
  if (make) return make;
  return [format](std::ostream& out) { return make_capture_writer(out, format); };
}
}  // namespace

RotatingCaptureWriter::RotatingCaptureWriter(const std::string& path, CaptureFormat format, RotationOptions rotation,
                                             std::function<void(const std::string&)> on_new_file, MakeWriter make,
                                             Compression packing, bool append)
    : RotatingFiles(path, rotation, std::move(on_new_file), can_writer(path, format, std::move(make)), packing, append) {}

}  // namespace saul::host
