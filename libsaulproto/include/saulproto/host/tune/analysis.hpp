// What a trace of the balance loop says about its tuning: the step response of the pitch loop (setpoint -> pitch)
// estimated by regularised deconvolution over overlapping windows, and measured directly at the setpoint's steps;
// Welch spectra of the pitch rate, the D term and the output, with the oscillation they show, if any; the share of
// time the output is saturated, the I term's wind-up, the loop's timing and the trace's gaps. Each figure that the
// input cannot support (a 10 Hz source, too little excitation) is absent with the reason instead of a wrong number.
//
// The method is the one drone tuners use (Betaflight's Blackbox Explorer, Plasmatree PID-Analyzer; see
// docs/tuning.md): for each window of the trace where the setpoint moves enough, H = Y X* / (|X|^2 + lambda) with
// X, Y the Hann-weighted FFTs of setpoint and pitch and lambda a fraction of the window's mean input power (Wiener
// / Tikhonov regularisation: frequencies the input did not excite are not divided by ~0); the impulse response
// (inverse FFT) is summed into a step response. The cross and input spectra are summed over the used windows
// before dividing (the H1 estimator), so a chirp that excites each frequency in a different window still gives
// one well-conditioned estimate, and measurement noise on the pitch averages out.
// The windows are longer than a quad's (a balancing robot's pitch loop answers in 0.2-1 s, not 20 ms).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "saulproto/host/tune/series.hpp"

