#include "saulproto/host/capture/candump_scan.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <bit>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/compressed.hpp"
#include "../threads/read_ahead.hpp"

namespace saul::host {
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

CandumpScanner::CandumpScanner(int fd, std::size_t block_bytes)
    : fd_(fd), positional_(false), cap_(block_bytes + kMaxCandumpLine + 1), block_(block_bytes) {
  allocate();
}

CandumpScanner::CandumpScanner(int fd, std::uint64_t begin, std::uint64_t end, std::size_t block_bytes)
    : fd_(fd), positional_(true), offset_(begin), end_(end), cap_(block_bytes + kMaxCandumpLine + 1),
      block_(block_bytes) {
  allocate();
}

CandumpScanner::~CandumpScanner() = default;

void CandumpScanner::allocate() {
  buf_.reset(new char[cap_ + kCandumpLineSlack]);  // not zeroed: only what was read is looked at
  std::memset(buf_.get() + cap_, 0, kCandumpLineSlack);
}

CandumpScanner::CandumpScanner(std::string_view text, std::size_t block_bytes)
    : fd_(-1), positional_(false), text_(text), cap_(block_bytes + kMaxCandumpLine + 1), block_(block_bytes) {
  allocate();
}

std::size_t CandumpScanner::fill(char* dst, std::size_t n) {
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

void CandumpScanner::line(std::string_view text, FrameBatch& batch, CandumpLineTaker* taker) {
  ++line_;
  if (text.empty() || text[0] != '(') {  // comment or blank, as canplayer (and CandumpReader) does
    if (first_other_.empty() && text.find_first_not_of(" \t\r") != std::string_view::npos)
      first_other_.assign(text.substr(0, 256));
    return;
  }
  if (text.size() > kMaxCandumpLine) {
    too_long(batch);
    return;
  }
  if (taker != nullptr && taker->take(text)) return;
  CanFrame& f = batch.frames.emplace_back();
  std::string_view name;
  if (parse_candump_usual(text, f, name)) {
    batch.interfaces.push_back(name);
    return;
  }
  batch.frames.pop_back();
  CandumpLine parsed;
  FrameBatch::Corrupt bad;
  if (parse_candump_line(text, parsed, bad.error)) {
    batch.frames.push_back(parsed.frame);
    batch.interfaces.push_back(parsed.interface);
    return;
  }
  bad.before = batch.frames.size();
  bad.error.kind = PositionKind::line;
  bad.error.position = line_;
  bad.error.recovery = Recovery::next_line;
  batch.corrupt.push_back(std::move(bad));
}

void CandumpScanner::too_long(FrameBatch& batch) {
  FrameBatch::Corrupt bad;
  bad.before = batch.frames.size();
  bad.error.column = 0;
  bad.error.message = fmt::format("line longer than {} bytes", kMaxCandumpLine);
  bad.error.kind = PositionKind::line;
  bad.error.position = line_;
  bad.error.recovery = Recovery::next_line;
  batch.corrupt.push_back(std::move(bad));
}

bool CandumpScanner::next_batch(FrameBatch& batch, CandumpLineTaker* taker) {
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
        line(std::string_view(buf + head_, at - head_), batch, taker);
        consumed_ += at + 1 - head_;
        head_ = at + 1;
        if (batch.frames.size() >= kMaxBatch) return true;
      }
      if (eof_) {
        if (head_ < tail_) {  // a last line without newline
          line(std::string_view(buf + head_, tail_ - head_), batch, taker);
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
      if (buf[head_] == '(') too_long(batch);
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

namespace {

/// A batch read ahead, with its interfaces copied out of the scanner's buffer (which the next read reuses).
struct AheadSlot {
  FrameBatch batch;
  std::string names;
  std::uint64_t bytes = 0;
  void own() {
    std::size_t total = 0;
    for (auto v : batch.interfaces) total += v.size();
    names.clear();
    names.reserve(total);  // no reallocation below: the views stay valid
    std::string_view previous_from, previous_to;
    for (auto& v : batch.interfaces) {
      if (v == previous_from) {  // the same interface as the frame before (nearly always): one copy
        v = previous_to;
        continue;
      }
      previous_from = v;
      const std::size_t at = names.size();
      names.append(v);
      v = previous_to = std::string_view(names.data() + at, v.size());
    }
  }
};

}  // namespace

void scan_candump(int fd, std::uint64_t begin, std::uint64_t end, bool ahead, const FrameBatchSink& on_batch,
                  const FrameBatchPrepare& prepare) {
  if (!ahead) {
    CandumpScanner scanner(fd, begin, end);
    FrameBatch batch;
    while (scanner.next_batch(batch)) {
      if (prepare) prepare(batch, 0);
      on_batch(batch, scanner.bytes_read(), 0);
    }
    return;
  }
  std::array<AheadSlot, kAheadBatches> slots;
  CandumpScanner scanner(fd, begin, end);
  read_ahead(
      slots.size(),
      [&](std::size_t k) {
        AheadSlot& slot = slots[k];
        if (!scanner.next_batch(slot.batch)) return false;
        slot.own();
        slot.bytes = scanner.bytes_read();
        if (prepare) prepare(slot.batch, k);
        return true;
      },
      [&](std::size_t k) { on_batch(slots[k].batch, slots[k].bytes, k); });
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
      const ssize_t got = ::pread(fd, probe, want, static_cast<off_t>(pos));
      if (got < 0) {
        if (errno == EINTR) continue;
        throw std::system_error(errno, std::generic_category(), "reading the capture");
      }
      if (got == 0) break;
      const void* nl = std::memchr(probe, '\n', static_cast<std::size_t>(got));
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

std::unique_ptr<CandumpFile> CandumpFile::open(const std::string& path) {
  const int fd = ::open(capture_open_name(path), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return nullptr;
  std::unique_ptr<CandumpFile> file(new CandumpFile(fd, 0));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return nullptr;
  file->size_ = static_cast<std::uint64_t>(st.st_size);
  std::uint8_t head[4096];
  const ssize_t got = ::pread(fd, head, sizeof head, 0);
  if (got <= 0) return nullptr;
  const std::span<const std::uint8_t> first(head, static_cast<std::size_t>(got));
  if (detect_compression(first) != Compression::none || detect_capture_format(first) != CaptureFormat::candump)
    return nullptr;
  return file;
}

CandumpFile::~CandumpFile() { ::close(fd_); }

}  // namespace saul::host
