// MCAP (mcap.dev/spec), the log format of ROS 2 (rosbag2's default storage since Iron) that Foxglove, Lichtblick
// and PlotJuggler open: written from the specification, as no Debian package holds a library for it.
//
// File: magic, Header, then the data section (Metadata, Chunks, each followed by its Message Index records),
// DataEnd with the CRC-32 of everything before it, the summary (Schemas, Channels, Chunk Indexes, Metadata
// Indexes, Statistics), Summary Offsets, the Footer (with the summary's CRC-32) and the magic again. Every record
// is `opcode u8, length u64, body`, little-endian; CRCs are zlib's crc32.
//
// Writing (McapWriter): Schema and Channel records go into the data section between chunks (before the chunk
// that first uses them, which is still being filled in memory), not into a chunk: a chunk found damaged then
// loses its own messages only, not the channels of all that follow. A file cut short (a recorder killed) reads
// up to its last complete chunk by a reader that scans it (MCAP readers can read a file without its summary). A
// chunk is closed when its records reach McapWriterOptions::chunk_bytes, when its messages span chunk_ns of log
// time, and on flush(); each closed chunk goes to the stream at once.
// Speed: a closed chunk is checksummed, compressed and written by a thread of the writer's own while the caller
// fills the next one (a chunk is independent of the others; at most one waits, so memory stays two chunks), and
// the CRC-32s are libdeflate's (carry-less multiplication; zlib 1.2's crc32 ran at ~0.9 GB/s). Anything else
// that writes (a Schema, Channel or Metadata record, flush(), close()) first waits for that thread, so the
// records keep their order. A file converted in blocks (McapCaptureWriter::copy) goes further: each thread fills
// and seals (compresses) McapChunks of its own, and the writer writes them in file order (write_chunk()); channels
// are then added as chunks that use them are written (on_undeclared), with ids that do not depend on the order
// (report/mcap_signals.hpp's mcap_channel_id()).
//
// CAN frames (McapCaptureWriter, McapFrameReader): one channel "/can/frames", schema "saul.can_frame"
// (jsonschema, below), message encoding json, one message per frame
// {"id":291,"extended":false,"remote":false,"error":false,"dlc":2,"data":"1122","interface":"can0"}, log time =
// the frame's time in ns since 1970. The decoded signals go on channels of their own (report/mcap_signals.hpp
// adds them through McapFrameExtra); docs/captures.md lists them.
//
// Reading (McapRecordReader) scans the records in order without seeking (pipes work), opening chunks (none,
// zstd, lz4), checking the chunk CRCs and the data section's, and stops at DataEnd: the summary is not needed.
// A chunk whose CRC does not match or that does not decompress is reported with its byte offset and skipped; a
// record longer than what is left of the file, or a file that ends inside a record, ends the reading after a
// report. Memory: one chunk (compressed and not), at most kMcapMaxRecord each.
#pragma once

#include <array>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <istream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include "saulproto/core/can_frame.hpp"
#include "saulproto/host/capture/capture.hpp"

struct ZSTD_CCtx_s;  // zstd.h's ZSTD_CCtx

namespace saul::host {

inline constexpr std::array<std::uint8_t, 8> kMcapMagic = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
/// The largest record (and uncompressed chunk) the reader accepts: a hostile length must not take the memory.
inline constexpr std::uint64_t kMcapMaxRecord = std::uint64_t{256} << 20;

/// The topic, schema name and JSON Schema of the raw frames.
inline constexpr std::string_view kMcapFramesTopic = "/can/frames";
inline constexpr std::string_view kMcapFrameSchemaName = "saul.can_frame";
std::string_view mcap_frame_json_schema() noexcept;

enum class McapCompression : std::uint8_t { none, lz4, zstd };
/// "none", "lz4", "zstd"; nullopt for another name.
std::optional<McapCompression> mcap_compression_from_name(std::string_view name) noexcept;

using McapMap = std::vector<std::pair<std::string, std::string>>;

struct McapWriterOptions {
  McapCompression compression = McapCompression::zstd;
  /// zstd's level: 1, its fastest regular level, packs a bus's JSON ~5x at ~0.6-0.8 GB/s (bench/README.md).
  /// Negative levels are faster still and pack less; higher ones pack more, slower (up to 19 for an archive).
  int zstd_level = 1;
  std::uint64_t chunk_bytes = std::uint64_t{1} << 20;  ///< a chunk is closed when its records reach this
  std::uint64_t chunk_ns = 1'000'000'000;              ///< ... or its messages span this much log time
  std::string library = "saulctl";                     ///< the Header's library field
  /// Compress and write closed chunks on a thread of the writer's own (convert: a file read at disk speed). A live
  /// recording sets it false: a 1 Mbit/s bus leaves the caller time to compress, and its recorder reads the file's
  /// position (rotation, progress) between writes, which must not race a thread writing to the same stream.
  bool chunk_thread = true;
};

/// zstd's context, kept from chunk to chunk by the thread that seals them (made by the first chunk).
class McapSealer {
 public:
  explicit McapSealer(McapCompression compression = McapCompression::zstd, int zstd_level = 1)
      : compression_(compression), zstd_level_(zstd_level) {}
  [[nodiscard]] McapCompression compression() const noexcept { return compression_; }

