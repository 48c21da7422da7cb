#include "saulproto/host/suite/suite.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <map>
#include <sstream>

#include "saulproto/core/quantity.hpp"
#include "saulproto/core/saul_can.hpp"
#include "saulproto/host/suite/tune_expect.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/report/signal_rows.hpp"
#include "../util.hpp"

namespace saul::host::suite {
namespace {

namespace sc = saul::saulcan;
using detail::ascii_lower;

std::vector<std::string> words(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> w;
  std::string t;
  while (in >> t) w.push_back(t);
  return w;
}

std::optional<double> number(const std::string& s) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(s, &used);  // decimal, or hex after 0x (strtod reads both)
  } catch (...) {
    return std::nullopt;
  }
  if (used != s.size()) return std::nullopt;
  return v;
}

std::map<std::string, std::string> assignments(const std::vector<std::string>& w, std::size_t from,
                                               const std::string& path, int line) {
  std::map<std::string, std::string> a;
  for (std::size_t i = from; i < w.size(); ++i) {
    const auto eq = w[i].find('=');
    if (eq == std::string::npos || eq == 0) throw ParseError(path, line, "expected FIELD=VALUE, got '" + w[i] + "'");
    a[w[i].substr(0, eq)] = w[i].substr(eq + 1);
  }
  return a;
}

double need_number(std::map<std::string, std::string>& a, const std::string& key, std::optional<double> fallback,
                   const std::string& path, int line) {
  const auto it = a.find(key);
  if (it == a.end()) {
    if (fallback) return *fallback;
    throw ParseError(path, line, "missing " + key + "=...");
  }
  const auto v = number(it->second);
  if (!v) throw ParseError(path, line, key + "=" + it->second + " is not a number");
  a.erase(it);
  return *v;
}

template <class T>
T checked(double v, const std::string& key, const std::string& path, int line) {
  if (v < static_cast<double>(std::numeric_limits<T>::min()) || v > static_cast<double>(std::numeric_limits<T>::max()))
    throw ParseError(path, line, fmt::format("{}={} does not fit the field", key, v));
  return static_cast<T>(std::lround(v));
}

