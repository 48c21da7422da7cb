#include "saulproto/host/capture/blf.hpp"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>

#include "capture_io.hpp"
#include "civil_time.hpp"

namespace saul::host {
namespace {

using detail::kFdUnsupported;

using detail::load_u16;
using detail::load_u32;
using detail::load_u64;

constexpr std::array<std::uint8_t, 4> kFileSignature = {'L', 'O', 'G', 'G'};
constexpr std::array<std::uint8_t, 4> kObjectSignature = {'L', 'O', 'B', 'J'};
constexpr std::uint32_t kFileHeaderFields = 72;  // signature .. stop time: what we read of the file header
constexpr std::uint32_t kFileHeaderSize = 144;   // what Vector's tools and python-can write
constexpr std::uint32_t kMaxFileHeader = 64 * 1024;
constexpr std::uint32_t kBaseHeader = 16;       // LOBJ, header size, header version, object size, type
constexpr std::uint32_t kContainerHeader = 16;  // compression method, reserved, uncompressed size, reserved
constexpr std::uint32_t kHeaderV1 = 32;
constexpr std::uint32_t kHeaderV2 = 40;

// Object types (Vector's numbering, as python-can and Vector's BLF libraries name them).
constexpr std::uint32_t kCanMessage = 1;
constexpr std::uint32_t kCanError = 2;
constexpr std::uint32_t kLogContainer = 10;
constexpr std::uint32_t kCanErrorExt = 73;
constexpr std::uint32_t kCanMessage2 = 86;
constexpr std::uint32_t kCanFdMessage = 100;
constexpr std::uint32_t kCanFdMessage64 = 101;

constexpr std::uint16_t kStored = 0;
constexpr std::uint16_t kZlibDeflate = 2;

constexpr std::uint32_t kTimeTenMicroseconds = 1;  // object header flags
constexpr std::uint32_t kTimeNanoseconds = 2;
constexpr std::uint32_t kIdExtended = 0x8000'0000;
constexpr std::uint8_t kMsgRemote = 0x80;
constexpr std::uint8_t kFdEdl = 0x01;              // CAN_FD_MESSAGE fd flags
constexpr std::uint32_t kFd64Edl = 0x1000;         // CAN_FD_MESSAGE_64 flags
constexpr std::uint32_t kFd64Remote = 0x0010;

bool signature_at(const std::uint8_t* p, const std::array<std::uint8_t, 4>& sig) {
  return std::memcmp(p, sig.data(), sig.size()) == 0;
}

/// SYSTEMTIME (year, month, day of week, day, hour, minute, second, milliseconds) as ns since 1970, UTC; 0 when
/// it is not a date (python-can writes zeros when it has none).
std::uint64_t systemtime_to_ns(const std::uint8_t* p) {
  const unsigned year = load_u16(p, false);
  const unsigned month = load_u16(p + 2, false);
  const unsigned day = load_u16(p + 6, false);
  const unsigned hour = load_u16(p + 8, false);
  const unsigned minute = load_u16(p + 10, false);
  const unsigned second = load_u16(p + 12, false);
  const unsigned ms = load_u16(p + 14, false);
  if (year < 1970 || year > 9999 || month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 ||
      second > 60 || ms > 999)
    return 0;
  const auto days = static_cast<std::uint64_t>(detail::days_from_civil(year, month, day));
  return days * detail::kNsPerDay + ((hour * 60ULL + minute) * 60ULL + second) * detail::kNsPerSecond +
         ms * 1'000'000ULL;
}

void store_systemtime(std::uint8_t* p, std::uint64_t ns) {
  const auto days = static_cast<std::int64_t>(ns / detail::kNsPerDay);
  const detail::Civil c = detail::civil_from_days(days);
  const std::uint64_t in_day = ns % detail::kNsPerDay;
  const std::uint64_t sec = in_day / detail::kNsPerSecond;
  const std::array<std::uint64_t, 8> fields = {static_cast<std::uint64_t>(c.year), c.month,
                                               detail::weekday_from_days(days), c.day, sec / 3600, sec / 60 % 60,
                                               sec % 60, in_day / 1'000'000 % 1000};
  for (std::size_t i = 0; i < fields.size(); ++i)
    bytes::put_u16le(p + 2 * i, static_cast<std::uint16_t>(fields[i]));
}

BlfReader::Container inflate_container(std::uint64_t offset, std::vector<std::uint8_t> data, std::uint32_t declared) {
  BlfReader::Container c;
  c.offset = offset;
  c.bytes.resize(declared);
  z_stream z{};
  if (inflateInit(&z) != Z_OK) {
    c.error = "zlib: cannot start inflating";
    return c;
  }
  z.next_in = data.data();
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = c.bytes.data();
  z.avail_out = static_cast<uInt>(c.bytes.size());
  const int r = inflate(&z, Z_FINISH);
  if (r == Z_STREAM_END) {
    if (z.total_out != declared)
      c.error = fmt::format("log container inflates to {} bytes, its header says {}", z.total_out, declared);
  } else if (r == Z_BUF_ERROR && z.avail_out == 0) {
    c.error = fmt::format("log container inflates to more than the {} bytes its header says", declared);
  } else if (r == Z_BUF_ERROR) {
    c.error = fmt::format("log container's zlib data ends early ({} of {} bytes)", z.total_out, declared);
  } else {
    c.error = fmt::format("log container's zlib data is corrupt: {}", z.msg ? z.msg : "inflate failed");
  }
  inflateEnd(&z);
  if (!c.error.empty()) c.bytes.clear();
  return c;
}

}  // namespace

// ---- reader ----

BlfReader::BlfReader(std::istream& in) : in_(in) {
  std::array<std::uint8_t, kFileHeaderFields> h{};
  const std::size_t got = detail::read_counted(in_, h.data(), h.size(), offset_);
  if (got < 8 || !signature_at(h.data(), kFileSignature))
    throw CaptureOpenError("not a BLF file: it does not start with \"LOGG\"");
  const std::uint32_t header_size = load_u32(h.data() + 4, false);
  if (got < h.size() || header_size < kFileHeaderFields || header_size > kMaxFileHeader)
    throw CaptureOpenError(fmt::format("BLF file header of {} bytes is not valid", header_size));
  if (detail::skip_counted(in_, header_size - kFileHeaderFields, offset_) < header_size - kFileHeaderFields)
    throw CaptureOpenError("BLF file ends inside its header");
  start_ns_ = systemtime_to_ns(h.data() + 40);
}

BlfReader::Status BlfReader::corrupt(std::uint64_t position, Recovery recovery, std::string message) {
  error_ = detail::byte_error(position, recovery, std::move(message));
  return Status::corrupt;
}

BlfReader::Step BlfReader::bad_object(std::string message) {
  corrupt(container_offset_, Recovery::next_record, std::move(message));
  return Step::corrupt;
}

std::size_t BlfReader::read_top(std::uint8_t* dst, std::size_t n) {
  std::size_t done = 0;
  while (done < n && !look_.empty()) {
    dst[done++] = look_.front();
    look_.erase(look_.begin());
  }
  if (done < n) done += detail::read_counted(in_, dst + done, n - done, offset_);
  return done;
}

/// Skips to the next "LOBJ" in the file, one byte at a time (constant memory); returns the bytes skipped.
std::uint64_t BlfReader::resync_top() {
  std::array<std::uint8_t, 4> window{};
  std::size_t have = 0;
  std::uint64_t skipped = 0;
  for (;;) {
    std::uint8_t b = 0;
    if (read_top(&b, 1) == 0) {
      top_ended_ = true;
      return skipped + have;
    }
    if (have < window.size()) {
      window[have++] = b;
    } else {
      window = {window[1], window[2], window[3], b};
      ++skipped;
    }
    if (have == window.size() && window == kObjectSignature) {
      look_.insert(look_.begin(), window.begin(), window.end());
      return skipped;
    }
  }
}

/// The next top-level object: a log container inflated, another object's bytes, or a problem (a Container with an
/// error, in file order). nullopt at the end of the file.
std::optional<BlfReader::Container> BlfReader::read_top_level() {
  if (top_ended_) return std::nullopt;
  const std::uint64_t start = offset_ - look_.size();
  std::array<std::uint8_t, kBaseHeader> h{};
  const std::size_t got = read_top(h.data(), h.size());
  Container bad;
  bad.offset = start;
  bad.starts_fresh = true;
  if (got == 0) {
    top_ended_ = true;
    return std::nullopt;
  }
  if (got < h.size()) {
    top_ended_ = true;
    bad.error = fmt::format("file ends inside an object header ({} of 16 bytes)", got);
    return bad;
  }
  const std::uint32_t header_size = load_u16(h.data() + 4, false);
  const std::uint32_t size = load_u32(h.data() + 8, false);
  const std::uint32_t type = load_u32(h.data() + 12, false);
  const bool container = type == kLogContainer;
  std::string problem;
  if (!signature_at(h.data(), kObjectSignature)) {
    problem = "no object signature \"LOBJ\"";
  } else if (size < kBaseHeader || header_size < kBaseHeader || header_size > size ||
             (container && size < header_size + kContainerHeader)) {
    problem = fmt::format("object size {} (header {}) is not valid", size, header_size);
  } else if (size > (container ? kMaxContainerBytes + header_size + kContainerHeader : kMaxObjectBytes)) {
    problem = fmt::format("object of {} bytes is longer than any this reader accepts", size);
  }
  if (!problem.empty()) {
    look_.insert(look_.begin(), h.begin() + 1, h.end());
    const std::uint64_t skipped = 1 + resync_top();
    bad.error = fmt::format("{}: {} bytes skipped to the next object", problem, skipped);
    return bad;
  }
  std::vector<std::uint8_t> body(size - kBaseHeader);
  const std::size_t have = read_top(body.data(), body.size());
  if (have < body.size()) {
    top_ended_ = true;
    bad.error = fmt::format("file ends inside an object ({} of {} bytes)", have + kBaseHeader, size);
    return bad;
  }
  std::array<std::uint8_t, 3> padding{};
  read_top(padding.data(), size % 4);  // the end of the file may come instead
  if (!container) {  // an object outside any container: parsed like one
    Container c;
    c.offset = start;
    c.bytes.assign(h.begin(), h.end());
    c.bytes.insert(c.bytes.end(), body.begin(), body.end());
    c.bytes.insert(c.bytes.end(), padding.begin(), padding.begin() + size % 4);
    return c;
  }
  const std::uint8_t* ch = body.data() + (header_size - kBaseHeader);
  const std::uint16_t method = load_u16(ch, false);
  const std::uint32_t declared = load_u32(ch + 8, false);
  const std::size_t data_at = header_size - kBaseHeader + kContainerHeader;
  if (method == kStored) {
    Container c;
    c.offset = start;
    c.bytes.assign(body.begin() + static_cast<std::ptrdiff_t>(data_at), body.end());
    return c;
  }
  if (method != kZlibDeflate) {
    bad.starts_fresh = false;
    bad.error = fmt::format("log container compressed with method {}, which is not zlib (2)", method);
    return bad;
  }
  if (declared > kMaxContainerBytes) {
    bad.error = fmt::format("log container declares {} uncompressed bytes, more than this reader accepts", declared);
    return bad;
  }
  body.erase(body.begin(), body.begin() + static_cast<std::ptrdiff_t>(data_at));
  return inflate_container(start, std::move(body), declared);
}

BlfReader::Load BlfReader::load_container() {
  std::optional<Container> next = read_top_level();
  if (!next) return Load::none;
  Container& c = *next;
  if (!c.error.empty()) {
    // The objects of this container are lost; one that began before it cannot be finished.
    buf_.clear();
    pos_ = 0;
    corrupt(c.offset, Recovery::next_block, std::move(c.error));
    return Load::corrupt;
  }
  buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(pos_));
  pos_ = 0;
  if (c.starts_fresh) buf_.clear();
  if (buf_.empty()) buf_ = std::move(c.bytes);
  else buf_.insert(buf_.end(), c.bytes.begin(), c.bytes.end());
  container_offset_ = c.offset;
  return Load::loaded;
}