 private:
  friend class McapChunk;
  struct ZstdFree {
    void operator()(ZSTD_CCtx_s* context) const noexcept;
  };
  McapCompression compression_;
  int zstd_level_;
  std::unique_ptr<ZSTD_CCtx_s, ZstdFree> zstd_;
};

/// One chunk's Message records and their message indexes, filled by one thread: an McapWriter's open chunk, or a
/// chunk a worker fills apart while a file is converted in blocks, seals and hands to McapWriter::write_chunk() in
/// file order. Messages are numbered 0 on their channel ("sequence" not assigned, as the spec allows): a chunk
/// filled apart cannot know how many messages its channels had before it. Cost: O(1) per message (amortised).
class McapChunk {
 public:
  /// Room for a message of up to `max` bytes, valid until end_message(), which must come next with the bytes written.
  char* begin_message(std::uint16_t channel_id, std::uint64_t log_time, std::size_t max);
  void end_message(std::size_t size);
  /// begin_message() and end_message() with a copy of `data`.
  void add_message(std::uint16_t channel_id, std::uint64_t log_time, std::string_view data);
  /// Whether a message at `log_time` belongs in a new chunk: this one holds messages and has reached the options'
  /// chunk_bytes, or would span chunk_ns of log time.
  [[nodiscard]] bool full(const McapWriterOptions& options, std::uint64_t log_time) const noexcept;
  [[nodiscard]] bool empty() const noexcept { return !has_messages_; }
  [[nodiscard]] std::size_t bytes() const noexcept { return used_; }
  /// The records' CRC-32 and their compression: the costly part of writing a chunk, done by the thread holding it.
  void seal(McapSealer& sealer);

 private:
  friend class McapWriter;
  using TimeOffsets = std::vector<std::pair<std::uint64_t, std::uint64_t>>;  ///< a channel's messages: time, offset
  /// Bytes whose resize() leaves new elements uninitialised: a message's record is written over them at once (the
  /// zeroing of std::vector's resize was 1 % of convert's time).
  template <class T>
  struct NoInit : std::allocator<T> {
    template <class U>
    struct rebind {
      using other = NoInit<U>;
    };
    template <class U>
    void construct(U* p) noexcept {
      ::new (static_cast<void*>(p)) U;
    }
  };
  /// Emptied, its memory kept for the next one.
  void clear();
  /// The records: records_'s first used_ bytes (records_ grows and never shrinks: a resize() up and down per
  /// message was a third of begin_message()).
  [[nodiscard]] std::span<const std::uint8_t> records() const noexcept { return {records_.data(), used_}; }
  std::vector<std::uint8_t, NoInit<std::uint8_t>> records_;
  std::size_t used_ = 0;
  std::vector<TimeOffsets> index_;       ///< by channel id (grown to the largest used)
  std::vector<std::uint16_t> channels_;  ///< the ids with entries in index_
  std::uint64_t start_ = 0, end_ = 0;
  bool has_messages_ = false;
  std::size_t message_at_ = 0;  ///< where the record begin_message() started is
  // seal()'s
  std::uint32_t crc_ = 0;                ///< of records_
  std::vector<std::uint8_t> packed_;     ///< the compressed records (grown, never shrunk)
  std::size_t packed_size_ = 0;
  McapCompression compression_ = McapCompression::none;
  bool sealed_ = false;
};

/// Writes MCAP records to a stream (which need not seek: offsets are counted).
class McapWriter {
 public:
  /// Writes the magic and the Header at once.
  McapWriter(std::ostream& out, McapWriterOptions options);
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;
  ~McapWriter();

