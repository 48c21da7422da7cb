#include "saulproto/host/capture/mcap.hpp"

#include <fmt/format.h>
#include <libdeflate.h>
#include <lz4frame.h>
#include <nlohmann/json.hpp>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>

#include "capture_io.hpp"
#include "read_path.hpp"

namespace saul::host {
namespace {

using detail::load_u16;
using detail::load_u32;
using detail::load_u64;

// Opcodes (mcap.dev/spec).
constexpr std::uint8_t kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05,
                       kChunk = 0x06, kMessageIndex = 0x07, kChunkIndex = 0x08, kStatistics = 0x0B,
                       kMetadata = 0x0C, kMetadataIndex = 0x0D, kSummaryOffset = 0x0E, kDataEnd = 0x0F;
constexpr std::size_t kRecordHead = 9;  // opcode u8, length u64
constexpr std::size_t kMessageFields = 2 + 4 + 8 + 8;  // a Message's channel id, sequence, log and publish time

/// The CRC-32 MCAP uses (zlib's), continued from `crc`: libdeflate's, which folds 64 bytes at a time with
/// carry-less multiplication where the CPU has it (zlib 1.2's table-driven crc32 made a quarter of convert's time).
std::uint32_t crc_of(std::uint32_t crc, const std::uint8_t* p, std::size_t n) { return libdeflate_crc32(crc, p, n); }

/// `v`'s low `n` bytes, little-endian, at `p`; returns their end. One store on a little-endian CPU (a store per
/// byte made a third of a message record's cost).
std::uint8_t* put_le(std::uint8_t* p, std::uint64_t v, int n) {
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(p, &v, static_cast<std::size_t>(n));
    return p + n;
  }
  for (int i = 0; i < n; ++i) *p++ = static_cast<std::uint8_t>(v >> (8 * i));
  return p;
}

/// A record's body built field by field, little-endian; record() prefixes opcode and length.
class Body {
 public:
  Body& u8(std::uint8_t v) {
    b_.push_back(v);
    return *this;
  }
  Body& u16(std::uint16_t v) { return le(v, 2); }
  Body& u32(std::uint32_t v) { return le(v, 4); }
  Body& u64(std::uint64_t v) { return le(v, 8); }
  Body& str(std::string_view s) {
    u32(static_cast<std::uint32_t>(s.size()));
    b_.insert(b_.end(), s.begin(), s.end());
    return *this;
  }
  Body& bytes(std::span<const std::uint8_t> s) {
    b_.insert(b_.end(), s.begin(), s.end());
    return *this;
  }
  Body& map(const McapMap& m) {
    Body e;
    for (const auto& [k, v] : m) e.str(k).str(v);
    u32(static_cast<std::uint32_t>(e.b_.size()));
    return bytes(e.b_);
  }
  [[nodiscard]] const std::vector<std::uint8_t>& data() const { return b_; }
  [[nodiscard]] std::vector<std::uint8_t> record(std::uint8_t opcode) const {
    Body r;
    r.u8(opcode).u64(b_.size()).bytes(b_);
    return std::move(r.b_);
  }

 private:
  Body& le(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    return *this;
  }
  std::vector<std::uint8_t> b_;
};

void append(std::vector<std::uint8_t>& to, const std::vector<std::uint8_t>& from) {
  to.insert(to.end(), from.begin(), from.end());
}

std::string_view compression_name(McapCompression c) {
  switch (c) {
    case McapCompression::none: return "";
    case McapCompression::lz4: return "lz4";
    case McapCompression::zstd: return "zstd";
  }
  return "";
}

/// `in` as an lz4 frame in `out` (replaced).
/// `out` grown to `bound` bytes if it is smaller, never shrunk: a resize down and up again would zero the bytes
/// anew for every chunk (a megabyte of memset per chunk, for bytes the compressor overwrites).
std::span<std::uint8_t> room(std::vector<std::uint8_t>& out, std::size_t bound) {
  if (out.size() < bound) out.resize(bound);
  return out;
}

/// `in` as an lz4 frame in `out`'s first bytes, which it returns.
std::span<const std::uint8_t> compress_lz4(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out) {
  LZ4F_preferences_t prefs{};
  prefs.frameInfo.contentSize = in.size();
  const auto dst = room(out, LZ4F_compressFrameBound(in.size(), &prefs));
  const std::size_t n = LZ4F_compressFrame(dst.data(), dst.size(), in.data(), in.size(), &prefs);
  if (LZ4F_isError(n)) throw std::runtime_error(std::string("lz4: ") + LZ4F_getErrorName(n));
  return dst.first(n);
}

/// `in` decompressed into `out`, which must come out exactly `size` bytes; the error, or "" when it did.
std::string decompress(std::string_view name, std::span<const std::uint8_t> in, std::uint64_t size,
                       std::vector<std::uint8_t>& out) {
  out.resize(size);
  if (name == "zstd") {
    const std::size_t n = ZSTD_decompress(out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(n)) return std::string("zstd: ") + ZSTD_getErrorName(n);
    if (n != size) return fmt::format("zstd data holds {} bytes, the chunk says {}", n, size);
    return "";
  }
  if (name == "lz4") {
    LZ4F_dctx* ctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION))) return "lz4: no memory";
    std::size_t done = 0, used = 0;
    std::string failure;
    while (used < in.size()) {
      std::size_t dst = out.size() - done, src = in.size() - used;
      const std::size_t r = LZ4F_decompress(ctx, out.data() + done, &dst, in.data() + used, &src, nullptr);
      if (LZ4F_isError(r)) {
        failure = std::string("lz4: ") + LZ4F_getErrorName(r);
        break;
      }
      done += dst;
      used += src;
      if (r == 0) break;                 // the frame is complete
      if (dst == 0 && src == 0) break;  // no progress: output full
    }
    LZ4F_freeDecompressionContext(ctx);
    if (failure.empty() && done != size) failure = fmt::format("lz4 data holds {} bytes or more, the chunk says {}", done, size);
    return failure;
  }
  if (name.empty()) {
    if (in.size() != size) return fmt::format("{} bytes stored, the chunk says {}", in.size(), size);
    std::copy(in.begin(), in.end(), out.begin());
    return "";
  }
  return fmt::format("compression '{}' is not one saulctl reads (zstd, lz4 or none)", name);
}

