#include "saulproto/host/capture/capture.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <streambuf>
#include <string_view>
#include <vector>

#include "saulproto/host/capture/asc.hpp"
#include "saulproto/host/capture/blf.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/compressed.hpp"
#include "saulproto/host/capture/csv_log.hpp"
#include "saulproto/host/capture/gvret_csv.hpp"
#include "saulproto/host/capture/interface_index.hpp"
#include "saulproto/host/capture/pcap.hpp"
#include "saulproto/host/capture/mcap.hpp"
#include "saulproto/host/capture/pcapng.hpp"
#include "saulproto/host/capture/recorder.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/capture/trc.hpp"
#include "../util.hpp"
#include "capture_io.hpp"
#include "read_path.hpp"
#include "text_fields.hpp"

namespace saul::host {
namespace {

constexpr std::size_t kHeadBytes = 4096;

/// Serves the bytes already read for format detection, then the rest of the file: detection never seeks, so
/// pipes and process substitutions work.
class ReplayBuf final : public std::streambuf {
 public:
  ReplayBuf(std::streambuf& source, std::string head) : source_(source), head_(std::move(head)) {
    setg(head_.data(), head_.data(), head_.data() + head_.size());
    delivered_ = head_.size();
  }
  /// Bytes taken from the file so far (what the reader consumed, plus at most one buffer).
  [[nodiscard]] std::uint64_t delivered() const { return delivered_; }

 protected:
  int_type underflow() override {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    const std::streamsize n = source_.sgetn(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    if (n <= 0) return traits_type::eof();
    delivered_ += static_cast<std::uint64_t>(n);
    setg(buffer_.data(), buffer_.data(), buffer_.data() + n);
    return traits_type::to_int_type(*gptr());
  }

 private:
  std::streambuf& source_;
  std::string head_;
  std::array<char, 64 * 1024> buffer_;  // not zeroed (its pages are touched only when read into): see underflow()
  std::uint64_t delivered_ = 0;
};

struct FileSource {
  std::filebuf file;
  std::unique_ptr<ReplayBuf> raw;                 ///< compressed files: the file's bytes, head first
  std::unique_ptr<DecompressingBuf> inflater;     ///< compressed files: what they hold
  std::unique_ptr<ReplayBuf> replay;
  std::istream stream{nullptr};
  std::optional<std::uint64_t> size;  ///< regular files only
  bool reported = false;              ///< the decompression error went out as a corrupt record

  /// Bytes of the file read so far (compressed bytes for a compressed file, to compare with its size).
  [[nodiscard]] std::uint64_t bytes_read() const { return inflater ? inflater->compressed_bytes() : replay->delivered(); }
  /// After the reader's end: a decompression error, once, as a corrupt record that stops the reading.
  bool take_error(CaptureError& error) {
    const auto e = decompression_error();
    if (reported || !e) return false;
    reported = true;
    error = *e;
    return true;
  }
  /// What stopped the decompressor (nullopt: nothing), as a corrupt record at the compressed byte it reached.
  [[nodiscard]] std::optional<CaptureError> decompression_error() const {
    if (!inflater || inflater->error().empty()) return std::nullopt;
    return detail::byte_error(inflater->compressed_bytes(), Recovery::stop, inflater->error());
  }
};

/// A reader that owns its file; the format reader (CAN or serial) works on the file's stream. A decompression error
/// comes after the reader's end, once, as a corrupt record.
template <class Reader>
class FileOwned : public Reader {
 public:
  FileOwned(std::unique_ptr<FileSource> source, std::unique_ptr<Reader> inner)
      : source_(std::move(source)), inner_(std::move(inner)) {}
  [[nodiscard]] CaptureFormat format() const override { return inner_->format(); }
  [[nodiscard]] std::uint64_t bytes_read() const override { return source_->bytes_read(); }
  [[nodiscard]] std::optional<std::uint64_t> bytes_total() const override { return source_->size; }

 protected:
  std::unique_ptr<FileSource> source_;  // declared first: destroyed after the reader of its stream
  std::unique_ptr<Reader> inner_;
};

class FileReader final : public FileOwned<CaptureReader> {
 public:
  using FileOwned::FileOwned;
  bool next_batch(FrameBatch& batch) override {
    started_ = true;
    if (inner_->next_batch(batch)) return true;
    CaptureError error;
    if (!source_->take_error(error)) return false;
    batch.corrupt.push_back({0, std::move(error)});  // the decompressor stopped: one corrupt record at its end
    return true;
  }
  /// The file, for take_capture_text(): only before the first next_batch() (the format reader may buffer what it
  /// read). This reader is not to be used afterwards.
  std::unique_ptr<FileSource> release_source() {
    if (started_) return nullptr;
    inner_.reset();  // it refers to the source's stream
    return std::move(source_);
  }