  /// A schema with the next free id (from 1); written at once (between chunks), and into the summary at close().
  std::uint16_t add_schema(std::string_view name, std::string_view encoding, std::string_view data);
  /// A schema with this id (1-65535, not yet added).
  void add_schema(std::uint16_t id, std::string_view name, std::string_view encoding, std::string_view data);
  /// A channel with the next free id (from 0). Throws std::length_error past 65535 channels.
  std::uint16_t add_channel(std::uint16_t schema_id, std::string_view topic, std::string_view message_encoding,
                            const McapMap& metadata = {});
  /// A channel with this id (not yet added).
  void add_channel(std::uint16_t id, std::uint16_t schema_id, std::string_view topic,
                   std::string_view message_encoding, const McapMap& metadata = {});
  [[nodiscard]] bool has_schema(std::uint16_t id) const noexcept;
  [[nodiscard]] bool has_channel(std::uint16_t id) const noexcept;
  /// Adds a channel that a chunk's messages use and that was not added: true when it did. Asked when the chunk is
  /// closed, before it is written (so channels can be declared as their first messages come, by whichever thread
  /// filled the chunk). Without it, or when it says false, a message on a channel not added throws
  /// std::out_of_range then.
  void on_undeclared(std::function<bool(McapWriter&, std::uint16_t channel_id)> declare) {
    declare_ = std::move(declare);
  }

  /// A message; may close the chunk first (its size or time span reached).
  void add_message(std::uint16_t channel_id, std::uint64_t log_time, std::string_view data);
  /// A message whose data the caller writes in place (no copy): as McapChunk's, in the open chunk.
  char* begin_message(std::uint16_t channel_id, std::uint64_t log_time, std::size_t max);
  void end_message(std::size_t size) { open_.end_message(size); }
  /// The chunk a message at `log_time` goes into (the open one closed first when it is full), valid until the
  /// writer's next call: for callers that write several messages of one moment.
  McapChunk& chunk_for(std::uint64_t log_time);
  /// Writes a chunk filled apart (converting in blocks) and sealed, after the chunks written before it; leaves it
  /// emptied for reuse.
  void write_chunk(McapChunk& sealed);
  /// A Metadata record (written between chunks: the current one is closed first).
  void add_metadata(std::string_view name, const McapMap& entries);
  /// Closes the current chunk (if it holds anything) and flushes the stream. Throws std::runtime_error when the
  /// stream has failed.
  void flush();
  /// Closes the chunk, writes DataEnd, the summary, the Footer and the magic, and flushes. Idempotent.
  void close();
  /// Messages in the chunks written so far (the chunk thread counts them: after flush() or close()).
  [[nodiscard]] std::uint64_t messages() const noexcept { return message_count_; }
  [[nodiscard]] std::uint64_t messages_on(std::uint16_t channel_id) const;
  [[nodiscard]] const McapWriterOptions& options() const noexcept { return options_; }

 private:
  struct ChunkIndex {
    std::uint64_t start_time = 0, end_time = 0, offset = 0, length = 0, index_length = 0;
    std::uint64_t compressed_size = 0, uncompressed_size = 0;
    std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;
  };
  /// Hands the open chunk (if it holds anything) to the chunk thread; the next one is filled meanwhile.
  void close_chunk();
  /// Adds the channels `chunk` uses that were not added (on_undeclared), on the caller's thread.
  void declare_used(const McapChunk& chunk);
  /// Waits until the chunk thread has written what it was given; rethrows what it failed with.
  void wait_for_chunk();
  void chunk_thread();
  /// The chunk record and its Message Index records of a sealed chunk, and its counts.
  void emit_chunk(McapChunk& chunk);
  void emit(std::span<const std::uint8_t> bytes);
  void emit(const std::vector<std::uint8_t>& record) { emit(std::span<const std::uint8_t>(record)); }

