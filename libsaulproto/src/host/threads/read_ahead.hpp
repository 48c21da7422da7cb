// Two-stage pipelines over a fixed ring of slots: a second thread produces into slot after slot (reading and
// parsing a capture) while the caller's thread consumes them in the same order (decoding, counting, writing), up to
// the ring's size apart. Results stay exactly those of one thread: the consumer sees every slot in order.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>

namespace saul::host {

/// Batches a reading thread keeps ready ahead of their consumer.
inline constexpr std::size_t kAheadBatches = 4;

/// Calls produce(k % slots) -> bool on a new thread for k = 0, 1, ... until it returns false, and consume(k % slots)
/// on this thread for every slot produced, in order; slot k % slots is produced again only after its consume
/// returned. Rethrows what produce or consume threw (after stopping and joining the thread).
template <class Produce, class Consume>
void read_ahead(std::size_t slots, Produce&& produce, Consume&& consume) {
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t produced = 0, consumed = 0;
  bool done = false, stop = false;
  std::exception_ptr failure;
  std::thread producer([&] {
    try {
      for (std::size_t k = 0;; ++k) {
        {
          std::unique_lock lock(mutex);
          changed.wait(lock, [&] { return stop || k < consumed + slots; });
          if (stop) break;
        }
        if (!produce(k % slots)) break;
        std::lock_guard lock(mutex);
        ++produced;
        changed.notify_all();
      }
    } catch (...) {
      std::lock_guard lock(mutex);
      failure = std::current_exception();
    }
    std::lock_guard lock(mutex);
    done = true;
    changed.notify_all();
  });
  try {
    for (std::size_t k = 0;; ++k) {
      {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return done || k < produced; });
        if (k >= produced) break;  // done, and every slot produced was consumed
      }
      consume(k % slots);
      std::lock_guard lock(mutex);
      ++consumed;
      changed.notify_all();
    }
  } catch (...) {
    {
      std::lock_guard lock(mutex);
      stop = true;
      changed.notify_all();
    }
    producer.join();
    throw;
  }
  producer.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace saul::host
