// Throughput of the core decoders: the inter-board UART stream decoder (bytes/s) and CAN dispatch (frames/s).
// Run: build/bench/saul_bench --benchmark_filter=. (see bench/README.md)
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/core/interboard.hpp"
#include "saulproto/core/saul_can.hpp"

namespace {

using namespace saul;

// A realistic link: back-to-back RC_CMD/SENSOR/STATE frames, no noise.
std::vector<std::uint8_t> clean_uart_stream(std::size_t bytes) {
  std::vector<std::uint8_t> out;
  std::uint8_t buf[interboard::kMaxFrameSize];
  std::int16_t i = 0;
  while (out.size() < bytes) {
    const interboard::Message ms[] = {interboard::RcCmd{i, static_cast<std::int16_t>(-i), 1},
                                      interboard::Sensor{1000, -3, 0}, interboard::State{i, 10, 1}};
    for (const auto& m : ms) {
      auto n = interboard::encode(m, buf);
      out.insert(out.end(), buf, buf + *n);
    }
    ++i;
  }
  return out;
}

void BM_UartDecodeClean(benchmark::State& state) {
  const auto stream = clean_uart_stream(1 << 20);
  std::size_t frames = 0;
  for (auto _ : state) {
    interboard::StreamDecoder d;
    for (auto b : stream)
      if (d.push(b)) ++frames;
    benchmark::DoNotOptimize(frames);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * stream.size()));
}
BENCHMARK(BM_UartDecodeClean);

// Worst case for resync: random bytes with a 0xAA every few bytes, so most candidates are rejected.
void BM_UartDecodeNoise(benchmark::State& state) {
  std::mt19937 rng(1);
  std::vector<std::uint8_t> stream(1 << 20);
  for (auto& b : stream) b = (rng() % 4 == 0) ? 0xAA : static_cast<std::uint8_t>(rng() % 6);
  std::size_t frames = 0;
  for (auto _ : state) {
    interboard::StreamDecoder d;
    for (auto b : stream)
      if (d.push(b)) ++frames;
    benchmark::DoNotOptimize(frames);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * stream.size()));
}
BENCHMARK(BM_UartDecodeNoise);

void BM_CanDispatch(benchmark::State& state) {
  std::vector<CanFrame> frames;
  for (int i = 0; i < 1024; ++i) {
    frames.push_back(saulcan::encode(saulcan::VelocityCmd{static_cast<std::int16_t>(i), 5}));
    frames.push_back(saulcan::encode(saulcan::TelemetryA{static_cast<std::int16_t>(i), 1, 2, saulcan::RobotState::balance}));
    frames.push_back(saulcan::encode(saulcan::TelemetryB{1, 2, 39000, 0}));
    frames.push_back(saulcan::encode(saulcan::PidGain{saulcan::Gain::kp, 1, 1.5F}));
  }
  std::size_t ok = 0;
  for (auto _ : state) {
    for (const auto& f : frames)
      if (decode_bus_frame(f)) ++ok;
    benchmark::DoNotOptimize(ok);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * frames.size()));
}
BENCHMARK(BM_CanDispatch);

}  // namespace

BENCHMARK_MAIN();