/// Reads fields out of a record body; any read past its end sets bad().
class Fields {
 public:
  explicit Fields(std::span<const std::uint8_t> b) : b_(b) {}
  std::uint16_t u16() { return have(2) ? load_u16(at(2), false) : 0; }
  std::uint32_t u32() { return have(4) ? load_u32(at(4), false) : 0; }
  std::uint64_t u64() { return have(8) ? load_u64(at(8), false) : 0; }
  std::string str() {
    const std::uint32_t n = u32();
    if (!have(n)) return {};
    const auto* p = at(n);
    return {reinterpret_cast<const char*>(p), n};
  }
  void skip_prefixed32() {
    const std::uint32_t n = u32();
    if (have(n)) at(n);
  }
  std::span<const std::uint8_t> rest() { return b_.subspan(pos_); }
  [[nodiscard]] bool bad() const { return bad_; }

 private:
  bool have(std::uint64_t n) {
    if (b_.size() - pos_ < n) bad_ = true;
    return !bad_;
  }
  const std::uint8_t* at(std::size_t n) {
    const auto* p = b_.data() + pos_;
    pos_ += n;
    return p;
  }
  std::span<const std::uint8_t> b_;
  std::size_t pos_ = 0;
  bool bad_ = false;
};

constexpr char kHex[] = "0123456789ABCDEF";

}  // namespace

std::string_view mcap_frame_json_schema() noexcept {
  return R"J({"title":"saul.can_frame","description":"One CAN frame as saulctl captured it (log time: when it was seen)",)J"
         R"J("type":"object","properties":{)J"
         R"J("id":{"type":"integer","minimum":0,"maximum":536870911,"description":"CAN identifier (11 or 29 bits); for an error frame, SocketCAN's error class bits"},)J"
         R"J("extended":{"type":"boolean","description":"29-bit identifier"},)J"
         R"J("remote":{"type":"boolean","description":"remote transmission request (no data)"},)J"
         R"J("error":{"type":"boolean","description":"SocketCAN error frame (data: its details)"},)J"
         R"J("dlc":{"type":"integer","minimum":0,"maximum":8,"description":"data length code, bytes"},)J"
         R"J("data":{"type":"string","pattern":"^([0-9A-F]{2}){0,8}$","description":"payload bytes, hexadecimal"},)J"
         R"J("interface":{"type":"string","description":"interface the frame was seen on (can0)"}},)J"
         R"J("required":["id","extended","remote","error","dlc","data"]})J";
}

std::optional<McapCompression> mcap_compression_from_name(std::string_view name) noexcept {
  if (name == "none") return McapCompression::none;
  if (name == "lz4") return McapCompression::lz4;
  if (name == "zstd") return McapCompression::zstd;
  return std::nullopt;
}

// ---- writer -----------------------------------------------------------------------------------------------------

void McapSealer::ZstdFree::operator()(ZSTD_CCtx* context) const noexcept { ZSTD_freeCCtx(context); }

char* McapChunk::begin_message(std::uint16_t channel_id, std::uint64_t log_time, std::size_t max) {
  if (!has_messages_) {
    start_ = end_ = log_time;
    has_messages_ = true;
  }
  start_ = std::min(start_, log_time);
  end_ = std::max(end_, log_time);
  if (channel_id >= index_.size()) index_.resize(std::size_t{channel_id} + 1);
  TimeOffsets& index = index_[channel_id];
  if (index.empty()) channels_.push_back(channel_id);
  index.emplace_back(log_time, used_);
  // The record's 31 bytes before its data (its length at end_message()), then the data, written where they go in
  // the chunk (a head built on the stack and copied in stalled on the copy's wide load of bytes just stored one by
  // one: half of this function's time).
  message_at_ = used_;
  if (const std::size_t need = used_ + kRecordHead + kMessageFields + max; need > records_.size())
    records_.resize(std::max(need, 2 * records_.size()));  // left uninitialised (NoInit)
  std::uint8_t* p = records_.data() + message_at_;
  *p = kMessage;
  p += kRecordHead;
  p = put_le(p, channel_id, 2);
  p = put_le(p, 0, 4);  // sequence: 0, not assigned (see the class)
  p = put_le(p, log_time, 8);
  p = put_le(p, log_time, 8);  // publish time: not known apart, so the log time (as the spec asks)
  return reinterpret_cast<char*>(p);
}

void McapChunk::end_message(std::size_t size) {
  put_le(records_.data() + message_at_ + 1, kMessageFields + size, 8);
  used_ = message_at_ + kRecordHead + kMessageFields + size;
}

void McapChunk::add_message(std::uint16_t channel_id, std::uint64_t log_time, std::string_view data) {
  char* p = begin_message(channel_id, log_time, data.size());
  std::memcpy(p, data.data(), data.size());
  end_message(data.size());
}

