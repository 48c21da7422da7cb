// The tuning analysis (analysis.hpp): timing and gaps first, then what any rate can say, then the step response
// and the spectra when the rate allows them.
#include "saulproto/host/tune/analysis.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <numeric>

#include "fft.hpp"

// Test-only: the mutants the tuning checks must catch (tests/tune/README.md). Define SAUL_TUNE_MUTANT to 1 (the
// sample period 10 % off), 2 (no window: rectangular) or 3 (no regularisation) and rerun tests/tune.
#ifndef SAUL_TUNE_MUTANT
#define SAUL_TUNE_MUTANT 0
#endif

namespace saul::host::tune {
namespace {

constexpr std::size_t kMaxListed = 50;  // gaps and wind-ups listed (all are counted)

/// A stretch of records with no gap: [begin, end).
struct Segment {
  std::size_t begin = 0, end = 0;
};

/// Records in the longest segment: nothing longer is allocated for it (a time column in the wrong unit must not
/// ask for gigabytes).
std::size_t longest(const std::vector<Segment>& segments) {
  std::size_t most = 0;
  for (const auto& seg : segments) most = std::max(most, seg.end - seg.begin);
  return most;
}

std::size_t next_pow2(std::size_t n) {
  std::size_t p = 1;
  while (p < n) p <<= 1U;
  return p;
}

/// The smallest 2^a 3^b 5^c >= n: FFTW's fast sizes. 9 500 (8 s + 1.5 s at 1 kHz) becomes 9 600, not 16 384, and
/// FFTW_ESTIMATE's plan for it runs several times faster.
std::size_t next_fast_size(std::size_t n) {
  for (std::size_t m = std::max<std::size_t>(n, 1);; ++m) {
    std::size_t r = m;
    for (const std::size_t f : {2U, 3U, 5U})
      while (r % f == 0) r /= f;
    if (r == 1) return m;
  }
}

/// The periodic Hann window (scipy's get_window("hann", n)): the FFT sees a smooth cycle.
std::vector<double> hann(std::size_t n) {
  std::vector<double> w(n);
  for (std::size_t k = 0; k < n; ++k)
    w[k] = SAUL_TUNE_MUTANT == 2 ? 1.0 : 0.5 - 0.5 * std::cos(2 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(n));
  return w;
}

/// The p-quantile of the values, linear between neighbours (numpy's default); reorders them. Two selections, not a
/// sort: 600 000 loop periods are a few ms less.
double quantile(std::vector<double>& values, double p) {
  const double at = p * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(at));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(lo), values.end());
  const double below = values[lo];
  const double above = lo + 1 < values.size()
                           ? *std::min_element(values.begin() + static_cast<std::ptrdiff_t>(lo) + 1, values.end())
                           : below;
  return below + (above - below) * (at - static_cast<double>(lo));
}

/// Running sums of a column: the mean of any window in O(1) instead of a pass over it.
std::vector<double> running_sums(const std::vector<double>& x) {
  std::vector<double> sums(x.size() + 1, 0.0);
  for (std::size_t i = 0; i < x.size(); ++i) sums[i + 1] = sums[i] + x[i];
  return sums;
}

/// samples[0, w.size()) = (x[begin + k] - mean) * w[k]; what follows in samples (the zero padding) is left alone.
void load_window(std::span<double> samples, const std::vector<double>& x, std::size_t begin, double mean,
                 const std::vector<double>& w) {
  const double* in = x.data() + begin;
  for (std::size_t k = 0; k < w.size(); ++k) samples[k] = (in[k] - mean) * w[k];
}

/// The mean of x over [begin, begin + length) from its running sums.
double window_mean(const std::vector<double>& sums, std::size_t begin, std::size_t length) {
  return (sums[begin + length] - sums[begin]) / static_cast<double>(length);
}

