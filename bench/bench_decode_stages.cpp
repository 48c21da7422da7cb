// saulctl decode and stats stage by stage, on a generated robot-bus candump log (the mix of bench_capture_decode.cpp
// with payloads that vary): scan (CandumpReader: big reads, lines in place, batches), parse (parse_candump_line
// alone), decode (decode_bus_frame), emit (FrameEmitter text / CSV / JSON into one buffer; a message's JSON by
// append_message and by nlohmann's dump), stuff bits (table-driven against the bit-by-bit count), and the whole decode_capture on one thread
// and two. Run: build/bench/saul_bench --benchmark_filter='Scan|Parse|Emit|Stuff|Decode'
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "saulproto/core/dispatch.hpp"
#include "saulproto/host/capture/candump.hpp"
#include "saulproto/host/capture/serial_capture.hpp"
#include "saulproto/host/report/bus_stats.hpp"
#include "saulproto/host/report/fast_decode.hpp"
#include "saulproto/host/report/fast_emit.hpp"
#include "saulproto/host/report/format.hpp"

namespace {

using namespace saul::host;

constexpr std::size_t kLines = 200'000;

std::string generated_log(std::size_t lines) {
  std::string out;
  out.reserve(lines * 48);
  char line[96];
  for (std::size_t i = 0; i < lines; ++i) {
    const std::uint64_t us = 1'763'800'000'000'000ULL + i * 500;
    const unsigned v = static_cast<unsigned>(i * 2654435761U);
    const auto sec = static_cast<unsigned long long>(us / 1'000'000);
    const auto usec = static_cast<unsigned long long>(us % 1'000'000);
    switch (i % 6) {
      case 0: std::snprintf(line, sizeof line, "(%llu.%06llu) can0 300#%04X0CFE\n", sec, usec, v & 0x3FF); break;
      case 1: std::snprintf(line, sizeof line, "(%llu.%06llu) can0 400#%04XA4012C0101\n", sec, usec, v & 0xFF); break;
      case 2: std::snprintf(line, sizeof line, "(%llu.%06llu) can0 401#B00464FBB09A11\n", sec, usec); break;
      case 3: std::snprintf(line, sizeof line, "(%llu.%06llu) can0 00000344#0000%04X\n", sec, usec, v & 0xFFF); break;
      case 4:
        std::snprintf(line, sizeof line, "(%llu.%06llu) can0 00000944#0000%04X000C000B\n", sec, usec, v & 0x3FF);
        break;
      default: std::snprintf(line, sizeof line, "(%llu.%06llu) can0 00001B38#%08X018C0000\n", sec, usec, v); break;
    }
    out += line;
  }
  return out;
}

const std::string& log_text() {
  static const std::string log = generated_log(kLines);
  return log;
}

/// The log as a file, for the scanner and the driver.
struct LogFile {
  std::string path;
  LogFile() {
    char name[] = "/tmp/saul_bench_XXXXXX";
    const int fd = mkstemp(name);
    const std::string& log = log_text();
    if (fd < 0 || ::write(fd, log.data(), log.size()) != static_cast<ssize_t>(log.size())) std::abort();
    ::close(fd);
    path = name;
  }
  ~LogFile() { std::remove(path.c_str()); }
};
const LogFile& log_file() {
  static const LogFile file;
  return file;
}

std::vector<std::pair<saul::CanFrame, std::string>> parsed_frames() {
  std::vector<std::pair<saul::CanFrame, std::string>> out;
  const std::string& log = log_text();
  std::size_t pos = 0;
  while (pos < log.size()) {
    const std::size_t nl = log.find('\n', pos);
    CandumpLine l;
    CaptureError e;
    if (parse_candump_line(std::string_view(log).substr(pos, nl - pos), l, e))
      out.emplace_back(l.frame, std::string(l.interface));
    pos = nl + 1;
  }
  return out;
}

void rate(benchmark::State& state, std::uint64_t frames) {
  state.SetItemsProcessed(static_cast<std::int64_t>(frames));
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
}

void BM_Scan(benchmark::State& state) {
  std::uint64_t frames = 0;
  FrameBatch batch;
  for (auto _ : state) {
    std::ifstream in(log_file().path, std::ios::binary);
    CandumpReader scanner(in);
    while (scanner.next_batch(batch)) frames += batch.frames.size();
  }
  rate(state, frames);
}
BENCHMARK(BM_Scan)->Unit(benchmark::kMillisecond);

void BM_ParseLine(benchmark::State& state) {
  const std::string& log = log_text();
  std::uint64_t frames = 0;
  for (auto _ : state) {
    std::size_t pos = 0;
    CandumpLine l;
    CaptureError e;
    while (pos < log.size()) {
      const std::size_t nl = log.find('\n', pos);
      frames += parse_candump_line(std::string_view(log).substr(pos, nl - pos), l, e);
      pos = nl + 1;
    }
    benchmark::DoNotOptimize(l);
  }
  rate(state, frames);
}
BENCHMARK(BM_ParseLine)->Unit(benchmark::kMillisecond);

void BM_DecodeBusFrame(benchmark::State& state) {
  const auto frames = parsed_frames();
  std::uint64_t n = 0;
  for (auto _ : state) {
    for (const auto& [f, iface] : frames) benchmark::DoNotOptimize(saul::decode_bus_frame(f));
    n += frames.size();
  }
  rate(state, n);
}
BENCHMARK(BM_DecodeBusFrame)->Unit(benchmark::kMillisecond);

void emit(benchmark::State& state, DecodeFormat format) {
  const auto frames = parsed_frames();
  std::uint64_t n = 0;
  fmt::memory_buffer out;
  for (auto _ : state) {
    FrameEmitter emitter(format, TimeMode::absolute);
    DecodeCounts counts;
    for (const auto& [f, iface] : frames) {
      emitter.add(f, iface, out, counts);
      if (out.size() > (1 << 20)) out.clear();
    }
    n += frames.size();
  }
  rate(state, n);
}
void BM_EmitText(benchmark::State& state) { emit(state, DecodeFormat::text); }
void BM_EmitCsv(benchmark::State& state) { emit(state, DecodeFormat::csv); }
void BM_EmitJson(benchmark::State& state) { emit(state, DecodeFormat::jsonl); }
BENCHMARK(BM_EmitText)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EmitCsv)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EmitJson)->Unit(benchmark::kMillisecond);