std::vector<CanFrame> build_frames(const std::vector<std::string>& w, std::size_t at, const std::string& path,
                                   int line) {
  if (at >= w.size()) throw ParseError(path, line, "send/stream needs a message name");
  const std::string& name = w[at];
  if (name == "frame") {
    if (at + 1 >= w.size()) throw ParseError(path, line, "send frame needs a frame, e.g. 302#01");
    CandumpLine parsed;
    CandumpError err;
    if (!parse_candump_line("(0.0) x " + w[at + 1], parsed, err))
      throw ParseError(path, line, "bad frame '" + w[at + 1] + "': " + err.message);
    parsed.frame.timestamp_ns.reset();  // a frame to send carries no time
    return {parsed.frame};
  }
  auto a = assignments(w, at + 1, path, line);
  std::vector<CanFrame> out;
  if (name == "velocity_cmd") {
    sc::VelocityCmd m;
    m.speed_mmps = checked<std::int16_t>(need_number(a, "speed_mmps", 0.0, path, line), "speed_mmps", path, line);
    m.steer_mrad = checked<std::int16_t>(need_number(a, "steer_mrad", 0.0, path, line), "steer_mrad", path, line);
    out.push_back(sc::encode(m));
  } else if (name == "mode_cmd") {
    static const std::map<std::string, sc::Mode> kModes = {
        {"off", sc::Mode::off}, {"balance", sc::Mode::balance}, {"manual", sc::Mode::manual}, {"estop", sc::Mode::estop}};
    const auto it = a.find("mode");
    if (it == a.end() || !kModes.count(ascii_lower(it->second)))
      throw ParseError(path, line, "mode_cmd needs mode=off|balance|manual|estop");
    out.push_back(sc::encode(sc::ModeCmd{kModes.at(ascii_lower(it->second))}));
    a.erase("mode");
  } else if (name == "config_cmd") {
    // The signal names decode --json prints (docs/cli.md): tilt_limit in degrees, or tilt_limit_raw, its wire
    // integer in 0.01 deg; the struct's own name (tilt_limit_x100) is not one of them.
    if (a.count("tilt_limit_x100"))
      throw ParseError(path, line, "config_cmd has no field 'tilt_limit_x100': use tilt_limit=DEG or tilt_limit_raw=N");
    sc::ConfigCmd m;
    const bool raw = a.count("tilt_limit_raw") != 0;
    const char* tilt = raw ? "tilt_limit_raw" : "tilt_limit";
    const double limit = need_number(a, tilt, std::nullopt, path, line);
    m.tilt_limit_x100 = checked<std::uint16_t>(raw ? limit : limit * 100.0, tilt, path, line);
    m.max_speed_mmps = checked<std::uint16_t>(need_number(a, "max_speed_mmps", std::nullopt, path, line),
                                              "max_speed_mmps", path, line);
    out.push_back(sc::encode(m));
  } else if (name == "pid_set") {
    const auto seq = checked<std::uint8_t>(need_number(a, "sequence", 1.0, path, line), "sequence", path, line);
    const double kp = need_number(a, "kp", std::nullopt, path, line);
    const double ki = need_number(a, "ki", std::nullopt, path, line);
    const double kd = need_number(a, "kd", std::nullopt, path, line);
    out.push_back(sc::encode(sc::PidGain{sc::Gain::kp, seq, static_cast<float>(kp)}));
    out.push_back(sc::encode(sc::PidGain{sc::Gain::ki, seq, static_cast<float>(ki)}));
    out.push_back(sc::encode(sc::PidGain{sc::Gain::kd, seq, static_cast<float>(kd)}));
  } else if (name == "pid_gain") {
    static const std::map<std::string, sc::Gain> kGains = {{"kp", sc::Gain::kp}, {"ki", sc::Gain::ki}, {"kd", sc::Gain::kd}};
    const auto it = a.find("gain");
    if (it == a.end() || !kGains.count(ascii_lower(it->second)))
      throw ParseError(path, line, "pid_gain needs gain=kp|ki|kd");
    const auto g = kGains.at(ascii_lower(it->second));
    a.erase("gain");
    const auto seq = checked<std::uint8_t>(need_number(a, "sequence", 1.0, path, line), "sequence", path, line);
    const double v = need_number(a, "value", std::nullopt, path, line);
    out.push_back(sc::encode(sc::PidGain{g, seq, static_cast<float>(v)}));
  } else {
    throw ParseError(path, line,
                     "cannot send '" + name + "': use velocity_cmd, mode_cmd, config_cmd, pid_set, pid_gain or frame");
  }
  if (!a.empty()) throw ParseError(path, line, "unknown field '" + a.begin()->first + "' for " + name);
  return out;
}

/// MESSAGE COND... from w[i] up to (not including) one of the stop words; i is left on the stop word (or the end).
Step::Clause parse_clause(const std::vector<std::string>& w, std::size_t& i, std::initializer_list<const char*> stops,
                          const std::string& verb, const std::string& path, int line) {
  const auto stop = [&](const std::string& word) {
    return std::any_of(stops.begin(), stops.end(), [&](const char* s) { return word == s; });
  };
  if (i >= w.size() || stop(w[i])) throw ParseError(path, line, verb + " needs a message name");
  Step::Clause c;
  c.message = w[i] == "any" ? "" : w[i];
  for (++i; i < w.size() && !stop(w[i]); ++i) c.conditions.push_back(parse_condition(w[i], path, line));
  // A condition names a signal as decode --json does (docs/cli.md); a name the message lacks would never match.
  const signals::MessageDesc* d = signals::find_named(signals::Protocol::saul_can, c.message);
  if (d == nullptr) d = signals::find_named(signals::Protocol::vesc_can, c.message);
  for (const auto& cond : c.conditions)
    if (d != nullptr && !has_signal(*d, cond.field))
      throw ParseError(path, line, unknown_signal_error(c.message, d, cond.field));
  return c;
}

std::uint64_t need_duration(const std::string& w, const std::string& path, int line) {
  const auto d = quantity::parse_duration_us(w);
  if (!d) throw ParseError(path, line, "bad duration '" + w + "' (use 500ms, 2s, 1.5s, 1m)");
  return *d;
}

}  // namespace

