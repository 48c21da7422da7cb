#include "saulproto/host/capture/compressed.hpp"

#include <fmt/format.h>
#include <zlib.h>
#include <zstd.h>

#include <array>
#include <cerrno>
#include <vector>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "../util.hpp"
#include "capture_io.hpp"

namespace saul::host {
namespace {

constexpr std::size_t kBufferBytes = 64 * 1024;
constexpr int kZstdWindowLogMax = 27;  // 128 MiB: zstd's own default limit for streaming decoders

/// Writes n bytes to a stream buffer; false when it takes fewer.
bool write_all(std::streambuf& sink, const char* src, std::size_t n) {
  return n == 0 || sink.sputn(src, static_cast<std::streamsize>(n)) == static_cast<std::streamsize>(n);
}

// ---- reading ----

/// What both decompressors keep: the source, the output buffer, the count of compressed bytes, the first error.
class InflaterBase : public DecompressingBuf {
 public:
  InflaterBase(const InflaterBase&) = delete;
  InflaterBase& operator=(const InflaterBase&) = delete;
  [[nodiscard]] std::uint64_t compressed_bytes() const override { return compressed_; }
  [[nodiscard]] const std::string& error() const override { return error_; }

 protected:
  explicit InflaterBase(std::streambuf& source) : source_(source) {}
  /// Reads more compressed bytes into `dst`; 0 at the end of the source.
  std::size_t take(char* dst, std::size_t n) {
    const std::size_t got = detail::read_some(source_, dst, n);
    compressed_ += got;
    return got;
  }
  /// Hands out `n` decompressed bytes of out_.
  int_type hand_out(std::size_t n) {
    setg(out_.data(), out_.data(), out_.data() + n);
    return traits_type::to_int_type(*gptr());
  }
  void fail(std::string message) {
    if (error_.empty()) error_ = std::move(message);
    done_ = true;
  }

  std::array<char, kBufferBytes> out_{};
  bool done_ = false;

 private:
  std::streambuf& source_;
  std::uint64_t compressed_ = 0;
  std::string error_;
};

class GzipInflater final : public InflaterBase {
 public:
  explicit GzipInflater(std::streambuf& source) : InflaterBase(source) {
    if (inflateInit2(&z_, 15 + 32) != Z_OK) throw std::runtime_error("zlib: cannot start inflating");
  }
  ~GzipInflater() override { inflateEnd(&z_); }

 protected:
  int_type underflow() override {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    while (!done_) {
      if (z_.avail_in == 0 && !refill()) break;
      if (!in_member_) {
        // The next gzip member must start with its magic: anything else after a complete member is not ours.
        if (in_[pos()] != '\x1F') {
          fail("bytes after the end of the gzip data are not gzip (ignored)");
          break;
        }
        in_member_ = true;
      }
      z_.next_out = reinterpret_cast<Bytef*>(out_.data());
      z_.avail_out = static_cast<uInt>(out_.size());
      const int r = inflate(&z_, Z_NO_FLUSH);
      const std::size_t produced = out_.size() - z_.avail_out;
      if (r == Z_STREAM_END) {
        in_member_ = false;
        inflateReset(&z_);
      } else if (r != Z_OK && r != Z_BUF_ERROR) {
        fail(fmt::format("gzip data is corrupt: {}", z_.msg ? z_.msg : "inflate failed"));
      }
      if (produced > 0) return hand_out(produced);
    }
    return traits_type::eof();
  }

 private:
  std::size_t pos() const { return static_cast<std::size_t>(reinterpret_cast<const char*>(z_.next_in) - in_.data()); }
  bool refill() {
    const std::size_t n = take(in_.data(), in_.size());
    if (n == 0) {
      if (in_member_) fail("the gzip file ends before its end marker (truncated?)");
      done_ = true;
      return false;
    }
    z_.next_in = reinterpret_cast<Bytef*>(in_.data());
    z_.avail_in = static_cast<uInt>(n);
    return true;
  }
  z_stream z_{};
  std::array<char, kBufferBytes> in_{};
  bool in_member_ = true;
};

class ZstdInflater final : public InflaterBase {
 public:
  explicit ZstdInflater(std::streambuf& source) : InflaterBase(source), d_(ZSTD_createDCtx()) {
    if (!d_) throw std::runtime_error("zstd: cannot start decompressing");
    ZSTD_DCtx_setParameter(d_, ZSTD_d_windowLogMax, kZstdWindowLogMax);
  }
  ~ZstdInflater() override { ZSTD_freeDCtx(d_); }