bool McapChunk::full(const McapWriterOptions& options, std::uint64_t log_time) const noexcept {
  return has_messages_ && (used_ >= options.chunk_bytes ||
                           std::max(end_, log_time) - std::min(start_, log_time) >= options.chunk_ns);
}

void McapChunk::seal(McapSealer& sealer) {
  crc_ = crc_of(0, records_.data(), used_);
  compression_ = sealer.compression_;
  packed_size_ = used_;
  if (compression_ == McapCompression::zstd) {
    if (!sealer.zstd_) {
      sealer.zstd_.reset(ZSTD_createCCtx());
      if (!sealer.zstd_) throw std::runtime_error("zstd: no memory for a context");
    }
    const auto dst = room(packed_, ZSTD_compressBound(used_));
    packed_size_ = ZSTD_compressCCtx(sealer.zstd_.get(), dst.data(), dst.size(), records_.data(), used_,
                                     sealer.zstd_level_);
    if (ZSTD_isError(packed_size_)) throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(packed_size_));
  } else if (compression_ == McapCompression::lz4) {
    packed_size_ = compress_lz4(records(), packed_).size();
  }
  sealed_ = true;
}

void McapChunk::clear() {
  used_ = 0;
  for (const std::uint16_t channel : channels_) index_[channel].clear();
  channels_.clear();
  has_messages_ = sealed_ = false;
}

McapWriter::McapWriter(std::ostream& out, McapWriterOptions options)
    : out_(out), options_(std::move(options)), sealer_(options_.compression, options_.zstd_level) {
  emit(kMcapMagic);
  emit(Body().str("").str(options_.library).record(kHeader));
}

McapWriter::~McapWriter() {
  if (!thread_.joinable()) return;
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;  // a chunk still given is written first (to a stream that outlives the writer)
  }
  wake_.notify_one();
  thread_.join();
}

void McapWriter::emit(std::span<const std::uint8_t> bytes) {
  out_.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  data_crc_ = crc_of(data_crc_, bytes.data(), bytes.size());
  offset_ += bytes.size();
}

std::uint16_t McapWriter::add_schema(std::string_view name, std::string_view encoding, std::string_view data) {
  if (next_schema_ > 0xFFFF) throw std::length_error("mcap: no schema id left");
  const auto id = static_cast<std::uint16_t>(next_schema_);
  add_schema(id, name, encoding, data);
  return id;
}

void McapWriter::add_schema(std::uint16_t id, std::string_view name, std::string_view encoding, std::string_view data) {
  if (id == 0 || schema_added_[id]) throw std::invalid_argument(fmt::format("mcap: schema id {} is taken", id));
  schema_added_[id] = true;
  next_schema_ = std::max<std::uint32_t>(next_schema_, std::uint32_t{id} + 1);
  Body b;
  b.u16(id).str(name).str(encoding).str(data);
  schemas_.push_back(b.record(kSchema));
  wait_for_chunk();
  emit(schemas_.back());
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, std::string_view topic,
                                      std::string_view message_encoding, const McapMap& metadata) {
  if (next_channel_ > 0xFFFF) throw std::length_error("mcap: more than 65536 channels");
  const auto id = static_cast<std::uint16_t>(next_channel_);
  add_channel(id, schema_id, topic, message_encoding, metadata);
  return id;
}

void McapWriter::add_channel(std::uint16_t id, std::uint16_t schema_id, std::string_view topic,
                             std::string_view message_encoding, const McapMap& metadata) {
  if (channel_added_[id]) throw std::invalid_argument(fmt::format("mcap: channel id {} is taken", id));
  channel_added_[id] = true;
  next_channel_ = std::max<std::uint32_t>(next_channel_, std::uint32_t{id} + 1);
  Body b;
  b.u16(id).u16(schema_id).str(topic).str(message_encoding).map(metadata);
  channels_.push_back(b.record(kChannel));
  channel_ids_.push_back(id);
  wait_for_chunk();
  if (channel_counts_.size() <= id) channel_counts_.resize(std::size_t{id} + 1);  // after: the chunk thread counts
  emit(channels_.back());
}

bool McapWriter::has_schema(std::uint16_t id) const noexcept { return schema_added_[id]; }
bool McapWriter::has_channel(std::uint16_t id) const noexcept { return channel_added_[id]; }

void McapWriter::add_message(std::uint16_t channel_id, std::uint64_t log_time, std::string_view data) {
  chunk_for(log_time).add_message(channel_id, log_time, data);
}

char* McapWriter::begin_message(std::uint16_t channel_id, std::uint64_t log_time, std::size_t max) {
  return chunk_for(log_time).begin_message(channel_id, log_time, max);
}

McapChunk& McapWriter::chunk_for(std::uint64_t log_time) {
  if (closed_) throw std::runtime_error("mcap: the writer is closed");
  if (open_.full(options_, log_time)) close_chunk();
  // Room for a whole chunk at once: grown by doubling, a 4 MiB chunk's buffer ended at 8 MiB (twice, with the
  // chunk thread's).
  if (open_.records_.empty()) open_.records_.resize(options_.chunk_bytes + (std::size_t{64} << 10));
  return open_;
}

void McapWriter::add_metadata(std::string_view name, const McapMap& entries) {
  close_chunk();
  wait_for_chunk();
  const std::uint64_t at = offset_;
  const auto record = Body().str(name).map(entries).record(kMetadata);
  emit(record);
  metadata_index_.push_back(Body().u64(at).u64(record.size()).str(name).record(kMetadataIndex));
  ++metadata_count_;
}

