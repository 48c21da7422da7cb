#include "saulproto/host/capture/candump.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include "saulproto/core/hex.hpp"
#include "capture_io.hpp"
#include "text_fields.hpp"

namespace saul::host {

using detail::column_error;

bool parse_candump_line(std::string_view line, CandumpLine& out, CandumpError& error) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  std::uint64_t ns = 0;
  std::size_t close = 0;
  if (!detail::parse_paren_time(line, UINT64_MAX, ns, close, error)) return false;

  // interface, then the frame: ID '#' DATA
  std::size_t pos = close + 1, if_start = 0, frame_start = 0;
  out.interface = detail::word(line, pos, if_start);
  if (out.interface.empty()) return column_error(error, if_start, "missing interface name");
  const std::string_view text = detail::word(line, pos, frame_start);
  const std::size_t hash = text.find('#');
  if (hash == std::string_view::npos) return column_error(error, frame_start, "frame needs '#' between id and data");
  if (hash != 3 && hash != 8) return column_error(error, frame_start, "id must be 3 hex digits (11-bit) or 8 (29-bit)");
  std::uint32_t id = 0;
  for (std::size_t i = 0; i < hash; ++i) {
    const int v = hex::value(text[i]);
    if (v < 0) return column_error(error, frame_start + i, "id is not hexadecimal");
    id = (id << 4) | static_cast<std::uint32_t>(v);
  }
  CanFrame f;
  f.timestamp_ns = ns;
  std::string_view data = text.substr(hash + 1);
  std::size_t data_col = frame_start + hash + 1;
  if (!data.empty() && data[0] == '#')
    return column_error(error, data_col, std::string(detail::kFdUnsupported));
  if (hash == 8) {
    constexpr std::uint32_t kErrFlag = 0x2000'0000;
    if (id & kErrFlag) {
      f.error = true;
      id &= CanFrame::kMaxExtendedId;
    } else {
      f.extended = true;
      if (id > CanFrame::kMaxExtendedId) return column_error(error, frame_start, "29-bit id above 1FFFFFFF");
    }
  } else if (id > CanFrame::kMaxStandardId) {
    return column_error(error, frame_start, "11-bit id above 7FF");
  }
  f.id = id;
  // A raw DLC of 9..F after 8 data bytes (len8_dlc, can-utils since 2020.12: "3FF#55AA010203040506_D", "123#R8_D"):
  // classic CAN carries 8 bytes then, which is what the frame keeps.
  bool raw_dlc = false;
  if (data.size() >= 2 && data[data.size() - 2] == '_') {
    const int v = hex::value(data.back());
    if (v < 9)
      return column_error(error, data_col + data.size() - 1, "raw DLC suffix must be _9 to _F (after 8 data bytes)");
    data.remove_suffix(2);
    raw_dlc = true;
  }
  if (!data.empty() && (data[0] == 'R' || data[0] == 'r')) {
    if (f.error) return column_error(error, data_col, "an error frame cannot be a remote frame");
    f.remote = true;
    if (data.size() == 2 && data[1] >= '0' && data[1] <= '8') {
      f.dlc = static_cast<std::uint8_t>(data[1] - '0');
    } else if (data.size() != 1) {
      return column_error(error, data_col + 1, "remote frame length must be one digit 0..8");
    }
  } else {
    std::uint8_t n = 0;
    for (std::size_t i = 0; i < data.size();) {
      if (data[i] == '.') {
        ++i;
        continue;
      }
      if (i + 1 >= data.size()) return column_error(error, data_col + i, "data has an odd number of hex digits");
      const int hi = hex::value(data[i]);
      const int lo = hex::value(data[i + 1]);
      if (hi < 0 || lo < 0) return column_error(error, data_col + i, "data is not hexadecimal");
      if (n == 8) return column_error(error, data_col + i, "more than 8 data bytes");
      f.data[n++] = static_cast<std::uint8_t>(hi << 4 | lo);
      i += 2;
    }
    f.dlc = n;
  }
  if (raw_dlc && f.dlc != 8)
    return column_error(error, data_col + data.size(), "a raw DLC suffix needs 8 data bytes (or R8)");
  out.frame = f;
  return true;
}