 protected:
  int_type underflow() override {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    while (!done_) {
      if (in_.pos == in_.size && !output_pending_) {
        const std::size_t n = take(in_data_.data(), in_data_.size());
        if (n == 0) {
          if (frame_open_) fail("the zstd file ends before the end of its frame (truncated?)");
          done_ = true;
          break;
        }
        in_ = {in_data_.data(), n, 0};
      }
      ZSTD_outBuffer out{out_.data(), out_.size(), 0};
      const std::size_t r = ZSTD_decompressStream(d_, &out, &in_);
      if (ZSTD_isError(r)) {
        fail(fmt::format("zstd data is corrupt: {}", ZSTD_getErrorName(r)));
        break;
      }
      frame_open_ = r != 0;
      output_pending_ = out.pos == out.size;
      if (out.pos > 0) return hand_out(out.pos);
    }
    return traits_type::eof();
  }

 private:
  ZSTD_DCtx* d_;
  std::array<char, kBufferBytes> in_data_{};
  ZSTD_inBuffer in_{nullptr, 0, 0};
  bool frame_open_ = false;
  bool output_pending_ = false;
};

// ---- writing ----

/// The put area collects what is written; a full area, a sync and finish() hand it to the compressor.
class CompressorBase : public CompressingBuf {
 public:
  CompressorBase(const CompressorBase&) = delete;
  CompressorBase& operator=(const CompressorBase&) = delete;

 protected:
  explicit CompressorBase(std::streambuf& sink) : sink_(sink) { setp(in_.data(), in_.data() + in_.size()); }

  enum class Mode { more, flush, end };
  /// Compresses `data` (all of it) and writes the output to the sink; false on failure.
  virtual bool compress(const char* data, std::size_t n, Mode mode) = 0;

  bool drain(Mode mode) {
    const auto n = static_cast<std::size_t>(pptr() - pbase());
    const bool ok = compress(pbase(), n, mode);
    setp(in_.data(), in_.data() + in_.size());
    return ok;
  }
  int_type overflow(int_type c) override {
    if (finished_ || !drain(Mode::more)) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  int sync() override {
    if (finished_) return 0;
    if (!drain(Mode::flush)) return -1;
    return sink_.pubsync();
  }

 public:
  void finish() override {
    if (finished_) return;
    finished_ = true;
    if (!drain(Mode::end) || sink_.pubsync() != 0) throw std::runtime_error("cannot write the compressed stream");
  }

 protected:
  std::streambuf& sink_;
  std::array<char, kBufferBytes> out_{};

 private:
  std::array<char, kBufferBytes> in_{};
  bool finished_ = false;
};

class GzipDeflater final : public CompressorBase {
 public:
  explicit GzipDeflater(std::streambuf& sink) : CompressorBase(sink) {
    if (deflateInit2(&z_, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
      throw std::runtime_error("zlib: cannot start deflating");
  }
  ~GzipDeflater() override { deflateEnd(&z_); }

 private:
  bool compress(const char* data, std::size_t n, Mode mode) override {
    z_.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data));
    z_.avail_in = static_cast<uInt>(n);
    const int flush = mode == Mode::more ? Z_NO_FLUSH : mode == Mode::flush ? Z_SYNC_FLUSH : Z_FINISH;
    for (;;) {
      z_.next_out = reinterpret_cast<Bytef*>(out_.data());
      z_.avail_out = static_cast<uInt>(out_.size());
      const int r = deflate(&z_, flush);
      if (r == Z_STREAM_ERROR) return false;
      if (!write_all(sink_, out_.data(), out_.size() - z_.avail_out)) return false;
      if (mode == Mode::end ? r == Z_STREAM_END : (z_.avail_in == 0 && z_.avail_out != 0)) return true;
    }
  }
  z_stream z_{};
};

class ZstdDeflater final : public CompressorBase {
 public:
  explicit ZstdDeflater(std::streambuf& sink) : CompressorBase(sink), c_(ZSTD_createCCtx()) {
    if (!c_) throw std::runtime_error("zstd: cannot start compressing");
    ZSTD_CCtx_setParameter(c_, ZSTD_c_compressionLevel, 3);
    ZSTD_CCtx_setParameter(c_, ZSTD_c_checksumFlag, 1);
  }
  ~ZstdDeflater() override { ZSTD_freeCCtx(c_); }