 private:
  bool started_ = false;
};

class FileSerialReader final : public FileOwned<SerialCaptureReader> {
 public:
  using FileOwned::FileOwned;
  Status next() override {
    const Status st = inner_->next();
    own_error_ = st == Status::end && source_->take_error(error_);
    return own_error_ ? Status::corrupt : st;
  }
  [[nodiscard]] const CaptureError& error() const override { return own_error_ ? error_ : inner_->error(); }
  [[nodiscard]] const SerialChunk& chunk() const override { return inner_->chunk(); }

 private:
  CaptureError error_;
  bool own_error_ = false;
};

bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// f(line) of `text`'s lines (without their '\n') in order up to the first that gives a value, which it returns.
template <class F>
auto first_line_where(std::string_view text, const F& f) -> decltype(f(text)) {
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    if (auto found = f(text.substr(pos, end - pos))) return found;
    pos = end + 1;
  }
  return {};
}

/// "uart-1: ..." (a sigrok-cli decoder instance) or "START-END NAME: ..." (sample numbers first).
bool looks_like_sigrok_annotation(std::string_view line) {
  std::size_t i = 0;
  if (!line.empty() && is_digit(line[0])) {
    while (i < line.size() && is_digit(line[i])) ++i;
    if (i >= line.size() || line[i] != '-') return false;
    const std::size_t start = ++i;
    while (i < line.size() && is_digit(line[i])) ++i;
    if (i == start || i >= line.size() || line[i] != ' ') return false;
    ++i;
    const std::size_t colon = line.find(':', i);
    if (colon == std::string_view::npos || colon == i) return false;
    const std::string_view name = line.substr(i, colon - i);
    return name.find(' ') == std::string_view::npos && colon + 1 < line.size() && line[colon + 1] == ' ';
  }
  while (i < line.size() && (std::isalnum(static_cast<unsigned char>(line[i])) || line[i] == '_')) ++i;
  if (i == 0 || i >= line.size() || line[i] != '-') return false;
  const std::size_t digits = ++i;
  while (i < line.size() && is_digit(line[i])) ++i;
  return i > digits && i + 1 < line.size() && line[i] == ':' && line[i + 1] == ' ';
}

/// A PCAN message line of a version 1 trace: "     1)      1841.0  Rx ...": a number, ')', white space.
bool looks_like_trc_message(std::string_view line) {
  std::size_t i = 0;
  while (i < line.size() && is_digit(line[i])) ++i;
  return i > 0 && i + 1 < line.size() && line[i] == ')' && (line[i + 1] == ' ' || line[i + 1] == '\t');
}

/// A candump line has '#' in its third word; our serial log has the protocol name there.
CaptureFormat candump_or_serial(std::string_view line) {
  std::size_t pos = 0;
  for (int word = 0; word < 2; ++word) {
    pos = line.find(' ', pos);
    if (pos == std::string_view::npos) return CaptureFormat::candump;
    while (pos < line.size() && line[pos] == ' ') ++pos;
  }
  std::size_t end = line.find(' ', pos);
  if (end == std::string_view::npos) end = line.size();
  const std::string_view third = line.substr(pos, end - pos);
  if (third.find('#') != std::string_view::npos || third.empty()) return CaptureFormat::candump;
  return CaptureFormat::serial;
}

/// Reads up to kHeadBytes from a stream buffer, for detection (the ReplayBuf hands them out again).
std::string read_head(std::streambuf& source) {
  std::string head(kHeadBytes, '\0');
  head.resize(detail::read_some(source, head.data(), head.size()));
  return head;
}

std::span<const std::uint8_t> head_bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

/// A line of candump's default output (no -L): "  can0  400   [7]  96 00 ..." (with -t, a "(time)" first).
bool looks_like_candump_default(std::string_view line) {
  std::vector<std::pair<std::size_t, std::string_view>> words;
  detail::split_tokens(line, words);
  if (!words.empty() && words[0].second.starts_with('(')) words.erase(words.begin());
  if (words.size() < 3) return false;
  const auto hex = [](std::string_view w) {
    return !w.empty() && w.find_first_not_of("0123456789abcdefABCDEF") == std::string_view::npos;
  };
  const std::string_view id = words[1].second, dlc = words[2].second;
  return (id.size() == 3 || id.size() == 8) && hex(id) && dlc.size() >= 3 && dlc.front() == '[' &&
         dlc.back() == ']' && is_digit(dlc[1]);
}

/// Bytes that no text file has: NUL, or control characters (other than tab, CR, LF, FF) in more than 1 of 20.
bool looks_binary(std::string_view head) {
  std::size_t control = 0;
  for (const char c : head) {
    const auto u = static_cast<unsigned char>(c);
    if (u == 0) return true;
    if ((u < 0x20 && u != '\t' && u != '\n' && u != '\r' && u != '\f') || u == 0x7F) ++control;
  }
  return control * 20 > head.size();
}

/// What a file that is no capture looks like, for the message that refuses it.
std::string describe_other_text(std::string_view head) {
  if (head.empty()) return "empty: not one byte";  // (an empty pipe, /dev/null: not "a text file of blank lines")
  if (looks_binary(head)) {
    std::string first;
    for (std::size_t i = 0; i < std::min<std::size_t>(head.size(), 8); ++i)
      first += fmt::format("{}{:02X}", i ? " " : "", static_cast<unsigned char>(head[i]));
    return fmt::format("binary data of no format saulctl knows, starting {}", first);
  }
  if (head.find("***BUSMASTER") != std::string_view::npos) return "a BusMaster log";
  const auto first = first_line_where(head, [](std::string_view line) -> std::optional<std::string> {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
    if (line.empty()) return std::nullopt;
    if (looks_like_candump_default(line))
      return "candump's default output, which has no timestamps and is no log; record with 'candump -L can0 > "
             "run.log' instead";
    std::string shown;
    for (char c : line.substr(0, 60)) shown += (c >= 0x20 && c < 0x7F) ? c : '?';
    return fmt::format("a text file whose first line is '{}{}'", shown, line.size() > 60 ? "..." : "");
  });
  return first.value_or("a text file of blank lines");
}

/// True when some line of `head` starts with '(' and a digit, as candump lines do.
bool has_candump_line(std::string_view head) {
  return first_line_where(head, [](std::string_view line) {
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
    return line.size() >= 2 && line[0] == '(' && is_digit(line[1]);
  });
}

/// Opens a file and works out its format from its first bytes (or `format`, or the extension); a gzip or zstd
/// file is opened through a decompressor and its content decides.
std::unique_ptr<FileSource> open_source(const std::string& path, std::optional<CaptureFormat>& format) {
  auto source = std::make_unique<FileSource>();
  const char* const name = capture_open_name(path);  // "-": standard input
  std::error_code dir_ec;
  if (std::filesystem::is_directory(name, dir_ec))
    throw CaptureOpenError(fmt::format("{}: is a directory, not a capture file (name the files in it, e.g. {}/*.log)",
                                       path, path));
  if (!source->file.open(name, std::ios::in | std::ios::binary))
    throw CaptureOpenError(fmt::format("cannot open '{}': {} (check the path)", path, std::strerror(errno)));
  std::string head = read_head(source->file);
  const Compression compression = detect_compression(head_bytes(head));
  std::streambuf* content = &source->file;
  if (compression != Compression::none) {
    source->raw = std::make_unique<ReplayBuf>(source->file, std::move(head));
    source->inflater = make_decompressing_buf(*source->raw, compression);
    content = source->inflater.get();
    head = read_head(*content);
    if (head.empty() && !source->inflater->error().empty())
      throw CaptureOpenError(fmt::format("'{}' ({}): {}", path, to_string(compression), source->inflater->error()));
  }
  const bool forced = format.has_value();
  if (!format) format = detect_capture_format(head_bytes(head));
  const std::string_view inner_name = strip_compression_extension(path);
  const bool by_extension = !format;
  if (!format) format = capture_format_from_extension(inner_name);
  if (!format)
    throw CaptureOpenError(fmt::format(
        "{}: not a capture ({}{}): cannot tell the format of its content, which is not pcap, pcapng, candump -L, "
        "ASC, BLF, TRC, python-can or SavvyCAN CSV, a serial log or a sigrok/PulseView UART export, nor of its "
        "extension, none of .pcap .pcapng .log .asc .blf .trc .csv .serial (--input-format names one)",
        path, compression != Compression::none ? fmt::format("{}-compressed ", to_string(compression)) : "",
        describe_other_text(head)));
  if (!forced && by_extension && *format == CaptureFormat::candump && !head.empty() && !has_candump_line(head))
    throw CaptureOpenError(fmt::format(
        "{}: not a capture (it is not a candump log: it is {}); none of its first lines is a candump -L line "
        "\"(time) can0 123#...\"; saulctl reads candump -L, pcap, pcapng, ASC, BLF, TRC and CSV logs "
        "(--input-format candump reads it anyway)",
        path, describe_other_text(head)));
  source->replay = std::make_unique<ReplayBuf>(*content, std::move(head));
  source->stream.rdbuf(source->replay.get());
  std::error_code ec;
  if (std::filesystem::is_regular_file(name, ec)) {
    const auto size = std::filesystem::file_size(name, ec);
    if (!ec) source->size = size;
  }
  return source;
}

}  // namespace

std::string describe_non_capture(std::string_view head) { return describe_other_text(head); }

void FrameBatch::own() {
  std::string text;
  std::vector<std::size_t> at(interfaces.size());
  for (std::size_t i = 0; i < interfaces.size(); ++i) {
    if (i == 0 || interfaces[i] != interfaces[i - 1]) {  // the same interface as the frame before (nearly always): one copy
      at[i] = text.size();
      text.append(interfaces[i]);
    } else {
      at[i] = at[i - 1];
    }
  }
  names = std::move(text);  // the views are made after the move (a short string moves its bytes)
  for (std::size_t i = 0; i < interfaces.size(); ++i)
    interfaces[i] = std::string_view(names.data() + at[i], interfaces[i].size());
}

bool RecordCaptureReader::next_batch(FrameBatch& batch) {
  batch.clear();
  batch.names.clear();
  std::vector<std::pair<std::size_t, std::size_t>> spans;  // of the interfaces in names, made views at the end
  spans.reserve(FrameBatch::kMax);
  while (batch.frames.size() < FrameBatch::kMax && batch.corrupt.size() < FrameBatch::kMax) {
    const auto st = next();
    if (st == Status::end) break;
    if (st == Status::corrupt) {
      batch.corrupt.push_back({batch.frames.size(), error_});
      continue;
    }
    batch.frames.push_back(frame_);
    const std::string_view name = name_;
    if (spans.empty() || name != std::string_view(batch.names).substr(spans.back().first, spans.back().second)) {
      spans.emplace_back(batch.names.size(), name.size());
      batch.names.append(name);
    } else {
      spans.push_back(spans.back());
    }
  }
  for (const auto& [at, n] : spans) batch.interfaces.emplace_back(batch.names.data() + at, n);
  return !batch.empty();
}

LineCaptureReader::Status LineCaptureReader::next() {
  while (const auto line = detail::next_line(in_, line_, line_number_))
    if (const Step step = parse_line(*line); step != Step::skipped) return status(step);
  return Status::end;
}

LineCaptureReader::Step LineCaptureReader::corrupt(std::size_t column, std::string message) {
  detail::line_error(error_, line_number_, column, std::move(message));
  return Step::corrupt;
}

namespace {

/// What saulctl knows of each format, in the order help lists them: its names (the first is to_string()'s, the
/// others --format takes too), the file extensions that name it, its label in help text, and what it keeps of a frame.
struct FormatInfo {
  CaptureFormat format;
  std::string_view names;
  std::string_view extensions;
  std::string_view label;
  CaptureTraits traits;  // resolution, interface names, channel order, error details, remote frames, error frames
};
constexpr FormatInfo kFormats[] = {
    {CaptureFormat::candump, "candump log", "log candump", "candump", {1000, true, false, true, true, true}},
    {CaptureFormat::pcap, "pcap", "pcap cap", "pcap", {1000, false, false, true, true, true}},
    {CaptureFormat::pcapng, "pcapng", "pcapng ntar", "pcapng", {1, true, false, true, true, true}},
    {CaptureFormat::asc, "asc", "asc", "ASC", {1000, false, true, false, true, true}},
    {CaptureFormat::blf, "blf", "blf", "BLF", {1, false, true, false, true, true}},
    {CaptureFormat::trc, "trc", "trc", "TRC", {1000, false, true, false, true, true}},
    {CaptureFormat::csv, "csv", "csv", "CSV", {1000, false, false, true, true, true}},
    {CaptureFormat::gvret_csv, "gvret-csv", "", "GVRET CSV", {1000, false, true, false, false, false}},
    {CaptureFormat::mcap, "mcap", "mcap", "MCAP", {1, true, false, true, true, true}},
    {CaptureFormat::serial, "serial", "serial", "serial log", {1000, true, false, false, false, false}},
    {CaptureFormat::sigrok, "sigrok", "", "sigrok UART", {1, true, false, false, false, false}},
    {CaptureFormat::sigrok_json, "sigrok-json", "", "sigrok JSON", {1, true, false, false, false, false}},
    {CaptureFormat::pulseview_csv, "pulseview-csv", "", "PulseView CSV", {1, true, false, false, false, false}},
};

static_assert([] {
  for (std::size_t i = 0; i < std::size(kFormats); ++i)
    if (kFormats[i].format != static_cast<CaptureFormat>(i)) return false;  // info() indexes by the enum
  return true;
}());

const FormatInfo& info(CaptureFormat format) noexcept { return kFormats[static_cast<std::size_t>(format)]; }

/// Whether `word` is one of the space-separated words of `list`.
bool listed(std::string_view list, std::string_view word) noexcept {
  while (!list.empty()) {
    const std::size_t space = std::min(list.find(' '), list.size());
    if (list.substr(0, space) == word) return true;
    list.remove_prefix(std::min(space + 1, list.size()));
  }
  return false;
}

}  // namespace

std::string_view to_string(CaptureFormat format) noexcept {
  const std::string_view names = info(format).names;
  return names.substr(0, names.find(' '));
}

std::optional<CaptureFormat> capture_format_from_name(std::string_view name) noexcept {
  for (const FormatInfo& f : kFormats)
    if (listed(f.names, name)) return f.format;
  return std::nullopt;
}

CaptureTraits capture_traits(CaptureFormat format) noexcept { return info(format).traits; }

std::vector<std::string> capture_format_names() {
  std::vector<std::string> names;
  for (const FormatInfo& f : kFormats) names.emplace_back(to_string(f.format));
  return names;
}

std::string capture_format_list(bool with_serial) {
  std::string list;
  for (const FormatInfo& f : kFormats) {
    if (holds_serial_bytes(f.format) && !with_serial) continue;
    if (!list.empty()) list += ", ";
    list += f.label;
  }
  return list + "; .gz/.zst too";
}

std::optional<CaptureFormat> capture_format_from_extension(std::string_view path) noexcept {
  const std::size_t slash = path.find_last_of('/');
  const std::string_view base = slash == std::string_view::npos ? path : path.substr(slash + 1);
  const std::size_t dot = base.find_last_of('.');
  if (dot == std::string_view::npos) return std::nullopt;
  std::array<char, 8> ext{};
  const std::string_view e = base.substr(dot + 1);
  if (e.size() > ext.size()) return std::nullopt;
  for (std::size_t i = 0; i < e.size(); ++i) ext[i] = detail::ascii_lower(e[i]);
  const std::string_view x(ext.data(), e.size());
  for (const FormatInfo& f : kFormats)
    if (listed(f.extensions, x)) return f.format;
  return std::nullopt;
}

std::optional<CaptureFormat> detect_capture_format(std::span<const std::uint8_t> head) noexcept {
  if (head.size() >= 4) {
    const std::array<std::uint8_t, 4> m{head[0], head[1], head[2], head[3]};
    constexpr std::array<std::array<std::uint8_t, 4>, 4> kPcap{{{0xD4, 0xC3, 0xB2, 0xA1},
                                                                {0xA1, 0xB2, 0xC3, 0xD4},
                                                                {0x4D, 0x3C, 0xB2, 0xA1},
                                                                {0xA1, 0xB2, 0x3C, 0x4D}}};
    for (const auto& magic : kPcap)
      if (m == magic) return CaptureFormat::pcap;
    if (m == std::array<std::uint8_t, 4>{0x0A, 0x0D, 0x0D, 0x0A}) return CaptureFormat::pcapng;
    if (m == std::array<std::uint8_t, 4>{'L', 'O', 'G', 'G'}) return CaptureFormat::blf;
    if (m == std::array<std::uint8_t, 4>{0x89, 'M', 'C', 'A'}) return CaptureFormat::mcap;
  }
  std::string_view text(reinterpret_cast<const char*>(head.data()), head.size());
  if (text.find('\0') != std::string_view::npos) return std::nullopt;
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);  // UTF-8 byte-order mark
  return first_line_where(text, [](std::string_view line) -> std::optional<CaptureFormat> {
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.size() >= 2 && line[0] == '(' && is_digit(line[1])) return candump_or_serial(line);
    if (detail::starts_with_nocase(line, "date ") || detail::starts_with_nocase(line, "base ") ||
        detail::starts_with_nocase(line, "begin triggerblock"))
      return CaptureFormat::asc;
    if (line.starts_with("{\"traceEvents\"")) return CaptureFormat::sigrok_json;
    if (line.starts_with("Sample,Time,Decoder,") || line.starts_with("\"Sample\",\"Time\",\"Decoder\","))
      return CaptureFormat::pulseview_csv;
    if (looks_like_sigrok_annotation(line)) return CaptureFormat::sigrok;
    if (line.starts_with(";$FILEVERSION") || line.starts_with(";$STARTTIME") || looks_like_trc_message(line))
      return CaptureFormat::trc;
    if (line.starts_with("timestamp,arbitration_id,")) return CaptureFormat::csv;
    if (detail::starts_with_nocase(line, "time stamp,id,extended,")) return CaptureFormat::gvret_csv;
    return std::nullopt;
  });
}