  std::ostream& out_;
  McapWriterOptions options_;
  // Written by whichever thread writes (the caller, or the chunk thread while it holds a chunk): the caller waits
  // for the chunk thread before it writes itself or reads them.
  std::uint64_t offset_ = 0;
  std::uint32_t data_crc_ = 0;  ///< crc32 of everything written so far (the data section's, at DataEnd)
  std::vector<ChunkIndex> chunk_indexes_;
  std::vector<std::uint8_t> index_record_;  ///< a Message Index record, reused
  std::vector<std::uint64_t> channel_counts_;  ///< by channel id
  std::uint64_t message_count_ = 0, first_time_ = 0, last_time_ = 0;
  McapSealer sealer_;
  // The caller's.
  bool closed_ = false;
  std::vector<std::vector<std::uint8_t>> schemas_;   ///< records, for the summary
  std::vector<std::vector<std::uint8_t>> channels_;  ///< records, for the summary
  std::vector<std::uint16_t> channel_ids_;           ///< of channels_, in the order added
  std::vector<bool> schema_added_ = std::vector<bool>(65536), channel_added_ = std::vector<bool>(65536);
  std::uint32_t next_schema_ = 1, next_channel_ = 0;  ///< what the next add without an id takes
  std::vector<std::vector<std::uint8_t>> metadata_index_;
  std::uint32_t metadata_count_ = 0;
  std::function<bool(McapWriter&, std::uint16_t)> declare_;
  McapChunk open_;  ///< the chunk being filled
  // The chunk thread (started by the first chunk closed) and what it is given.
  McapChunk given_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  bool busy_ = false, stop_ = false;
  std::exception_ptr failure_;
};

/// A frame's "/can/frames" JSON (above) up to its interface's value, `{"id":291,...,"interface":`, written at `out`
/// (room for kMcapFrameHeadMax bytes); returns its end.
inline constexpr std::size_t kMcapFrameHeadMax = 128;
char* mcap_frame_json_head(const CanFrame& frame, char* out);
/// A frame's message on "/can/frames" written into a chunk; `interface_json` is the interface's name as a JSON
/// string (McapInterfaceJson). Cost O(1).
void add_frame_message(McapChunk& chunk, std::uint16_t channel_id, const CanFrame& frame, std::uint64_t log_time,
                       std::string_view interface_json);
/// The same from the frame's mcap_frame_json_head() made before (a cache of them).
void add_frame_message(McapChunk& chunk, std::uint16_t channel_id, std::string_view head, std::uint64_t log_time,
                       std::string_view interface_json);
/// The JSON string of the last interface name asked for, made again only when the name changes.
class McapInterfaceJson {
 public:
  std::string_view operator()(std::string_view interface);

 private:
  std::string name_, json_;
  bool made_ = false;
};

/// What a writer of frames may add for each frame: messages on channels of its own (the decoded signals).
class McapFrameExtra {
 public:
  virtual ~McapFrameExtra() = default;
  /// The frame's messages in `chunk`: its own on kMcapFramesChannel first (add_frame_message(), whose head an
  /// extra may keep in a cache of its own with what else it renders of the frame), then its channels'.
  virtual void on_frame(const CanFrame& frame, std::uint64_t log_time, std::string_view interface_json,
                        McapChunk& chunk) = 0;
  /// Adds a channel its messages use to `out` (McapWriter::on_undeclared); false for an id it does not know.
  virtual bool declare(McapWriter& out, std::uint16_t channel_id) = 0;
};

/// The channel and schema ids of "/can/frames" in files saulctl writes.
inline constexpr std::uint16_t kMcapFramesChannel = 0, kMcapFrameSchema = 1;

/// Makes the extra channels' writer of a thread (each thread converting blocks has its own: its caches).
using McapExtraMaker = std::function<std::unique_ptr<McapFrameExtra>()>;

/// CAN frames as an MCAP file: "/can/frames", plus what the extras `make_extra` makes add (may be empty). A
/// Metadata record "saulctl" holds `metadata`.
class McapCaptureWriter final : public CaptureWriter {
 public:
  McapCaptureWriter(std::ostream& out, McapWriterOptions options = {}, McapExtraMaker make_extra = {},
                    const McapMap& metadata = {});
  void write(const CanFrame& frame, std::string_view interface) override;
  /// Closes the chunk (it goes to the file whole) and flushes: what a recorder calls every second.
  void flush() override;
  void close() override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::mcap; }
  McapCaptureWriter* mcap() noexcept override { return this; }
  [[nodiscard]] McapWriter& writer() noexcept { return writer_; }
  /// copy_frames() into this file: a file the read path cuts into blocks (read_capture) is converted on
  /// `read.threads` threads, each filling and compressing chunks of its own (with extras of its own), written in
  /// file order; else frame by frame through write(). The same messages either way (chunks end at blocks' ends).
  CopyStats copy(const std::string& path, std::unique_ptr<CaptureReader>& reader, bool compressed,
                 const ReadOptions& read, const std::function<void(const CaptureError&)>& on_corrupt,
                 const std::function<void(std::uint64_t records, std::uint64_t bytes)>& progress);

