#include "saulproto/host/report/fast_decode.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <functional>
#include <string>
#include <system_error>
#include <vector>

#include "saulproto/host/capture/candump_scan.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/capture_blocks.hpp"
#include "saulproto/host/capture/pcap_scan.hpp"
#include "saulproto/host/capture/pcapng.hpp"
#include "../threads/read_ahead.hpp"
#include "../threads/in_order.hpp"

namespace saul::host {
namespace {

/// What one range of the file gave.
struct Piece {
  fmt::memory_buffer out;
  DecodeCounts counts;
  std::uint64_t records = 0;
  std::vector<CaptureError> corrupt;  // positions: lines counted from the range's start
  std::uint64_t lines = 0;
  std::uint64_t bytes = 0;
};

bool wanted(const FrameDecodeOptions& o, const CanFrame& f) { return !o.keep || o.keep(f); }

/// One batch's frames into `piece` (its corrupt records kept there for the caller).
void emit_batch(const FrameBatch& batch, FrameEmitter& emitter, const FrameDecodeOptions& o, Piece& piece) {
  for (const auto& c : batch.corrupt) piece.corrupt.push_back(c.error);
  const std::size_t n = batch.frames.size();
  piece.records += n;
  for (std::size_t i = 0; i < n; ++i) {
    const CanFrame& f = batch.frames[i];
    if (!wanted(o, f)) continue;
    emitter.add(f, batch.interfaces[i], piece.out, piece.counts);
  }
}

/// Reads every batch of `scanner` into `piece`; after each batch calls after_batch(piece, corrupt_from) where
/// corrupt_from is the first corrupt entry that batch added.
template <class Scanner, class AfterBatch>
void scan_all(Scanner& scanner, FrameEmitter& emitter, const FrameDecodeOptions& o, Piece& piece,
              AfterBatch&& after_batch) {
  FrameBatch batch;
  while (scanner.next_batch(batch)) {
    const std::size_t corrupt_from = piece.corrupt.size();
    emit_batch(batch, emitter, o, piece);
    if constexpr (requires { scanner.lines(); }) piece.lines = scanner.lines();
    piece.bytes = scanner.bytes_read();
    after_batch(piece, corrupt_from);
  }
}

/// One thread's output: reports the batch's corrupt records and progress, writes every flush_at bytes (every batch
/// when `live`).
struct InOrder {
  InOrder(const FrameDecodeOptions& options, const FrameDecodeSinks& to, bool is_live)
      : o(options), sinks(to), live(is_live), emitter(options.format, options.time) {}
  const FrameDecodeOptions& o;
  const FrameDecodeSinks& sinks;
  bool live;
  FrameEmitter emitter;
  Piece piece;
  FrameDecodeResult result;
  void after_batch(std::size_t corrupt_from) {
    Piece& p = piece;
    if (sinks.progress) sinks.progress(p.records + result.corrupt + p.corrupt.size() - corrupt_from, p.bytes);
    for (std::size_t i = corrupt_from; i < p.corrupt.size(); ++i) sinks.corrupt(p.corrupt[i]);
    result.corrupt += p.corrupt.size() - corrupt_from;
    p.corrupt.clear();
    if (p.out.size() >= o.flush_at || (live && p.out.size() > 0)) {  // a pipe may be live: no waiting
      sinks.write(std::string_view(p.out.data(), p.out.size()));
      p.out.clear();
    }
  }
  FrameDecodeResult finish() {
    if (piece.out.size() > 0) sinks.write(std::string_view(piece.out.data(), piece.out.size()));
    result.counts = piece.counts;
    result.records = piece.records;
    return result;
  }
};

/// One thread: batches in file order.
template <class Scanner>
FrameDecodeResult single(Scanner& scanner, bool live, const FrameDecodeOptions& o,
                           const FrameDecodeSinks& sinks) {
  InOrder run(o, sinks, live);
  scan_all(scanner, run.emitter, o, run.piece, [&](Piece&, std::size_t corrupt_from) { run.after_batch(corrupt_from); });
  return run.finish();
}

/// A batch of any CaptureReader's frames, as CandumpScanner hands them out, its interfaces in `names`.
struct ReaderSlot {
  FrameBatch batch;
  std::string names;
  std::uint64_t bytes = 0;
};

bool read_batch(CaptureReader& reader, ReaderSlot& slot) {
  FrameBatch& batch = slot.batch;
  batch.clear();
  slot.names.clear();
  std::vector<std::pair<std::size_t, std::size_t>> spans;  // of the interfaces in names, made views at the end
  spans.reserve(CandumpScanner::kMaxBatch);
  while (batch.frames.size() + batch.corrupt.size() < CandumpScanner::kMaxBatch) {
    const auto st = reader.next();
    if (st == CaptureReader::Status::end) break;
    if (st == CaptureReader::Status::corrupt) {
      batch.corrupt.push_back({batch.frames.size(), reader.error()});
      continue;
    }
    batch.frames.push_back(reader.frame());
    const std::string_view name = reader.interface();
    if (spans.empty() || name != std::string_view(slot.names).substr(spans.back().first, spans.back().second)) {
      spans.emplace_back(slot.names.size(), name.size());
      slot.names.append(name);
    } else {
      spans.push_back(spans.back());
    }
  }
  for (const auto& [at, n] : spans) batch.interfaces.emplace_back(slot.names.data() + at, n);
  slot.bytes = reader.bytes_read();
  return !batch.frames.empty() || !batch.corrupt.empty();
}

/// Blocks decoded on o.threads threads, two in flight per thread, handed to the sinks in file order.
/// read_block(k, worker, piece) decodes block k into `piece` (false: there is no block k) with worker.emitter;
/// piece.bytes is the block's share of the bytes read (the shares add up to the file's size).
/// Corrupt positions are counted from the block's start when its scanner counts lines (candump), else they are
/// the file's byte offsets already (pcap, pcapng). Relative times count from `first`.
struct Worker {
  Worker(const FrameDecodeOptions& o, std::optional<std::uint64_t> first) : emitter(o.format, o.time) {
    if (first) emitter.set_first(*first);
  }
  FrameEmitter emitter;
  CaptureBlocks::Scratch scratch;
  std::string text;  // decode_candump_text: the block's lines
};
template <class ReadBlock>
FrameDecodeResult in_blocks(const FrameDecodeOptions& o, const FrameDecodeSinks& sinks,
                              std::optional<std::uint64_t> first, ReadBlock&& read_block) {
  FrameDecodeResult result;
  std::uint64_t lines = 0;
  std::uint64_t bytes = 0;
  detail::run_blocks_in_order<Piece>(
      detail::kBlocksUntilNone, o.threads, [&] { return Worker(o, first); },
      [&](std::size_t k, Worker& w, Piece& piece) {
        piece.out.clear();
        piece.counts = {};
        piece.records = 0;
        piece.corrupt.clear();
        return read_block(k, w, piece);
      },
      [&](std::size_t, Piece& piece) {
        for (auto& e : piece.corrupt) {
          e.position += lines;
          sinks.corrupt(e);
        }
        result.corrupt += piece.corrupt.size();
        if (piece.out.size() > 0) sinks.write(std::string_view(piece.out.data(), piece.out.size()));
        result.counts += piece.counts;
        result.records += piece.records;
        lines += piece.lines;
        bytes += piece.bytes;
        if (sinks.progress) sinks.progress(result.records + result.corrupt, bytes);
      });
  return result;
}

/// The blocks of a file (CaptureBlocks).
FrameDecodeResult parallel(const CaptureBlocks& blocks, const FrameDecodeOptions& o,
                             const FrameDecodeSinks& sinks) {
  std::optional<std::uint64_t> first;
  if (o.time == TimeMode::relative) first = blocks.first_time(o.keep);
  return in_blocks(o, sinks, first, [&](std::size_t k, Worker& w, Piece& piece) {
    if (!blocks.has(k)) return false;  // a pcap or pcapng file is cut as its blocks are read
    const auto read = blocks.read(k, w.scratch, [&](const FrameBatch& batch) {
      emit_batch(batch, w.emitter, o, piece);
      return true;
    });
    piece.lines = read.lines;
    piece.bytes = read.bytes;
    return true;
  });
}

}  // namespace

bool decodes_candump_text(const FrameDecodeOptions& options) noexcept {
  return options.threads >= 2 && options.time == TimeMode::absolute;
}

std::optional<FrameDecodeResult> decode_candump_text(CaptureText& text, const FrameDecodeOptions& options,
                                                       const FrameDecodeSinks& sinks) {
  if (!decodes_candump_text(options)) return std::nullopt;
  CaptureTextBlocks blocks(text, options.block);
  FrameDecodeResult result = in_blocks(options, sinks, std::nullopt, [&](std::size_t k, Worker& w, Piece& piece) {
    if (!blocks.take(k, w.text, piece.bytes)) return false;
    CandumpScanner scanner(std::string_view(w.text), options.block);
    FrameBatch& batch = w.scratch.batch;
    while (scanner.next_batch(batch)) emit_batch(batch, w.emitter, options, piece);
    piece.lines = scanner.lines();
    return true;
  });
  if (const auto e = text.end_error()) {  // the decompressor stopped: what the reader reports at its end
    sinks.corrupt(*e);
    ++result.corrupt;
    if (sinks.progress) sinks.progress(result.records + result.corrupt, text.bytes_read());
  }
  return result;
}

FrameDecodeResult decode_candump(int fd, std::optional<std::uint64_t> size, const FrameDecodeOptions& options,
                                   const FrameDecodeSinks& sinks) {
  // delta needs the previous frame's time across block boundaries: one thread.
  if (size && options.threads > 1 && *size >= options.parallel_from && options.time != TimeMode::delta)
    return parallel(*CaptureBlocks::of(fd, *size, CaptureFormat::candump, options.block), options, sinks);
  if (size) {
    CandumpScanner scanner(fd, 0, *size);
    return single(scanner, false, options, sinks);
  }
  CandumpScanner scanner(fd);
  FrameDecodeResult result = single(scanner, true, options, sinks);
  result.first_other = scanner.first_other();
  return result;
}

std::optional<FrameDecodeResult> decode_candump_file(const std::string& path, const FrameDecodeOptions& options,
                                                       const FrameDecodeSinks& sinks) {
  const auto file = CandumpFile::open(path);
  if (!file) return std::nullopt;
  return decode_candump(file->fd(), file->size(), options, sinks);
}

FrameDecodeResult decode_reader(CaptureReader& reader, bool ahead, const FrameDecodeOptions& options,
                                  const FrameDecodeSinks& sinks) {
  InOrder run(options, sinks, false);
  auto take = [&](const ReaderSlot& slot) {
    const std::size_t corrupt_from = run.piece.corrupt.size();
    emit_batch(slot.batch, run.emitter, options, run.piece);
    run.piece.bytes = slot.bytes;
    run.after_batch(corrupt_from);
  };
  if (!ahead) {
    ReaderSlot slot;
    while (read_batch(reader, slot)) take(slot);
    return run.finish();
  }
  std::array<ReaderSlot, kAheadBatches> slots;
  read_ahead(
      slots.size(), [&](std::size_t k) { return read_batch(reader, slots[k]); },
      [&](std::size_t k) { take(slots[k]); });
  return run.finish();
}

namespace {

/// A regular file opened for reading (fd -1 when it cannot be, or is no regular file), closed at the end.
struct RegularFile {
  int fd = -1;
  std::uint64_t size = 0;
  explicit RegularFile(const std::string& path) : fd(::open(capture_open_name(path), O_RDONLY | O_CLOEXEC)) {
    struct stat st {};
    if (fd >= 0 && (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))) {
      ::close(fd);
      fd = -1;
    }
    if (fd >= 0) size = static_cast<std::uint64_t>(st.st_size);
  }
  ~RegularFile() {
    if (fd >= 0) ::close(fd);
  }
  RegularFile(const RegularFile&) = delete;
  RegularFile& operator=(const RegularFile&) = delete;
};

}  // namespace