void timing(const Series& s, Report& r, std::vector<Segment>& segments) {
  std::vector<double> dt(s.size() - 1);
  for (std::size_t i = 1; i < s.size(); ++i) dt[i - 1] = s.time_s[i] - s.time_s[i - 1];
  std::vector<double> periods = dt;
  const double median = quantile(periods, 0.5);
  const double period = median * (SAUL_TUNE_MUTANT == 1 ? 1.1 : 1.0);
  r.sample_rate_hz = 1.0 / period;
  // A trace of every N-th iteration (`trace on N`, tune record --divider) steps its loop counter by N: the loop's
  // period is the record's over N, and a counter step of N loses nothing.
  if (!s.seq.empty()) {
    std::vector<double> steps;
    for (std::size_t i = 1; i < s.seq.size(); ++i)
      if (s.seq[i] > s.seq[i - 1]) steps.push_back(s.seq[i] - s.seq[i - 1]);
    if (!steps.empty())
      r.loop_divider = static_cast<std::uint64_t>(std::max<long long>(1, std::llround(quantile(steps, 0.5))));
  }
  const double per_iteration = 1e6 / static_cast<double>(r.loop_divider);
  r.period_p50_us = median * per_iteration;
  r.period_p99_us = quantile(periods, 0.99) * per_iteration;
  r.period_max_us = *std::max_element(periods.begin(), periods.end()) * per_iteration;
  std::size_t begin = 0;
  for (std::size_t i = 0; i < dt.size(); ++i) {
    if (dt[i] <= 1.5 * period) continue;  // one iteration late is jitter; a missing one is a gap
    const auto missed = static_cast<std::uint64_t>(std::max<long long>(1, std::llround(dt[i] / period) - 1));
    r.missed_iterations += missed;
    if (r.gaps.size() < kMaxListed)
      r.gaps.push_back({s.time_s[i] - s.time_s[0], dt[i], s.line.empty() ? i + 1 : s.line[i + 1], missed});
    ++r.gaps_total;
    segments.push_back({begin, i + 1});
    begin = i + 1;
  }
  segments.push_back({begin, s.size()});
  if (!s.seq.empty()) {
    std::uint64_t missing = 0;
    const auto n = static_cast<double>(r.loop_divider);
    for (std::size_t i = 1; i < s.seq.size(); ++i)  // a counter going back (a restart, a wrap) is no loss
      if (s.seq[i] > s.seq[i - 1] + n)
        missing += static_cast<std::uint64_t>(std::max<long long>(1, std::llround((s.seq[i] - s.seq[i - 1]) / n) - 1));
    r.seq_missing = missing;
  }
}

/// The segments cut to the records in BALANCE (when there is a state column): a fall, the robot lying in OFF or a
/// fault's transient is no response of the balance loop and must not enter its step response or spectra.
std::vector<Segment> balancing(const Series& s, const std::vector<Segment>& segments) {
  if (s.state.empty()) return segments;
  std::vector<Segment> out;
  for (const auto& seg : segments) {
    std::size_t i = seg.begin;
    while (i < seg.end) {
      while (i < seg.end && s.state[i] != 1) ++i;
      const std::size_t start = i;
      while (i < seg.end && s.state[i] == 1) ++i;
      if (i > start) out.push_back({start, i});
    }
  }
  return out;
}

/// Pitch RMS, offset and drift over the balancing records; saturation, falls, wind-up, excitation share.
void basics(const Series& s, const AnalysisOptions& opt, Report& r) {
  const bool has_state = !s.state.empty();
  double sum = 0, sum2 = 0, st = 0, stt = 0, ste = 0;
  std::uint64_t n = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (has_state && s.state[i] != 1) continue;
    const double e = s.pitch_deg[i] - (s.setpoint_deg.empty() ? 0.0 : s.setpoint_deg[i]);
    const double t = s.time_s[i] - s.time_s[0];
    sum += e, sum2 += e * e, st += t, stt += t * t, ste += t * e;
    ++n;
  }
  r.balancing_records = n;
  if (n > 0) {
    const auto nn = static_cast<double>(n);
    r.pitch_offset_deg = sum / nn;
    r.pitch_rms_deg = std::sqrt(sum2 / nn);
    const double var_t = stt / nn - (st / nn) * (st / nn);
    if (var_t > 0) r.pitch_drift_deg_per_min = (ste / nn - st / nn * (sum / nn)) / var_t * 60.0;
  }
  const double limit = opt.output_limit - 0.5;  // the output is a whole number of permille
  if (!s.output.empty()) {
    const auto saturated = std::count_if(s.output.begin(), s.output.end(), [&](double o) { return std::abs(o) >= limit; });
    r.saturation_pct = 100.0 * static_cast<double>(saturated) / static_cast<double>(s.size());
  }
  if (has_state)
    for (std::size_t i = 1; i < s.size(); ++i)
      if (s.state[i] == 4 && s.state[i - 1] != 4) ++r.falls;
  if (!s.excite.empty())
    r.excite_pct = 100.0 * static_cast<double>(std::count(s.excite.begin(), s.excite.end(), 1)) /
                   static_cast<double>(s.size());
  if (!s.i_term.empty() && !s.output.empty()) {
    std::vector<Windup> windups;
    // Where the wind-up under way began (none: not winding). Not a std::optional: GCC 12 at -O1 takes its value
    // for "maybe used uninitialised".
    constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
    std::size_t start = kNone;
    double peak = 0;
    for (std::size_t i = 0; i <= s.size(); ++i) {
      const bool winding = i < s.size() && std::abs(s.output[i]) >= limit &&
                           std::abs(s.i_term[i]) >= opt.windup_fraction * opt.output_limit &&
                           (s.i_term[i] > 0) == (s.output[i] > 0);
      if (winding) {
        if (start == kNone) start = i, peak = 0;
        peak = std::max(peak, std::abs(s.i_term[i]));
      } else if (start != kNone) {
        const double duration = s.time_s[i - 1] - s.time_s[start] + 1.0 / r.sample_rate_hz;
        if (duration >= opt.windup_min_s && windups.size() < kMaxListed)
          windups.push_back({s.time_s[start] - s.time_s[0], duration, peak});
        start = kNone;
      }
    }
    r.windups = std::move(windups);
  }
}