char* write_candump_frame(char* w, const CanFrame& frame, bool data_only) {
  if (!data_only) {
    std::uint32_t id = frame.error ? (frame.id | 0x2000'0000U) : frame.id;
    const int digits = frame.error || frame.extended ? 8 : 3;
    for (int i = digits - 1; i >= 0; --i, id >>= 4) w[i] = hex::kUpperDigits[id & 0xF];
    w += digits;
    *w++ = '#';
  }
  if (frame.remote) {
    *w++ = 'R';
    if (frame.dlc) *w++ = static_cast<char>('0' + frame.dlc);
    return w;
  }
  for (std::uint8_t b : frame.payload()) {
    *w++ = hex::kUpperDigits[b >> 4];
    *w++ = hex::kUpperDigits[b & 0xF];
  }
  return w;
}

std::string format_candump_frame(const CanFrame& frame) {
  char text[kCandumpFrameMax];
  return {text, write_candump_frame(text, frame)};
}

std::string candump_interface(std::string_view interface) {
  std::string name(interface.empty() ? std::string_view("can0") : interface);
  for (char& c : name)
    if (static_cast<unsigned char>(c) <= 0x20 || c == 0x7F) c = '_';
  return name;
}

std::string format_candump_line(const CanFrame& frame, std::string_view interface) {
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  return fmt::format("({:010}.{:06}) {} {}", ns / 1'000'000'000ULL, (ns % 1'000'000'000ULL) / 1000,
                     candump_interface(interface), format_candump_frame(frame));
}

void CandumpWriter::put(const CanFrame& frame, std::string_view interface) {
  out_ << format_candump_line(frame, interface) << '\n';
}

// ---- the reader -------------------------------------------------------------------------------------------------
namespace {

constexpr std::array<std::int8_t, 256> kHexValue = [] {
  std::array<std::int8_t, 256> t{};
  for (auto& v : t) v = -1;
  for (int c = '0'; c <= '9'; ++c) t[static_cast<std::size_t>(c)] = static_cast<std::int8_t>(c - '0');
  for (int c = 'A'; c <= 'F'; ++c) t[static_cast<std::size_t>(c)] = static_cast<std::int8_t>(c - 'A' + 10);
  for (int c = 'a'; c <= 'f'; ++c) t[static_cast<std::size_t>(c)] = static_cast<std::int8_t>(c - 'a' + 10);
  return t;
}();

int hex_value(char c) noexcept { return kHexValue[static_cast<unsigned char>(c)]; }

}  // namespace

// For anything else parse_candump_line reads the line, so frames and reports stay exactly its own.
bool parse_candump_usual(std::string_view line, CanFrame& f, std::string_view& interface) noexcept {
  const char* p = line.data() + 1;  // after '('
  const char* const end = line.data() + line.size();
  std::uint64_t ns = 0;
  if (candump_fixed_time(line, ns)) {
    p = line.data() + kCandumpFixedTimeLength;
  } else {
    std::uint64_t sec = 0;
    std::uint64_t frac = 0;
    const char* digits = p;
    while (p < end && static_cast<unsigned>(*p - '0') < 10) sec = sec * 10 + static_cast<unsigned>(*p++ - '0');
    if (p == digits || p - digits > 19 || p == end || *p != '.') return false;
    digits = ++p;
    while (p < end && static_cast<unsigned>(*p - '0') < 10) frac = frac * 10 + static_cast<unsigned>(*p++ - '0');
    const auto frac_digits = p - digits;
    if (frac_digits == 0 || frac_digits > 9 || end - p < 2 || p[0] != ')' || p[1] != ' ') return false;
    for (auto i = frac_digits; i < 9; ++i) frac *= 10;
    p += 2;
    ns = sec * 1'000'000'000ULL + frac;
  }
  const char* name = p;
  while (p < end && *p != ' ') ++p;
  if (p == name || end - p < 2 || p[1] == ' ') return false;
  interface = std::string_view(name, static_cast<std::size_t>(p - name));
  ++p;
  std::uint32_t id = 0;
  const char* id_start = p;
  int v = 0;
  while (p < end && (v = hex_value(*p)) >= 0) {
    id = id << 4 | static_cast<std::uint32_t>(v);
    ++p;
  }
  const auto id_digits = p - id_start;
  if (p == end || *p != '#' || (id_digits != 3 && id_digits != 8)) return false;
  ++p;
  if (id_digits == 3 ? id > CanFrame::kMaxStandardId : id > CanFrame::kMaxExtendedId) return false;
  std::uint8_t n = 0;
  while (end - p >= 2) {
    const int hi = hex_value(p[0]);
    const int lo = hex_value(p[1]);
    if (hi < 0 || lo < 0 || n == 8) return false;
    f.data[n++] = static_cast<std::uint8_t>(hi << 4 | lo);
    p += 2;
  }
  if (p != end) return false;
  f.id = id;
  f.extended = id_digits == 8;
  f.remote = false;
  f.error = false;
  f.dlc = n;
  for (std::size_t i = n; i < 8; ++i) f.data[i] = 0;
  f.timestamp_ns = ns;
  return true;
}

