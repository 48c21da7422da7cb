// MCAP (capture/mcap.hpp): the bytes at both ends written out by hand from mcap.dev/spec, the CRCs recomputed
// here over the spans the spec names, and the reader against every cut and every flipped byte of a file.
#include <catch2/catch.hpp>
#include <zlib.h>

#include <cstring>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "saulproto/host/capture/mcap.hpp"

using namespace saul;
using namespace saul::host;

namespace {

std::vector<CanFrame> random_frames(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<CanFrame> frames;
  std::uint64_t t = 1'700'000'000'000'000'000ULL;
  for (std::size_t i = 0; i < n; ++i) {
    CanFrame f;
    f.extended = rng() % 2 == 0;
    f.id = f.extended ? rng() % 0x20000000 : rng() % 0x800;
    f.dlc = static_cast<std::uint8_t>(rng() % 9);
    for (std::size_t k = 0; k < f.dlc; ++k) f.data[k] = static_cast<std::uint8_t>(rng());
    t += rng() % 300'000'000;  // up to 0.3 s apart: chunks close on time too
    f.timestamp_ns = t;
    frames.push_back(f);
  }
  return frames;
}

std::string write_file(const std::vector<CanFrame>& frames, McapCompression c, std::uint64_t chunk_bytes,
                       bool chunk_thread = true) {
  std::ostringstream out;
  McapWriterOptions o;
  o.compression = c;
  o.chunk_bytes = chunk_bytes;
  o.chunk_thread = chunk_thread;
  McapCaptureWriter w(out, o);
  for (const auto& f : frames) w.write(f, "can1");
  w.close();
  return out.str();
}

std::uint64_t u64_at(const std::string& s, std::size_t at) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = v << 8 | static_cast<std::uint8_t>(s[at + static_cast<std::size_t>(i)]);
  return v;
}
std::uint32_t crc_of(const std::string& s, std::size_t from, std::size_t to) {
  return static_cast<std::uint32_t>(::crc32(0, reinterpret_cast<const Bytef*>(s.data()) + from, static_cast<uInt>(to - from)));
}

struct ReadBack {
  std::vector<CanFrame> frames;
  std::vector<std::string> errors;
};
ReadBack read_back(const std::string& bytes) {
  std::istringstream in(bytes);
  ReadBack r;
  McapFrameReader reader(in, bytes.size());
  FrameBatch batch;
  for (std::size_t n = 0; n < bytes.size() + 10 && reader.next_batch(batch); ++n) {
    r.frames.insert(r.frames.end(), batch.frames.begin(), batch.frames.end());
    for (const auto& c : batch.corrupt) r.errors.push_back(format_capture_error("f", c.error));
  }
  return r;
}

}  // namespace

TEST_CASE("mcap: magic, Header, DataEnd, Footer and magic as the spec lays them out; the CRCs over its spans") {
  const std::string file = write_file(random_frames(50, 1), McapCompression::none, 1024);
  // Magic, then Header: opcode 01, length 15 (u64), profile "" (u32 0), library "saulctl" (u32 7 + bytes).
  const std::string head("\x89MCAP0\r\n\x01\x0F\0\0\0\0\0\0\0\0\0\0\0\x07\0\0\0saulctl", 8 + 9 + 15);
  REQUIRE(file.substr(0, head.size()) == head);
  // The end: Footer (opcode 02, length 20, summary_start, summary_offset_start, summary_crc), magic.
  REQUIRE(file.substr(file.size() - 8) == std::string("\x89MCAP0\r\n", 8));
  const std::size_t footer = file.size() - 8 - 29;
  REQUIRE(file.substr(footer, 9) == std::string("\x02\x14\0\0\0\0\0\0\0", 9));
  const std::uint64_t summary_start = u64_at(file, footer + 9);
  const std::uint64_t offsets_start = u64_at(file, footer + 17);
  REQUIRE(summary_start < offsets_start);
  REQUIRE(offsets_start < footer);
  std::uint32_t stored = 0;
  std::memcpy(&stored, file.data() + footer + 25, 4);
  CHECK(stored == crc_of(file, summary_start, footer + 25));  // summary .. summary_offset_start field
  // DataEnd (opcode 0F, length 4) ends where the summary starts; its CRC covers everything before it.
  const std::size_t data_end = summary_start - 13;
  REQUIRE(file.substr(data_end, 9) == std::string("\x0F\x04\0\0\0\0\0\0\0", 9));
  std::memcpy(&stored, file.data() + data_end + 9, 4);
  CHECK(stored == crc_of(file, 0, data_end));
}