/// H1 deconvolution over the windows of every gap-free segment.
void estimate_step(const Series& s, const std::vector<Segment>& segments, const AnalysisOptions& opt, Report& r) {
  const double fs = r.sample_rate_hz;
  const auto length = static_cast<std::size_t>(std::lround(opt.window_s * fs));
  const auto hop = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(opt.hop_s * fs)));
  const auto kept = static_cast<std::size_t>(std::lround(opt.response_s * fs));
  if (length < 8 || length > longest(segments)) {
    r.step_reason = fmt::format("the trace has no gap-free stretch of {:g} s (one deconvolution window)", opt.window_s);
    return;
  }
  const std::size_t n = next_fast_size(length + kept);
  detail::RealFft fx(n), fy(n);  // one per signal: both spectra stay where FFTW put them
  std::fill(fx.samples().begin(), fx.samples().end(), 0.0);  // the padding after each window: written once
  std::fill(fy.samples().begin(), fy.samples().end(), 0.0);
  const auto w = hann(length);
  const auto sp_sums = running_sums(s.setpoint_deg);
  const auto pitch_sums = running_sums(s.pitch_deg);
  std::vector<std::complex<double>> sxy(fx.bins());
  std::vector<double> sxx(fx.bins());
  std::vector<double> block_lo, block_hi;
  StepResponse step;
  step.dt_s = 1.0 / fs;
  for (const auto& seg : segments) {
    // The setpoint's range per hop-long block from the segment's start (where the windows start): a window's
    // range is then its whole blocks' and a scan of the rest, not a pass over all its samples.
    block_lo.clear();
    block_hi.clear();
    for (std::size_t b = seg.begin; b < seg.end; b += hop) {
      const auto [lo, hi] = std::minmax_element(s.setpoint_deg.begin() + static_cast<std::ptrdiff_t>(b),
                                                s.setpoint_deg.begin() + static_cast<std::ptrdiff_t>(std::min(b + hop, seg.end)));
      block_lo.push_back(*lo);
      block_hi.push_back(*hi);
    }
    const std::size_t whole = length / hop;
    for (std::size_t b = seg.begin, j = 0; b + length <= seg.end; b += hop, ++j) {
      ++step.windows_total;
      double lo = *std::min_element(block_lo.begin() + static_cast<std::ptrdiff_t>(j),
                                    block_lo.begin() + static_cast<std::ptrdiff_t>(j + whole));
      double hi = *std::max_element(block_hi.begin() + static_cast<std::ptrdiff_t>(j),
                                    block_hi.begin() + static_cast<std::ptrdiff_t>(j + whole));
      for (std::size_t i = b + whole * hop; i < b + length; ++i)
        lo = std::min(lo, s.setpoint_deg[i]), hi = std::max(hi, s.setpoint_deg[i]);
      if (hi - lo < opt.min_input_deg) {
        ++step.windows_quiet;
        continue;
      }
      load_window(fx.samples(), s.setpoint_deg, b, window_mean(sp_sums, b, length), w);
      load_window(fy.samples(), s.pitch_deg, b, window_mean(pitch_sums, b, length), w);
      fx.forward();
      fy.forward();
      const auto x = fx.spectrum();
      const auto y = fy.spectrum();
      for (std::size_t k = 0; k < x.size(); ++k) {  // y conj(x) and |x|^2 written out: no library NaN/inf checks
        const double xr = x[k].real(), xi = x[k].imag(), yr = y[k].real(), yi = y[k].imag();
        sxy[k] += std::complex<double>(yr * xr + yi * xi, yi * xr - yr * xi);
        sxx[k] += xr * xr + xi * xi;
      }
      ++step.windows_used;
    }
  }
  if (step.windows_used < opt.min_windows) {
    r.step_reason = fmt::format(
        "too little excitation: {} of {} windows of {:g} s have the setpoint moving {:g} deg or more peak to peak, "
        "{} are needed (run an excitation: a chirp, PRBS or steps of 0.5-2 deg)",
        step.windows_used, step.windows_total, opt.window_s, opt.min_input_deg, opt.min_windows);
    return;
  }
  // Wiener/Tikhonov: lambda, a fraction of the mean input power, keeps bins the input did not reach near 0
  // instead of dividing noise by ~0.
  const double lambda = SAUL_TUNE_MUTANT == 3 ? 0.0
                                              : opt.regularisation * std::accumulate(sxx.begin(), sxx.end(), 0.0) /
                                                    static_cast<double>(sxx.size());
  auto h = fx.spectrum();
  for (std::size_t k = 0; k < h.size(); ++k) h[k] = sxy[k] / (sxx[k] + lambda);
  // Each window's mean was taken out, so bin 0 carries nothing: its gain is the lowest measured frequency's
  // (fs / n, 0.10 Hz at 1 kHz with 8 s windows: far below the loop's response).
  h[0] = h[1].real();
  const double df = fs / static_cast<double>(n);
  double best = 0;
  for (std::size_t k = 1; k < h.size() && static_cast<double>(k) * df <= opt.band_hi_hz; ++k) {
    const double f = static_cast<double>(k) * df;
    step.gain_hz.push_back(f);
    step.gain.push_back(std::abs(h[k]));
    if (f >= 0.2 && std::abs(h[k]) > best) best = std::abs(h[k]), step.resonance_hz = f;
  }
  step.resonance_gain = best;
  if (!step.gain.empty() && best < 1.05 * step.gain.front()) step.resonance_hz.reset();  // no peak: a damped loop
  fx.inverse();
  const auto impulse = fx.samples();
  step.response.resize(kept);
  double sum = 0;
  for (std::size_t k = 0; k < kept; ++k) step.response[k] = sum += impulse[k] / static_cast<double>(n);
  step.figures = step_figures(step.response, step.dt_s);
  r.step = std::move(step);
}