CandumpReader::CandumpReader(int fd, std::size_t block_bytes) : fd_(fd) { allocate(block_bytes); }

CandumpReader::CandumpReader(int fd, std::uint64_t begin, std::uint64_t end, std::size_t block_bytes)
    : fd_(fd), positional_(true), offset_(begin), end_(end) {
  allocate(block_bytes);
}

CandumpReader::CandumpReader(std::string_view text, std::size_t block_bytes) : text_(text) { allocate(block_bytes); }

CandumpReader::CandumpReader(std::istream& in, std::size_t block_bytes) : in_(&in) { allocate(block_bytes); }

void CandumpReader::allocate(std::size_t block_bytes) {
  block_ = block_bytes;
  cap_ = block_bytes + kMaxCandumpLine + 1;
  buf_.reset(new char[cap_ + kCandumpLineSlack]);  // not zeroed: only what was read is looked at
  std::memset(buf_.get() + cap_, 0, kCandumpLineSlack);
}

std::size_t CandumpReader::fill(char* dst, std::size_t n) {
  if (in_ != nullptr) {
    const auto got = static_cast<std::size_t>(in_->rdbuf()->sgetn(dst, static_cast<std::streamsize>(n)));
    offset_ += got;
    return got;
  }
  if (fd_ < 0) {
    if (n > text_.size()) n = text_.size();
    std::memcpy(dst, text_.data(), n);
    text_.remove_prefix(n);
    offset_ += n;
    return n;
  }
  if (positional_) {
    if (offset_ >= end_) return 0;
    if (n > end_ - offset_) n = static_cast<std::size_t>(end_ - offset_);
  }
  for (;;) {
    const ssize_t got = positional_ ? ::pread(fd_, dst, n, static_cast<off_t>(offset_)) : ::read(fd_, dst, n);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw std::system_error(errno, std::generic_category(), "reading the capture");
    }
    offset_ += static_cast<std::uint64_t>(got);
    return static_cast<std::size_t>(got);
  }
}

void CandumpReader::line(std::string_view text, FrameBatch& batch) {
  ++line_;
  if (text.empty() || text[0] != '(') {  // comment or blank, as canplayer does
    if (first_other_.empty() && text.find_first_not_of(" \t\r") != std::string_view::npos)
      first_other_.assign(text.substr(0, 256));
    return;
  }
  if (text.size() > kMaxCandumpLine) {
    corrupt(batch, 0, fmt::format("line longer than {} bytes", kMaxCandumpLine));
    return;
  }
  CanFrame& f = batch.frames.emplace_back();
  std::string_view name;
  if (parse_candump_usual(text, f, name)) {
    batch.interfaces.push_back(name);
    return;
  }
  batch.frames.pop_back();
  CandumpLine parsed;
  CandumpError error;
  if (parse_candump_line(text, parsed, error)) {
    batch.frames.push_back(parsed.frame);
    batch.interfaces.push_back(parsed.interface);
    return;
  }
  corrupt(batch, error.column, std::move(error.message));
}

void CandumpReader::corrupt(FrameBatch& batch, std::size_t column, std::string message) {
  FrameBatch::Corrupt& bad = batch.corrupt.emplace_back();
  bad.before = batch.frames.size();
  detail::line_error(bad.error, line_, column, std::move(message));
}

