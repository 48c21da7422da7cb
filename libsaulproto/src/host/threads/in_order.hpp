// Blocks of a file worked on several threads and handed back in file order (private to the host library): the
// engine under decode's and stats' two-core paths (report/fast_decode.cpp, report/bus_stats.cpp).
#pragma once

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace saul::host::detail {

/// `blocks` for run_blocks_in_order when the blocks are found as they are read: work() says where they end.
inline constexpr std::size_t kBlocksUntilNone = static_cast<std::size_t>(-1);

/// Calls work(k, state, result) for every block k in [0, blocks) on `threads` threads (the caller's and threads - 1
/// more), and take(k, result) for k = 0, 1, 2... in that order, one call at a time, on whichever of them finished a
/// block while no other was taking. Each thread has its own `state`, made on it by make_state() (a prvalue: it need
/// not be movable), kept from block to block. At most 2 x threads blocks are worked ahead of take(): memory is that
/// many Results, whatever the number of blocks. Results are slots that are reused, so work() starts by resetting
/// what it fills. What work() or take() throws stops every thread (the blocks under way finish first) and is
/// rethrown here. work() returns false when there is no block k (nor any after it: blocks may then be
/// kBlocksUntilNone); take() then ends with block k - 1. The caller works too: a third thread that only takes would
/// cost a context switch per block.
template <class Result, class MakeState, class Work, class Take>
void run_blocks_in_order(std::size_t blocks, unsigned threads, MakeState&& make_state, Work&& work, Take&& take) {
  if (threads == 0) threads = 1;
  const std::size_t ring = 2 * std::size_t{threads};
  struct Slot {
    Result result;
    std::size_t block = 0;
    bool ready = false;
  };
  std::vector<Slot> slots(ring);
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t next_block = 0;  // the next block a thread works on
  std::size_t taken = 0;       // blocks handed to take(); only the taking thread changes it
  bool taking = false;         // a thread is handing blocks to take()
  std::exception_ptr failure;
  bool stop = false;
  auto fail_locked = [&] {
    if (!failure) failure = std::current_exception();
    stop = true;
    changed.notify_all();
  };
  // Hands the blocks that are ready to take(), in order, unless another thread is doing so (it will see them: it
  // looks again under the lock before it stops). `lock` holds `mutex`.
  auto take_ready = [&](std::unique_lock<std::mutex>& lock) {
    if (taking) return;
    taking = true;
    while (!stop && taken < blocks) {
      Slot& slot = slots[taken % ring];
      if (!slot.ready || slot.block != taken) break;
      lock.unlock();
      try {
        take(taken, slot.result);
      } catch (...) {
        lock.lock();
        fail_locked();
        break;
      }
      lock.lock();
      slot.ready = false;
      ++taken;
      changed.notify_all();
    }
    taking = false;
  };

  auto worker = [&](auto& state) {
    for (;;) {
      std::size_t k;
      {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return stop || next_block >= blocks || next_block < taken + ring; });
        if (stop || next_block >= blocks) return;
        k = next_block++;
      }
      Slot& slot = slots[k % ring];
      bool there = false;
      try {
        there = work(k, state, slot.result);
      } catch (...) {
        std::lock_guard lock(mutex);
        fail_locked();
        return;
      }
      std::unique_lock lock(mutex);
      if (!there) {  // the blocks end before k: no thread works on another, take() stops at k
        if (k < blocks) blocks = k;
        changed.notify_all();
        return;
      }
      slot.block = k;
      slot.ready = true;
      take_ready(lock);
      changed.notify_all();
    }
  };
  std::vector<std::thread> pool;
  try {
    for (unsigned t = 1; t < threads; ++t) {
      pool.emplace_back([&] {
        auto state = make_state();
        worker(state);
      });
    }
  } catch (...) {  // no more threads to be had: those there are do the work
  }
  {
    auto state = make_state();
    worker(state);
  }
  // Every block is worked on or done: a block still under way on a helper is taken by the helper (a thread that
  // marks a block ready takes it unless another is taking, and a taker looks again before it stops).
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace saul::host::detail
