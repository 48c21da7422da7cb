#include "trace_cli.hpp"

#include <fmt/core.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "commands.hpp"
#include "saulproto/host/capture/trace_file.hpp"
#include "saulproto/host/report/format.hpp"
#include "saulproto/host/report/plot.hpp"
#include "saulproto/host/report/trace_report.hpp"

namespace saulctl {

namespace {

/// Reads the file, calling on_record for each record with its unwrapped time; corrupt records go to stderr.
/// Returns the stats, or nullopt after printing why the file could not be read.
template <class OnRecord>
std::optional<saul::host::TraceStats> read(const char* verb, const std::string& path, OnRecord&& on_record) {
  saul::host::TraceStats stats;
  saul::host::TraceClock clock;
  saul::host::TraceSink sink;
  sink.record = [&](const saul::trace::LoopTrace& r, std::uint64_t) {
    stats.add(r);
    on_record(r, clock.seconds(r.time_us));
  };
  sink.corrupt = [&](saul::Reason reason, std::uint64_t offset) {
    fmt::print(stderr, "saulctl {}: {}: corrupt record at byte {} ({}); the rest is read\n", verb, path, offset,
               saul::to_string(reason));
  };
  try {
    stats.finish(saul::host::read_trace_file(path, sink));
  } catch (const std::runtime_error& e) {
    fmt::print(stderr, "saulctl {}: {}\n", verb, e.what());
    return std::nullopt;
  }
  return stats;
}

}  // namespace

bool is_trace(const std::string& path) { return saul::host::is_trace_file(path); }

int decode_trace(const std::string& path, bool json) {
  const auto stats = read("decode", path, [&](const saul::trace::LoopTrace& r, double t) {
    if (json) {
      fmt::print("{}\n", saul::host::json_line(saul::host::trace_json(r, t)));
    } else {
      fmt::print("{}\n", saul::host::trace_text(r, t));
    }
  });
  return stats ? kOk : kFailure;
}

int stats_trace(const std::string& path, bool json) {
  const auto stats = read("stats", path, [](const saul::trace::LoopTrace&, double) {});
  if (!stats) return kFailure;
  if (json) {
    fmt::print("{}\n", saul::host::json_line(stats->json(path)));
  } else {
    fmt::print("{}", stats->text(path));
  }
  return kOk;
}

int convert_trace(const std::string& in, const std::string& out) {
  std::FILE* f = out == "-" ? stdout : std::fopen(out.c_str(), "w");
  if (f == nullptr) {
    say("cannot create '{}'", out);
    return kFailure;
  }
  std::fputs(saul::host::trace_csv_header().c_str(), f);
  const auto stats = read("convert", in, [&](const saul::trace::LoopTrace& r, double t) {
    std::fputs(saul::host::trace_csv_row(r, t).c_str(), f);
  });
  const bool written = std::ferror(f) == 0;
  if (f != stdout) std::fclose(f);
  if (!stats) {
    if (out != "-") std::remove(out.c_str());
    return kFailure;
  }
  if (!written) {
    say("cannot write '{}'", out);
    return kFailure;
  }
  say("{} records from {} into {} (CSV)", stats->records(), in, out);
  return kOk;
}

int convert_trace_mcap(const std::string& in, const std::string& out, const saul::host::McapWriterOptions& options,
                       const saul::host::McapMap& metadata) {
  using namespace saul::host;
  std::ofstream file;
  if (out != "-") file.open(out, std::ios::binary | std::ios::trunc);
  std::ostream& stream = out == "-" ? std::cout : file;
  if (!stream) {
    say("cannot create '{}'", out);
    return kFailure;
  }
  std::optional<TraceStats> stats;
  try {
    McapWriter mcap(stream, options);
    mcap.add_metadata("saulctl", metadata);
    const auto schema = mcap.add_schema("saul.loop_trace", "jsonschema", trace_json_schema());
    const auto channel = mcap.add_channel(schema, "/saul/loop_trace", "json");
    stats = read("convert", in, [&](const saul::trace::LoopTrace& r, double t) {
      // Log time in ns from the record's whole microseconds (t is their unwrapped count times 1e-6).
      const auto ns = static_cast<std::uint64_t>(std::llround(t * 1e6)) * 1000;
      mcap.add_message(channel, ns, json_line(trace_json(r, t)));
    });
    mcap.close();
  } catch (const std::runtime_error& e) {  // the stream failed (a full disk)
    stats.reset();
    say("cannot write '{}': {}", out, e.what());
  }
  if (!stats) {
    if (out != "-") {
      file.close();
      std::remove(out.c_str());
    }
    return kFailure;
  }
  say("{} records from {} into {} (MCAP, channel /saul/loop_trace)",
      stats->records(), in, out);
  return kOk;
}

int plot_trace(const std::string& in, const std::string& format, const std::string& out) {
  using namespace saul::host;
  try {
    const bool picture = format == "svg" || format == "png" || format == "pdf";
    const PlotDocument doc = trace_plot_document(in, picture ? kStaticColumns : kInteractiveColumns);
    if (picture) {
      render_static(doc, format, out == "-" ? "" : out);
    } else if (format == "html") {
      const std::string page = render_html(doc, load_dygraphs());
      std::FILE* f = out == "-" ? stdout : std::fopen(out.c_str(), "w");
      const bool ok = f != nullptr && std::fwrite(page.data(), 1, page.size(), f) == page.size();
      if (f != nullptr && f != stdout) std::fclose(f);
      if (!ok) throw std::runtime_error("cannot write '" + out + "'");
    } else {
      return convert_trace(in, out);  // csv: the trace's own columns
    }
  } catch (const std::runtime_error& e) {
    say("{}", e.what());
    return kFailure;
  }
  say("the loop trace {} written to {}", in, out == "-" ? "stdout" : out);
  return kOk;
}

}  // namespace saulctl