std::string format_capture_error(std::string_view path, const CaptureError& error) {
  static constexpr std::string_view kAfter[] = {"line skipped", "record skipped", "block skipped", "reading stopped"};
  const std::string_view after = kAfter[static_cast<std::size_t>(error.recovery)];  // by Recovery
  if (error.kind == PositionKind::line)
    return fmt::format("{}:{}:{}: {} ({})", path, error.position, error.column + 1, error.message, after);
  return fmt::format("{}: byte {}: {} ({})", path, error.position, error.message, after);
}

namespace {

template <class Reader>
std::unique_ptr<CaptureReader> make_reader(std::istream& in) {
  return std::make_unique<Reader>(in);
}
template <class Writer>
std::unique_ptr<CaptureWriter> make_writer(std::ostream& out) {
  return std::make_unique<Writer>(out);
}
/// The CAN formats' readers and writers, by CaptureFormat (the serial formats come after them).
using MakeReader = std::unique_ptr<CaptureReader> (*)(std::istream&);
using MakeWriter = std::unique_ptr<CaptureWriter> (*)(std::ostream&);
constexpr std::pair<MakeReader, MakeWriter> kFactories[] = {
    {make_reader<CandumpReader>, make_writer<CandumpWriter>},
    {make_reader<PcapReader>, make_writer<PcapWriter>},
    {make_reader<PcapngReader>, make_writer<PcapngWriter>},
    {make_reader<AscReader>, make_writer<AscWriter>},
    {make_reader<BlfReader>, make_writer<BlfWriter>},
    {make_reader<TrcReader>, make_writer<TrcWriter>},
    {make_reader<CsvLogReader>, make_writer<CsvLogWriter>},
    {make_reader<GvretCsvReader>, make_writer<GvretCsvWriter>},
    {make_reader<McapFrameReader>, make_writer<McapCaptureWriter>},
};
static_assert(std::size(kFactories) == static_cast<std::size_t>(CaptureFormat::serial));

}  // namespace