void McapWriter::declare_used(const McapChunk& chunk) {
  for (const std::uint16_t channel : chunk.channels_)
    if (!channel_added_[channel] && !(declare_ && declare_(*this, channel) && channel_added_[channel]))
      throw std::out_of_range(fmt::format("mcap: a message on channel {}, which was not added", channel));
}

void McapWriter::close_chunk() {
  if (open_.empty()) return;
  declare_used(open_);
  if (!options_.chunk_thread) {
    open_.seal(sealer_);
    emit_chunk(open_);  // leaves open_ emptied, its memory kept
    return;
  }
  wait_for_chunk();
  if (!thread_.joinable()) thread_ = std::thread([this] { chunk_thread(); });
  {
    const std::lock_guard lock(mutex_);
    std::swap(open_, given_);  // the chunk thread's last buffers (emptied) are filled next
    busy_ = true;
  }
  wake_.notify_one();
}

void McapWriter::write_chunk(McapChunk& sealed) {
  if (closed_) throw std::runtime_error("mcap: the writer is closed");
  if (sealed.empty()) return;
  if (!sealed.sealed_) throw std::logic_error("mcap: write_chunk() of a chunk not sealed");
  close_chunk();  // the open chunk's messages came first
  declare_used(sealed);
  wait_for_chunk();
  emit_chunk(sealed);
}

void McapWriter::wait_for_chunk() {
  std::unique_lock lock(mutex_);
  done_.wait(lock, [this] { return !busy_; });
  if (failure_) std::rethrow_exception(std::exchange(failure_, nullptr));
}

void McapWriter::chunk_thread() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return busy_ || stop_; });
    if (!busy_) return;  // stopped, nothing given
    lock.unlock();
    try {
      given_.seal(sealer_);
      emit_chunk(given_);
    } catch (...) {
      lock.lock();
      failure_ = std::current_exception();
      lock.unlock();
    }
    lock.lock();
    busy_ = false;
    done_.notify_all();
  }
}

void McapWriter::emit_chunk(McapChunk& chunk) {
  ChunkIndex ix;
  ix.start_time = chunk.start_;
  ix.end_time = chunk.end_;
  ix.offset = offset_;
  ix.uncompressed_size = chunk.used_;
  const std::span<const std::uint8_t> records =
      chunk.compression_ == McapCompression::none ? chunk.records()
                                                  : std::span<const std::uint8_t>(chunk.packed_).first(chunk.packed_size_);
  ix.compressed_size = records.size();
  Body head;
  head.u64(ix.start_time).u64(ix.end_time).u64(chunk.used_).u32(chunk.crc_);
  head.str(compression_name(chunk.compression_)).u64(records.size());
  const std::uint64_t length = head.data().size() + records.size();
  emit(Body().u8(kChunk).u64(length).bytes(head.data()).data());
  emit(records);
  ix.length = offset_ - ix.offset;
  const std::uint64_t index_start = offset_;
  std::sort(chunk.channels_.begin(), chunk.channels_.end());
  for (const std::uint16_t channel : chunk.channels_) {
    const McapChunk::TimeOffsets& entries = chunk.index_[channel];
    ix.index_offsets.emplace_back(channel, offset_);
    channel_counts_[channel] += entries.size();
    message_count_ += entries.size();
    // Written in place (a chunk of 1 MiB indexes some 3 600 messages: 58 KiB).
    const std::uint64_t record_length = 2 + 4 + entries.size() * 16;
    index_record_.resize(kRecordHead + record_length);
    index_record_[0] = kMessageIndex;
    std::uint8_t* p = put_le(index_record_.data() + 1, record_length, 8);
    p = put_le(p, channel, 2);
    p = put_le(p, entries.size() * 16, 4);
    for (const auto& [time, at] : entries) p = put_le(put_le(p, time, 8), at, 8);
    emit(index_record_);
  }
  ix.index_length = offset_ - index_start;
  if (chunk_indexes_.empty()) first_time_ = last_time_ = chunk.start_;
  first_time_ = std::min(first_time_, chunk.start_);
  last_time_ = std::max(last_time_, chunk.end_);
  chunk_indexes_.push_back(std::move(ix));
  out_.flush();
  chunk.clear();
}

void McapWriter::flush() {
  close_chunk();
  wait_for_chunk();
  detail::flush_checked(out_, "mcap");
}

std::uint64_t McapWriter::messages_on(std::uint16_t channel_id) const {
  return channel_id < channel_counts_.size() ? channel_counts_[channel_id] : 0;
}