BlfReader::Step BlfReader::object() {
  const std::size_t avail = buf_.size() - pos_;
  if (avail < kBaseHeader) return Step::need_more;
  const std::uint8_t* p = buf_.data() + pos_;
  if (!signature_at(p, kObjectSignature)) {
    // Padding (zero bytes) may come before the next object; anything else is garbage to skip to the next "LOBJ".
    const auto begin = buf_.begin() + static_cast<std::ptrdiff_t>(pos_);
    const auto found = std::search(begin, buf_.end(), kObjectSignature.begin(), kObjectSignature.end());
    const auto gap = static_cast<std::size_t>(found - begin);
    if (found != buf_.end() && gap < 8 && std::all_of(begin, found, [](std::uint8_t b) { return b == 0; })) {
      pos_ += gap;
      return Step::skipped;
    }
    const std::size_t skip = found != buf_.end() ? gap : avail - 3;  // 3 bytes may start a signature
    pos_ += skip;
    return bad_object(fmt::format("{} bytes without an object signature \"LOBJ\" in the log container skipped", skip));
  }
  const std::uint32_t header_size = load_u16(p + 4, false);
  const std::uint32_t version = load_u16(p + 6, false);
  const std::uint32_t size = load_u32(p + 8, false);
  const std::uint32_t type = load_u32(p + 12, false);
  if (size < kBaseHeader || header_size < kBaseHeader || header_size > size || size > kMaxObjectBytes) {
    pos_ += kObjectSignature.size();  // look for the next object after this signature
    return bad_object(fmt::format("object size {} (header {}) is not valid", size, header_size));
  }
  if (avail < size) return Step::need_more;
  pos_ += size;
  if ((version != 1 || header_size < kHeaderV1) && (version != 2 || header_size < kHeaderV2)) {
    ++skipped_objects_;  // a header this reader does not know
    return Step::skipped;
  }
  const std::uint32_t flags = load_u32(p + 16, false);
  const std::uint64_t stamp = load_u64(p + 24, false);
  std::uint64_t ns = stamp;
  if (flags == kTimeTenMicroseconds) ns = stamp > UINT64_MAX / 10'000 ? UINT64_MAX : stamp * 10'000;
  // otherwise kTimeNanoseconds (2): python-can and Vector's tools write both
  ns = ns > UINT64_MAX - start_ns_ ? UINT64_MAX : ns + start_ns_;
  return can_object(type, p + header_size, size - header_size, ns);
}