std::unique_ptr<CaptureReader> make_capture_reader(std::istream& in, CaptureFormat format) {
  if (holds_serial_bytes(format))
    throw CaptureOpenError(fmt::format("this is a {} file of serial bytes, not CAN frames", to_string(format)));
  return kFactories[static_cast<std::size_t>(format)].first(in);
}

std::unique_ptr<CaptureWriter> make_capture_writer(std::ostream& out, CaptureFormat format) {
  if (holds_serial_bytes(format))
    throw std::invalid_argument(fmt::format("{} is not a CAN capture format", to_string(format)));
  return kFactories[static_cast<std::size_t>(format)].second(out);
}

namespace {
/// open_capture(), with the kind of capture the caller reads (`serial`; any when nullopt): the other kind is refused
/// before a reader is made. MCAP's reader is told the file's size, so that a record longer than the file is reported
/// as such at once (not read up to the file's end first).
OpenedCapture open_kind(const std::string& path, const SerialReadOptions& options,
                        std::optional<CaptureFormat> format, std::optional<bool> serial) {
  if (!format) format = options.format;
  auto source = open_source(path, format);
  OpenedCapture opened;
  opened.format = *format;
  opened.compressed = source->inflater != nullptr;
  if (serial && holds_serial_bytes(*format) != *serial)
    throw CaptureOpenError(fmt::format("'{}' holds {} ({}), not {}", path, *serial ? "CAN frames" : "serial bytes",
                                       to_string(*format), *serial ? "serial bytes" : "CAN frames"));
  if (holds_serial_bytes(*format)) {
    auto inner = make_serial_capture_reader(source->stream, *format, options);
    opened.chunks = std::make_unique<FileSerialReader>(std::move(source), std::move(inner));
    return opened;
  }
  try {
    std::unique_ptr<CaptureReader> inner;
    if (*format == CaptureFormat::mcap && !source->inflater)
      inner = std::make_unique<McapFrameReader>(source->stream, source->size);
    else
      inner = make_capture_reader(source->stream, *format);
    opened.frames = std::make_unique<FileReader>(std::move(source), std::move(inner));
  } catch (const CaptureOpenError& e) {
    throw CaptureOpenError(fmt::format("'{}': {}", path, e.what()));
  }
  return opened;
}
}  // namespace

