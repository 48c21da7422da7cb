// Running a parsed suite against a target (suite.hpp) and its JUnit report. Apart from the parser so that the
// parser stands alone (the fuzz build links it without the tuning analysis the `expect tune` step needs).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/suite/suite.hpp"
#include "saulproto/host/suite/tune_expect.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/report/signal_rows.hpp"
#include "saulproto/host/report/trace_report.hpp"
#include "../util.hpp"

namespace saul::host::suite {
namespace {

std::string us_text(std::uint64_t us) { return fmt::format("{:.3f} s", static_cast<double>(us) / 1e6); }

/// BALANCE's first "error: ..." line among a trace's console bytes (its records skipped), or empty.
std::string refusal_in(const std::string& bytes) {
  TraceTap tap;
  tap.push(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
  tap.finish();
  return tap.refusal();
}

/// True when the frame decodes to `message` (or any message when empty) and every condition holds.
bool matches(const CanFrame& frame, const std::string& message, const std::vector<Condition>& conditions) {
  const auto r = decode_bus_frame(frame);
  if (!r) return false;
  if (!message.empty() && message != name_of(r.value())) return false;
  const SignalValues values = signal_values(r.value());
  for (const auto& c : conditions) {
    const auto v = signal_value(values, c.field);
    if (!v || !holds(c, FieldValue{v->number, v->text})) return false;
  }
  return true;
}

}  // namespace

bool SuiteResult::passed() const {
  if (skipped) return true;
  return std::none_of(steps.begin(), steps.end(),
                      [](const StepResult& s) { return s.status == StepResult::Status::failed; });
}

SuiteResult run_suite(const Suite& suite, Target& target) {
  SuiteResult result;
  result.name = suite.name;
  result.path = suite.path;
  if (suite.requires_sim && !target.is_simulator()) {
    result.skipped = true;
    result.skip_reason = "needs the simulator (requires: sim)";
    return result;
  }
  // Background stream state.
  std::vector<CanFrame> stream;
  std::uint64_t stream_period = 0;
  std::uint64_t stream_next = 0;
  const std::uint64_t suite_start = target.now_us();

  // Receives until deadline, sending stream frames when due; calls on_frame for each frame (return false to stop).
  auto pump = [&](std::uint64_t deadline, const auto& on_frame) {
    for (;;) {
      std::uint64_t until = deadline;
      if (target.now_us() >= deadline) return;
      if (!stream.empty()) {
        if (target.now_us() >= stream_next) {
          for (const auto& f : stream) target.send(f);
          stream_next += stream_period;
          continue;
        }
        until = std::min(until, stream_next);
      }
      auto f = target.receive_until(until);
      if (f && !on_frame(*f)) return;
    }
  };

  // The frames of the step's message within its time from t0, each to `each` (false stops); returns how many.
  const auto each_of = [&](const Step& step, std::uint64_t t0, const auto& each) {
    std::uint64_t count = 0;
    pump(t0 + step.duration_us, [&](const CanFrame& f) {
      if (!matches(f, step.message, {})) return true;
      ++count;
      return each(f);
    });
    return count;
  };
  // expect / expect none: the first frame matching the step within its time from t0, the streams running meanwhile.
  const auto first_match = [&](const Step& step, std::uint64_t t0) {
    std::optional<CanFrame> seen;
    each_of(step, t0, [&](const CanFrame& f) {
      if (matches(f, step.message, step.conditions)) seen = f;
      return !seen;
    });
    return seen;
  };

  // The last `trace` step's analysis, for `expect tune` (none yet, or the trace step was skipped on this target).
  std::optional<tune::Report> traced;
  bool trace_skipped = false;
  // BALANCE's console bytes for `duration_us` from now, the suite's streams running meanwhile.
  const auto collect = [&](std::uint64_t duration_us, std::string& bytes) {
    constexpr std::uint64_t kSlice = 10'000;  // the console is read every 10 ms of target time
    for (const std::uint64_t end = target.now_us() + duration_us; target.now_us() < end;) {
      pump(std::min(end, target.now_us() + kSlice), [](const CanFrame&) { return true; });
      bytes += target.console_take("balance").value_or("");
    }
  };
  const auto type = [&](const trace::Command& command) {
    char text[64];
    const auto n = trace::format_command(command, text);
    target.console_type("balance", std::string(text, n.ok() ? *n : 0));
  };

  using S = StepResult::Status;
  for (const auto& step : suite.steps) {
    StepResult r;
    r.line = step.line;
    r.source = step.source;
    const auto verdict = [&r](S status, std::string why) {
      r.status = status;
      r.message = std::move(why);
    };
    const auto fail = [&verdict](std::string why) { verdict(S::failed, std::move(why)); };
    if (!result.passed()) {
      verdict(S::skipped, "not run: an earlier step failed");
      result.steps.push_back(r);
      continue;
    }
    const std::uint64_t t0 = target.now_us();
    try {
      switch (step.kind) {
        case Step::Kind::send:
          for (const auto& f : step.frames) target.send(f);
          r.message = fmt::format("sent {} frame(s)", step.frames.size());
          break;
        case Step::Kind::stream:
          stream = step.frames;
          stream_period = step.period_us;
          stream_next = target.now_us();
          r.message = fmt::format("streaming every {}", us_text(step.period_us));
          break;
        case Step::Kind::stop:
          stream.clear();
          r.message = "stream stopped";
          break;
        case Step::Kind::wait:
          pump(t0 + step.duration_us, [](const CanFrame&) { return true; });
          break;
        case Step::Kind::expect:
          if (first_match(step, t0)) {
            r.message = fmt::format("seen after {}", us_text(target.now_us() - t0));
          } else {
            fail(fmt::format("no matching {} within {}", step.message.empty() ? "frame" : step.message,
                             us_text(step.duration_us)));
          }
          break;
        case Step::Kind::expect_none:
          if (first_match(step, t0))
            fail(fmt::format("a matching {} arrived after {}", step.message, us_text(target.now_us() - t0)));
          break;
        case Step::Kind::hold: {
          std::string broken;
          const std::uint64_t count = each_of(step, t0, [&](const CanFrame& f) {
            if (matches(f, step.message, step.conditions)) return true;
            broken = fmt::format("condition broken after {} by {}", us_text(target.now_us() - t0),
                                 format_candump_frame(f));
            return false;
          });
          if (!broken.empty()) {
            fail(broken);
          } else if (count == 0) {
            fail(fmt::format("no {} at all in {}", step.message, us_text(step.duration_us)));
          } else {
            r.message = fmt::format("held over {} frames", count);
          }
          break;
        }
        case Step::Kind::mean: {
          // One sum per field ("|field|" for the absolute values), however many conditions name it.
          const auto key = [](const Condition& c) { return c.absolute ? "|" + c.field + "|" : c.field; };
          std::map<std::string, const Condition*> fields;
          for (const auto& c : step.conditions) fields.emplace(key(c), &c);
          std::map<std::string, double> sums;
          const std::uint64_t count = each_of(step, t0, [&](const CanFrame& f) {
            const SignalValues values = signal_values(decode_bus_frame(f).value());
            for (const auto& [field, c] : fields) {
              const auto v = signal_value(values, c->field);
              if (!v) throw std::runtime_error(step.message + " has no signal '" + c->field + "'");
              sums[field] += c->absolute ? std::fabs(v->number) : v->number;
            }
            return true;
          });
          if (count == 0) {
            fail(fmt::format("no {} at all in {}", step.message, us_text(step.duration_us)));
            break;
          }
          std::string means;
          for (const auto& [field, sum] : sums) means += fmt::format("{}{} {:.2f}", means.empty() ? "" : ", ", field, sum / static_cast<double>(count));
          r.output = fmt::format("means over {} frames: {}", count, means);
          for (const auto& c : step.conditions) {
            Condition plain = c;
            plain.absolute = false;  // the mean is already of the absolute values
            const double mean = sums[key(c)] / static_cast<double>(count);
            if (!holds(plain, FieldValue{mean, fmt::format("{}", mean)})) {
              fail(fmt::format("{} mean {:.2f} breaks the condition ({})", c.field, mean, r.output));
              break;
            }
          }
          if (r.status == S::passed) r.message = r.output;
          break;
        }
        case Step::Kind::stable: {
          std::vector<Step::Clause> clauses{{step.message, step.conditions}};
          clauses.insert(clauses.end(), step.more.begin(), step.more.end());
          std::vector<std::uint64_t> seen(clauses.size(), t0);
          std::uint64_t since = t0;
          std::uint64_t longest = 0;
          std::uint64_t restarts = 0;
          std::string last_break;
          bool done = false;
          const auto restart = [&](std::uint64_t now, std::string why) {
            longest = std::max(longest, now - since);
            since = now;
            ++restarts;
            last_break = fmt::format("at {}: {}", us_text(now - t0), why);
          };
          // A silent message restarts the clock once per kStableMaxGapUs of silence.
          const auto check_gaps = [&](std::uint64_t now) {
            for (std::size_t c = 0; c < clauses.size(); ++c) {
              if (now - seen[c] <= kStableMaxGapUs) continue;
              restart(now, clauses[c].message + " silent for over " + us_text(kStableMaxGapUs));
              seen[c] = now;
            }
          };
          pump(t0 + step.limit_us, [&](const CanFrame& f) {
            const std::uint64_t now = target.now_us();
            check_gaps(now);
            for (std::size_t c = 0; c < clauses.size(); ++c) {
              if (!matches(f, clauses[c].message, {})) continue;
              seen[c] = now;
              if (!matches(f, clauses[c].message, clauses[c].conditions))
                restart(now, "broken by " + format_candump_frame(f));
            }
            done = now - since >= step.duration_us;
            return !done;
          });
          const std::uint64_t end = target.now_us();
          if (!done) check_gaps(end);
          const std::uint64_t stretch = end - since;
          longest = std::max(longest, stretch);
          const std::string summary =
              fmt::format("longest stable stretch {} (needed {}), {} restart(s){}{}", us_text(longest),
                          us_text(step.duration_us), restarts, restarts > 0 ? ", the last " : "", last_break);
          if (done) {
            r.message = fmt::format("stable for {} from {} on; {}", us_text(stretch), us_text(since - t0), summary);
          } else {
            fail(fmt::format("never stable for {} within {}: {}", us_text(step.duration_us), us_text(step.limit_us),
                             summary));
          }
          r.output = r.message;
          break;
        }
        case Step::Kind::console: {
          const auto reply = target.console(step.board, step.text, step.expect_text, step.duration_us);
          if (!reply) {
            verdict(S::skipped, "no console for board " + step.board + " on this target");
          } else if (reply->find(step.expect_text) == std::string::npos) {
            fail(fmt::format("reply did not contain '{}': '{}'", step.expect_text, *reply));
          } else {
            r.message = "reply ok";
          }
          break;
        }
        case Step::Kind::trace: {
          // As `saulctl tune record --sim` does: trace on, a step after a quiet stretch (so the trace holds the level
          // before it), the other signals at once; the excitation lasts the trace (at most its 20 s).
          if (!target.console_take("balance")) {
            verdict(S::skipped, "no BALANCE console to trace on this target");
            trace_skipped = true;
            break;
          }
          std::string bytes;
          type(trace::TraceOn{1});
          std::uint64_t left = step.duration_us;
          if (step.excite) {
            const std::uint64_t quiet = step.excite->kind == trace::Excite::step ? std::min<std::uint64_t>(1'000'000, left / 4) : 0;
            collect(quiet, bytes);
            left -= quiet;
            trace::ExciteStart e = *step.excite;
            e.duration_s = std::min(trace::kMaxDurationS, static_cast<float>(left) * 1e-6F);
            type(e);
          }
          collect(left, bytes);
          type(trace::TraceOff{});
          collect(20'000, bytes);  // the records still on their way
          if (const std::string refused = refusal_in(bytes); !refused.empty()) {
            fail("BALANCE refused: " + refused);
            if (refused.find(trace::kExciteCapRefusal) != std::string::npos)
              r.message += fmt::format(" (raise the cap before arming: 'console balance speed_limit 20 expect ok', "
                                       "then 30, 40 ... {})", trace::kExciteMinCapPct);
            traced.reset();
            break;
          }
          traced = analyse_trace(bytes, fmt::format("{}:{}", suite.path, step.line));
          trace_skipped = false;
          r.output = tune_figures_text(*traced);
          r.message = r.output;
          break;
        }
        case Step::Kind::expect_tune: {
          if (!traced) {
            verdict(trace_skipped ? S::skipped : S::failed,
                    trace_skipped ? "the trace step was skipped on this target"
                                  : "no trace to judge: a 'trace ... for DURATION' step must come first");
            break;
          }
          const std::string broken = check_tune(step.conditions, *traced);
          if (!broken.empty()) {
            fail(broken);
          } else {
            r.message = "held: " + tune_figures_text(*traced);
          }
          break;
        }
        case Step::Kind::sim: {
          std::string error;
          if (!target.sim(step.text, error)) verdict(target.is_simulator() ? S::failed : S::skipped, error);
          break;
        }
      }
    } catch (const std::exception& e) {
      fail(e.what());
    }
    r.elapsed_us = target.now_us() - t0;
    result.steps.push_back(r);
  }
  result.elapsed_us = target.now_us() - suite_start;
  return result;
}

std::string junit_xml(const std::vector<SuiteResult>& results) {
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites>\n";
  for (const auto& s : results) {
    std::size_t failures = 0, skipped = 0;
    for (const auto& st : s.steps) {
      failures += st.status == StepResult::Status::failed;
      skipped += st.status == StepResult::Status::skipped;
    }
    if (s.skipped) skipped = 1;
    x += fmt::format("  <testsuite name=\"{}\" tests=\"{}\" failures=\"{}\" skipped=\"{}\" time=\"{:.3f}\">\n",
                     detail::markup_escape(s.name), s.skipped ? 1 : s.steps.size(), failures, skipped,
                     static_cast<double>(s.elapsed_us) / 1e6);
    if (s.skipped) {
      x += fmt::format("    <testcase name=\"{}\"><skipped message=\"{}\"/></testcase>\n", detail::markup_escape(s.name),
                       detail::markup_escape(s.skip_reason));
    }
    for (const auto& st : s.steps) {
      x += fmt::format("    <testcase classname=\"{}\" name=\"line {}: {}\" time=\"{:.3f}\"", detail::markup_escape(s.name), st.line,
                       detail::markup_escape(st.source), static_cast<double>(st.elapsed_us) / 1e6);
      const std::string out =
          st.output.empty() ? "" : fmt::format("<system-out>{}</system-out>", detail::markup_escape(st.output));
      if (st.status == StepResult::Status::passed) {
        x += out.empty() ? "/>\n" : ">" + out + "</testcase>\n";
      } else if (st.status == StepResult::Status::failed) {
        x += fmt::format("><failure message=\"{}\"/>{}</testcase>\n", detail::markup_escape(st.message), out);
      } else {
        x += fmt::format("><skipped message=\"{}\"/></testcase>\n", detail::markup_escape(st.message));
      }
    }
    x += "  </testsuite>\n";
  }
  x += "</testsuites>\n";
  return x;
}

}  // namespace saul::host::suite
