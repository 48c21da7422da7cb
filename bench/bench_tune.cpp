// The tuning analysis (saulproto/host/tune) on a 10-minute 1 kHz trace: 600 000 records of a second-order loop
// under a PRBS setpoint with a 17 Hz wobble in the rate, as `saulctl tune report` analyses them (the goal: within
// 1 s on one core; bench/tune_oracle.py times scipy doing the same work). Run: saul_bench --benchmark_filter=Tune
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>

#include "saulproto/host/tune/analysis.hpp"

namespace {

using saul::host::tune::Series;

/// zeta 0.5, fn 3 Hz, stepped with semi-implicit Euler at 1 kHz: a realistic shape, not a reference.
Series ten_minutes(std::size_t n = 600'000) {
  Series s;
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.02);
  const double dt = 1e-3, wn = 2 * std::numbers::pi * 3.0, zeta = 0.5;
  double pitch = 0, rate = 0, sp = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (i % 200 == 0) sp = (rng() & 1U) ? 0.5 : -0.5;
    rate += (wn * wn * (sp - pitch) - 2 * zeta * wn * rate) * dt;
    pitch += rate * dt;
    const double t = static_cast<double>(i) * dt;
    const double wobble = 4.0 * std::sin(2 * std::numbers::pi * 17.3 * t);
    s.time_s.push_back(t);
    s.setpoint_deg.push_back(sp);
    s.pitch_deg.push_back(pitch + noise(rng));
    s.rate_dps.push_back(rate + wobble + 20 * noise(rng));
    s.d_term.push_back(-1.5 * s.rate_dps.back());
    s.output.push_back(40 * (sp - s.pitch_deg.back()) + s.d_term.back());
    s.line.push_back(i + 2);
  }
  return s;
}

void BM_TuneAnalyse600k(benchmark::State& state) {
  const Series s = ten_minutes();
  for (auto _ : state) {
    auto report = saul::host::tune::analyse(s);
    benchmark::DoNotOptimize(report.step);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * s.size()));
}
BENCHMARK(BM_TuneAnalyse600k)->Unit(benchmark::kMillisecond);

}  // namespace
