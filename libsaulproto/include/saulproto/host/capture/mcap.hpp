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
// records keep their order.
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

/// Writes MCAP records to a stream (which need not seek: offsets are counted).
class McapWriter {
 public:
  /// Writes the magic and the Header at once.
  McapWriter(std::ostream& out, McapWriterOptions options);
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;
  ~McapWriter();

  /// A schema (its id, from 1); written at once (between chunks), and into the summary at close().
  std::uint16_t add_schema(std::string_view name, std::string_view encoding, std::string_view data);
  /// A channel (its id, from 0). Throws std::length_error past 65535 channels.
  std::uint16_t add_channel(std::uint16_t schema_id, std::string_view topic, std::string_view message_encoding,
                            const McapMap& metadata = {});
  /// A message; may close the chunk first (its size or time span reached).
  void add_message(std::uint16_t channel_id, std::uint64_t log_time, std::string_view data);
  /// A message whose data the caller writes in place (no copy): room for up to `max` bytes of it in the chunk,
  /// valid until end_message(), which must come next with the bytes written. add_message() is these two and a copy.
  char* begin_message(std::uint16_t channel_id, std::uint64_t log_time, std::size_t max);
  void end_message(std::size_t size);
  /// A Metadata record (written between chunks: the current one is closed first).
  void add_metadata(std::string_view name, const McapMap& entries);
  /// Closes the current chunk (if it holds anything) and flushes the stream. Throws std::runtime_error when the
  /// stream has failed.
  void flush();
  /// Closes the chunk, writes DataEnd, the summary, the Footer and the magic, and flushes. Idempotent.
  void close();
  [[nodiscard]] std::uint64_t messages() const noexcept { return message_count_; }
  [[nodiscard]] std::uint64_t messages_on(std::uint16_t channel_id) const;

 private:
  struct ChunkIndex {
    std::uint64_t start_time = 0, end_time = 0, offset = 0, length = 0, index_length = 0;
    std::uint64_t compressed_size = 0, uncompressed_size = 0;
    std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;
  };
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
  /// A chunk's records and message index: the one being filled, and the one the chunk thread writes.
  struct Chunk {
    std::vector<std::uint8_t, NoInit<std::uint8_t>> records;
    std::uint32_t crc = 0;  ///< of `records`, taken by the caller when it closes the chunk (the chunk thread is the busier)
    std::vector<TimeOffsets> index;       ///< by channel id
    std::vector<std::uint16_t> channels;  ///< the ids with entries in `index`
    std::uint64_t start = 0, end = 0;
    bool has_messages = false;
  };
  /// Hands the open chunk (if it holds anything) to the chunk thread; the next one is filled meanwhile.
  void close_chunk();
  /// Waits until the chunk thread has written what it was given; rethrows what it failed with.
  void wait_for_chunk();
  void chunk_thread();
  /// The chunk record (CRC, compression) and its Message Index records, on the chunk thread.
  void write_chunk(Chunk& chunk);
  void emit(std::span<const std::uint8_t> bytes);
  void emit(const std::vector<std::uint8_t>& record) { emit(std::span<const std::uint8_t>(record)); }

  std::ostream& out_;
  McapWriterOptions options_;
  // Written by whichever thread writes (the caller, or the chunk thread while it holds a chunk): the caller waits
  // for the chunk thread before it writes itself or reads them.
  std::uint64_t offset_ = 0;
  std::uint32_t data_crc_ = 0;  ///< crc32 of everything written so far (the data section's, at DataEnd)
  std::vector<ChunkIndex> chunk_indexes_;
  std::vector<std::uint8_t> packed_;        ///< compression output, reused
  std::vector<std::uint8_t> index_record_;  ///< a Message Index record, reused
  struct ZstdFree {
    void operator()(ZSTD_CCtx_s* context) const noexcept;
  };
  std::unique_ptr<ZSTD_CCtx_s, ZstdFree> zstd_;  ///< zstd's context, reused (made by the first chunk)
  // The caller's.
  bool closed_ = false;
  std::vector<std::vector<std::uint8_t>> schemas_;   ///< records, for the summary
  std::vector<std::vector<std::uint8_t>> channels_;  ///< records, for the summary
  std::vector<std::uint64_t> channel_counts_;
  std::vector<std::vector<std::uint8_t>> metadata_index_;
  std::uint64_t message_count_ = 0, first_time_ = 0, last_time_ = 0;
  std::uint32_t metadata_count_ = 0;
  std::size_t message_at_ = 0;  ///< where the record begin_message() started is, in open_.records
  std::uint16_t message_channel_ = 0;
  Chunk open_;  ///< the chunk being filled
  // The chunk thread (started by the first chunk closed) and what it is given.
  Chunk given_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  bool busy_ = false, stop_ = false;
  std::exception_ptr failure_;
};

/// What a writer of frames may add for each frame: messages on channels of its own (the decoded signals).
class McapFrameExtra {
 public:
  virtual ~McapFrameExtra() = default;
  virtual void on_frame(const CanFrame& frame, std::string_view interface, std::uint64_t log_time,
                        McapWriter& out) = 0;
};

/// CAN frames as an MCAP file: "/can/frames", plus what `extra` adds. A Metadata record "saulctl" holds `metadata`.
class McapCaptureWriter final : public CaptureWriter {
 public:
  McapCaptureWriter(std::ostream& out, McapWriterOptions options = {}, std::unique_ptr<McapFrameExtra> extra = nullptr,
                    const McapMap& metadata = {});
  void write(const CanFrame& frame, std::string_view interface) override;
  /// Closes the chunk (it goes to the file whole) and flushes: what a recorder calls every second.
  void flush() override;
  void close() override;
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::mcap; }
  [[nodiscard]] const McapWriter& mcap() const noexcept { return writer_; }

 private:
  std::ostream& out_;
  McapWriter writer_;
  std::unique_ptr<McapFrameExtra> extra_;
  std::uint16_t frames_channel_ = 0;
  std::string interface_, interface_json_;  ///< the last interface name and its JSON string
  bool closed_ = false;
};

/// Creates (truncates) an MCAP file of CAN frames at `path` ("-": standard output) as open_capture_writer() does,
/// with these options, extra channels and metadata. Throws CaptureOpenError when it cannot be created.
std::unique_ptr<CaptureWriter> open_mcap_writer(const std::string& path, McapWriterOptions options,
                                                std::unique_ptr<McapFrameExtra> extra, const McapMap& metadata);

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
class McapFrameReader final : public CaptureReader {
 public:
  explicit McapFrameReader(std::istream& in, std::optional<std::uint64_t> size = std::nullopt);
  Status next() override;
  [[nodiscard]] const CanFrame& frame() const override { return frame_; }
  [[nodiscard]] std::string_view interface() const override { return interface_; }
  [[nodiscard]] const CaptureError& error() const override { return error_; }
  [[nodiscard]] CaptureFormat format() const override { return CaptureFormat::mcap; }

 private:
  bool frames_channel(std::uint16_t id);
  McapRecordReader records_;
  std::map<std::uint16_t, bool> is_frames_;
  CanFrame frame_;
  std::string interface_;
  CaptureError error_;
};

}  // namespace saul::host
