// start_beside(): a helper thread is put on another CPU to start, then left free to run on every CPU its creator may
// use (a helper left pinned to one CPU would share it with its creator whenever the kernel moves the creator there).
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <thread>

#include "saulproto/host/capture/work_threads.hpp"

using saul::host::start_beside;

namespace {

/// The thread's CPU mask; `ok` false when it could not be read (checked once the thread is joined: a REQUIRE that
/// throws before would leave it running).
cpu_set_t affinity_of(std::thread& t, bool& ok) {
  cpu_set_t set;
  CPU_ZERO(&set);
  ok = pthread_getaffinity_np(t.native_handle(), sizeof set, &set) == 0;
  return set;
}

}  // namespace

TEST_CASE("a helper started beside its creator may run on every CPU its creator may use afterwards") {
  cpu_set_t mine;
  CPU_ZERO(&mine);
  REQUIRE(sched_getaffinity(0, sizeof mine, &mine) == 0);
  for (unsigned index = 0; index < 3; ++index) {
    std::atomic<bool> go{false};
    std::atomic<int> ran_on{-1};
    std::thread helper([&] {
      while (!go.load()) std::this_thread::yield();
      ran_on = sched_getcpu();
    });
    start_beside(helper, index);
    bool read = false;
    const cpu_set_t after = affinity_of(helper, read);
    go = true;
    helper.join();
    REQUIRE(read);
    CHECK(CPU_EQUAL(&after, &mine));
    CHECK(ran_on.load() >= 0);
  }
}

TEST_CASE("start_beside leaves alone a helper whose creator may use one CPU, and a thread that is not there") {
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
  std::thread helper([&] {
    while (!go.load()) std::this_thread::yield();
  });
  start_beside(helper);
  bool read = false;
  const cpu_set_t after = affinity_of(helper, read);
  go = true;
  helper.join();
  REQUIRE(read);
  CHECK(CPU_EQUAL(&after, &one));
}