std::unique_ptr<CaptureReader> open_capture_reader(const std::string& path, std::optional<CaptureFormat> format) {
  return open_kind(path, {}, format, false).frames;
}

namespace {

class FileText final : public CaptureText {
 public:
  explicit FileText(std::unique_ptr<FileSource> source) : source_(std::move(source)) {}
  std::size_t read(char* dst, std::size_t n) override { return detail::read_some(*source_->stream.rdbuf(), dst, n); }
  [[nodiscard]] std::uint64_t bytes_read() const override { return source_->bytes_read(); }
  [[nodiscard]] std::optional<CaptureError> end_error() const override { return source_->decompression_error(); }
  [[nodiscard]] bool compressed() const override { return source_->inflater != nullptr; }

 private:
  std::unique_ptr<FileSource> source_;
};

}  // namespace

std::unique_ptr<CaptureText> take_capture_text(std::unique_ptr<CaptureReader>& reader) {
  auto* const file = dynamic_cast<FileReader*>(reader.get());  // only a reader these functions made owns its file
  if (file == nullptr || file->format() != CaptureFormat::candump) return nullptr;
  auto source = file->release_source();
  if (!source) return nullptr;
  reader.reset();
  return std::make_unique<FileText>(std::move(source));
}

std::unique_ptr<SerialCaptureReader> open_serial_capture_reader(const std::string& path,
                                                                const SerialReadOptions& options,
                                                                std::optional<CaptureFormat> format) {
  return open_kind(path, options, format, true).chunks;
}

