// Compressed capture files: any format inside gzip (.gz) or Zstandard (.zst), told by the first bytes, not the name
// (docs/captures.md "Compressed files"). Both directions stream through fixed buffers: a gzip stream needs its 32 KiB
// window, a zstd frame may ask for at most 128 MiB (windowLog 27; more is refused as corrupt). Several gzip members
// or zstd frames one after the other read as one stream.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <streambuf>
#include <string>
#include <string_view>

namespace saul::host {

enum class Compression : std::uint8_t { none, gzip, zstd };

/// "none", "gzip", "zstd".
std::string_view to_string(Compression compression) noexcept;
/// "gz"/"gzip" and "zst"/"zstd" (and "none"); nullopt otherwise.
std::optional<Compression> compression_from_name(std::string_view name) noexcept;
/// ".gz" or ".zst" for gzip and zstd, "" for none.
std::string_view file_suffix(Compression compression) noexcept;
/// By the first bytes: gzip's 1F 8B 08, a Zstandard frame (28 B5 2F FD) or skippable frame (5x 2A 4D 18).
/// Compression::none when neither.
Compression detect_compression(std::span<const std::uint8_t> head) noexcept;
/// By a name ending in .gz or .zst (any case); Compression::none otherwise.
Compression compression_from_extension(std::string_view path) noexcept;
/// The name without its .gz or .zst ("run.blf.gz" -> "run.blf"), so the inner format can be told by extension.
std::string_view strip_compression_extension(std::string_view path) noexcept;

/// A stream buffer of the decompressed bytes of `source`. At the end of the data or at the first corrupt byte it
/// reports end of file; error() then says which (empty at a clean end).
class DecompressingBuf : public std::streambuf {
 public:
  /// Bytes taken from the source so far (for progress over the compressed file's size).
  [[nodiscard]] virtual std::uint64_t compressed_bytes() const = 0;
  /// Empty, or what is wrong: "gzip data is corrupt: invalid distance too far back", ...
  [[nodiscard]] virtual const std::string& error() const = 0;
};
/// Throws std::invalid_argument for Compression::none.
std::unique_ptr<DecompressingBuf> make_decompressing_buf(std::streambuf& source, Compression compression);

/// A stream buffer that compresses onto `sink`. pubsync() is a sync flush (the file is readable up to there);
/// finish() ends the stream and must be called at the end (the destructor does not). Sink errors fail overflow/sync.
class CompressingBuf : public std::streambuf {
 public:
  /// Ends the compressed stream and flushes it to the sink; throws std::runtime_error when the sink fails.
  virtual void finish() = 0;
};
/// Default levels: gzip 6, zstd 3. Throws std::invalid_argument for Compression::none.
std::unique_ptr<CompressingBuf> make_compressing_buf(std::streambuf& sink, Compression compression);

/// Compresses the finished file `path` into `path` + ".gz"/".zst" and removes `path`; returns the new name. On
/// failure the original is kept, the partial output removed, and std::runtime_error thrown.
std::string compress_file(const std::string& path, Compression compression);

}  // namespace saul::host