TEST_CASE("mcap: frames read back exactly, in every compression, chunks small and large") {
  const auto frames = random_frames(400, 2);
  for (auto c : {McapCompression::none, McapCompression::lz4, McapCompression::zstd}) {
    for (std::uint64_t chunk : {std::uint64_t{200}, std::uint64_t{1} << 20}) {
      const auto r = read_back(write_file(frames, c, chunk));
      CHECK(r.errors.empty());
      REQUIRE(r.frames.size() == frames.size());
      for (std::size_t i = 0; i < frames.size(); ++i) REQUIRE(r.frames[i] == frames[i]);
    }
  }
}

TEST_CASE("mcap: chunks written by the caller (a live recording) give the same bytes as the chunk thread's") {
  const auto frames = random_frames(3000, 11);
  for (const auto c : {McapCompression::none, McapCompression::lz4, McapCompression::zstd}) {
    const std::string threaded = write_file(frames, c, 4096);
    const std::string inline_ = write_file(frames, c, 4096, false);
    CHECK(inline_ == threaded);
    CHECK(read_back(inline_).frames.size() == frames.size());
  }
}

TEST_CASE("mcap: a file cut at every byte reads a prefix of its frames, growing with the cut, and says it is cut") {
  // 30 frames in ~10 chunks: every kind of record and boundary is cut. Each cut is read whole and each of its
  // messages is a JSON document, so the cost grows with the square of the file (60 frames: a minute under ASan).
  const auto frames = random_frames(30, 3);
  const std::string file = write_file(frames, McapCompression::zstd, 300);
  std::size_t before = 0;
  for (std::size_t cut = 0; cut < file.size(); ++cut) {
    ReadBack r;
    try {
      r = read_back(file.substr(0, cut));
    } catch (const CaptureOpenError&) {
      REQUIRE(cut < 8);  // only a cut inside the magic is refused
      continue;
    }
    REQUIRE(r.frames.size() >= before);
    REQUIRE(r.frames.size() <= frames.size());
    for (std::size_t i = 0; i < r.frames.size(); ++i) REQUIRE(r.frames[i] == frames[i]);
    if (r.frames.size() < frames.size()) REQUIRE(r.errors.size() == 1);  // the cut, once
    before = r.frames.size();
  }
  CHECK(before == frames.size());
}

TEST_CASE("mcap: a flipped byte anywhere never makes a frame that was not written") {
  const auto frames = random_frames(20, 4);  // ~7 chunks; the square of the size, as above
  const std::string file = write_file(frames, McapCompression::none, 400);
  for (std::size_t at = 8; at < file.size(); ++at) {
    std::string bad = file;
    bad[at] = static_cast<char>(bad[at] ^ 0x10);
    const auto r = read_back(bad);
    // Every chunk's CRC covers its records: whatever byte is flipped, what comes out is frames that were written,
    // in order (some may be missing, reported).
    std::size_t k = 0;
    for (const auto& f : r.frames) {
      while (k < frames.size() && !(frames[k] == f)) ++k;
      INFO("byte " << at << " flipped: a frame that was not written came out");
      REQUIRE(k < frames.size());
    }
  }
}