/// The steps of the setpoint (a jump held for the response's length, steady before it), responses averaged.
void measure_steps(const Series& s, const std::vector<Segment>& segments, const AnalysisOptions& opt, Report& r) {
  const double fs = r.sample_rate_hz;
  const auto kept = static_cast<std::size_t>(std::lround(opt.response_s * fs));
  const auto before = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(0.2 * fs)));
  const auto base = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(0.05 * fs)));
  if (kept < 5 || before + kept > longest(segments)) {
    r.direct_step_reason = fmt::format("no gap-free stretch of {:g} s (0.2 s before a step and the response)",
                                       0.2 + opt.response_s);
    return;
  }
  DirectStep d;
  d.dt_s = 1.0 / fs;
  d.response.assign(kept, 0.0);
  const auto& sp = s.setpoint_deg;
  for (const auto& seg : segments) {
    for (std::size_t i = seg.begin + before; i + kept <= seg.end; ++i) {
      const double jump = sp[i] - sp[i - 1];
      if (std::abs(jump) < opt.direct_step_min_deg) continue;
      // Steady before within 10 % of the jump (an outer loop may still move it a little: the level is the mean of
      // the pitch just before), held after within 2 % (the response must be to this jump alone).
      bool held = true;
      for (std::size_t j = i - before; j < i && held; ++j) held = std::abs(sp[j] - sp[i - 1]) <= 0.1 * std::abs(jump);
      for (std::size_t j = i; j < i + kept && held; ++j) held = std::abs(sp[j] - sp[i]) <= 0.02 * std::abs(jump);
      if (!held) continue;
      double start = 0;
      for (std::size_t j = i - base; j < i; ++j) start += s.pitch_deg[j];
      start /= static_cast<double>(base);
      for (std::size_t k = 0; k < kept; ++k) d.response[k] += (s.pitch_deg[i + k] - start) / jump;
      ++d.steps;
      i += kept - 1;
    }
  }
  if (d.steps == 0) {
    r.direct_step_reason = fmt::format("no setpoint step: a jump of {:g} deg or more, steady 0.2 s before and held "
                                       "{:g} s after",
                                       opt.direct_step_min_deg, opt.response_s);
    return;
  }
  for (double& v : d.response) v /= static_cast<double>(d.steps);
  d.figures = step_figures(d.response, d.dt_s);
  r.direct_step = std::move(d);
}

