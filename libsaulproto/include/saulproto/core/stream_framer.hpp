// One resync mechanism for every byte-stream protocol of the core: the inter-board UART (interboard.hpp), Pride ES
// (pride.hpp), CRSF (crsf.hpp) and slcan lines (slcan.hpp). The framer holds the bytes of the frame being
// assembled (the "candidate"); a protocol plugs in a small Rules object that looks at the candidate after every
// byte and says what it is. The framer does the rest: buffering, dropping, rescanning, delivering.
//
// ---- The rules a protocol supplies --------------------------------------------------------------------------
//
//   struct Rules {
//     framing::Verdict check(std::span<const std::uint8_t> candidate) noexcept;
//     void skipped(std::size_t n) noexcept;
//   };
//
// check() is called once for every byte the candidate grows by, with the whole candidate (its first byte at
// candidate[0], the byte just added at candidate.back()). Each candidate is shown growing from 1 byte, one byte at
// a time, and never shown again once check() answered anything but `more`; so check() may keep running state
// (CRSF keeps a running CRC) and must start it afresh when candidate.size() is 1 or at the header byte that sets
// it up. In that one call check() tells the start byte(s) apart (size 1), the length (from the header bytes),
// validates the whole candidate (CRC, ranges) and counts each rejection in the protocol's own counters. It answers:
//   more     the candidate may still become a frame: wait for the next byte;
//   frame    the candidate is one whole valid frame: it is delivered, then dropped;
//   reject   the candidate cannot be a frame (a size-1 candidate: the byte is not a start byte): its first byte
//            is dropped as skipped and the bytes after it are scanned again as new candidates;
//   discard  drop the whole candidate as skipped, without a rescan (for line protocols, where a candidate
//            is a line and no line starts inside another: slcan's overlong line).
// skipped(n) is told about every byte that ends up in no frame (a noise byte, a rejected start byte, a discarded
// candidate), so a protocol keeps its own bytes_skipped (CountedRules below does that; slcan has no such counter
// and ignores it).
// Rules must not throw (everything is noexcept) and must never answer `more` for a candidate of Capacity bytes;
// if one does, the framer rejects that candidate instead so that its buffer cannot overflow.
//
// ---- Why a rejected start byte triggers a rescan -------------------------------------------------------------
//
// A start byte is only a hint: 0xAA, 0xC8 or 0xFE also occur inside payloads, CRCs and noise. When a false start
// byte opens a candidate, the bytes that follow are taken as its header and body, and a real frame that began
// after the false start byte sits inside the candidate. The rejection (bad LEN, unknown TYPE, bad CRC) can come
// only when the candidate has grown, possibly to its full claimed length (CRSF: up to 64 bytes). Throwing the
// whole candidate away would throw the real frame away with it, and on a link whose frames follow each other
// back to back the next one after it too, and so on. So only the first byte, the one proved not to start a frame,
// is dropped, and the framer scans the rest again from the byte after it, exactly as if the false start byte
// had never arrived. The result is that the frames found are those of the simple rule "at every offset, in
// order, try to read a whole frame; on success jump past it, otherwise move on one byte" (the reference model of
// tests/unit/test_stream_framer.cpp), computed online.
//
// ---- Cost and lifetime of each function ----------------------------------------------------------------------
//
// N is Capacity (the longest candidate, i.e. the longest frame). "check" counts calls of Rules::check().
//
// push(byte, rules, on_frame)
//   Appends one byte and scans until every held byte has been checked. on_frame(std::span<const std::uint8_t>)
//   is called for each frame found, oldest first: one push() can complete several frames when a rescan finds
//   them (CRSF), or none. The span points into the framer's buffer and is valid during the call only (copy
//   what you keep); do not call into the same framer from on_frame. pending() already leaves the frame out
//   during the call; its bytes are moved out after it.
//   Time: one check when nothing is rejected. A byte is checked again only by a rescan, and a rescan only
//   re-checks bytes of a candidate that started less than N bytes before them, each rejection removing one
//   byte for good; so each byte is checked at most N times over its life: O(1) amortised per byte (N a compile-
//   time constant), O(N^2) checks and byte moves for the worst single push(). No allocation, no exception.
// abandon(rules, on_frame)
//   Gives up the held candidate as if check() had rejected it: its first byte is skipped and the rest is
//   scanned again, delivering what it finds; afterwards pending() is smaller than before (or 0 if it was 0).
//   For the end of a capture or an idle line (CRSF's flush() calls it until pending() is 0). O(N^2) at worst.
// drop_all(rules)
//   Forgets the held bytes, telling rules.skipped() how many. O(1).
// pending()
//   Bytes held: the unfinished candidate (after push() returns, every held byte has been checked). O(1).
//
// State: the N-byte buffer and one byte of count; no pointers, so a framer is trivially copyable and a decoder
// holding one can be reset with `*this = Decoder{}`. Neither rules nor on_frame is kept past the call it was given
// to; the protocol's counters live in its Rules. Not thread-safe; safe in an ISR if the caller owns it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace saul::framing {