OpenedCapture open_capture(const std::string& path, const SerialReadOptions& options,
                           std::optional<CaptureFormat> format) {
  return open_kind(path, options, format, std::nullopt);
}

std::unique_ptr<CaptureWriter> open_capture_writer(
    const std::string& path, std::optional<CaptureFormat> format,
    const std::function<std::unique_ptr<CaptureWriter>(std::ostream&)>& make) {
  const Compression compression = compression_from_extension(path);
  const bool to_stdout = path == "-";
  if (!format && !to_stdout) format = capture_format_from_extension(strip_compression_extension(path));
  if (!format && to_stdout)
    throw CaptureOpenError("cannot tell which format to write to standard output ('-'): give the format "
                           "(--format pcap, candump, ...)");
  if (!format)
    throw CaptureOpenError(fmt::format("cannot tell which format to write to '{}': name it .log, .pcap, .pcapng, "
                                       ".asc, .blf, .trc or .csv (+ .gz or .zst to compress), or give the format",
                                       path));
  if (to_stdout && ::isatty(STDOUT_FILENO) &&
      (*format == CaptureFormat::pcap || *format == CaptureFormat::pcapng || *format == CaptureFormat::blf ||
       *format == CaptureFormat::mcap))
    throw CaptureOpenError(fmt::format("standard output is a terminal and {} is binary: redirect it (> run.{}) or "
                                       "pipe it (| wireshark -k -i -)",
                                       to_string(*format), to_string(*format)));
  // (RotatingCaptureWriter refuses a format of serial bytes)
  // Standard output is opened again by its name (/dev/stdout), so it is appended to: a pipe does not mind, and
  // "convert ... - >> all.log" keeps what was there. Not for BLF, which seeks back to its header at the end: in
  // append mode that header would be written at the end instead (a pipe cannot seek, and BLF then leaves it).
  const bool append = to_stdout && *format != CaptureFormat::blf;
  return std::make_unique<RotatingCaptureWriter>(path, *format, RotationOptions{}, nullptr, make, compression, append);
}

