// The loop trace's cost (docs/protocol.md section 10, firmware/README.md): what a loop iteration of BALANCE pays for
// its record (built, kept in the flight recorder's ring, encoded and written when streaming), and how fast the
// simulated robot records a trace (`saulctl tune record --sim`).
// Run: build-release/bench/saul_bench --benchmark_filter=Trace (see bench/README.md)
#include <benchmark/benchmark.h>

#include "saulfw/trace.hpp"
#include "saulsim/trace_run.hpp"
#include "saulsim/world.hpp"

namespace {

using namespace saul;

/// A simulated robot armed and balancing (the 3 s button hold, as `tune record --sim` arms it).
std::unique_ptr<sim::World> balancing_world() {
  auto w = std::make_unique<sim::World>();
  w->run_until(1'500'000);
  (void)w->command("button down");
  w->run_until(4'700'000);
  (void)w->command("button up");
  w->run_until(7'000'000);
  return w;
}

// One step of the whole simulated robot (plant, both boards, the bus), BALANCE balancing, with the trace off or on
// (arg 1: a record every loop, written into the console and taken out as a reader would). The difference between
// the two is what the trace costs a loop (the ring records in both).
void BM_TraceWorldStep(benchmark::State& state) {
  auto w = balancing_world();
  if (state.range(0) != 0) w->console_input("balance", "trace on\n");
  std::uint64_t n = 0;
  for (auto _ : state) {
    w->step();
    benchmark::DoNotOptimize(w->take_console_output("balance"));
    if (++n % 64 == 0) (void)w->take_can_output();
  }
  if (w->balance().state() != saulcan::RobotState::balance) state.SkipWithError("the robot fell");
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TraceWorldStep)->Arg(0)->Arg(1);

// The trace's own work per loop: one record encoded (39 bytes) and kept in the 175 000-byte ring.
void BM_TraceRecordAndRing(benchmark::State& state) {
  static fw::FlightRecorder ring;  // 175 kB: not on the stack
  trace::LoopTrace r{};
  std::uint8_t frame[trace::kFrameSize];
  for (auto _ : state) {
    ++r.seq;
    r.time_us += 1000;
    r.pitch_x100 = static_cast<std::int16_t>(r.seq & 0x3FF);
    ring.record(r);
    benchmark::DoNotOptimize(trace::encode(r, frame));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TraceRecordAndRing);

// `saulctl tune record --sim` for arg seconds of trace (600: the 10 minutes, 600 000 records): records per
// second of wall time; the counter x_real_time is simulated seconds per wall second.
void BM_TraceSimRecord(benchmark::State& state) {
  sim::TraceRunOptions options;
  options.seed = 3;
  options.duration_us = static_cast<fw::TimeUs>(state.range(0)) * 1'000'000;
  std::uint64_t records = 0, gaps = 0;
  double simulated = 0;
  for (auto _ : state) {
    std::uint64_t bytes = 0;
    const auto r = sim::run_sim_trace(options, [&](std::span<const std::uint8_t> b) { bytes += b.size(); },
                                      [] { return false; });
    if (!r.ok) state.SkipWithError(r.stopped.c_str());
    records += r.records;
    gaps += r.gaps;
    simulated += r.simulated_s;
    benchmark::DoNotOptimize(bytes);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(records));
  state.counters["records"] = benchmark::Counter(static_cast<double>(records), benchmark::Counter::kAvgIterations);
  state.counters["gaps"] = static_cast<double>(gaps);
  state.counters["x_real_time"] = benchmark::Counter(simulated, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TraceSimRecord)->Arg(10)->Arg(600)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