void McapWriter::close() {
  if (closed_) return;
  close_chunk();
  wait_for_chunk();
  closed_ = true;
  emit(Body().u32(data_crc_).record(kDataEnd));
  const std::uint64_t summary_start = offset_;
  std::uint32_t summary_crc = 0;
  std::vector<std::uint8_t> offsets;  // the Summary Offset records
  auto group = [&](std::uint8_t opcode, const std::vector<std::vector<std::uint8_t>>& records) {
    if (records.empty()) return;
    const std::uint64_t start = offset_;
    for (const auto& r : records) {
      summary_crc = crc_of(summary_crc, r.data(), r.size());
      emit(r);
    }
    append(offsets, Body().u8(opcode).u64(start).u64(offset_ - start).record(kSummaryOffset));
  };
  group(kSchema, schemas_);
  group(kChannel, channels_);
  std::vector<std::vector<std::uint8_t>> indexes;
  for (const auto& ix : chunk_indexes_) {
    Body b;
    b.u64(ix.start_time).u64(ix.end_time).u64(ix.offset).u64(ix.length);
    Body m;
    for (const auto& [channel, at] : ix.index_offsets) m.u16(channel).u64(at);
    b.u32(static_cast<std::uint32_t>(m.data().size())).bytes(m.data());
    b.u64(ix.index_length).str(compression_name(options_.compression)).u64(ix.compressed_size).u64(ix.uncompressed_size);
    indexes.push_back(b.record(kChunkIndex));
  }
  group(kChunkIndex, indexes);
  group(kMetadataIndex, metadata_index_);
  Body stats;
  stats.u64(message_count_).u16(static_cast<std::uint16_t>(schemas_.size()));
  stats.u32(static_cast<std::uint32_t>(channels_.size())).u32(0).u32(metadata_count_);
  stats.u32(static_cast<std::uint32_t>(chunk_indexes_.size())).u64(first_time_).u64(last_time_);
  Body counts;
  std::vector<std::uint16_t> ids = channel_ids_;
  std::sort(ids.begin(), ids.end());
  for (const std::uint16_t c : ids) counts.u16(c).u64(channel_counts_[c]);
  stats.u32(static_cast<std::uint32_t>(counts.data().size())).bytes(counts.data());
  group(kStatistics, {stats.record(kStatistics)});
  const std::uint64_t summary_offset_start = offset_;
  summary_crc = crc_of(summary_crc, offsets.data(), offsets.size());
  emit(offsets);
  // The footer's CRC covers the summary up to and including summary_offset_start.
  Body footer;
  footer.u8(kFooter).u64(20).u64(summary_start).u64(summary_offset_start);
  summary_crc = crc_of(summary_crc, footer.data().data(), footer.data().size());
  footer.u32(summary_crc);
  emit(footer.data());
  emit(kMcapMagic);
  detail::flush_checked(out_, "mcap");
}

// ---- CAN frames writer ------------------------------------------------------------------------------------------

char* mcap_frame_json_head(const CanFrame& frame, char* out) {
  char* w = out;
  auto copy = [&w](std::string_view text) {
    std::memcpy(w, text.data(), text.size());
    w += text.size();
  };
  copy(R"({"id":)");
  w = std::to_chars(w, w + 10, frame.id).ptr;
  copy(frame.extended ? std::string_view(R"(,"extended":true)") : std::string_view(R"(,"extended":false)"));
  copy(frame.remote ? std::string_view(R"(,"remote":true)") : std::string_view(R"(,"remote":false)"));
  copy(frame.error ? std::string_view(R"(,"error":true)") : std::string_view(R"(,"error":false)"));
  copy(R"(,"dlc":)");
  w = std::to_chars(w, w + 3, frame.dlc).ptr;
  copy(R"(,"data":")");
  for (std::uint8_t b : frame.payload()) {
    *w++ = kHex[b >> 4];
    *w++ = kHex[b & 15];
  }
  copy(R"(","interface":)");
  return w;
}

void add_frame_message(McapChunk& chunk, std::uint16_t channel_id, std::string_view head, std::uint64_t log_time,
                       std::string_view interface_json) {
  // Written straight into the chunk (no string between: its zero fill and the copy were a fifth of this function).
  char* const start = chunk.begin_message(channel_id, log_time, head.size() + interface_json.size() + 1);
  std::memcpy(start, head.data(), head.size());
  std::memcpy(start + head.size(), interface_json.data(), interface_json.size());
  start[head.size() + interface_json.size()] = '}';
  chunk.end_message(head.size() + interface_json.size() + 1);
}

void add_frame_message(McapChunk& chunk, std::uint16_t channel_id, const CanFrame& frame, std::uint64_t log_time,
                       std::string_view interface_json) {
  std::array<char, kMcapFrameHeadMax> head;
  const char* end = mcap_frame_json_head(frame, head.data());
  add_frame_message(chunk, channel_id, std::string_view(head.data(), static_cast<std::size_t>(end - head.data())),
                    log_time, interface_json);
}

std::string_view McapInterfaceJson::operator()(std::string_view interface) {
  if (interface.empty()) interface = "can0";
  // compared by size and bytes (string_view's compare() was 5 % of convert's own work)
  if (!made_ || interface.size() != name_.size() || std::memcmp(interface.data(), name_.data(), name_.size()) != 0) {
    // escaped, invalid UTF-8 replaced
    name_.assign(interface);
    json_ = nlohmann::json(name_).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    made_ = true;
  }
  return json_;
}

McapCaptureWriter::McapCaptureWriter(std::ostream& out, McapWriterOptions options, McapExtraMaker make_extra,
                                     const McapMap& metadata)
    : writer_(out, std::move(options)), make_extra_(std::move(make_extra)) {
  if (make_extra_) {
    extra_ = make_extra_();
    writer_.on_undeclared([extra = extra_.get()](McapWriter& w, std::uint16_t id) { return extra->declare(w, id); });
  }
  if (!metadata.empty()) writer_.add_metadata("saulctl", metadata);
  writer_.add_schema(kMcapFrameSchema, kMcapFrameSchemaName, "jsonschema", mcap_frame_json_schema());
  writer_.add_channel(kMcapFramesChannel, kMcapFrameSchema, kMcapFramesTopic, "json");
}

namespace {
/// The frame's message and the extras' in `chunk`.
void add_frame(McapChunk& chunk, McapFrameExtra* extra, McapInterfaceJson& interface, const CanFrame& frame,
               std::string_view interface_name) {
  check_writable(frame);
  const std::uint64_t t = frame.timestamp_ns.value_or(0);
  if (extra != nullptr) return extra->on_frame(frame, t, interface(interface_name), chunk);
  add_frame_message(chunk, kMcapFramesChannel, frame, t, interface(interface_name));
}
}  // namespace