namespace saul::host::tune {

/// The method's constants, in one place (defaults as documented in docs/tuning.md).
struct AnalysisOptions {
  double window_s = 8.0;           ///< deconvolution window
  double hop_s = 0.5;              ///< a new window every hop_s (8x overlap)
  double response_s = 1.5;         ///< step response kept
  double min_input_deg = 0.3;      ///< a window's setpoint must move this much peak to peak
  double regularisation = 0.01;    ///< lambda as a fraction of the window's mean |X|^2
  std::size_t min_windows = 5;     ///< fewer used windows: no estimated step response
  double min_step_rate_hz = 200;   ///< below it: no step response (rise times of tens of ms need ms samples)
  double min_spectrum_rate_hz = 200;  ///< below it: no spectra (the oscillation band reaches 100 Hz)
  double band_lo_hz = 1.0;         ///< oscillation band: from the slowest wobble of the body ...
  double band_hi_hz = 100.0;       ///< ... to well above the wheels' and the motor controllers' reach
  double peak_ratio = 40.0;        ///< a peak this many times the median of its octave is an oscillation
  double segment_s = 2.0;          ///< Welch segment (2048 samples at 1 kHz: 0.49 Hz bins)
  double output_limit = 1000.0;    ///< permille: the PID output's saturation
  double windup_fraction = 0.25;   ///< I term beyond this share of the limit while saturated ...
  double windup_min_s = 0.05;      ///< ... for at least this long is a wind-up period
  double direct_step_min_deg = 0.2;   ///< a setpoint jump at least this large in one sample is a step
};

/// A step response and its figures. Times in seconds from the setpoint's change; t = i / sample_rate.
struct StepFigures {
  double rise_time_s = 0;         ///< 10 % to 90 % of the final value
  double overshoot_pct = 0;       ///< (peak - final) / final
  std::optional<double> settling_time_s;  ///< last time outside +-5 % of the final value (none: never settles)
  double steady_state_error_pct = 0;      ///< (1 - final) x 100: 0 when pitch ends where the setpoint went
  double delay_s = 0;             ///< to 50 % of the final value (the textbook delay time)
  double final_value = 0;         ///< mean over the last fifth of the response (1 = follows the setpoint)
};

struct StepResponse {
  std::vector<double> response;   ///< the averaged step response, one value per sample
  double dt_s = 0;
  StepFigures figures;
  std::size_t windows_total = 0;  ///< windows in the trace
  std::size_t windows_used = 0;   ///< of them, with enough input
  std::size_t windows_quiet = 0;  ///< left out: the setpoint moved less than min_input_deg
  std::optional<double> resonance_hz;  ///< peak of |H| above 0.2 Hz when it stands 5 % above the low-frequency gain
  double resonance_gain = 0;           ///< |H| there (1 = no amplification)
  std::vector<double> gain_hz, gain;   ///< averaged |H| (for the report's plot), up to band_hi_hz
};

struct DirectStep {
  std::size_t steps = 0;          ///< setpoint steps with a full response after them
  std::vector<double> response;   ///< normalised and averaged
  double dt_s = 0;
  StepFigures figures;
};

/// Welch spectrum of one signal, one-sided power spectral density (unit^2/Hz), and its oscillation check.
struct Spectrum {
  std::string signal;             ///< "rate_dps", "d_term", "output"
  double resolution_hz = 0;       ///< bin spacing
  std::size_t segments = 0;
  std::vector<double> freq_hz, psd;
  std::optional<double> peak_hz;  ///< the strongest peak in the band against its octave's median
  double peak_ratio = 0;          ///< that peak / the median of the octave around it
};

struct Oscillation {
  std::string signal;
  double frequency_hz = 0;
  double ratio_to_median = 0;
};

/// A stretch of the trace where the I term winds up against a saturated output.
struct Windup {
  double start_s = 0;
  double duration_s = 0;
  double i_term_peak = 0;
};

struct Gap {
  double at_s = 0;                ///< time before the gap (from the first record)
  double duration_s = 0;
  std::uint64_t line = 0;         ///< the record after the gap
  std::uint64_t missed = 0;       ///< loop iterations missing
};

struct Report {
  std::string name;
  SeriesSource source = SeriesSource::loop_trace;
  Gains gains;
  std::uint64_t records = 0;
  double duration_s = 0;
  double sample_rate_hz = 0;      ///< 1 / the median period
  /// Loop iterations per record: the seq column's median step (a trace of every N-th loop), 1 without seq.
  std::uint64_t loop_divider = 1;
  // Loop timing: the time column's steps over loop_divider (the loop's own period, averaged over N iterations)
  double period_p50_us = 0, period_p99_us = 0, period_max_us = 0;
  std::uint64_t missed_iterations = 0;  ///< by the time column: periods missing in the gaps (records, at a divider)
  /// By the loop's counter (a seq column): records absent from the trace (dropped by it, or rows left out as
  /// bad; at a divider of N, a counter step of 2N is one). Missed by time but not by seq: the loop itself ran late.
  std::optional<std::uint64_t> seq_missing;
  std::uint64_t gaps_total = 0;
  std::vector<Gap> gaps;          ///< the first few
  // What any rate can say
  std::uint64_t balancing_records = 0;  ///< records in BALANCE (all when there is no state column): the ones below
  double pitch_rms_deg = 0;       ///< about the setpoint when there is one, else about 0
  double pitch_offset_deg = 0;    ///< mean of pitch - setpoint (or pitch)
  double pitch_drift_deg_per_min = 0;  ///< slope of the same, fitted over the whole trace
  std::optional<double> saturation_pct;   ///< share of records with |output| at the limit
  std::uint64_t falls = 0;        ///< BALANCE -> TILT_CUTOFF (or FAULT) changes
  std::optional<std::vector<Windup>> windups;  ///< none when there is no I term or no output
  double excite_pct = 0;          ///< share of records flagged as excitation
  // What needs the loop's rate
  std::optional<StepResponse> step;
  std::string step_reason;        ///< why step is absent
  std::optional<DirectStep> direct_step;
  std::string direct_step_reason;
  std::vector<Spectrum> spectra;
  std::string spectra_reason;     ///< why spectra is empty
  std::optional<Oscillation> oscillation;  ///< the strongest peak at or above peak_ratio, if any
  std::vector<std::string> problems;  ///< the reader's, as they were told
  std::uint64_t problems_total = 0;
};

/// Analyses a series (at least 2 records). Never throws for content: what cannot be computed has a reason.
Report analyse(const Series& series, const AnalysisOptions& options = {});

/// The figures of a step response sampled every dt_s.
StepFigures step_figures(const std::vector<double>& response, double dt_s);

}  // namespace saul::host::tune