/// Welch's method (scipy.signal.welch's defaults: periodic Hann, half overlap, each segment's mean removed,
/// one-sided density) over the gap-free segments, then the oscillation check.
Spectrum welch(const std::string& name, const std::vector<double>& x, const std::vector<Segment>& segments, double fs,
               detail::RealFft& fft, const AnalysisOptions& opt) {
  const std::size_t n = fft.size();
  const auto w = hann(n);
  std::vector<double> acc(fft.bins());
  Spectrum sp;
  sp.signal = name;
  for (const auto& seg : segments)
    for (std::size_t b = seg.begin; b + n <= seg.end; b += n / 2) {
      load_window(fft.samples(), x, b, std::accumulate(x.begin() + static_cast<std::ptrdiff_t>(b),
                                                       x.begin() + static_cast<std::ptrdiff_t>(b + n), 0.0) /
                                           static_cast<double>(n), w);
      fft.forward();
      const auto X = fft.spectrum();
      for (std::size_t k = 0; k < acc.size(); ++k) acc[k] += std::norm(X[k]);
      ++sp.segments;
    }
  const double w2 = std::inner_product(w.begin(), w.end(), w.begin(), 0.0);
  sp.resolution_hz = fs / static_cast<double>(n);
  sp.freq_hz.resize(acc.size());
  sp.psd.resize(acc.size());
  for (std::size_t k = 0; k < acc.size(); ++k) {
    const double one_sided = (k == 0 || k == acc.size() - 1) ? 1.0 : 2.0;
    sp.freq_hz[k] = static_cast<double>(k) * sp.resolution_hz;
    sp.psd[k] = acc[k] / static_cast<double>(sp.segments) * one_sided / (fs * w2);
  }
  // The oscillation check: each local maximum in the band against the median of the octave around it, so a
  // spectrum's slope (a loop's response falls off with frequency) is not taken for a peak, a narrow line is.
  const double hi = std::min(opt.band_hi_hz, 0.45 * fs);
  std::vector<double> octave;
  for (std::size_t k = 1; k + 1 < sp.psd.size(); ++k) {
    const double f = sp.freq_hz[k];
    if (f < opt.band_lo_hz || f > hi || sp.psd[k] < sp.psd[k - 1] || sp.psd[k] < sp.psd[k + 1]) continue;
    const auto from = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(f / std::numbers::sqrt2 / sp.resolution_hz)));
    const auto to = std::min(sp.psd.size() - 1, static_cast<std::size_t>(std::floor(f * std::numbers::sqrt2 / sp.resolution_hz)));
    octave.assign(sp.psd.begin() + static_cast<std::ptrdiff_t>(from), sp.psd.begin() + static_cast<std::ptrdiff_t>(to + 1));
    auto mid = octave.begin() + static_cast<std::ptrdiff_t>(octave.size() / 2);
    std::nth_element(octave.begin(), mid, octave.end());
    if (*mid <= 0) continue;
    const double ratio = sp.psd[k] / *mid;
    if (ratio <= sp.peak_ratio) continue;
    // The peak between bins: a parabola through the three around it.
    const double a = sp.psd[k - 1], b = sp.psd[k], c = sp.psd[k + 1];
    const double denom = a - 2 * b + c;
    const double shift = denom != 0 ? std::clamp(0.5 * (a - c) / denom, -0.5, 0.5) : 0.0;
    sp.peak_ratio = ratio;
    sp.peak_hz = f + shift * sp.resolution_hz;
  }
  return sp;
}