std::optional<FrameDecodeResult> decode_pcap_file(const std::string& path, const FrameDecodeOptions& options,
                                                    const FrameDecodeSinks& sinks) {
  const RegularFile file(path);
  if (file.fd < 0) return std::nullopt;
  const int fd = file.fd;
  const std::uint64_t size = file.size;
  std::optional<PcapScanner> scanner;
  try {
    scanner.emplace(fd, size);
  } catch (const CaptureOpenError&) {
    return std::nullopt;  // compressed, or not pcap: the caller's reader
  }
  // As candump files: large ones in blocks of whole records on both cores (delta needs the previous frame: one).
  if (options.threads > 1 && size >= options.parallel_from && options.time != TimeMode::delta) {
    if (const auto blocks = CaptureBlocks::of(fd, size, CaptureFormat::pcap, options.block))
      return parallel(*blocks, options, sinks);
  }
  return single(*scanner, false, options, sinks);
}

std::optional<FrameDecodeResult> decode_pcapng_file(const std::string& path, const FrameDecodeOptions& options,
                                                      const FrameDecodeSinks& sinks) {
  if (options.threads < 2 || options.time == TimeMode::delta) return std::nullopt;
  const RegularFile file(path);
  if (file.fd < 0) return std::nullopt;
  const int fd = file.fd;
  const std::uint64_t size = file.size;
  if (size < options.parallel_from) return std::nullopt;
  const auto blocks = CaptureBlocks::of(fd, size, CaptureFormat::pcapng, options.block);
  if (!blocks || !blocks->has(1)) return std::nullopt;  // one block: the reader reads ahead instead
  return parallel(*blocks, options, sinks);
}

}  // namespace saul::host