BlfReader::Step BlfReader::can_object(std::uint32_t type, const std::uint8_t* body, std::uint32_t length,
                                      std::uint64_t time_ns) {
  auto too_short = [&](std::uint32_t need) {
    return bad_object(fmt::format("object of type {} has {} bytes after its header, {} needed", type, length, need));
  };
  CanFrame f;
  f.timestamp_ns = time_ns;
  unsigned channel = 0;
  std::uint32_t raw_id = 0;
  unsigned dlc = 0;
  bool remote = false;
  const std::uint8_t* data = nullptr;
  switch (type) {
    case kCanMessage:
    case kCanMessage2:
    case kCanFdMessage: {  // the same fields; CAN_FD_MESSAGE's data after 12 more bytes (its FD flags among them)
      const bool fd = type == kCanFdMessage;
      if (length < (fd ? 20U : 16U)) return too_short(fd ? 20 : 16);
      if (fd && (body[13] & kFdEdl) != 0) break;
      channel = load_u16(body, false);
      remote = (body[2] & kMsgRemote) != 0;
      dlc = body[3];
      raw_id = load_u32(body + 4, false);
      data = body + (fd ? 20 : 8);
      if (fd && !remote && length < 20 + std::min(dlc, 8U)) return too_short(20 + std::min(dlc, 8U));
      break;
    }
    case kCanError:
    case kCanErrorExt:
      if (length < 4) return too_short(4);
      frame_ = detail::bus_error_frame();
      frame_.timestamp_ns = time_ns;
      name_ = detail::channel_name(std::max(load_u16(body, false), std::uint16_t{1}));
      return Step::frame;
    case kCanFdMessage64: {
      if (length < 40) return too_short(40);
      const std::uint32_t flags = load_u32(body + 12, false);
      const unsigned valid = body[2];
      if (length < 40 + valid) return too_short(40 + valid);
      if ((flags & kFd64Edl) != 0) break;
      channel = body[0];
      dlc = body[1];
      remote = (flags & kFd64Remote) != 0;
      raw_id = load_u32(body + 4, false);
      data = body + 40;
      if (!remote && valid < std::min(dlc, 8U)) return too_short(40 + std::min(dlc, 8U));
      break;
    }
    default:
      ++skipped_objects_;
      return Step::skipped;
  }
  if (data == nullptr) return bad_object(std::string(kFdUnsupported));
  if (dlc > 15) return bad_object(fmt::format("DLC {} is above 15", dlc));
  f.extended = (raw_id & kIdExtended) != 0;
  f.id = raw_id & CanFrame::kMaxExtendedId;
  if (!f.extended && f.id > CanFrame::kMaxStandardId)
    return bad_object(fmt::format("11-bit id 0x{:X} above 7FF (extended flag not set)", f.id));
  f.remote = remote;
  f.dlc = static_cast<std::uint8_t>(std::min(dlc, 8U));  // classic CAN: a DLC of 9..15 still means 8 bytes
  if (!remote) std::copy_n(data, f.dlc, f.data.begin());
  frame_ = f;
  name_ = detail::channel_name(std::max(channel, 1U));
  return Step::frame;
}

