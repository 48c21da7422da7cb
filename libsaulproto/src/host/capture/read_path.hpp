// The one read path of a capture file's frames (private to the host library): decode, stats and read_in_order
// (convert, plot, replay) hand it what they do with a batch of frames, and it reads the file the fastest way the
// file and the work allow, with the same results whichever way:
//  - in blocks on ReadOptions::threads threads (a piece per block, taken in file order): an uncompressed candump,
//    pcap or pcapng regular file of at least parallel_from bytes (CaptureBlocks), or a candump log that is
//    compressed or a pipe, cut as it is read (CaptureTextBlocks);
//  - else in batches on this thread, a second thread reading the next batches ahead from parallel_from bytes on.
// The work says whether its results allow blocks (decode --time delta and stats --signals need every frame in order).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/capture.hpp"
#include "saulproto/host/capture/capture_blocks.hpp"
#include "../threads/in_order.hpp"

namespace saul::host::detail {

struct ReadSinks {
  std::function<void(const CaptureError&)> corrupt;  ///< each corrupt record, in file order
  std::function<void(std::uint64_t records, std::uint64_t bytes)> progress;  ///< so far (frames + corrupt); may be empty
};

/// Reads `reader` (opened from `path`; `compressed`: gzip or zstd) through `work`, which has
///   Worker worker();                       state of a thread, kept from piece to piece
///   bool in_blocks(const CaptureBlocks*);  whether its pieces may be blocks worked on at once (nullptr: text blocks)
///   void start(Worker&, Piece&, bool block);  before a piece (block: a block, else a batch taken right after)
///   CandumpLineTaker* taker(Worker&);      takes candump lines of blocks before they are parsed (or nullptr)
///   void add(Worker&, Piece&, const FrameBatch&);  a batch's frames (its corrupt records are the path's)
///   std::uint64_t finish(Worker&, Piece&);  after a piece: the frames its taker took
///   void take(Piece&);                      the pieces in file order, one at a time
/// `reader` may be given up for its text (take_capture_text). Throws what reading or the work throws.
template <class Work>
ReadCounts read_capture(const std::string& path, std::unique_ptr<CaptureReader>& reader, bool compressed,
                        const ReadOptions& o, Work& work, const ReadSinks& sinks) {
  using Worker = typename Work::Worker;
  struct Piece {
    typename Work::Piece piece;
    std::vector<CaptureError> corrupt;
    std::uint64_t frames = 0, lines = 0, bytes = 0;
  };
  struct Thread {
    Worker worker;
    CaptureBlocks::Scratch scratch;
    std::string text;  // a text block's lines
  };
  ReadCounts counts;
  std::uint64_t lines = 0, bytes = 0;
  auto start = [&](Thread& t, Piece& p, bool block) {
    p.corrupt.clear();
    p.frames = p.lines = p.bytes = 0;
    work.start(t.worker, p.piece, block);
  };
  auto add = [&](Thread& t, Piece& p, const FrameBatch& batch) {
    for (const auto& c : batch.corrupt) p.corrupt.push_back(c.error);
    p.frames += batch.frames.size();
    work.add(t.worker, p.piece, batch);
  };
  // block: positions count from the block's first line (candump), bytes are the block's share
  auto take = [&](Piece& p, bool block) {
    for (CaptureError& e : p.corrupt) {
      if (block) e.position += lines;
      if (sinks.corrupt) sinks.corrupt(e);
    }
    counts.corrupt += p.corrupt.size();
    counts.frames += p.frames;
    lines += p.lines;
    bytes = block ? bytes + p.bytes : p.bytes;
    work.take(p.piece);
    if (sinks.progress) sinks.progress(counts.frames + counts.corrupt, bytes);
  };
  auto in_blocks = [&](auto&& read_block) {  // read_block(k, thread, piece): false when there is no block k
    run_blocks_in_order<Piece>(
        kBlocksUntilNone, o.threads, [&] { return Thread{work.worker(), {}, {}}; },
        [&](std::size_t k, Thread& t, Piece& p) {
          start(t, p, true);
          const bool there = read_block(k, t, p);
          p.frames += work.finish(t.worker, p.piece);
          return there;
        },
        [&](std::size_t, Piece& p) { take(p, true); });
  };

  const auto total = reader->bytes_total();
  const bool parallel = o.threads > 1 && !o.live;
  if (parallel && total && *total >= o.parallel_from && !compressed) {
    const auto blocks = CaptureBlocks::open(path, o.block);
    // a pcapng file of one block: read ahead instead
    if (blocks && (blocks->format() != CaptureFormat::pcapng || blocks->has(1)) && work.in_blocks(blocks.get())) {
      in_blocks([&](std::size_t k, Thread& t, Piece& p) {
        if (!blocks->has(k)) return false;  // a pcap or pcapng file is cut as its blocks are read
        const auto read = blocks->read(
            k, t.scratch,
            [&](const FrameBatch& batch) {
              add(t, p, batch);
              return true;
            },
            work.taker(t.worker));
        p.lines = read.lines;
        p.bytes = read.bytes;
        return true;
      });
      return counts;
    }
  }
  if (parallel && (compressed || !total) && reader->format() == CaptureFormat::candump && work.in_blocks(nullptr)) {
    if (const auto text = take_capture_text(reader)) {
      CaptureTextBlocks blocks(*text, o.block);
      in_blocks([&](std::size_t k, Thread& t, Piece& p) {
        if (!blocks.take(k, t.text, p.bytes)) return false;
        CandumpReader scanner(std::string_view(t.text), o.block);
        while (scanner.next_batch(t.scratch.batch, work.taker(t.worker))) add(t, p, t.scratch.batch);
        p.lines = scanner.lines();
        return true;
      });
      if (const auto e = text->end_error()) {  // the decompressor stopped: what the reader reports at its end
        if (sinks.corrupt) sinks.corrupt(*e);
        ++counts.corrupt;
        if (sinks.progress) sinks.progress(counts.frames + counts.corrupt, text->bytes_read());
      }
      return counts;
    }
  }
  // Else batches in file order. From parallel_from bytes on, the next kAhead batches are read on a second thread
  // while this one hands on the ones before (reading ahead); else each is read once the one before was handed on.
  // kAhead, not 1: handing batches over one at a time made the two threads wait on each other, and decode of a
  // 1 M-frame ASC log took 54 % longer in wall time than reading on this thread alone (bench/README.md).
  constexpr std::size_t kAhead = 16;
  const bool ahead = parallel && total && *total >= o.parallel_from;
  Thread t{work.worker(), {}, {}};
  Piece p;
  std::array<std::array<FrameBatch, kAhead>, 2> groups;
  std::array<std::array<std::uint64_t, kAhead>, 2> read_bytes{};
  std::array<std::size_t, 2> held{};
  bool ended = false;  // the reader said so: it is not asked again (a pipe would wait for more)
  auto read = [&](std::size_t g) {
    for (held[g] = 0; held[g] < (ahead ? kAhead : 1) && !ended; ++held[g]) {
      if (!reader->next_batch(groups[g][held[g]])) {
        ended = true;
        break;
      }
      if (ahead) groups[g][held[g]].own();  // the reader's next batch reuses its buffer
      read_bytes[g][held[g]] = reader->bytes_read();
    }
    return held[g] > 0;
  };
  bool more = read(0);
  for (std::size_t g = 0; more; g ^= 1) {
    // what the batches' work throws waits for the reading under way (the future's destructor), then goes on up
    auto next = std::async(ahead ? std::launch::async : std::launch::deferred, read, g ^ 1);
    for (std::size_t i = 0; i < held[g]; ++i) {
      start(t, p, false);
      add(t, p, groups[g][i]);
      p.frames += work.finish(t.worker, p.piece);
      p.bytes = read_bytes[g][i];
      take(p, false);
    }
    more = next.get();
  }
  return counts;
}

}  // namespace saul::host::detail
