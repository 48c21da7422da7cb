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

/// A helper that waits to be let go, started beside this thread with start_beside(helper, index): its CPU mask
/// right after (`read`: whether it could be read) and the CPU it ran on once let go. Joined here, so a failed check
/// in the test cannot leave it running.
struct Started {
  cpu_set_t mask;
  bool read = false;
  int ran_on = -1;
};
Started start_one_beside(unsigned index) {
  Started s;
  CPU_ZERO(&s.mask);
  std::atomic<bool> go{false};
  std::atomic<int> ran_on{-1};
  std::thread helper([&] {
    while (!go.load()) std::this_thread::yield();
    ran_on = sched_getcpu();
  });
  start_beside(helper, index);
  s.read = pthread_getaffinity_np(helper.native_handle(), sizeof s.mask, &s.mask) == 0;
  go = true;
  helper.join();
  s.ran_on = ran_on.load();
  return s;
}

}  // namespace

TEST_CASE("a helper started beside its creator may run on every CPU its creator may use afterwards") {
  cpu_set_t mine;
  CPU_ZERO(&mine);
  REQUIRE(sched_getaffinity(0, sizeof mine, &mine) == 0);
  for (unsigned index = 0; index < 3; ++index) {
    const Started s = start_one_beside(index);
    REQUIRE(s.read);
    CHECK(CPU_EQUAL(&s.mask, &mine));
    CHECK(s.ran_on >= 0);
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
  const Started s = start_one_beside(0);
  REQUIRE(s.read);
  CHECK(CPU_EQUAL(&s.mask, &one));
  CHECK(s.ran_on == here);
}