 private:
  bool compress(const char* data, std::size_t n, Mode mode) override {
    ZSTD_inBuffer in{data, n, 0};
    const ZSTD_EndDirective op = mode == Mode::more ? ZSTD_e_continue : mode == Mode::flush ? ZSTD_e_flush : ZSTD_e_end;
    for (;;) {
      ZSTD_outBuffer out{out_.data(), out_.size(), 0};
      const std::size_t left = ZSTD_compressStream2(c_, &out, &in, op);
      if (ZSTD_isError(left)) return false;
      if (!write_all(sink_, out_.data(), out.pos)) return false;
      if (mode == Mode::more ? in.pos == in.size : left == 0) return true;
    }
  }
  ZSTD_CCtx* c_;
};

}  // namespace

namespace {
/// Each compression's name, the short name it is given by too, and its file suffix (by Compression).
struct CompressionNames {
  std::string_view name, short_name, suffix;
};
constexpr CompressionNames kNames[] = {{"none", "none", ""}, {"gzip", "gz", ".gz"}, {"zstd", "zst", ".zst"}};
}  // namespace

std::string_view to_string(Compression compression) noexcept {
  return kNames[static_cast<std::size_t>(compression)].name;
}

std::optional<Compression> compression_from_name(std::string_view name) noexcept {
  for (std::size_t i = 0; i < std::size(kNames); ++i)
    if (name == kNames[i].name || name == kNames[i].short_name) return static_cast<Compression>(i);
  return std::nullopt;
}

std::string_view file_suffix(Compression compression) noexcept {
  return kNames[static_cast<std::size_t>(compression)].suffix;
}

Compression detect_compression(std::span<const std::uint8_t> head) noexcept {
  if (head.size() >= 3 && head[0] == 0x1F && head[1] == 0x8B && head[2] == 0x08) return Compression::gzip;
  if (head.size() >= 4 && head[1] == 0xB5 && head[2] == 0x2F && head[3] == 0xFD && head[0] == 0x28)
    return Compression::zstd;
  if (head.size() >= 4 && (head[0] & 0xF0) == 0x50 && head[1] == 0x2A && head[2] == 0x4D && head[3] == 0x18)
    return Compression::zstd;
  return Compression::none;
}

Compression compression_from_extension(std::string_view path) noexcept {
  if (detail::ends_with_nocase(path, ".gz")) return Compression::gzip;
  if (detail::ends_with_nocase(path, ".zst")) return Compression::zstd;
  return Compression::none;
}

std::string_view strip_compression_extension(std::string_view path) noexcept {
  const Compression c = compression_from_extension(path);
  return path.substr(0, path.size() - file_suffix(c).size());
}

std::unique_ptr<DecompressingBuf> make_decompressing_buf(std::streambuf& source, Compression compression) {
  switch (compression) {
    case Compression::gzip: return std::make_unique<GzipInflater>(source);
    case Compression::zstd: return std::make_unique<ZstdInflater>(source);
    case Compression::none: break;
  }
  throw std::invalid_argument("make_decompressing_buf: no compression");
}

std::unique_ptr<CompressingBuf> make_compressing_buf(std::streambuf& sink, Compression compression) {
  switch (compression) {
    case Compression::gzip: return std::make_unique<GzipDeflater>(sink);
    case Compression::zstd: return std::make_unique<ZstdDeflater>(sink);
    case Compression::none: break;
  }
  throw std::invalid_argument("make_compressing_buf: no compression");
}

std::string compress_file(const std::string& path, Compression compression) {
  const std::string target = path + std::string(file_suffix(compression));
  std::filebuf in;
  if (!in.open(path, std::ios::in | std::ios::binary))
    throw std::runtime_error(fmt::format("cannot compress '{}': {}", path, std::strerror(errno)));
  std::filebuf out;
  if (!out.open(target, std::ios::out | std::ios::binary | std::ios::trunc))
    throw std::runtime_error(fmt::format("cannot create '{}': {}", target, std::strerror(errno)));
  bool ok = true;
  try {
    auto z = make_compressing_buf(out, compression);
    std::array<char, kBufferBytes> buffer{};
    for (;;) {
      const std::size_t n = detail::read_some(in, buffer.data(), buffer.size());
      if (n == 0) break;
      if (!write_all(*z, buffer.data(), n)) {
        ok = false;
        break;
      }
    }
    if (ok) z->finish();
  } catch (const std::runtime_error&) {
    ok = false;
  }
  ok = out.close() != nullptr && ok;
  in.close();
  if (!ok) {
    std::remove(target.c_str());
    throw std::runtime_error(fmt::format("cannot write '{}': {}", target, std::strerror(errno)));
  }
  if (std::remove(path.c_str()) != 0)
    throw std::runtime_error(fmt::format("compressed '{}' but cannot remove it: {}", path, std::strerror(errno)));
  return target;
}

}  // namespace saul::host