/// What a protocol's Rules::check() says about the candidate it was shown (see the top of this file).
enum class Verdict : std::uint8_t { more, frame, reject, discard };

/// A base for Rules whose protocol counts skipped bytes in Counters::bytes_skipped: it holds the protocol's
/// Counters and supplies skipped(). A derived Rules adds check(). O(1).
template <class Counters>
struct CountedRules {
  Counters counters{};
  void skipped(std::size_t n) noexcept { counters.bytes_skipped += static_cast<std::uint32_t>(n); }
};

template <std::size_t Capacity>
class StreamFramer {
  static_assert(Capacity >= 1 && Capacity <= 255, "count_ is one byte");

 public:
  template <class Rules, class OnFrame>
  void push(std::uint8_t byte, Rules& rules, OnFrame&& on_frame) noexcept {
    // Invariant: count_ < Capacity here, because a candidate of Capacity bytes is never left held.
    buffer_[count_] = byte;
    ++count_;
    scan(count_ - 1U, rules, on_frame);
  }

  template <class Rules, class OnFrame>
  void abandon(Rules& rules, OnFrame&& on_frame) noexcept {
    if (count_ == 0) return;
    rules.skipped(1);
    count_ = static_cast<std::uint8_t>(count_ - 1);
    move_down(1, count_);
    scan(0, rules, on_frame);
  }

  template <class Rules>
  void drop_all(Rules& rules) noexcept {
    rules.skipped(count_);
    count_ = 0;
  }

  [[nodiscard]] std::size_t pending() const noexcept { return count_; }

 private:
  // Checks the held bytes from offset `checked` on (the first `checked` bytes are the candidate so far, already
  // answered `more`). Returns with every held byte checked.
  template <class Rules, class OnFrame>
  void scan(std::size_t checked, Rules& rules, OnFrame& on_frame) noexcept {
    while (checked < count_) {
      ++checked;
      const std::span<const std::uint8_t> candidate{buffer_, checked};
      Verdict verdict = rules.check(candidate);
      if (verdict == Verdict::more) {
        if (checked < Capacity) continue;
        verdict = Verdict::reject;  // a Rules bug; never lets the buffer overflow
      }
      const std::size_t dropped = verdict == Verdict::reject ? 1 : checked;
      if (verdict != Verdict::frame) rules.skipped(dropped);
      // pending() leaves the dropped bytes out at once, even inside on_frame; they move out after it.
      const std::size_t kept = count_ - dropped;
      count_ = static_cast<std::uint8_t>(kept);
      if (verdict == Verdict::frame) on_frame(candidate);
      move_down(dropped, kept);
      checked = 0;
    }
  }

  // Moves the kept bytes from buffer_[from] to the front: a candidate always starts at buffer_[0].
  void move_down(std::size_t from, std::size_t kept) noexcept {
    for (std::size_t i = 0; i < kept; ++i) buffer_[i] = buffer_[from + i];
  }

  std::uint8_t buffer_[Capacity]{};
  std::uint8_t count_ = 0;
};

}  // namespace saul::framing
