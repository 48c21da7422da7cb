// Capture decoding throughput: a generated in-memory candump log of 1 000 000 lines read by the host candump reader
// (saulproto/host/capture/candump.hpp) and every frame decoded by the bus dispatch (decode_bus_frame), as `saulctl decode`
// does before formatting. Reports frames/s. Run: build/bench/saul_bench --benchmark_filter=CandumpDecode
#include <benchmark/benchmark.h>

#include <cstdio>
#include <sstream>
#include <string>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture/candump.hpp"

namespace {

constexpr std::size_t kLines = 1'000'000;

// The robot's traffic mix, as in captures/robot_bus.log: SAUL commands and telemetry, VESC SET_RPM and status.
std::string generated_log(std::size_t lines) {
  static constexpr const char* kFrames[] = {
      "300#E8030CFE",          "400#06FFA4012C0101",        "401#B00464FBB09A11",        "00000344#000005DC",
      "00000338#FFFFFA24",     "00000944#00000093000C000B", "00000938#FFFFFB50002300FA", "301#000700000000C03F",
      "00001B38#000001D1018C0000", "402#010703",            "302#01",                    "303#D007DC05",
  };
  std::string out;
  out.reserve(lines * 48);
  char stamp[40];
  for (std::size_t i = 0; i < lines; ++i) {
    const std::uint64_t us = 1'763'800'000'000'000ULL + i * 500;  // 2000 frames/s
    std::snprintf(stamp, sizeof stamp, "(%llu.%06llu) can0 ", static_cast<unsigned long long>(us / 1'000'000),
                  static_cast<unsigned long long>(us % 1'000'000));
    out += stamp;
    out += kFrames[i % (sizeof kFrames / sizeof kFrames[0])];
    out += '\n';
  }
  return out;
}

void BM_CandumpDecode(benchmark::State& state) {
  const std::string log = generated_log(kLines);
  std::uint64_t frames = 0;
  for (auto _ : state) {
    std::istringstream in(log);
    saul::host::CandumpReader reader(in);
    std::uint64_t decoded = 0, read = 0;
    for (saul::host::FrameBatch batch; reader.next_batch(batch);) {
      read += batch.frames.size();
      for (const saul::CanFrame& frame : batch.frames)
        if (saul::decode_bus_frame(frame)) ++decoded;
    }
    if (read != kLines || decoded != kLines) state.SkipWithError("not every generated line decoded");
    frames += read;
    benchmark::DoNotOptimize(decoded);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(frames));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * log.size()));
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CandumpDecode)->Unit(benchmark::kMillisecond);

}  // namespace