TEST_CASE("mcap: channels and metadata added while the chunk thread writes come before the messages that use them") {
  // Chunks of ~64 bytes: nearly every message closes one and hands it to the chunk thread, while the caller
  // declares channels and writes metadata: each must wait for that thread, or its record lands inside a chunk's.
  for (auto c : {McapCompression::none, McapCompression::zstd}) {
    std::ostringstream out;
    McapWriterOptions o;
    o.compression = c;
    o.chunk_bytes = 64;
    std::vector<std::string> sent;
    std::vector<std::uint16_t> on;
    {
      McapWriter w(out, o);
      const auto schema = w.add_schema("s", "jsonschema", "{}");
      std::vector<std::uint16_t> channels{w.add_channel(schema, "/c0", "json")};
      std::mt19937 rng(5);
      for (int i = 0; i < 3000; ++i) {
        if (i % 7 == 0) channels.push_back(w.add_channel(schema, "/c" + std::to_string(channels.size()), "json"));
        if (i % 97 == 0) w.add_metadata("m", {{"i", std::to_string(i)}});
        on.push_back(channels[rng() % channels.size()]);
        sent.push_back("{\"i\":" + std::to_string(i) + "}");
        w.add_message(on.back(), 1'000'000'000ULL + static_cast<std::uint64_t>(i), sent.back());
      }
      w.close();
    }
    const std::string file = out.str();
    std::istringstream in(file);
    McapRecordReader r(in, file.size());
    std::size_t n = 0;
    for (;;) {
      const auto st = r.next();
      if (st == McapRecordReader::Status::end) break;
      REQUIRE(st == McapRecordReader::Status::message);  // no CRC mismatch, no record cut short
      const auto& m = r.message();
      REQUIRE(n < sent.size());
      REQUIRE(r.channel(m.channel_id) != nullptr);  // declared before its first message
      CHECK(m.channel_id == on[n]);
      CHECK(m.sequence == 0);  // not assigned (McapChunk)
      CHECK(std::string(m.data.begin(), m.data.end()) == sent[n]);
      ++n;
    }
    CHECK(n == sent.size());
    // The data section's CRC (DataEnd), summed by both threads, is zlib's crc32 of its bytes.
    const std::uint64_t summary_start = u64_at(file, file.size() - 8 - 29 + 9);
    std::uint32_t stored = 0;
    std::memcpy(&stored, file.data() + summary_start - 4, 4);
    CHECK(stored == crc_of(file, 0, summary_start - 13));
  }
}

TEST_CASE("mcap: a message written in place (begin_message, end_message) is the record add_message writes") {
  // In place, with more room asked than written (as the frames' JSON is): the record's length is the bytes written,
  // and the next message follows them, exactly as through add_message's copy.
  auto file = [](bool in_place) {
    std::ostringstream out;
    McapWriterOptions o;
    o.compression = McapCompression::none;
    {
      McapWriter w(out, o);
      const auto channel = w.add_channel(w.add_schema("s", "jsonschema", "{}"), "/c", "json");
      for (int i = 0; i < 50; ++i) {
        const std::string data = "{\"i\":" + std::to_string(i * 7919) + "}";
        const auto t = 1'000'000'000ULL + static_cast<std::uint64_t>(i);
        if (in_place) {
          char* p = w.begin_message(channel, t, data.size() + 100);
          std::memcpy(p, data.data(), data.size());
          w.end_message(data.size());
        } else {
          w.add_message(channel, t, data);
        }
      }
      w.close();
    }
    return out.str();
  };
  const std::string copied = file(false);
  CHECK(file(true) == copied);
  // The first Message record, by hand: opcode 05, length 29 (22 + the 7 bytes of data), channel 0, sequence 0, log
  // and publish time 1e9 ns (0x3B9ACA00), the data.
  const std::string record = std::string("\x05\x1D\0\0\0\0\0\0\0" "\0\0" "\0\0\0\0", 15) +
                             std::string("\x00\xCA\x9A\x3B\0\0\0\0" "\x00\xCA\x9A\x3B\0\0\0\0", 16) + "{\"i\":0}";
  CHECK(copied.find(record) != std::string::npos);
}

TEST_CASE("mcap: chunks filled apart and written in order (convert in blocks) give the bytes of one writer's chunks") {
  // The same frames cut into chunks by the same rule (McapChunk::full), once by the writer itself and once by the
  // caller filling chunks of its own, sealing them and handing them to write_chunk() in order: the same file.
  const auto frames = random_frames(2000, 12);
  for (const auto c : {McapCompression::none, McapCompression::lz4, McapCompression::zstd}) {
    const std::string one = write_file(frames, c, 4096);
    std::ostringstream out;
    McapWriterOptions o;
    o.compression = c;
    o.chunk_bytes = 4096;
    {
      McapCaptureWriter w(out, o);
      McapSealer sealer(o.compression, o.zstd_level);
      std::vector<McapChunk> chunks(1);
      for (const auto& f : frames) {
        const std::uint64_t t = *f.timestamp_ns;
        if (chunks.back().full(o, t)) chunks.emplace_back();
        add_frame_message(chunks.back(), kMcapFramesChannel, f, t, "\"can1\"");
      }
      REQUIRE(chunks.size() > 10);
      for (auto& chunk : chunks) chunk.seal(sealer);
      for (auto& chunk : chunks) w.writer().write_chunk(chunk);
      w.close();
    }
    CHECK(out.str() == one);
  }
}

TEST_CASE("mcap: a chunk's channel not added is added by on_undeclared before the chunk, or refused") {
  auto file = [](bool with_hook) {
    std::ostringstream out;
    McapWriterOptions o;
    o.compression = McapCompression::none;
    McapWriter w(out, o);
    const auto schema = w.add_schema("s", "jsonschema", "{}");
    w.add_channel(schema, "/a", "json");  // id 0
    if (with_hook)
      w.on_undeclared([schema](McapWriter& to, std::uint16_t id) {
        if (id != 700) return false;
        to.add_channel(id, schema, "/seven_hundred", "json");
        return true;
      });
    w.add_message(0, 1, "{}");
    w.add_message(700, 2, "{\"x\":1}");
    w.close();
    return out.str();
  };
  CHECK_THROWS_AS(file(false), std::out_of_range);
  const std::string f = file(true);
  std::istringstream in(f);
  McapRecordReader r(in, f.size());
  std::vector<std::string> topics;
  while (r.next() == McapRecordReader::Status::message) {
    REQUIRE(r.channel(r.message().channel_id) != nullptr);  // declared before the chunk that uses it
    topics.push_back(r.channel(r.message().channel_id)->topic);
  }
  CHECK(topics == std::vector<std::string>{"/a", "/seven_hundred"});
}