namespace {

/// read_in_order's work on the read path: every batch handed on at once, never in blocks.
struct InOrderWork {
  struct Worker {};
  struct Piece {};
  struct Stop {};  // thrown when `each` says stop: out of read_capture's loops and its reading thread, joined
  const std::function<bool(const FrameBatch&)>& each;
  ReadCounts counts;

  Worker worker() { return {}; }
  bool in_blocks(const CaptureBlocks*) { return false; }
  void start(Worker&, Piece&, bool) {}
  CandumpLineTaker* taker(Worker&) { return nullptr; }
  void add(Worker&, Piece&, const FrameBatch& batch) {
    counts.frames += batch.frames.size();
    counts.corrupt += batch.corrupt.size();
    if (!each(batch)) throw Stop{};
  }
  std::uint64_t finish(Worker&, Piece&) { return 0; }
  void take(Piece&) {}
};

}  // namespace

ReadCounts read_in_order(std::unique_ptr<CaptureReader>& reader, const ReadOptions& options,
                         const std::function<bool(const FrameBatch&)>& each,
                         const std::function<void(std::uint64_t records, std::uint64_t bytes)>& progress) {
  InOrderWork work{each, {}};
  try {
    // no path: work in order is never cut into blocks
    detail::read_capture({}, reader, false, options, work, {{}, progress});
  } catch (const InOrderWork::Stop&) {
  }
  return work.counts;
}

