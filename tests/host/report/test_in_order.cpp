// The engine under decode's and stats' two-core paths (host/threads/in_order.hpp, private to the host library), on
// its own:
// on many random runs (1-4 threads, blocks of random cost, known or found count, failures in work and in take) every
// block is taken once, in order, one take at a time, never more than 2 x threads blocks ahead of take, and a failure
// comes out with every thread joined.
#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <random>
#include <stdexcept>
#include <thread>
#include <vector>

#include "../../../libsaulproto/src/host/threads/in_order.hpp"

using saul::host::detail::kBlocksUntilNone;
using saul::host::detail::run_blocks_in_order;

namespace {

struct Result {
  std::size_t block = 0;
  std::size_t value = 0;
};

/// A little work whose length varies (no sleeps: the order threads finish in is what varies).
std::size_t busy(std::size_t rounds) {
  std::size_t x = rounds;
  for (std::size_t i = 0; i < rounds; ++i) x = x * 6364136223846793005ULL + 1442695040888963407ULL;
  return x;
}

}  // namespace

TEST_CASE("blocks in order: every block taken once, in order, one at a time, at most 2 x threads ahead") {
  std::mt19937_64 rng(42);
  for (int run = 0; run < 300; ++run) {
    const unsigned threads = 1 + static_cast<unsigned>(rng() % 4);
    const std::size_t n = rng() % 60;
    const bool found = rng() % 2 == 0;  // the count is found by work() saying there is no block n
    std::vector<std::size_t> cost(n + 4);
    for (auto& c : cost) c = rng() % 4 == 0 ? 20000 + rng() % 100000 : rng() % 2000;
    INFO("run " << run << ": " << threads << " threads, " << n << " blocks" << (found ? ", found" : ""));
    std::atomic<std::size_t> taken{0};
    std::atomic<int> in_take{0};
    std::atomic<bool> overlap{false}, too_far{false}, wrong{false};
    std::vector<std::size_t> order;
    std::atomic<int> states{0};
    run_blocks_in_order<Result>(
        found ? kBlocksUntilNone : n, threads,
        [&] {
          ++states;
          return 0;
        },
        [&](std::size_t k, int&, Result& r) {
          if (k >= taken.load() + 2 * std::size_t{threads}) too_far = true;
          if (found && k >= n) return false;
          r.block = k;
          r.value = busy(cost[k]);
          return true;
        },
        [&](std::size_t k, Result& r) {
          if (in_take.fetch_add(1) != 0) overlap = true;
          if (r.block != k || r.value != busy(cost[k])) wrong = true;
          order.push_back(k);
          taken = k + 1;
          in_take.fetch_sub(1);
        });
    std::vector<std::size_t> expected(n);
    for (std::size_t k = 0; k < n; ++k) expected[k] = k;
    CHECK(order == expected);
    CHECK_FALSE(overlap);
    CHECK_FALSE(too_far);
    CHECK_FALSE(wrong);
    CHECK(states == static_cast<int>(threads));  // a state per thread, the caller's included
  }
}

TEST_CASE("blocks in order: what work() or take() throws comes out, after the blocks before it were taken in order") {
  std::mt19937_64 rng(43);
  for (int run = 0; run < 200; ++run) {
    const unsigned threads = 1 + static_cast<unsigned>(rng() % 4);
    const std::size_t n = 5 + rng() % 50;
    const std::size_t bad = rng() % n;
    const bool in_take = rng() % 2 == 0;
    INFO("run " << run << ": " << threads << " threads, block " << bad << " fails in " << (in_take ? "take" : "work"));
    std::vector<std::size_t> order;
    auto go = [&] {
      run_blocks_in_order<Result>(
          n, threads, [] { return 0; },
          [&](std::size_t k, int&, Result& r) {
            if (!in_take && k == bad) throw std::runtime_error("work failed");
            r.block = k;
            r.value = busy(k % 7 == 0 ? 50000 : 500);
            return true;
          },
          [&](std::size_t k, Result&) {
            if (in_take && k == bad) throw std::runtime_error("take failed");
            order.push_back(k);
          });
    };
    REQUIRE_THROWS_WITH(go(), in_take ? "take failed" : "work failed");
    // in order, none after the failure (blocks after it may have been worked, none taken)
    REQUIRE(order.size() <= bad);
    for (std::size_t k = 0; k < order.size(); ++k) CHECK(order[k] == k);
  }
}