BlfReader::Status BlfReader::next() {
  for (;;) {
    if (ended_) return Status::end;
    switch (object()) {
      case Step::frame: return Status::frame;
      case Step::corrupt: return Status::corrupt;
      case Step::skipped: break;
      case Step::need_more:
        switch (load_container()) {
          case Load::loaded: break;
          case Load::corrupt: return Status::corrupt;
          case Load::none: {
            ended_ = true;
            const std::size_t left = buf_.size() - pos_;
            const bool padding = std::all_of(buf_.begin() + static_cast<std::ptrdiff_t>(pos_), buf_.end(),
                                             [](std::uint8_t b) { return b == 0; });
            if (left > 0 && !padding)
              return corrupt(container_offset_, Recovery::stop,
                             fmt::format("file ends inside an object ({} bytes of it)", left));
            return Status::end;
          }
        }
        break;
    }
  }
}

// ---- writer ----

void BlfWriter::write_header(std::uint64_t file_size) {
  std::array<std::uint8_t, kFileHeaderSize> h{};
  std::copy(kFileSignature.begin(), kFileSignature.end(), h.begin());
  bytes::put_u32le(h.data() + 4, kFileHeaderSize);
  // application 5 and format version 2.6.8.1, as python-can writes them (files Vector's tools open)
  const std::array<std::uint8_t, 8> versions = {5, 0, 0, 0, 2, 6, 8, 1};
  std::copy(versions.begin(), versions.end(), h.begin() + 8);
  bytes::put_u32le(h.data() + 16, static_cast<std::uint32_t>(file_size));
  bytes::put_u32le(h.data() + 20, static_cast<std::uint32_t>(file_size >> 32));
  const std::uint64_t uncompressed = kFileHeaderSize + uncompressed_bytes_;
  bytes::put_u32le(h.data() + 24, static_cast<std::uint32_t>(uncompressed));
  bytes::put_u32le(h.data() + 28, static_cast<std::uint32_t>(uncompressed >> 32));
  bytes::put_u32le(h.data() + 32, objects_);
  if (start_ns_) {
    store_systemtime(h.data() + 40, *start_ns_);
    store_systemtime(h.data() + 56, std::max(stop_ns_, *start_ns_));
  }
  detail::write_bytes(out_, h.data(), h.size());
  check_written();
}

