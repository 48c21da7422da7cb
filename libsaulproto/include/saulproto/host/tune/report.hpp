// A tuning analysis (analysis.hpp) written out: the text a technician reads (each figure, what it means, whether it
// looks healthy), the JSON scripts read, and several reports side by side (`saulctl tune compare`).
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "saulproto/host/tune/analysis.hpp"

namespace saul::host::tune {

/// The health limits the text judges by (docs/tuning.md says why each).
struct Health {
  double overshoot_pct = 25;      ///< more: the loop rings
  double settling_s = 0.8;        ///< more: slow to recover from a push
  double steady_error_pct = 10;   ///< more: pitch does not reach the setpoint (I term too weak)
  /// Pitch past the setpoint: the most pitch / setpoint at the end of the response. Past it, the I term needs more
  /// than a third of the lean as error to follow the ramp a held lean asks of the output (1 - 1/1.5 = 1/3).
  double lean_gain = 1.5;
  double saturation_pct = 5;      ///< more: the motors are often at their limit
  double period_p99_us = 1500;    ///< more: the loop runs late (at 1 kHz)
};

/// The JSON object: sample_rate_hz, records, gaps, loop_period_us {p50, p99, max}, step {...} or null with
/// step_reason, oscillation {...} or null, saturation_pct, ... (docs/tuning.md lists every key).
nlohmann::json to_json(const Report& report);

/// The text summary.
std::string to_text(const Report& report, const Health& health = {});

/// The main figures of several reports, one column each, the gains in the first rows.
std::string compare_text(const std::vector<Report>& reports);
/// The same as a JSON array of to_json objects.
nlohmann::json compare_json(const std::vector<Report>& reports);

}  // namespace saul::host::tune
