// start_beside(): a helper thread is put on another CPU to start, then left free to run on every CPU its creator may
// use (a helper left pinned to one CPU would share it with its creator whenever the kernel moves the creator there).
//
// The first case makes the move observable: the helper starts pinned to its creator's CPU, so it can run nowhere
// else unless start_beside() moves it; it then reports the CPU it runs on until it has run on another one. Without
// the move (an empty start_beside) it never leaves, its mask stays one CPU, and the case fails.
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <thread>

#include "saulproto/host/capture/work_threads.hpp"

using saul::host::start_beside;

namespace {

/// What a helper started with start_beside(helper, index) showed: its CPU mask right after (`read`: whether it
/// could be read), the CPU its creator was on, and a CPU other than that one it ran on (-1: none within the wait).
struct Started {
  cpu_set_t mask;
  bool read = false;
  int creator_cpu = -1;
  int ran_elsewhere = -1;
};

/// Starts a helper pinned to the CPU this thread is on, calls start_beside on it and waits (up to 5 s, spinning, so
/// this thread keeps its CPU busy and the helper is not pulled back to it) until the helper has run on another CPU.
/// The helper is joined here, so a failed check in the test cannot leave it running. Retried when this thread
/// itself moved to another CPU during the call (start_beside moves the helper off the CPU its caller is on then).
Started start_one_beside(unsigned index) {
  for (int attempt = 0;; ++attempt) {
    Started s;
    CPU_ZERO(&s.mask);
    std::atomic<bool> go{false};
    std::atomic<bool> watching{false};  // set once start_beside has returned: CPUs seen before do not count
    std::atomic<int> here{-1};
    std::atomic<int> elsewhere{-1};
    std::thread helper([&] {
      while (!go.load()) {
        if (watching.load() && elsewhere.load() < 0) {
          const int cpu = sched_getcpu();
          if (cpu >= 0 && cpu != here.load()) elsewhere = cpu;
        }
        std::this_thread::yield();
      }
    });
    const int cpu = sched_getcpu();
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpu, &one);
    here = cpu;
    // pinned to this CPU (the call returns once the helper has moved there), as a new thread is queued on its creator's
    const bool pinned = pthread_setaffinity_np(helper.native_handle(), sizeof one, &one) == 0;
    start_beside(helper, index);
    watching = true;
    const bool stayed = sched_getcpu() == cpu;
    s.read = pthread_getaffinity_np(helper.native_handle(), sizeof s.mask, &s.mask) == 0;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (pinned && elsewhere.load() < 0 && std::chrono::steady_clock::now() < until) {
    }
    go = true;
    helper.join();
    s.creator_cpu = cpu;
    s.ran_elsewhere = elsewhere.load();
    if (!pinned) s.read = false;
    if (stayed || attempt == 4) return s;
  }
}

}  // namespace

TEST_CASE("start_beside moves a helper off its creator's CPU, then lets it run on every CPU its creator may use") {
  cpu_set_t mine;
  CPU_ZERO(&mine);
  REQUIRE(sched_getaffinity(0, sizeof mine, &mine) == 0);
  if (CPU_COUNT(&mine) < 2) {
    WARN("this process may use one CPU only: nothing to move a helper to");
    return;
  }
  for (unsigned index = 0; index < 3; ++index) {
    const Started s = start_one_beside(index);
    REQUIRE(s.read);
    CHECK(CPU_EQUAL(&s.mask, &mine));  // pinned to one CPU before the call: start_beside gave it every CPU
    CHECK(s.ran_elsewhere >= 0);       // ... and it ran on another CPU than its creator's
    CHECK(s.ran_elsewhere != s.creator_cpu);
  }
}

TEST_CASE("start_beside leaves alone a helper whose creator may use one CPU, and a thread that is not there") {
  // The do-nothing branch: a start_beside that ignored its caller's mask (moving the helper to any online CPU)
  // fails it.
  cpu_set_t mine;
  CPU_ZERO(&mine);
  REQUIRE(sched_getaffinity(0, sizeof mine, &mine) == 0);
  std::thread none;
  start_beside(none);  // not joinable: nothing to move
  // this thread alone on the CPU it runs on: a helper it starts inherits that and stays there
  const int here = sched_getcpu();
  REQUIRE(here >= 0);
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(here, &one);
  REQUIRE(sched_setaffinity(0, sizeof one, &one) == 0);
  struct Restore {  // whatever fails below, the tests after this one run on every CPU again
    const cpu_set_t& mask;
    ~Restore() { sched_setaffinity(0, sizeof mask, &mask); }
  } restore{mine};
  std::atomic<bool> go{false};
  std::atomic<int> ran_on{-1};
  std::thread helper([&] {
    while (!go.load()) std::this_thread::yield();
    ran_on = sched_getcpu();
  });
  start_beside(helper);
  cpu_set_t mask;
  CPU_ZERO(&mask);
  const bool read = pthread_getaffinity_np(helper.native_handle(), sizeof mask, &mask) == 0;
  go = true;
  helper.join();
  REQUIRE(read);
  CHECK(CPU_EQUAL(&mask, &one));
  CHECK(ran_on.load() == here);
}