CopyStats copy_frames(std::unique_ptr<CaptureReader>& in, CaptureWriter& out,
                      const std::function<void(const CaptureError&)>& on_corrupt,
                      const std::function<void(std::uint64_t records, std::uint64_t bytes)>& progress,
                      const std::string& path, bool compressed, const ReadOptions& read) {
  // MCAP keeps every frame and interface name (its traits): nothing to leave out or rename
  if (McapCaptureWriter* mcap = out.mcap()) return mcap->copy(path, in, compressed, read, on_corrupt, progress);
  CopyStats stats;
  InterfaceIndex seen;
  const CaptureTraits traits = capture_traits(out.format());
  const ReadCounts counts = read_in_order(
      in, read,
      [&](const FrameBatch& batch) {
        batch.walk(
            [&](std::size_t i) {
              const CanFrame& frame = batch.frames[i];
              if (frame.error) ++stats.error_frames;
              if (frame.remote) ++stats.remote_frames;
              if ((frame.error && !traits.error_frames) || (frame.remote && !traits.remote_frames)) {
                ++stats.left_out;
                return;
              }
              if (!seen.find_or_add(batch.interfaces[i], CopyStats::kListed)) stats.more_interfaces = true;
              out.write(frame, batch.interfaces[i]);
            },
            [&](const CaptureError& e) {
              if (on_corrupt) on_corrupt(e);
            });
        return true;
      },
      progress);
  stats.frames = counts.frames;
  stats.corrupt = counts.corrupt;
  stats.interfaces = seen.names();
  return stats;
}

std::vector<std::string> conversion_losses(const CopyStats& stats, CaptureFormat format) {
  std::vector<std::string> notes;
  const CaptureTraits traits = capture_traits(format);
  if (!traits.interface_names) {
    std::string renamed;
    for (std::size_t i = 0; i < stats.interfaces.size(); ++i) {
      const std::string back = traits.channel_order ? fmt::format("can{}", i) : "can0";
      if (stats.interfaces[i] != back)
        renamed += fmt::format("{}{} reads back as {}", renamed.empty() ? "" : ", ", stats.interfaces[i], back);
    }
    if (stats.more_interfaces) renamed += fmt::format(", and those of the interfaces after the first {}", CopyStats::kListed);
    if (!renamed.empty())
      notes.push_back(fmt::format("{} keeps no interface names: {}", to_string(format), renamed));
  }
  if (format == CaptureFormat::candump) {
    std::string renamed;
    for (const auto& name : stats.interfaces)
      if (candump_interface(name) != name)
        renamed += fmt::format("{}'{}' reads back as '{}'", renamed.empty() ? "" : ", ", name, candump_interface(name));
    if (!renamed.empty()) notes.push_back(fmt::format("candump writes white space in interface names as '_': {}", renamed));
  }
  if (stats.left_out > 0)
    notes.push_back(fmt::format("{} holds no remote or error frames: {} of them left out ({} remote, {} error)",
                                to_string(format), stats.left_out, stats.remote_frames, stats.error_frames));
  else if (!traits.error_details && stats.error_frames > 0)
    notes.push_back(fmt::format("{} keeps no error-frame details: {} error frame(s) read back as a bus error "
                                "(class 0x080, no data)",
                                to_string(format), stats.error_frames));
  return notes;
}

void check_writable(const CanFrame& frame) {
  if (!frame.valid())
    throw std::invalid_argument(fmt::format("cannot write a frame with id 0x{:X}{} and DLC {}: out of range",
                                            frame.id, frame.extended ? " (29-bit)" : "", frame.dlc));
  if (frame.error && (frame.remote || frame.extended))
    throw std::invalid_argument("cannot write an error frame flagged remote or extended");
}

}  // namespace saul::host
