// decode, stats, convert and plot of a loop trace file (`saulctl tune record`'s, docs/captures.md "Loop traces"):
// each verb hands a file that starts with the trace header to these before its own capture readers.
#pragma once

#include <string>

#include "saulproto/host/capture/mcap.hpp"

namespace saulctl {

/// True when `path` is a loop trace file (it starts with "SAULTRACE 1").
bool is_trace(const std::string& path);
/// One line per record (--json: one JSON object per record, physical units); corrupt records on stderr with their
/// byte offset. Exit code.
int decode_trace(const std::string& path, bool json);
/// Records, gaps, loop period and jitter, corrupt records. Exit code.
int stats_trace(const std::string& path, bool json);
/// CSV with one column per field, named with its unit. Exit code.
int convert_trace(const std::string& in, const std::string& out);
/// MCAP: one message per record on "/saul/loop_trace" (trace_json()'s object, schema trace_json_schema(); log time =
/// the record's time in ns), after a Metadata record "saulctl" holding `metadata`. Exit code.
int convert_trace_mcap(const std::string& in, const std::string& out, const saul::host::McapWriterOptions& options,
                       const saul::host::McapMap& metadata);

/// The trace's panels as a picture (svg, png, pdf through gnuplot) or a page (html). Exit code.
int plot_trace(const std::string& in, const std::string& format, const std::string& out);

}  // namespace saulctl