void BlfWriter::write_container() {
  if (!header_written_) {
    write_header(0);
    header_written_ = true;
    file_bytes_ = kFileHeaderSize;
  }
  if (buffer_.empty()) return;
  const std::size_t chunk = std::min(buffer_.size(), kContainerBytes);
  uLongf packed_size = compressBound(static_cast<uLong>(chunk));
  std::vector<std::uint8_t> packed(packed_size);
  if (compress2(packed.data(), &packed_size, buffer_.data(), static_cast<uLong>(chunk), 6) != Z_OK)
    throw std::runtime_error("BLF: zlib compression failed");
  const auto size = static_cast<std::uint32_t>(kBaseHeader + kContainerHeader + packed_size);
  std::array<std::uint8_t, kBaseHeader + kContainerHeader> h{};
  std::copy(kObjectSignature.begin(), kObjectSignature.end(), h.begin());
  bytes::put_u16le(h.data() + 4, kBaseHeader);
  bytes::put_u16le(h.data() + 6, 1);
  bytes::put_u32le(h.data() + 8, size);
  bytes::put_u32le(h.data() + 12, kLogContainer);
  bytes::put_u16le(h.data() + 16, kZlibDeflate);
  bytes::put_u32le(h.data() + 24, static_cast<std::uint32_t>(chunk));
  detail::write_bytes(out_, h.data(), h.size());
  detail::write_bytes(out_, packed.data(), packed_size);
  const std::array<std::uint8_t, 3> padding{};
  detail::write_bytes(out_, padding.data(), size % 4);
  check_written();
  file_bytes_ += size + size % 4;
  uncompressed_bytes_ += kBaseHeader + kContainerHeader + chunk;
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(chunk));
}

