#include "saulproto/core/console.hpp"

#include <limits>

namespace saul::console {
namespace {

// ---- words --------------------------------------------------------------------------------------------------

constexpr bool is_space(char c) noexcept { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

constexpr char lower(char c) noexcept { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

constexpr bool iequals(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (lower(a[i]) != lower(b[i])) return false;
  return true;
}

// Splits a line into words at runs of spaces, tabs, CR and LF. No copies: words are views into the line.
struct Words {
  std::string_view rest;
  bool next(std::string_view& word) noexcept {
    std::size_t i = 0;
    while (i < rest.size() && is_space(rest[i])) ++i;
    std::size_t j = i;
    while (j < rest.size() && !is_space(rest[j])) ++j;
    word = rest.substr(i, j - i);
    rest = rest.substr(j);
    return !word.empty();
  }
};

// ---- decimal numbers ----------------------------------------------------------------------------------------

// value = (negative ? -1 : 1) * mantissa * 10^exponent, plus a little more when inexact (nonzero digits beyond the
// 19 kept). 19 significant digits always fit in 64 bits.
struct Decimal {
  std::uint64_t mantissa = 0;
  std::int32_t exponent = 0;
  bool negative = false;
  bool inexact = false;
};

constexpr int kMaxDigits = 19;
constexpr std::int32_t kExponentCap = 100000;  // keeps exponent arithmetic far from overflow

constexpr bool is_digit(char c) noexcept { return c >= '0' && c <= '9'; }

Result<Decimal> parse_decimal(std::string_view w) noexcept {
  Decimal d;
  std::size_t i = 0;
  if (i < w.size() && (w[i] == '+' || w[i] == '-')) d.negative = w[i++] == '-';
  const std::string_view body = w.substr(i);
  if (iequals(body, "nan") || iequals(body, "inf") || iequals(body, "infinity")) return Reason::not_finite;

  int kept = 0;
  bool any = false;
  auto digit = [&](char c, bool after_point) {
    any = true;
    const auto v = static_cast<std::uint64_t>(c - '0');
    if (d.mantissa == 0 && v == 0) {  // leading zero: not significant
      if (after_point) --d.exponent;
      return;
    }
    if (kept < kMaxDigits) {
      d.mantissa = d.mantissa * 10 + v;
      ++kept;
      if (after_point) --d.exponent;
    } else {
      if (!after_point) ++d.exponent;
      if (v != 0) d.inexact = true;
    }
  };
  while (i < w.size() && is_digit(w[i])) digit(w[i++], false);
  if (i < w.size() && w[i] == '.') {
    ++i;
    while (i < w.size() && is_digit(w[i])) digit(w[i++], true);
  }
  if (!any) return Reason::not_a_number;
  if (i < w.size() && (w[i] == 'e' || w[i] == 'E')) {
    ++i;
    bool negative_exponent = false;
    if (i < w.size() && (w[i] == '+' || w[i] == '-')) negative_exponent = w[i++] == '-';
    if (i == w.size() || !is_digit(w[i])) return Reason::not_a_number;
    std::int32_t e = 0;
    while (i < w.size() && is_digit(w[i])) {
      if (e < kExponentCap) e = e * 10 + (w[i] - '0');
      ++i;
    }
    d.exponent += negative_exponent ? -e : e;
  }
  if (i != w.size()) return Reason::not_a_number;
  if (d.mantissa == 0) d.exponent = 0;
  return d;
}

// 10^k as a double: exact for k <= 22, one rounding per further factor 1e22 above (callers cap k near 400).
double pow10(std::int32_t k) noexcept {
  static constexpr double kExact[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                        1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  double r = 1.0;
  while (k > 22) {
    r *= 1e22;
    k -= 22;
  }
  return r * kExact[k];
}

// |value| as a double. Up to 19 digits and |exponent| <= 22 this is mantissa (rounded once if above 2^53) times or
// divided by an exact power: correctly rounded for the 9-digit numbers format_real() writes.
double magnitude(const Decimal& d) noexcept {
  if (d.mantissa == 0) return 0.0;
  const auto m = static_cast<double>(d.mantissa);
  if (d.exponent > 400) return std::numeric_limits<double>::infinity();
  if (d.exponent < -400) return 0.0;
  return d.exponent >= 0 ? m * pow10(d.exponent) : m / pow10(-d.exponent);
}

// |value| as a float, or out_of_range when it would round to infinity. Values between the largest float and
// 2^128 - 2^103 (half an ulp above it) round down to the largest float, as a compiler reads "3.4028235e38".
Result<float> to_float(const Decimal& d) noexcept {
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  constexpr double kRoundsToInfinity = kFloatMax + 0x1p103;  // exact in double
  const double v = magnitude(d);
  if (v >= kRoundsToInfinity) return Reason::out_of_range;
  if (v > kFloatMax) return std::numeric_limits<float>::max();  // converting it would be undefined
  return static_cast<float>(v);
}

// |value| * 10^shift split exactly into an integer part and what is left: saturated when the integer part does not
// fit in 64 bits; fraction when anything is left; half_up when what is left is at least one half.
struct Scaled {
  std::uint64_t whole = 0;
  bool saturated = false;
  bool fraction = false;
  bool half_up = false;
};

Scaled scale(const Decimal& d, std::int32_t shift) noexcept {
  Scaled s;
  if (d.mantissa == 0) return s;
  const std::int32_t e = d.exponent + shift;
  if (e >= 0) {
    s.whole = d.mantissa;
    for (std::int32_t i = 0; i < e; ++i) {
      if (s.whole > std::numeric_limits<std::uint64_t>::max() / 10) {
        s.saturated = true;
        break;
      }
      s.whole *= 10;
    }
    s.fraction = d.inexact;
    return s;
  }
  if (-e > kMaxDigits) {  // 10^-e > any 19-digit mantissa: all of it is fraction, less than one half
    s.fraction = true;
    return s;
  }
  std::uint64_t p = 1;
  for (std::int32_t i = 0; i < -e; ++i) p *= 10;  // <= 10^19 < 2^64
  s.whole = d.mantissa / p;
  const std::uint64_t r = d.mantissa % p;
  s.fraction = r != 0 || d.inexact;
  s.half_up = r >= p - r;  // r / p >= 1/2 without overflowing 2r
  return s;
}

// ---- command line -------------------------------------------------------------------------------------------

ParseResult fail(Reason reason, const char* message, std::size_t argument, const CommandSpec* spec) noexcept {
  ParseResult r;
  r.error = ParseError{reason, message, static_cast<std::uint8_t>(argument), spec};
  return r;
}

ParseResult done(const Command& command) noexcept {
  ParseResult r;
  r.command = command;
  return r;
}

constexpr const char* kNotANumber = "not a number";
constexpr const char* kNotFinite = "not a finite number";

const char* number_message(Reason reason) noexcept { return reason == Reason::not_finite ? kNotFinite : kNotANumber; }

}  // namespace

Result<float> parse_float(std::string_view word) noexcept {
  const auto d = parse_decimal(word);
  if (!d) return d.reason();
  const auto f = to_float(*d);
  if (!f) return f.reason();
  return d->negative ? -*f : *f;
}

ParseResult parse(std::string_view line) noexcept {
  Words words{line};
  std::string_view word;
  if (!words.next(word)) return fail(Reason::syntax, "empty line", 0, nullptr);
  const CommandSpec* spec = nullptr;
  for (const auto& c : kCommands)
    if (iequals(word, c.name)) spec = &c;
  if (spec == nullptr) return fail(Reason::unknown_command, "unknown command (try help)", 0, nullptr);

  std::string_view args[3];
  std::size_t count = 0;
  while (words.next(word)) {
    if (count == spec->arguments) return fail(Reason::extra_argument, "unexpected extra argument", count + 1, spec);
    args[count++] = word;
  }
  if (count < spec->arguments) return fail(Reason::missing_argument, "missing argument", count + 1, spec);

  switch (spec->verb) {
    case Verb::help: return done(HelpCmd{});
    case Verb::status: return done(StatusCmd{});
    case Verb::arm: return done(ArmCmd{});
    case Verb::disarm: return done(DisarmCmd{});
    case Verb::estop: return done(EstopCmd{});
    case Verb::can_stats: return done(CanStatsCmd{});
    case Verb::uart_stats: return done(UartStatsCmd{});
    case Verb::reboot: return done(RebootCmd{});
    case Verb::pid: {
      float gains[3] = {};
      for (std::size_t i = 0; i < 3; ++i) {
        const auto d = parse_decimal(args[i]);
        if (!d) return fail(d.reason(), number_message(d.reason()), i + 1, spec);
        if (d->negative && d->mantissa != 0) return fail(Reason::negative, "gain must not be negative", i + 1, spec);
        const auto f = to_float(*d);  // the magnitude, so "-0" becomes +0
        if (!f) return fail(Reason::out_of_range, "gain too large for a float", i + 1, spec);
        gains[i] = *f;
      }
      return done(PidCmd{gains[0], gains[1], gains[2]});
    }
    case Verb::tilt_limit: {
      constexpr const char* kRange = "tilt limit must be 5 to 25 degrees";
      const auto d = parse_decimal(args[0]);
      if (!d) return fail(d.reason(), number_message(d.reason()), 1, spec);
      // Exact comparison in hundredths: 25.001 and 4.999 are out, 25.004 is not rounded into range.
      const Scaled s = scale(*d, 2);
      if ((d->negative && d->mantissa != 0) || s.saturated || s.whole < TiltLimitCmd::kMinX100 ||
          s.whole > TiltLimitCmd::kMaxX100 || (s.whole == TiltLimitCmd::kMaxX100 && s.fraction))
        return fail(Reason::out_of_range, kRange, 1, spec);
      // Rounding up cannot leave the range: 2500 has no fraction here, and 2499.5.. rounds to 2500.
      return done(TiltLimitCmd{static_cast<std::uint16_t>(s.whole + (s.half_up ? 1U : 0U))});
    }
    case Verb::speed_limit: {
      const auto d = parse_decimal(args[0]);
      if (!d) return fail(d.reason(), number_message(d.reason()), 1, spec);
      const Scaled s = scale(*d, 0);
      if ((d->negative && d->mantissa != 0) || s.saturated || s.whole < SpeedLimitCmd::kMin ||
          s.whole > SpeedLimitCmd::kMax || (s.whole == SpeedLimitCmd::kMax && s.fraction))
        return fail(Reason::out_of_range, "speed limit must be 10 to 100 percent", 1, spec);
      if (s.fraction || s.whole % SpeedLimitCmd::kStep != 0)
        return fail(Reason::out_of_range, "speed limit must be a multiple of 10", 1, spec);
      return done(SpeedLimitCmd{static_cast<std::uint8_t>(s.whole)});
    }
  }
  return fail(Reason::unknown_command, "unknown command (try help)", 0, nullptr);
}

// ---- text writer --------------------------------------------------------------------------------------------

TextWriter& TextWriter::ch(char c) noexcept {
  if (length_ + 1 < out_.size()) {  // keep one char for the NUL
    out_[length_++] = c;
  } else {
    overflow_ = true;
  }
  return *this;
}

TextWriter& TextWriter::text(std::string_view s) noexcept {
  for (char c : s) ch(c);
  return *this;
}

TextWriter& TextWriter::unsigned_number(std::uint32_t v) noexcept {
  char digits[10];
  std::size_t n = 0;
  do {
    digits[n++] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v != 0);
  while (n > 0) ch(digits[--n]);
  return *this;
}

TextWriter& TextWriter::signed_number(std::int32_t v) noexcept {
  if (v < 0) {
    ch('-');
    return unsigned_number(0U - static_cast<std::uint32_t>(v));  // also right for INT32_MIN
  }
  return unsigned_number(static_cast<std::uint32_t>(v));
}

TextWriter& TextWriter::fixed(std::int32_t scaled, unsigned decimals) noexcept {
  std::uint32_t u = static_cast<std::uint32_t>(scaled);
  if (scaled < 0) {
    ch('-');
    u = 0U - u;
  }
  if (decimals > 9) decimals = 9;
  std::uint32_t p = 1;
  for (unsigned i = 0; i < decimals; ++i) p *= 10;
  unsigned_number(u / p);
  if (decimals == 0) return *this;
  ch('.');
  std::uint32_t frac = u % p;
  for (unsigned i = decimals; i > 0; --i) {
    p /= 10;
    ch(static_cast<char>('0' + frac / p));
    frac %= p;
  }
  return *this;
}

TextWriter& TextWriter::real(float v) noexcept {
  if (v != v) return text("nan");
  if (v > std::numeric_limits<float>::max()) return text("inf");
  if (v < -std::numeric_limits<float>::max()) return text("-inf");
  if (v == 0.0F) return ch('0');
  if (v < 0.0F) {
    ch('-');
    v = -v;
  }
  const double a = v;
  // Decimal exponent e: 10^e <= a < 10^(e+1). Estimated by repeated scaling (at most ~45 steps; the error of a
  // few ulp only matters right at a power of ten, and the digit count check below corrects it).
  std::int32_t e = 0;
  for (double s = a; s >= 10.0; s /= 10.0) ++e;
  for (double s = a; s < 1.0; s *= 10.0) --e;

  // Shortest p (1..9 significant digits) whose rounded digits read back as exactly v; 9 always do.
  std::uint64_t digits = 0;
  std::int32_t exponent = e;
  int p = 1;
  for (; p <= 9; ++p) {
    std::uint64_t lo = 1;
    for (int i = 1; i < p; ++i) lo *= 10;
    exponent = e;
    for (int attempt = 0; attempt < 3; ++attempt) {
      const std::int32_t k = exponent - p + 1;  // a / 10^k has p digits before the point
      const double scaled = k >= 0 ? a / pow10(k) : a * pow10(-k);
      digits = static_cast<std::uint64_t>(scaled + 0.5);
      if (digits >= lo * 10) {  // rounded up to 10^p, or the estimate was one too small
        ++exponent;
      } else if (digits < lo) {  // the estimate was one too large
        --exponent;
      } else {
        break;
      }
    }
    Decimal d;
    d.mantissa = digits;
    d.exponent = exponent - p + 1;
    const auto back = to_float(d);
    if (back && *back == v) break;
  }
  if (p > 9) p = 9;
  e = exponent;

  char ds[9];
  for (int i = p - 1; i >= 0; --i) {
    ds[i] = static_cast<char>('0' + digits % 10);
    digits /= 10;
  }
  while (p > 1 && ds[p - 1] == '0') --p;  // "1.50" -> "1.5" (only when p was forced to 9)
  if (e >= -5 && e < 9) {
    if (e < 0) {
      text("0.");
      for (std::int32_t i = -1; i > e; --i) ch('0');
      text({ds, static_cast<std::size_t>(p)});
    } else if (e >= p - 1) {
      text({ds, static_cast<std::size_t>(p)});
      for (std::int32_t i = p - 1; i < e; ++i) ch('0');
    } else {
      text({ds, static_cast<std::size_t>(e + 1)});
      ch('.');
      text({ds + e + 1, static_cast<std::size_t>(p - e - 1)});
    }
  } else {
    ch(ds[0]);
    if (p > 1) ch('.').text({ds + 1, static_cast<std::size_t>(p - 1)});
    ch('e');
    signed_number(e);
  }
  return *this;
}

Result<std::size_t> TextWriter::finish() noexcept {
  if (out_.empty()) return Reason::buffer_too_small;
  out_[length_] = '\0';  // length_ < out_.size() always: ch() keeps one char free
  if (overflow_) return Reason::buffer_too_small;
  return length_;
}

// ---- replies ------------------------------------------------------------------------------------------------

const char* to_string(Board board) noexcept {
  switch (board) {
    case Board::io: return "io";
    case Board::balance: return "balance";
  }
  return "?";
}

namespace {

void put(TextWriter& w, std::uint8_t v) noexcept { w.unsigned_number(v); }
void put(TextWriter& w, std::uint16_t v) noexcept { w.unsigned_number(v); }
void put(TextWriter& w, std::uint32_t v) noexcept { w.unsigned_number(v); }
void put(TextWriter& w, std::int16_t v) noexcept { w.signed_number(v); }
void put(TextWriter& w, float v) noexcept { w.real(v); }
void put(TextWriter& w, saulcan::RobotState v) noexcept { w.text(saulcan::to_string(v)); }
void put(TextWriter& w, Board v) noexcept { w.text(to_string(v)); }

template <class R>
Result<std::size_t> write_kv(const R& report, std::span<char> out) noexcept {
  TextWriter w(out);
  w.text("report=").text(R::kName);
  report.fields([&w](const char* key, const auto& value) {
    w.ch(' ').text(key).ch('=');
    put(w, value);
  });
  w.ch('\n');
  return w.finish();
}

// "LABEL: key value, key value\n" for reports whose fields need no units.
template <class R>
Result<std::size_t> write_plain_human(const char* label, const R& report, std::span<char> out) noexcept {
  TextWriter w(out);
  w.text(label).ch(':');
  bool first = true;
  report.fields([&](const char* key, const auto& value) {
    w.text(first ? " " : ", ").text(key).ch(' ');
    put(w, value);
    first = false;
  });
  w.ch('\n');
  return w.finish();
}

Reason get_unsigned(std::string_view s, std::uint32_t max, std::uint32_t& out) noexcept {
  if (s.empty()) return Reason::not_a_number;
  std::uint64_t v = 0;
  for (char c : s) {
    if (!is_digit(c)) return Reason::not_a_number;
    v = v * 10 + static_cast<std::uint64_t>(c - '0');
    if (v > max) return Reason::out_of_range;
  }
  out = static_cast<std::uint32_t>(v);
  return Reason::ok;
}

Reason get(std::string_view s, std::uint8_t& field) noexcept {
  std::uint32_t v = 0;
  const Reason r = get_unsigned(s, 0xFF, v);
  if (r == Reason::ok) field = static_cast<std::uint8_t>(v);
  return r;
}
Reason get(std::string_view s, std::uint16_t& field) noexcept {
  std::uint32_t v = 0;
  const Reason r = get_unsigned(s, 0xFFFF, v);
  if (r == Reason::ok) field = static_cast<std::uint16_t>(v);
  return r;
}
Reason get(std::string_view s, std::uint32_t& field) noexcept { return get_unsigned(s, 0xFFFFFFFFU, field); }
Reason get(std::string_view s, std::int16_t& field) noexcept {
  const bool negative = !s.empty() && s[0] == '-';
  std::uint32_t v = 0;
  const Reason r = get_unsigned(negative ? s.substr(1) : s, negative ? 32768U : 32767U, v);
  if (r == Reason::ok) {
    const auto magnitude_ = static_cast<std::int32_t>(v);
    field = static_cast<std::int16_t>(negative ? -magnitude_ : magnitude_);
  }
  return r;
}
Reason get(std::string_view s, float& field) noexcept {
  // A report may carry a non-finite value (a sensor gone bad); read back what TextWriter::real() writes.
  if (s == "nan") {
    field = std::numeric_limits<float>::quiet_NaN();
    return Reason::ok;
  }
  if (s == "inf" || s == "-inf") {
    field = s[0] == '-' ? -std::numeric_limits<float>::infinity() : std::numeric_limits<float>::infinity();
    return Reason::ok;
  }
  const auto f = parse_float(s);
  if (f) field = *f;
  return f.reason();
}
Reason get(std::string_view s, saulcan::RobotState& field) noexcept {
  for (std::uint8_t i = 0; i <= static_cast<std::uint8_t>(saulcan::RobotState::fault); ++i) {
    const auto state = static_cast<saulcan::RobotState>(i);
    if (s == saulcan::to_string(state)) {
      field = state;
      return Reason::ok;
    }
  }
  return Reason::out_of_range;
}
Reason get(std::string_view s, Board& field) noexcept {
  for (Board b : {Board::io, Board::balance}) {
    if (s == to_string(b)) {
      field = b;
      return Reason::ok;
    }
  }
  return Reason::out_of_range;
}

template <class R>
Result<R> read_kv(std::string_view line) noexcept {
  constexpr std::string_view kReport = "report=";
  Words words{line};
  std::string_view word;
  if (!words.next(word) || word.substr(0, kReport.size()) != kReport) return Reason::syntax;
  if (word.substr(kReport.size()) != R::kName) return Reason::unknown_type;

  R report{};
  unsigned total = 0;
  report.fields([&total](const char*, const auto&) { ++total; });
  static_assert(sizeof(std::uint32_t) * 8 >= 16, "seen is a bit set of fields");
  std::uint32_t seen = 0;
  while (words.next(word)) {
    const std::size_t eq = word.find('=');
    if (eq == std::string_view::npos || eq == 0) return Reason::syntax;
    const std::string_view key = word.substr(0, eq);
    const std::string_view value = word.substr(eq + 1);
    Reason result = Reason::ok;
    unsigned index = 0;
    report.fields([&](const char* name, auto& field) {
      if (key == name) {
        const std::uint32_t bit = 1U << index;
        result = (seen & bit) != 0 ? Reason::syntax : get(value, field);
        seen |= bit;
      }
      ++index;
    });
    if (result != Reason::ok) return result;  // unknown keys leave result ok: skipped
  }
  if (seen != (1U << total) - 1U) return Reason::missing_argument;
  return report;
}

}  // namespace

Result<std::size_t> format_kv(const StatusReport& report, std::span<char> out) noexcept { return write_kv(report, out); }
Result<std::size_t> format_kv(const CanStats& report, std::span<char> out) noexcept { return write_kv(report, out); }
Result<std::size_t> format_kv(const UartStats& report, std::span<char> out) noexcept { return write_kv(report, out); }

Result<StatusReport> parse_status(std::string_view line) noexcept { return read_kv<StatusReport>(line); }
Result<CanStats> parse_can_stats(std::string_view line) noexcept { return read_kv<CanStats>(line); }
Result<UartStats> parse_uart_stats(std::string_view line) noexcept { return read_kv<UartStats>(line); }

Result<std::size_t> format_human(const StatusReport& r, std::span<char> out) noexcept {
  TextWriter w(out);
  w.text("board ").text(to_string(r.board)).text(", state ").text(saulcan::to_string(r.state)).ch('\n');
  w.text("pitch ").fixed(r.pitch_x100, 2).text(" deg, pid_out ").signed_number(r.pid_out).text(" permille\n");
  w.text("pid kp ").real(r.kp).text(", ki ").real(r.ki).text(", kd ").real(r.kd).ch('\n');
  w.text("tilt limit ").fixed(r.tilt_limit_x100, 2).text(" deg, speed limit ").unsigned_number(r.speed_limit_pct).text(" %\n");
  w.text("battery ").fixed(r.battery_mv, 3).text(" V, faults");
  if (r.faults == 0) w.text(" none");
  for (unsigned bit = 0; bit < 8; ++bit)
    if ((r.faults >> bit) & 1U) w.ch(' ').text(saulcan::fault::bit_name(bit));
  w.ch('\n');
  w.text("uptime ").unsigned_number(r.uptime_ms / 1000).ch('.');
  const std::uint32_t ms = r.uptime_ms % 1000;
  w.ch(static_cast<char>('0' + ms / 100)).ch(static_cast<char>('0' + ms / 10 % 10)).ch(static_cast<char>('0' + ms % 10));
  w.text(" s\n");
  return w.finish();
}

Result<std::size_t> format_human(const CanStats& report, std::span<char> out) noexcept {
  return write_plain_human("CAN", report, out);
}

Result<std::size_t> format_human(const UartStats& report, std::span<char> out) noexcept {
  return write_plain_human("UART", report, out);
}

Result<std::size_t> format_help(std::span<char> out) noexcept {
  constexpr std::size_t kColumn = 20;
  TextWriter w(out);
  for (const auto& c : kCommands) {
    const std::string_view usage = c.usage;
    w.text(usage);
    for (std::size_t i = usage.size(); i < kColumn; ++i) w.ch(' ');
    w.ch(' ').text(c.summary).ch('\n');
  }
  return w.finish();
}

Result<std::size_t> format_ok(std::span<char> out) noexcept {
  TextWriter w(out);
  w.text("ok\n");
  return w.finish();
}

Result<std::size_t> format_error(const ParseError& error, std::span<char> out) noexcept {
  TextWriter w(out);
  w.text("error: ").text(error.message);
  if (error.argument > 0) {
    w.text(" (argument ").unsigned_number(error.argument);
    if (error.command != nullptr) w.text("; usage: ").text(error.command->usage);
    w.ch(')');
  }
  w.text(" [").text(to_string(error.reason)).text("]\n");
  return w.finish();
}

}  // namespace saul::console
