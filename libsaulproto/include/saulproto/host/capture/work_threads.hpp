// Threads that share a capture's work with the thread that starts them (decode's and stats' blocks on both cores,
// reading ahead, inflating ahead): start_beside() puts such a thread on another CPU at once.
//
// Why: on the 2-vCPU VM these paths are measured on, Linux queued a new thread on its creator's CPU and left it
// there until the load balancer moved it, 1 to 3 ms later (a scheduler tick), while the other CPU idled: `saulctl
// stats` of a 46 MB candump log ran single-threaded for its first ~2 ms of ~16 (its helper started 1.3-3.2 ms after
// it was made; placed on the other CPU, 0.02-0.03 ms after).
#pragma once

#include <pthread.h>
#include <sched.h>

#include <thread>

namespace saul::host {

/// Moves `helper`, a thread just started to work beside the caller, onto a CPU the caller may use other than the
/// one it runs on (the `index`-th such, for several helpers), then lets it run on any CPU the caller may use again:
/// the kernel leaves it where it is, so it starts there, and may move it later as it likes. Does nothing when the
/// caller may use one CPU only or the system refuses. Cost: three or four system calls.
inline void start_beside(std::thread& helper, unsigned index = 0) noexcept {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (!helper.joinable() || sched_getaffinity(0, sizeof allowed, &allowed) != 0) return;
  const int here = sched_getcpu();
  const int others = CPU_COUNT(&allowed) - (here >= 0 && CPU_ISSET(here, &allowed) ? 1 : 0);
  if (others <= 0) return;
  auto skip = static_cast<int>(index % static_cast<unsigned>(others));
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
    if (!CPU_ISSET(cpu, &allowed) || cpu == here || skip-- > 0) continue;
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpu, &one);
    // The first call moves the thread to `cpu` and wakes that CPU; the second allows every CPU again, where it stays.
    // (A helper that has already ended has no thread id left: glibc then applies both calls to the caller, whose
    // mask ends as it was.)
    if (pthread_setaffinity_np(helper.native_handle(), sizeof one, &one) == 0)
      pthread_setaffinity_np(helper.native_handle(), sizeof allowed, &allowed);
    return;
  }
}

}  // namespace saul::host