bool CandumpReader::next_batch(FrameBatch& batch, CandumpLineTaker* taker) {
  batch.clear();
  // with a taker, a batch ends at its first entry (what was taken after it would come before it)
  auto taker_stops = [&] { return taker != nullptr && (!batch.frames.empty() || !batch.corrupt.empty()); };
  for (;;) {
    char* const buf = buf_.get();
    if (skipping_) {
      // Drop the rest of an over-long line (already reported) up to and including its newline.
      const void* nl = std::memchr(buf + head_, '\n', tail_ - head_);
      if (nl == nullptr) {
        consumed_ += tail_ - head_;
        head_ = tail_;
      } else {
        const std::size_t at = static_cast<std::size_t>(static_cast<const char*>(nl) - buf);
        consumed_ += at + 1 - head_;
        head_ = at + 1;
        skipping_ = false;
      }
    }
    if (!skipping_) {
      // Every complete line in the buffer.
      for (;;) {
        if (taker_stops()) return true;
        if (taker != nullptr) {  // the batch is empty here
          std::size_t used = 0;
          line_ += taker->take_run(buf + head_, buf + tail_, used);
          consumed_ += used;
          head_ += used;
        }
        const void* nl = std::memchr(buf + head_, '\n', tail_ - head_);
        if (nl == nullptr) break;
        const std::size_t at = static_cast<std::size_t>(static_cast<const char*>(nl) - buf);
        line(std::string_view(buf + head_, at - head_), batch);
        consumed_ += at + 1 - head_;
        head_ = at + 1;
        if (batch.frames.size() >= FrameBatch::kMax) return true;
      }
      if (eof_) {
        if (head_ < tail_) {  // a last line without newline
          line(std::string_view(buf + head_, tail_ - head_), batch);
          consumed_ += tail_ - head_;
          head_ = tail_;
        }
        return !batch.frames.empty() || !batch.corrupt.empty();
      }
      if (!batch.frames.empty() || !batch.corrupt.empty()) return true;
    } else if (eof_) {
      return !batch.corrupt.empty();
    }
    // Keep the partial line, read more behind it.
    const std::size_t partial = tail_ - head_;
    if (partial > kMaxCandumpLine) {
      // A line too long to hold: report it now (a comment is just dropped), count it, skip to its end (the
      // newline that ends it is then consumed without counting the line again).
      ++line_;
      if (buf[head_] == '(') corrupt(batch, 0, fmt::format("line longer than {} bytes", kMaxCandumpLine));
      consumed_ += partial;
      head_ = tail_ = 0;
      skipping_ = true;
    } else if (head_ > 0) {
      std::memmove(buf, buf + head_, partial);
      head_ = 0;
      tail_ = partial;
    }
    const std::size_t room = cap_ - tail_;
    const std::size_t want = room < block_ ? room : block_;
    const std::size_t got = fill(buf + tail_, want);
    if (got == 0) eof_ = true;
    tail_ += got;
  }
}

std::vector<std::uint64_t> split_candump_blocks(int fd, std::uint64_t size, std::uint64_t block) {
  std::vector<std::uint64_t> starts{0};
  if (block == 0) block = 1;
  char probe[4096];
  std::uint64_t scanned_to = 0;  // every line start before this is known
  for (std::uint64_t nominal = block; nominal < size; nominal += block) {
    if (nominal < scanned_to) continue;  // inside a line already crossed
    // The first line start at or after nominal: the byte after the first '\n' at or after nominal - 1.
    std::uint64_t pos = nominal - 1;
    std::uint64_t start = size;
    while (pos < size) {
      const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(sizeof probe, size - pos));
      int error = 0;
      const std::size_t got = detail::pread_full(fd, probe, want, pos, &error);
      if (error != 0) throw std::system_error(error, std::generic_category(), "reading the capture");
      if (got == 0) break;
      const void* nl = std::memchr(probe, '\n', got);
      if (nl != nullptr) {
        start = pos + static_cast<std::uint64_t>(static_cast<const char*>(nl) - probe) + 1;
        break;
      }
      pos += static_cast<std::uint64_t>(got);
    }
    scanned_to = start;
    if (start >= size) break;
    if (start > starts.back()) starts.push_back(start);
  }
  starts.push_back(size);
  return starts;
}


}  // namespace saul::host