void BlfWriter::put(const CanFrame& frame, std::string_view interface) {
  const std::size_t index = detail::channel_index(channels_, interface, 0xFFFF, "BLF");
  const std::uint64_t ns = frame.timestamp_ns.value_or(0);
  if (!start_ns_) start_ns_ = ns - ns % 1'000'000;  // SYSTEMTIME holds milliseconds
  stop_ns_ = std::max(stop_ns_, ns);
  const std::uint64_t rel = ns > *start_ns_ ? ns - *start_ns_ : 0;

  const std::uint32_t body = frame.error ? 32 : 16;
  std::array<std::uint8_t, kHeaderV1 + 32> o{};
  std::copy(kObjectSignature.begin(), kObjectSignature.end(), o.begin());
  bytes::put_u16le(o.data() + 4, kHeaderV1);
  bytes::put_u16le(o.data() + 6, 1);
  bytes::put_u32le(o.data() + 8, kHeaderV1 + body);
  bytes::put_u32le(o.data() + 12, frame.error ? kCanErrorExt : kCanMessage);
  bytes::put_u32le(o.data() + 16, kTimeNanoseconds);
  bytes::put_u32le(o.data() + 24, static_cast<std::uint32_t>(rel));
  bytes::put_u32le(o.data() + 28, static_cast<std::uint32_t>(rel >> 32));
  std::uint8_t* b = o.data() + kHeaderV1;
  bytes::put_u16le(b, static_cast<std::uint16_t>(index + 1));
  if (!frame.error) {  // CAN_ERROR_EXT stays all zero but its channel: no SocketCAN class fits its fields
    b[2] = frame.remote ? kMsgRemote : 0;
    b[3] = frame.dlc;
    bytes::put_u32le(b + 4, frame.id | (frame.extended ? kIdExtended : 0));
    const auto payload = frame.payload();
    std::copy(payload.begin(), payload.end(), b + 8);
  }
  buffer_.insert(buffer_.end(), o.begin(), o.begin() + kHeaderV1 + body);  // sizes are multiples of 4: no padding
  ++objects_;
  if (buffer_.size() >= kContainerBytes) write_container();
}

void BlfWriter::flush() {
  if (!closed() && !buffer_.empty()) write_container();
  StreamCaptureWriter::flush();
}

void BlfWriter::finish() {
  while (!buffer_.empty()) write_container();
  if (!header_written_) write_container();  // an empty file still gets its header
  out_.flush();
  check_written();
  const auto end = out_.tellp();
  if (end != std::ostream::pos_type(-1)) {  // a file: put the final sizes, count and stop time in the header
    out_.seekp(0);
    if (out_) {
      write_header(static_cast<std::uint64_t>(end));
      out_.seekp(end);
    } else {
      out_.clear();  // the stream cannot seek after all: the first header stays
    }
  }
}

}  // namespace saul::host