 private:
  McapWriter writer_;
  McapExtraMaker make_extra_;
  std::unique_ptr<McapFrameExtra> extra_;  ///< write()'s
  McapInterfaceJson interface_;
  bool closed_ = false;
};

/// Creates (truncates) an MCAP file of CAN frames at `path` ("-": standard output) as open_capture_writer() does,
/// with these options, extra channels and metadata. Throws CaptureOpenError when it cannot be created.
std::unique_ptr<CaptureWriter> open_mcap_writer(const std::string& path, McapWriterOptions options,
                                                McapExtraMaker make_extra, const McapMap& metadata);

/// The messages of an MCAP file in file order, with the schemas and channels seen so far.
class McapRecordReader {
 public:
  struct Schema {
    std::string name, encoding;
  };
  struct Channel {
    std::uint16_t schema_id = 0;
    std::string topic, message_encoding;
  };
  struct Message {
    std::uint16_t channel_id = 0;
    std::uint32_t sequence = 0;
    std::uint64_t log_time = 0;
    std::span<const std::uint8_t> data;  ///< valid until the next call of next()
    std::uint64_t position = 0;          ///< the byte offset of the record, or of its chunk
  };
  enum class Status { message, corrupt, end };

  /// Reads the magic; throws CaptureOpenError when the stream does not start with it. `size`: the file's
  /// size when known, so a record longer than the file is told at once.
  explicit McapRecordReader(std::istream& in, std::optional<std::uint64_t> size = std::nullopt);
  Status next();
  [[nodiscard]] const Message& message() const noexcept { return message_; }
  [[nodiscard]] const CaptureError& error() const noexcept { return error_; }
  /// nullptr for an id not (yet) declared.
  [[nodiscard]] const Channel* channel(std::uint16_t id) const;
  [[nodiscard]] const Schema* schema(std::uint16_t id) const;
  [[nodiscard]] std::uint64_t bytes_read() const noexcept { return offset_; }

 private:
  enum class Step { message, corrupt, skipped, end };
  Step top_record();
  Step chunk_record();
  Step corrupt(std::uint64_t at, Recovery recovery, std::string text);
  /// Parses a Schema, Channel or Message body; false when it is malformed.
  bool body(std::uint8_t opcode, std::span<const std::uint8_t> b, std::uint64_t position, bool& is_message);
  std::size_t take(std::uint8_t* dst, std::size_t n);

  std::istream& in_;
  std::optional<std::uint64_t> size_;
  std::uint64_t offset_ = 0;
  std::uint32_t crc_ = 0;  ///< of every byte read, for DataEnd
  bool stopped_ = false;
  std::vector<std::uint8_t> record_, chunk_;
  std::size_t chunk_pos_ = 0;
  bool in_chunk_ = false;
  std::uint64_t chunk_offset_ = 0;
  std::map<std::uint16_t, Schema> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  Message message_;
  CaptureError error_;
};

/// The CAN frames of an MCAP file: the messages of every channel whose topic is "/can/frames" or whose schema is
/// "saul.can_frame", in json encoding, as written by McapCaptureWriter or any writer using that schema (other
/// channels are passed over). A message that is not such a frame is reported with the offset of its record (of
/// its chunk, for one in a chunk) and skipped.
class McapFrameReader final : public RecordCaptureReader {
 public:
  explicit McapFrameReader(std::istream& in, std::optional<std::uint64_t> size = std::nullopt);
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::mcap; }

 private:
  Status next() override;
  bool frames_channel(std::uint16_t id);
  McapRecordReader records_;
  std::map<std::uint16_t, bool> is_frames_;
};

}  // namespace saul::host