// JSON through one writer: format.hpp's append_message (reading the values and writing them) against nlohmann's
// dump() of the same messages' DOMs made beforehand (the writer alone), on the decoded frames of the mix.
std::vector<std::pair<const saul::signals::MessageDesc*, saul::CanFrame>> decoded_frames() {
  std::vector<std::pair<const saul::signals::MessageDesc*, saul::CanFrame>> out;
  for (const auto& [f, iface] : parsed_frames())
    if (saul::decode_bus_frame(f)) out.emplace_back(saul::signals::find_can(f.id, f.extended), f);
  return out;
}
void BM_MessageJson(benchmark::State& state) {
  const auto frames = decoded_frames();
  std::string out;
  for (auto _ : state) {
    for (const auto& [d, f] : frames) {
      out.clear();
      append_message(out, MessageFormat::json, *d, saul::signals::Wire{f.id, f.payload()});
      benchmark::DoNotOptimize(out.data());
    }
  }
  rate(state, static_cast<std::uint64_t>(state.iterations()) * frames.size());
}
void BM_MessageJsonNlohmannDump(benchmark::State& state) {
  std::vector<nlohmann::json> doms;
  for (const auto& [d, f] : decoded_frames()) doms.push_back(to_json(saul::decode_bus_frame(f).value()));
  for (auto _ : state)
    for (const auto& j : doms) benchmark::DoNotOptimize(json_line(j));
  rate(state, static_cast<std::uint64_t>(state.iterations()) * doms.size());
}
BENCHMARK(BM_MessageJson)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MessageJsonNlohmannDump)->Unit(benchmark::kMillisecond);

void BM_StuffBits(benchmark::State& state) {
  const auto frames = parsed_frames();
  std::uint64_t n = 0;
  for (auto _ : state) {
    unsigned total = 0;
    for (const auto& [f, iface] : frames) total += can_stuff_bits(f);
    benchmark::DoNotOptimize(total);
    n += frames.size();
  }
  rate(state, n);
}
BENCHMARK(BM_StuffBits)->Unit(benchmark::kMillisecond);

// What stats' line tables pay for a content they have not seen: the header's share known (CanStuffStart per id and
// DLC), the data bytes' steps one after another. Each frame's count feeds the next frame's start state, as a chain
// of new contents would: latency, not throughput.
void BM_StuffBitsData(benchmark::State& state) {
  const auto frames = parsed_frames();
  std::vector<std::pair<saul::host::CanStuffStart, std::array<std::uint8_t, 8>>> starts;
  for (const auto& [f, iface] : frames)
    starts.push_back({saul::host::can_stuff_start(f.id, f.extended, f.remote, f.dlc), f.data});
  std::uint64_t n = 0;
  for (auto _ : state) {
    unsigned total = 0;
    for (auto [start, data] : starts) {
      data[0] = static_cast<std::uint8_t>(data[0] ^ (total & 1));  // depends on the count before
      total += saul::host::can_stuff_bits(start, data.data());
    }
    benchmark::DoNotOptimize(total);
    n += starts.size();
  }
  rate(state, n);
}
BENCHMARK(BM_StuffBitsData)->Unit(benchmark::kMillisecond);

void BM_BusStatsAdd(benchmark::State& state) {
  const auto frames = parsed_frames();
  std::uint64_t n = 0;
  for (auto _ : state) {
    BusStats stats{BusStatsOptions{}};
    for (const auto& [f, iface] : frames) stats.add(f, iface);
    benchmark::DoNotOptimize(stats.frames());
    n += frames.size();
  }
  rate(state, n);
}
BENCHMARK(BM_BusStatsAdd)->Unit(benchmark::kMillisecond);

/// The whole decode of the file: arg 0 = format (0 text, 1 CSV, 2 JSON), arg 1 = threads.
void BM_DecodeFile(benchmark::State& state) {
  FrameDecodeOptions o;
  o.format = static_cast<DecodeFormat>(state.range(0));
  o.read.threads = static_cast<unsigned>(state.range(1));
  o.read.parallel_from = 0;
  FrameDecodeSinks sinks;
  std::uint64_t bytes = 0;
  sinks.write = [&](std::string_view s) { bytes += s.size(); };
  sinks.corrupt = [](const CaptureError&) {};
  std::uint64_t n = 0;
  for (auto _ : state) {
    auto opened = open_capture(log_file().path);
    n += decode_capture(log_file().path, opened.frames, opened.compressed, o, sinks).records;
  }
  benchmark::DoNotOptimize(bytes);
  rate(state, n);
}
BENCHMARK(BM_DecodeFile)->ArgsProduct({{0, 1, 2}, {1, 2}})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
