#include "saulproto/host/report/fast_decode.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "saulproto/host/capture/candump_scan.hpp"
#include "saulproto/host/capture/pcap_scan.hpp"

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

bool wanted(const CandumpDecodeOptions& o, const CanFrame& f) { return !o.keep || o.keep(f); }

/// Reads every batch of `scanner` into `piece`; after each batch calls after_batch(piece, corrupt_from) where
/// corrupt_from is the first corrupt entry that batch added.
template <class Scanner, class AfterBatch>
void scan_all(Scanner& scanner, FrameEmitter& emitter, const CandumpDecodeOptions& o, Piece& piece,
              AfterBatch&& after_batch) {
  CandumpBatch batch;
  while (scanner.next_batch(batch)) {
    const std::size_t corrupt_from = piece.corrupt.size();
    for (auto& c : batch.corrupt) piece.corrupt.push_back(std::move(c.error));
    const std::size_t n = batch.frames.size();
    piece.records += n;
    for (std::size_t i = 0; i < n; ++i) {
      const CanFrame& f = batch.frames[i];
      if (!wanted(o, f)) continue;
      emitter.add(f, batch.interfaces[i], piece.out, piece.counts);
    }
    if constexpr (requires { scanner.lines(); }) piece.lines = scanner.lines();
    piece.bytes = scanner.bytes_read();
    after_batch(piece, corrupt_from);
  }
}

/// One thread: batches in file order, output written every flush_at bytes (every batch when `live`).
template <class Scanner>
CandumpDecodeResult single(Scanner& scanner, bool live, const CandumpDecodeOptions& o,
                           const CandumpDecodeSinks& sinks) {
  FrameEmitter emitter(o.format, o.time);
  Piece piece;
  CandumpDecodeResult result;
  scan_all(scanner, emitter, o, piece, [&](Piece& p, std::size_t corrupt_from) {
    if (sinks.progress) sinks.progress(p.records + result.corrupt + p.corrupt.size() - corrupt_from, p.bytes);
    for (std::size_t i = corrupt_from; i < p.corrupt.size(); ++i) sinks.corrupt(p.corrupt[i]);
    result.corrupt += p.corrupt.size() - corrupt_from;
    p.corrupt.clear();
    if (p.out.size() >= o.flush_at || (live && p.out.size() > 0)) {  // a pipe may be live: no waiting
      sinks.write(std::string_view(p.out.data(), p.out.size()));
      p.out.clear();
    }
  });
  if (piece.out.size() > 0) sinks.write(std::string_view(piece.out.data(), piece.out.size()));
  result.counts = piece.counts;
  result.records = piece.records;
  return result;
}

/// The time of the first frame that passes the filter, for TimeMode::relative.
std::optional<std::uint64_t> first_time(int fd, std::uint64_t size, const CandumpDecodeOptions& o) {
  CandumpScanner scanner(fd, 0, size, std::size_t{64} << 10);
  CandumpBatch batch;
  while (scanner.next_batch(batch))
    for (const auto& f : batch.frames)
      if (wanted(o, f)) return f.timestamp_ns.value_or(0);
  return std::nullopt;
}

CandumpDecodeResult parallel(int fd, std::uint64_t size, const CandumpDecodeOptions& o,
                             const CandumpDecodeSinks& sinks) {
  const std::vector<std::uint64_t> starts = split_candump_blocks(fd, size, o.block);
  const std::size_t blocks = starts.size() - 1;
  const std::optional<std::uint64_t> first = o.time == TimeMode::relative ? first_time(fd, size, o) : std::nullopt;
  const unsigned threads = o.threads;
  const std::size_t ring = 2 * std::size_t{threads};

  struct Slot {
    Piece piece;
    std::size_t block = 0;
    bool ready = false;
  };
  std::vector<Slot> slots(ring);
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t next_block = 0;   // the next block a worker takes
  std::size_t written = 0;      // blocks handed to the sinks
  std::exception_ptr failure;
  bool stop = false;

  auto work = [&] {
    FrameEmitter emitter(o.format, o.time);
    if (first) emitter.set_first(*first);
    for (;;) {
      std::size_t k;
      {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return stop || next_block >= blocks || next_block < written + ring; });
        if (stop || next_block >= blocks) return;
        k = next_block++;
      }
      Slot& slot = slots[k % ring];
      Piece& piece = slot.piece;
      try {
        piece.out.clear();
        piece.counts = {};
        piece.records = piece.lines = piece.bytes = 0;
        piece.corrupt.clear();
        CandumpScanner scanner(fd, starts[k], starts[k + 1], std::size_t{256} << 10);
        scan_all(scanner, emitter, o, piece, [](Piece&, std::size_t) {});
      } catch (...) {
        std::lock_guard lock(mutex);
        if (!failure) failure = std::current_exception();
        stop = true;
        changed.notify_all();
        return;
      }
      std::lock_guard lock(mutex);
      slot.block = k;
      slot.ready = true;
      changed.notify_all();
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t) pool.emplace_back(work);

  CandumpDecodeResult result;
  std::uint64_t lines = 0;
  std::uint64_t bytes = 0;
  try {
    while (written < blocks) {
      Slot& slot = slots[written % ring];
      {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return stop || (slot.ready && slot.block == written); });
        if (stop) break;
      }
      Piece& piece = slot.piece;
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
      std::lock_guard lock(mutex);
      slot.ready = false;
      ++written;
      changed.notify_all();
    }
  } catch (...) {
    std::lock_guard lock(mutex);
    if (!failure) failure = std::current_exception();
    stop = true;
    changed.notify_all();
  }
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
  return result;
}

}  // namespace

CandumpDecodeResult decode_candump(int fd, std::optional<std::uint64_t> size, const CandumpDecodeOptions& options,
                                   const CandumpDecodeSinks& sinks) {
  // delta needs the previous frame's time across block boundaries: one thread.
  if (size && options.threads > 1 && *size >= options.parallel_from && options.time != TimeMode::delta)
    return parallel(fd, *size, options, sinks);
  if (size) {
    CandumpScanner scanner(fd, 0, *size);
    return single(scanner, false, options, sinks);
  }
  CandumpScanner scanner(fd);
  return single(scanner, true, options, sinks);
}

std::optional<CandumpDecodeResult> decode_candump_file(const std::string& path, const CandumpDecodeOptions& options,
                                                       const CandumpDecodeSinks& sinks) {
  const auto file = CandumpFile::open(path);
  if (!file) return std::nullopt;
  return decode_candump(file->fd(), file->size(), options, sinks);
}

std::optional<CandumpDecodeResult> decode_pcap_file(const std::string& path, const CandumpDecodeOptions& options,
                                                    const CandumpDecodeSinks& sinks) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt;
  std::optional<PcapScanner> scanner;
  try {
    scanner.emplace(fd, static_cast<std::uint64_t>(st.st_size));
  } catch (const CaptureOpenError&) {
    return std::nullopt;  // compressed, or not pcap: the caller's reader
  }
  return single(*scanner, false, options, sinks);
}

}  // namespace saul::host
