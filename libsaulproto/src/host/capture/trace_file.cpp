#include "saulproto/host/capture/trace_file.hpp"

#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>

namespace saul::host {

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

std::string why(const std::string& path, const char* what) {
  return "'" + path + "': " + what + " (" + std::strerror(errno) + ")";
}

/// The decoder's sink calls as a TraceSink's, offsets moved by what came before the bytes (the file's header).
struct SinkAdapter {
  const TraceSink& sink;
  std::uint64_t base = 0;
  void record(const trace::LoopTrace& r, std::uint64_t offset) const {
    if (sink.record) sink.record(r, offset + base);
  }
  void line(std::string_view text, bool) const {
    if (sink.line) sink.line(text);
  }
  void rejected(Reason reason, std::uint64_t offset) const {
    if (sink.corrupt) sink.corrupt(reason, offset + base);
  }
};

}  // namespace

bool is_trace_file(const std::string& path) {
  // Only a regular file is looked into: reading the head of a pipe (decode <(cat run.log), a named pipe) would take
  // those bytes from the reader that comes next. A trace through a pipe is saved to a file first.
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) return false;
  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "rb"));
  if (!f) return false;
  char head[kTraceMagic.size()];
  return std::fread(head, 1, sizeof head, f.get()) == sizeof head &&
         std::string_view(head, sizeof head) == kTraceMagic;
}

TraceFileWriter::TraceFileWriter(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) throw std::runtime_error(why(path, "cannot create the trace file"));
  write(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(kTraceMagic.data()), kTraceMagic.size()));
}

TraceFileWriter::~TraceFileWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

void TraceFileWriter::write(std::span<const std::uint8_t> bytes) {
  if (bytes.empty()) return;
  if (file_ == nullptr || std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size())
    throw std::runtime_error(why(path_, "cannot write the trace file"));
}

void TraceFileWriter::close() {
  if (file_ == nullptr) return;
  const bool ok = std::fflush(file_) == 0;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) throw std::runtime_error(why(path_, "cannot write the trace file"));
}

trace::Counters read_trace_file(const std::string& path, const TraceSink& sink) {
  std::unique_ptr<std::FILE, FileCloser> owned;
  std::FILE* f = stdin;
  if (path != "-") {
    owned.reset(std::fopen(path.c_str(), "rb"));
    if (!owned) throw std::runtime_error(why(path, "cannot open the trace file"));
    f = owned.get();
  }
  char head[kTraceMagic.size()];
  const std::size_t got = std::fread(head, 1, sizeof head, f);
  if (got != sizeof head || std::string_view(head, sizeof head) != kTraceMagic)
    throw std::runtime_error("'" + path + "': not a loop trace (no 'SAULTRACE 1' header; record one with saulctl tune record)");
  const SinkAdapter adapter{sink, kTraceMagic.size()};
  trace::ConsoleDecoder decoder;
  std::uint8_t buffer[1 << 16];
  for (;;) {
    const std::size_t n = std::fread(buffer, 1, sizeof buffer, f);
    if (n == 0) break;
    decoder.push(std::span<const std::uint8_t>(buffer, n), adapter);
  }
  if (std::ferror(f)) throw std::runtime_error(why(path, "cannot read the trace file"));
  decoder.finish(adapter);
  return decoder.counters();
}

trace::Counters read_trace_bytes(std::span<const std::uint8_t> bytes, const TraceSink& sink) {
  const SinkAdapter adapter{sink, 0};
  trace::ConsoleDecoder decoder;
  decoder.push(bytes, adapter);
  decoder.finish(adapter);
  return decoder.counters();
}

}  // namespace saul::host