void McapCaptureWriter::write(const CanFrame& frame, std::string_view interface) {
  if (closed_) throw std::runtime_error("mcap: the writer is closed");
  add_frame(writer_.chunk_for(frame.timestamp_ns.value_or(0)), extra_.get(), interface_, frame, interface);
}

void McapCaptureWriter::flush() { writer_.flush(); }

void McapCaptureWriter::close() {
  if (closed_) return;
  closed_ = true;
  writer_.close();
}

namespace {

/// McapCaptureWriter::copy's work on the read path (capture/read_path.hpp). A block's frames go into chunks of the
/// block's own, sealed (compressed) by the thread that read it; take() writes them in file order. A batch (a
/// file not cut into blocks) goes through write(), the writer's chunk thread compressing.
struct McapCopyWork {
  struct Worker {
    std::unique_ptr<McapFrameExtra> extra;
    McapInterfaceJson interface;
    McapSealer sealer;
  };
  struct Piece {
    std::vector<McapChunk> chunks;  ///< slots reused from block to block: [0, used) hold this block's
    std::size_t used = 0;
    bool block = false;
    CopyStats stats;
  };
  McapCaptureWriter& out;
  McapWriter& writer;
  const McapExtraMaker& make_extra;
  CopyStats stats;

  Worker worker() {
    const auto& o = writer.options();
    return {make_extra ? make_extra() : nullptr, {}, McapSealer(o.compression, o.zstd_level)};
  }
  bool in_blocks(const CaptureBlocks*) { return true; }
  void start(Worker&, Piece& p, bool block) {
    p.used = 0;
    p.block = block;
    p.stats = {};
  }
  CandumpLineTaker* taker(Worker&) { return nullptr; }
  void add(Worker& w, Piece& p, const FrameBatch& batch) {  // its corrupt records are the read path's to report
    for (std::size_t i = 0; i < batch.frames.size(); ++i) {
      const CanFrame& frame = batch.frames[i];
      if (frame.error) ++p.stats.error_frames;
      if (frame.remote) ++p.stats.remote_frames;
      if (!p.block) {
        out.write(frame, batch.interfaces[i]);
        continue;
      }
      const std::uint64_t t = frame.timestamp_ns.value_or(0);
      if (p.used == 0 || p.chunks[p.used - 1].full(writer.options(), t)) {
        if (p.used > 0) p.chunks[p.used - 1].seal(w.sealer);
        if (p.used == p.chunks.size()) p.chunks.emplace_back();
        ++p.used;
      }
      add_frame(p.chunks[p.used - 1], w.extra.get(), w.interface, frame, batch.interfaces[i]);
    }
  }
  std::uint64_t finish(Worker& w, Piece& p) {
    if (p.used > 0) p.chunks[p.used - 1].seal(w.sealer);
    return 0;
  }
  void take(Piece& p) {
    for (std::size_t i = 0; i < p.used; ++i) writer.write_chunk(p.chunks[i]);
    stats.error_frames += p.stats.error_frames;
    stats.remote_frames += p.stats.remote_frames;
  }
};

}  // namespace

CopyStats McapCaptureWriter::copy(const std::string& path, std::unique_ptr<CaptureReader>& reader, bool compressed,
                                  const ReadOptions& read, const std::function<void(const CaptureError&)>& on_corrupt,
                                  const std::function<void(std::uint64_t records, std::uint64_t bytes)>& progress) {
  if (closed_) throw std::runtime_error("mcap: the writer is closed");
  McapCopyWork work{*this, writer_, make_extra_, {}};
  const ReadCounts counts = detail::read_capture(path, reader, compressed, read, work, {on_corrupt, progress});
  work.stats.frames = counts.frames;
  work.stats.corrupt = counts.corrupt;
  return work.stats;
}

std::unique_ptr<CaptureWriter> open_mcap_writer(const std::string& path, McapWriterOptions options,
                                                McapExtraMaker make_extra, const McapMap& metadata) {
  return open_capture_writer(path, CaptureFormat::mcap, [&](std::ostream& out) -> std::unique_ptr<CaptureWriter> {
    return std::make_unique<McapCaptureWriter>(out, std::move(options), std::move(make_extra), metadata);
  });
}

// ---- reader -----------------------------------------------------------------------------------------------------

McapRecordReader::McapRecordReader(std::istream& in, std::optional<std::uint64_t> size) : in_(in), size_(size) {
  std::array<std::uint8_t, 8> magic{};
  if (take(magic.data(), magic.size()) != magic.size() || magic != kMcapMagic)
    throw CaptureOpenError("byte 0: not an MCAP file (no MCAP magic 89 4D 43 41 50 30 0D 0A)");
}

std::size_t McapRecordReader::take(std::uint8_t* dst, std::size_t n) {
  const std::size_t got = detail::read_counted(in_, dst, n, offset_);
  crc_ = crc_of(crc_, dst, got);
  return got;
}

McapRecordReader::Step McapRecordReader::corrupt(std::uint64_t at, Recovery recovery, std::string text) {
  error_ = CaptureError{0, std::move(text), PositionKind::byte_offset, at, recovery};
  if (recovery == Recovery::stop) stopped_ = true;
  return Step::corrupt;
}

const McapRecordReader::Channel* McapRecordReader::channel(std::uint16_t id) const {
  const auto it = channels_.find(id);
  return it == channels_.end() ? nullptr : &it->second;
}

const McapRecordReader::Schema* McapRecordReader::schema(std::uint16_t id) const {
  const auto it = schemas_.find(id);
  return it == schemas_.end() ? nullptr : &it->second;
}