Condition parse_condition(const std::string& w, const std::string& path, int line) {
  static const std::pair<const char*, Condition::Op> kOps[] = {{"!=", Condition::Op::ne}, {"<=", Condition::Op::le},
                                                               {">=", Condition::Op::ge}, {"=", Condition::Op::eq},
                                                               {"<", Condition::Op::lt},  {">", Condition::Op::gt}};
  for (const auto& [text, op] : kOps) {
    const auto pos = w.find(text);
    if (pos == std::string::npos || pos == 0) continue;
    Condition c;
    c.op = op;
    c.field = w.substr(0, pos);
    c.text = w.substr(pos + std::char_traits<char>::length(text));
    if (c.field.size() > 2 && c.field.front() == '|' && c.field.back() == '|') {
      c.absolute = true;
      c.field = c.field.substr(1, c.field.size() - 2);
    }
    c.number = number(c.text);
    if (c.text.empty()) throw ParseError(path, line, "condition '" + w + "' has no value");
    if ((op != Condition::Op::eq && op != Condition::Op::ne) && !c.number)
      throw ParseError(path, line, "condition '" + w + "' compares with a value that is not a number");
    return c;
  }
  throw ParseError(path, line, "'" + w + "' is not a condition (FIELD=VALUE, FIELD<VALUE, |FIELD|<VALUE, ...)");
}

bool holds(const Condition& c, const FieldValue& v) {
  if (c.number && v.number) {  // numbers compare as numbers (state=1 works as well as state=BALANCE)
    double x = *v.number;
    if (c.absolute) x = std::fabs(x);
    const double y = *c.number;
    switch (c.op) {
      case Condition::Op::eq: return x == y;
      case Condition::Op::ne: return x != y;
      case Condition::Op::lt: return x < y;
      case Condition::Op::le: return x <= y;
      case Condition::Op::gt: return x > y;
      case Condition::Op::ge: return x >= y;
    }
  }
  const bool same = ascii_lower(v.text) == ascii_lower(c.text);
  return c.op == Condition::Op::eq ? same : c.op == Condition::Op::ne ? !same : false;
}

Condition parse_tune_condition(const std::string& word, const std::string& path, int line) {
  // The unit is cut off a number before the condition is parsed (25% -> 25, 600ms -> 600 / 1000), then checked
  // against the figure's own. A division, so 300ms is the same double as 0.3 (300 x 0.001 need not be).
  static const std::pair<std::string_view, double> kUnits[] = {{"ms", 1000}, {"Hz", 1}, {"deg", 1}, {"%", 1}, {"s", 1}};
  std::string text = word;
  std::string_view unit;
  double divisor = 1;
  for (const auto& [u, per] : kUnits) {
    if (text.size() <= u.size() || !text.ends_with(u)) continue;
    const char before = text[text.size() - u.size() - 1];
    if (std::isdigit(static_cast<unsigned char>(before)) == 0 && before != '.') continue;
    text.resize(text.size() - u.size());
    unit = u == "ms" ? "s" : u;
    divisor = per;
    break;
  }
  Condition c = parse_condition(text, path, line);
  const auto* f = std::find_if(kTuneFigures.begin(), kTuneFigures.end(), [&](const auto& t) { return t.name == c.field; });
  if (f == kTuneFigures.end() || c.absolute) {
    std::string names;
    for (const auto& t : kTuneFigures) names += (names.empty() ? "" : ", ") + std::string(t.name);
    throw ParseError(path, line, "'" + word + "': no tuning figure '" + c.field + "' (" + names + ")");
  }
  if (!unit.empty() && unit != f->unit)
    throw ParseError(path, line, fmt::format("'{}': {} is in {}, not {}", word, f->name,
                                             f->unit.empty() ? std::string_view("a count") : f->unit, unit));
  if (c.number) {
    c.number = *c.number / divisor;
    c.text = fmt::format("{}", *c.number);
  } else if (c.field != "oscillation" || ascii_lower(c.text) != "none") {
    throw ParseError(path, line, "'" + word + "': the value must be a number (oscillation also takes none)");
  }
  return c;
}

