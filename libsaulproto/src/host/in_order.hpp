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

/// Calls work(k, state, result) for every block k in [0, blocks) on `threads` threads, and take(k, result) on the
/// caller's thread for k = 0, 1, 2... in that order. Each thread has its own `state`, made on it by make_state()
/// (a prvalue: it need not be movable), kept from block to block. At most 2 x threads blocks are worked ahead of
/// take(): memory is that many Results, whatever the number of blocks. Results are slots that are reused, so
/// work() starts by resetting what it fills. What work() or take() throws stops every thread (the blocks under
/// way finish first) and is rethrown here.
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
  std::size_t next_block = 0;  // the next block a worker takes
  std::size_t taken = 0;       // blocks handed to take()
  std::exception_ptr failure;
  bool stop = false;
  auto fail = [&] {
    std::lock_guard lock(mutex);
    if (!failure) failure = std::current_exception();
    stop = true;
    changed.notify_all();
  };

  auto worker = [&] {
    auto state = make_state();
    for (;;) {
      std::size_t k;
      {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return stop || next_block >= blocks || next_block < taken + ring; });
        if (stop || next_block >= blocks) return;
        k = next_block++;
      }
      Slot& slot = slots[k % ring];
      try {
        work(k, state, slot.result);
      } catch (...) {
        fail();
        return;
      }
      std::lock_guard lock(mutex);
      slot.block = k;
      slot.ready = true;
      changed.notify_all();
    }
  };
  std::vector<std::thread> pool;
  try {
    for (unsigned t = 0; t < threads; ++t) pool.emplace_back(worker);
  } catch (...) {  // no thread to be had: the threads that started do all the work, or none did and it is done here
    if (pool.empty()) {
      auto state = make_state();
      for (std::size_t k = 0; k < blocks; ++k) {
        work(k, state, slots[0].result);
        take(k, slots[0].result);
      }
      return;
    }
  }

  try {
    while (taken < blocks) {
      Slot& slot = slots[taken % ring];
      {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return stop || (slot.ready && slot.block == taken); });
        if (stop) break;
      }
      take(taken, slot.result);
      std::lock_guard lock(mutex);
      slot.ready = false;
      ++taken;
      changed.notify_all();
    }
  } catch (...) {
    fail();
  }
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace saul::host::detail