bool McapRecordReader::body(std::uint8_t opcode, std::span<const std::uint8_t> b, std::uint64_t position,
                            bool& is_message) {
  is_message = false;
  Fields f(b);
  if (opcode == kSchema) {
    const std::uint16_t id = f.u16();
    Schema s;
    s.name = f.str();
    s.encoding = f.str();
    f.skip_prefixed32();
    if (f.bad()) return false;
    if (id != 0 && schemas_.size() < 0xFFFF) schemas_[id] = std::move(s);
  } else if (opcode == kChannel) {
    const std::uint16_t id = f.u16();
    Channel c;
    c.schema_id = f.u16();
    c.topic = f.str();
    c.message_encoding = f.str();
    if (f.bad()) return false;
    channels_[id] = std::move(c);
  } else if (opcode == kMessage) {
    message_.channel_id = f.u16();
    message_.sequence = f.u32();
    message_.log_time = f.u64();
    f.u64();  // publish time
    if (f.bad()) return false;
    message_.data = f.rest();
    message_.position = position;
    is_message = true;
  }
  return true;
}

McapRecordReader::Status McapRecordReader::next() {
  for (;;) {
    Step s = Step::end;
    if (in_chunk_) {
      s = chunk_record();
    } else if (!stopped_) {
      s = top_record();
    }
    switch (s) {
      case Step::message: return Status::message;
      case Step::corrupt: return Status::corrupt;
      case Step::end: return Status::end;
      case Step::skipped: break;
    }
  }
}

McapRecordReader::Step McapRecordReader::chunk_record() {
  const std::size_t left = chunk_.size() - chunk_pos_;
  if (left == 0) {
    in_chunk_ = false;
    return Step::skipped;
  }
  const std::size_t at = chunk_pos_;
  if (left < kRecordHead || load_u64(chunk_.data() + at + 1, false) > left - kRecordHead) {
    in_chunk_ = false;
    return corrupt(chunk_offset_, Recovery::next_record,
                   fmt::format("chunk: the record at byte {} of its data runs past its end (rest of the chunk skipped)", at));
  }
  const std::uint8_t opcode = chunk_[at];
  const std::size_t length = load_u64(chunk_.data() + at + 1, false);
  chunk_pos_ = at + kRecordHead + length;
  bool is_message = false;
  if (!body(opcode, std::span<const std::uint8_t>(chunk_).subspan(at + kRecordHead, length), chunk_offset_, is_message))
    return corrupt(chunk_offset_, Recovery::next_record,
                   fmt::format("chunk: the record (opcode 0x{:02X}) at byte {} of its data is cut short", opcode, at));
  return is_message ? Step::message : Step::skipped;
}

McapRecordReader::Step McapRecordReader::top_record() {
  const std::uint64_t start = offset_;
  const std::uint32_t crc_before = crc_;  // the data section's CRC: every byte before the DataEnd record
  std::array<std::uint8_t, kRecordHead> head{};
  const std::size_t got = take(head.data(), head.size());
  if (got == 0) {
    stopped_ = true;
    return corrupt(start, Recovery::stop, "the file ends without its footer (a recording cut short?): read up to here");
  }
  if (got < head.size()) return corrupt(start, Recovery::stop, "the file ends inside a record's header");
  const std::uint8_t opcode = head[0];
  const std::uint64_t length = load_u64(head.data() + 1, false);
  if (opcode == 0x00) return corrupt(start, Recovery::stop, "opcode 0x00 is no MCAP record (not an MCAP file from here?)");
  if (size_ && length > *size_ - std::min(*size_, offset_))
    return corrupt(start, Recovery::stop,
                   fmt::format("a record (opcode 0x{:02X}) of {} bytes is longer than the rest of the file ({} "
                               "bytes): the file is cut short",
                               opcode, length, *size_ - std::min(*size_, offset_)));
  if (length > kMcapMaxRecord)
    return corrupt(start, Recovery::stop,
                   fmt::format("a record (opcode 0x{:02X}) of {} bytes: more than the {} MiB saulctl reads", opcode,
                               length, kMcapMaxRecord >> 20));
  if (opcode != kChunk && opcode != kSchema && opcode != kChannel && opcode != kMessage && opcode != kDataEnd &&
      opcode != kFooter) {
    // Passed over (not needed to read the messages), but read, so that the data section's CRC sums every byte.
    std::array<std::uint8_t, 4096> sink{};
    for (std::uint64_t left = length; left > 0;) {
      const std::size_t step = static_cast<std::size_t>(std::min<std::uint64_t>(left, sink.size()));
      if (take(sink.data(), step) != step)
        return corrupt(start, Recovery::stop, fmt::format("the file ends inside a record (opcode 0x{:02X})", opcode));
      left -= step;
    }
    return Step::skipped;
  }
  // Read in steps of 1 MiB: a length that a pipe's end makes a lie allocates no more than what came.
  record_.clear();
  while (record_.size() < length) {
    const std::size_t step = static_cast<std::size_t>(std::min<std::uint64_t>(length - record_.size(), 1 << 20));
    const std::size_t was = record_.size();
    record_.resize(was + step);
    const std::size_t n = take(record_.data() + was, step);
    if (n < step) {
      return corrupt(start, Recovery::stop,
                     fmt::format("a record (opcode 0x{:02X}) of {} bytes is longer than the rest of the file ({} "
                                 "bytes): the file is cut short",
                                 opcode, length, was + n));
    }
  }
  const std::span<const std::uint8_t> b(record_);
  if (opcode == kFooter) {
    stopped_ = true;
    return Step::end;
  }
  if (opcode == kDataEnd) {
    stopped_ = true;  // the summary repeats what the data section held
    Fields f(b);
    const std::uint32_t stored = f.u32();
    if (!f.bad() && stored != 0 && stored != crc_before)
      return corrupt(start, Recovery::stop,
                     fmt::format("the data section's CRC-32 is {:08X}, DataEnd says {:08X}: the file is damaged",
                                 crc_before, stored));
    return Step::end;
  }
  if (opcode == kChunk) {
    Fields f(b);
    f.u64();
    f.u64();
    const std::uint64_t size = f.u64();
    const std::uint32_t crc = f.u32();
    const std::string compression = f.str();
    const std::uint64_t n = f.u64();
    const auto rest = f.rest();
    if (f.bad() || n > rest.size())
      return corrupt(start, Recovery::next_record, "chunk: its header or records length runs past the record");
    if (size > kMcapMaxRecord)
      return corrupt(start, Recovery::next_record,
                     fmt::format("chunk: {} bytes uncompressed, more than the {} MiB saulctl reads", size,
                                 kMcapMaxRecord >> 20));
    if (const std::string failure = decompress(compression, rest.first(n), size, chunk_); !failure.empty())
      return corrupt(start, Recovery::next_record, "chunk: " + failure);
    if (crc != 0) {
      const std::uint32_t actual = crc_of(0, chunk_.data(), chunk_.size());
      if (actual != crc)
        return corrupt(start, Recovery::next_record,
                       fmt::format("chunk: CRC-32 of its records is {:08X}, the chunk says {:08X}", actual, crc));
    }
    in_chunk_ = true;
    chunk_pos_ = 0;
    chunk_offset_ = start;
    return Step::skipped;
  }
  bool is_message = false;
  if (!body(opcode, b, start, is_message))
    return corrupt(start, Recovery::next_record, fmt::format("record (opcode 0x{:02X}) cut short", opcode));
  return is_message ? Step::message : Step::skipped;
}