Suite parse_suite(std::istream& in, const std::string& path) {
  Suite suite;
  suite.path = path;
  const auto slash = path.find_last_of('/');
  suite.name = path.substr(slash == std::string::npos ? 0 : slash + 1);
  std::string raw;
  int line = 0;
  while (std::getline(in, raw)) {
    ++line;
    // '#' inside a raw frame (send frame 302#01) is not a comment: only a '#' at the start or after a space is.
    std::string text = raw;
    for (std::size_t i = 0; i < raw.size(); ++i) {
      if (raw[i] == '#' && (i == 0 || raw[i - 1] == ' ' || raw[i - 1] == '\t')) {
        text = raw.substr(0, i);
        break;
      }
    }
    auto w = words(text);
    if (w.empty()) continue;
    if (w[0] == "suite:") {
      suite.name = text.substr(text.find(':') + 1);
      suite.name.erase(0, suite.name.find_first_not_of(' '));
      while (!suite.name.empty() && std::isspace(static_cast<unsigned char>(suite.name.back()))) suite.name.pop_back();
      continue;
    }
    if (w[0] == "requires:") {
      if (w.size() != 2 || w[1] != "sim") throw ParseError(path, line, "requires: takes 'sim'");
      suite.requires_sim = true;
      continue;
    }
    Step s;
    s.line = line;
    s.source = text;
    while (!s.source.empty() && std::isspace(static_cast<unsigned char>(s.source.back()))) s.source.pop_back();
    s.source.erase(0, s.source.find_first_not_of(" \t"));
    const std::string& verb = w[0];
    if (verb == "send") {
      s.kind = Step::Kind::send;
      s.frames = build_frames(w, 1, path, line);
    } else if (verb == "stream") {
      s.kind = Step::Kind::stream;
      const auto every = std::find(w.begin(), w.end(), "every");
      if (every == w.end() || every + 1 == w.end()) throw ParseError(path, line, "stream needs 'every DURATION'");
      s.period_us = need_duration(*(every + 1), path, line);
      if (s.period_us == 0) throw ParseError(path, line, "stream period must be above 0");
      std::vector<std::string> head(w.begin(), every);
      s.frames = build_frames(head, 1, path, line);
    } else if (verb == "stop") {
      s.kind = Step::Kind::stop;
    } else if (verb == "expect" && w.size() >= 2 && w[1] == "tune") {
      s.kind = Step::Kind::expect_tune;
      if (w.size() < 3) throw ParseError(path, line, "expect tune needs figures, e.g. overshoot<25% settling<0.6s");
      for (std::size_t i = 2; i < w.size(); ++i) s.conditions.push_back(parse_tune_condition(w[i], path, line));
    } else if (verb == "trace") {
      // trace [step|chirp|prbs AMPLITUDE] for DURATION
      s.kind = Step::Kind::trace;
      std::size_t i = 1;
      if (i < w.size() && w[i] != "for") {
        static const std::map<std::string, trace::Excite> kKinds = {
            {"step", trace::Excite::step}, {"chirp", trace::Excite::chirp}, {"prbs", trace::Excite::prbs}};
        if (!kKinds.count(w[i]) || i + 1 >= w.size())
          throw ParseError(path, line, "trace takes a test signal 'step|chirp|prbs AMPLITUDE_DEG' before 'for'");
        std::string amplitude = w[i + 1];
        if (amplitude.ends_with("deg")) amplitude.resize(amplitude.size() - 3);
        const auto a = number(amplitude);
        if (!a || *a == 0 || std::fabs(*a) > trace::kMaxAmplitudeDeg)
          throw ParseError(path, line, fmt::format("trace: the amplitude '{}' must be a number of degrees, 0 < |A| <= {}",
                                                   w[i + 1], trace::kMaxAmplitudeDeg));
        trace::ExciteStart e;
        e.kind = kKinds.at(w[i]);
        e.amplitude_deg = static_cast<float>(*a);
        e.f0_hz = 0.5F;  // chirp: what tune record sweeps by default
        e.f1_hz = 15.0F;
        s.excite = e;
        i += 2;
      }
      if (i + 2 != w.size() || w[i] != "for") throw ParseError(path, line, "trace needs 'for DURATION' at the end");
      s.duration_us = need_duration(w[i + 1], path, line);
      if (s.duration_us < 1'000'000 || s.duration_us > 600'000'000)
        throw ParseError(path, line, "trace: the duration must be 1 s to 10 min");
    } else if (verb == "expect" || verb == "hold" || verb == "mean") {
      // MESSAGE COND..., then 'within DURATION' (expect) or 'for DURATION' (expect no, hold, mean)
      std::size_t i = 1;
      s.kind = verb == "hold" ? Step::Kind::hold : verb == "mean" ? Step::Kind::mean : Step::Kind::expect;
      if (verb == "expect" && i < w.size() && w[i] == "no") {
        s.kind = Step::Kind::expect_none;
        ++i;
      }
      const std::string until = s.kind == Step::Kind::expect ? "within" : "for";
      auto c = parse_clause(w, i, {until.c_str()}, verb, path, line);
      if (s.kind == Step::Kind::mean && (c.message.empty() || c.conditions.empty()))
        throw ParseError(path, line, "mean needs a message name and at least one condition");
      s.message = std::move(c.message);
      s.conditions = std::move(c.conditions);
      if (i + 1 >= w.size()) throw ParseError(path, line, verb + " needs '" + until + " DURATION' at the end");
      s.duration_us = need_duration(w[i + 1], path, line);
      if (i + 2 != w.size()) throw ParseError(path, line, "unexpected words after the duration");
    } else if (verb == "stable") {
      s.kind = Step::Kind::stable;
      std::size_t i = 1;
      for (;;) {
        auto c = parse_clause(w, i, {"and", "for"}, verb, path, line);
        if (c.message.empty()) throw ParseError(path, line, "stable needs message names, not 'any'");
        if (s.message.empty()) {
          s.message = std::move(c.message);
          s.conditions = std::move(c.conditions);
        } else {
          s.more.push_back(std::move(c));
        }
        if (i >= w.size() || w[i] != "and") break;
        ++i;
      }
      if (i + 4 != w.size() || w[i] != "for" || w[i + 2] != "within")
        throw ParseError(path, line, "stable needs 'for DURATION within DURATION' at the end");
      s.duration_us = need_duration(w[i + 1], path, line);
      s.limit_us = need_duration(w[i + 3], path, line);
      if (s.duration_us == 0 || s.limit_us < s.duration_us)
        throw ParseError(path, line, "stable needs 0 < for <= within");
    } else if (verb == "console") {
      s.kind = Step::Kind::console;
      if (w.size() < 3) throw ParseError(path, line, "console needs a board (balance|io) and a command");
      s.board = w[1];
      if (s.board != "balance" && s.board != "io") throw ParseError(path, line, "console board must be balance or io");
      const auto ex = std::find(w.begin(), w.end(), "expect");
      if (ex == w.end() || ex + 1 == w.end()) throw ParseError(path, line, "console needs 'expect TEXT'");
      for (auto it = w.begin() + 2; it != ex; ++it) s.text += (s.text.empty() ? "" : " ") + *it;
      auto within = std::find(ex, w.end(), "within");
      for (auto it = ex + 1; it != within; ++it) s.expect_text += (s.expect_text.empty() ? "" : " ") + *it;
      s.duration_us = within == w.end() ? 1'000'000 : need_duration(within + 1 == w.end() ? "" : *(within + 1), path, line);
    } else if (verb == "sim") {
      s.kind = Step::Kind::sim;
      if (w.size() < 2) throw ParseError(path, line, "sim needs a command");
      for (std::size_t i = 1; i < w.size(); ++i) s.text += (i > 1 ? " " : "") + w[i];
    } else if (verb == "wait") {
      s.kind = Step::Kind::wait;
      if (w.size() != 2) throw ParseError(path, line, "wait takes one duration");
      s.duration_us = need_duration(w[1], path, line);
    } else {
      throw ParseError(path, line, "unknown step '" + verb +
                                       "' (send, stream, stop, expect, hold, mean, stable, console, sim, wait, trace)");
    }
    suite.steps.push_back(std::move(s));
  }
  return suite;
}

Suite load_suite(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw ParseError(path, 0, "cannot open the suite file");
  return parse_suite(f, path);
}

}  // namespace saul::host::suite