void spectra(const Series& s, const std::vector<Segment>& segments, const AnalysisOptions& opt, Report& r) {
  const double fs = r.sample_rate_hz;
  const std::size_t n = next_pow2(static_cast<std::size_t>(std::lround(opt.segment_s * fs)));
  const std::pair<const char*, const std::vector<double>*> signals[] = {
      {"rate_dps", &s.rate_dps}, {"d_term", &s.d_term}, {"output", &s.output}};
  if (longest(segments) < n) {
    r.spectra_reason = fmt::format("no gap-free stretch of {} records ({:.2f} s), one spectrum segment", n,
                                   static_cast<double>(n) / fs);
    return;
  }
  detail::RealFft fft(n);
  for (const auto& [name, column] : signals) {
    if (column->empty()) continue;
    r.spectra.push_back(welch(name, *column, segments, fs, fft, opt));
    const auto& sp = r.spectra.back();
    if (sp.peak_hz && sp.peak_ratio >= opt.peak_ratio && (!r.oscillation || sp.peak_ratio > r.oscillation->ratio_to_median))
      r.oscillation = Oscillation{name, *sp.peak_hz, sp.peak_ratio};
  }
  if (r.spectra.empty()) r.spectra_reason = "no rate_dps, d_term or output column";
}

}  // namespace

StepFigures step_figures(const std::vector<double>& response, double dt_s) {
  StepFigures f;
  if (response.size() < 5) return f;
  const std::size_t tail = response.size() - response.size() / 5;
  f.final_value = std::accumulate(response.begin() + static_cast<std::ptrdiff_t>(tail), response.end(), 0.0) /
                  static_cast<double>(response.size() - tail);
  f.steady_state_error_pct = (1.0 - f.final_value) * 100.0;
  if (f.final_value <= 0) return f;  // no response at all: the other figures mean nothing
  const double final_value = f.final_value;
  // The first time the response reaches `level` of the final value, between samples.
  const auto reach = [&](double level) {
    const double target = level * final_value;
    for (std::size_t k = 0; k < response.size(); ++k) {
      if (response[k] < target) continue;
      if (k == 0) return 0.0;
      const double frac = (target - response[k - 1]) / (response[k] - response[k - 1]);
      return (static_cast<double>(k - 1) + frac) * dt_s;
    }
    return static_cast<double>(response.size()) * dt_s;
  };
  f.rise_time_s = reach(0.9) - reach(0.1);
  f.delay_s = reach(0.5);
  const double peak = *std::max_element(response.begin(), response.end());
  f.overshoot_pct = std::max(0.0, (peak - final_value) / final_value * 100.0);
  std::size_t last_out = response.size();
  for (std::size_t k = response.size(); k-- > 0;)
    if (std::abs(response[k] - final_value) > 0.05 * final_value) {
      last_out = k;
      break;
    }
  if (last_out == response.size()) f.settling_time_s = 0.0;
  else if (last_out < tail) f.settling_time_s = static_cast<double>(last_out + 1) * dt_s;
  return f;  // still outside the band in the last fifth: it does not settle within the response
}

Report analyse(const Series& s, const AnalysisOptions& opt) {
  Report r;
  r.name = s.name;
  r.source = s.source;
  r.gains = s.gains;
  r.records = s.size();
  r.problems = s.problems;
  r.problems_total = s.problems_total;
  if (s.size() < 2) {
    r.step_reason = r.direct_step_reason = r.spectra_reason = "fewer than 2 records";
    return r;
  }
  r.duration_s = s.time_s.back() - s.time_s.front();
  std::vector<Segment> segments;
  timing(s, r, segments);
  segments = balancing(s, segments);
  basics(s, opt, r);
  const double fs = r.sample_rate_hz;
  const auto slow = [&](double needed, const char* what) {
    return fmt::format("the trace is sampled at {:.4g} Hz: {} needs {:g} Hz or more ({}); record the loop's 1 kHz "
                       "trace (saulctl tune record)",
                       fs, what, needed,
                       s.source == SeriesSource::telemetry ? "CAN telemetry comes at 10 Hz" : "a slow log");
  };
  if (fs < opt.min_step_rate_hz) {
    r.step_reason = r.direct_step_reason =
        slow(opt.min_step_rate_hz, "a step response (rise times of tens of ms)");
  } else if (s.setpoint_deg.empty()) {
    r.step_reason = r.direct_step_reason = "no setpoint in the input (CAN telemetry carries pitch, not the setpoint)";
  } else {
    estimate_step(s, segments, opt, r);
    measure_steps(s, segments, opt, r);
  }
  if (fs < opt.min_spectrum_rate_hz) {
    r.spectra_reason = slow(opt.min_spectrum_rate_hz, "the oscillation band up to 100 Hz") +
                       fmt::format("; anything above {:.3g} Hz would show at a wrong, aliased frequency", fs / 2);
  } else {
    spectra(s, segments, opt, r);
  }
  return r;
}

}  // namespace saul::host::tune