// ---- CAN frames reader ------------------------------------------------------------------------------------------

McapFrameReader::McapFrameReader(std::istream& in, std::optional<std::uint64_t> size) : records_(in, size) {}

bool McapFrameReader::frames_channel(std::uint16_t id) {
  if (const auto it = is_frames_.find(id); it != is_frames_.end()) return it->second;
  const auto* c = records_.channel(id);
  if (c == nullptr) return false;  // not declared (yet): reported by next()
  const auto* s = records_.schema(c->schema_id);
  const bool yes = c->message_encoding == "json" &&
                   (c->topic == kMcapFramesTopic || (s != nullptr && s->name == kMcapFrameSchemaName));
  is_frames_[id] = yes;
  return yes;
}

McapFrameReader::Status McapFrameReader::next() {
  for (;;) {
    const auto st = records_.next();
    if (st == McapRecordReader::Status::end) return Status::end;
    if (st == McapRecordReader::Status::corrupt) {
      error_ = records_.error();
      return Status::corrupt;
    }
    const auto& m = records_.message();
    if (records_.channel(m.channel_id) == nullptr) {
      error_ = CaptureError{0, fmt::format("a message on channel {}, which no Channel record declared", m.channel_id),
                            PositionKind::byte_offset, m.position, Recovery::next_record};
      return Status::corrupt;
    }
    if (!frames_channel(m.channel_id)) continue;
    auto bad = [&](std::string_view what) {
      error_ = CaptureError{0, fmt::format("a {} message that is no CAN frame: {}", kMcapFramesTopic, what),
                            PositionKind::byte_offset, m.position, Recovery::next_record};
      return Status::corrupt;
    };
    const auto j = nlohmann::json::parse(m.data.begin(), m.data.end(), nullptr, false);
    if (j.is_discarded() || !j.is_object()) return bad("not a JSON object");
    CanFrame f;
    try {
      if (!j.at("id").is_number_unsigned()) return bad("id is not an unsigned integer");
      const auto id = j.at("id").get<std::uint64_t>();
      if (id > CanFrame::kMaxExtendedId) return bad("id is more than 29 bits");
      f.id = static_cast<std::uint32_t>(id);
      f.extended = j.value("extended", false);
      f.remote = j.value("remote", false);
      f.error = j.value("error", false);
      const std::string data = j.value("data", std::string());
      if (data.size() % 2 != 0 || data.size() > 16) return bad("data is not up to 8 bytes of hexadecimal");
      for (std::size_t i = 0; i < data.size(); i += 2) {
        unsigned v = 0;
        for (std::size_t k = i; k < i + 2; ++k) {
          const char c = data[k];
          const int d = c >= '0' && c <= '9' ? c - '0' : c >= 'A' && c <= 'F' ? c - 'A' + 10 : c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
          if (d < 0) return bad("data is not hexadecimal");
          v = v * 16 + static_cast<unsigned>(d);
        }
        f.data[i / 2] = static_cast<std::uint8_t>(v);
      }
      const auto dlc = j.value("dlc", static_cast<std::uint64_t>(data.size() / 2));
      if (dlc > CanFrame::kMaxDlc) return bad("dlc is more than 8");
      f.dlc = static_cast<std::uint8_t>(dlc);
      if (!f.remote && f.dlc != data.size() / 2) return bad("dlc does not match the data's length");
      name_ = j.contains("interface") && j["interface"].is_string() ? j["interface"].get<std::string>() : "can0";
    } catch (const nlohmann::json::exception& e) {
      return bad(e.what());
    }
    if (!f.valid() || (f.remote && f.error)) return bad("not a valid frame (id beyond its format, or remote and error)");
    f.timestamp_ns = m.log_time;
    frame_ = f;
    return Status::frame;
  }
}

}  // namespace saul::host
