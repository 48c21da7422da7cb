// gzip and zstd under the capture readers: bytes written by the gzip and zstd command-line tools (below as hex)
// decompress to their text; several gzip members read as one stream; truncation, corruption and trailing bytes
// end the stream with an error; a zstd frame asking for a huge window is refused; what we compress, the tools'
// formats say (magic numbers) and we read back.
#include <catch2/catch.hpp>

#include <random>
#include <sstream>
#include <string>

#include "saulproto/host/capture/compressed.hpp"

using namespace saul::host;

namespace {

std::string unhex(std::string_view hex) {
  std::string out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) out += static_cast<char>(std::stoi(std::string(hex.substr(i, 2)), nullptr, 16));
  return out;
}

struct Inflated {
  std::string text;
  std::string error;
  std::uint64_t compressed = 0;
};

Inflated inflate(const std::string& bytes, Compression c) {
  std::istringstream in(bytes);
  auto buf = make_decompressing_buf(*in.rdbuf(), c);
  Inflated out;
  out.text.assign(std::istreambuf_iterator<char>(buf.get()), std::istreambuf_iterator<char>());
  out.error = buf->error();
  out.compressed = buf->compressed_bytes();
  return out;
}

const std::string kLine = "(1700000000.000000) can0 123#11\n";
// printf '(1700000000.000000) can0 123#11\n' | zstd -q -c | xxd -p   (zstd 1.5.4, with its checksum)
const std::string kZstd = unhex("28b52ffd0458e50000a0283137302e30292063616e30203132332331310a020040e00c1001058e63e5");
// printf 'A' | gzip -n -c | xxd -p   and the same for 'B' (gzip 1.12)
const std::string kGzipA = unhex("1f8b08000000000000037304008b9ed9d301000000");
const std::string kGzipB = unhex("1f8b080000000000000373020031cfd04a01000000");

}  // namespace

TEST_CASE("compression told by magic numbers and by name") {
  auto bytes = [](const std::string& s) {
    return std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
  };
  CHECK(detect_compression(bytes(kGzipA)) == Compression::gzip);
  CHECK(detect_compression(bytes(kZstd)) == Compression::zstd);
  CHECK(detect_compression(bytes(unhex("502a4d18"))) == Compression::zstd);  // a skippable frame
  CHECK(detect_compression(bytes(kLine)) == Compression::none);
  CHECK(compression_from_extension("run.blf.GZ") == Compression::gzip);
  CHECK(compression_from_extension("run.zst") == Compression::zstd);
  CHECK(compression_from_extension("run.log") == Compression::none);
  CHECK(strip_compression_extension("dir/run.trc.zst") == "dir/run.trc");
  CHECK(strip_compression_extension("run.log") == "run.log");
}

TEST_CASE("the tools' files decompress; gzip members follow each other") {
  const Inflated z = inflate(kZstd, Compression::zstd);
  CHECK(z.text == kLine);
  CHECK(z.error.empty());
  CHECK(z.compressed == kZstd.size());
  const Inflated g = inflate(kGzipA + kGzipB, Compression::gzip);  // as `cat a.gz b.gz` makes
  CHECK(g.text == "AB");
  CHECK(g.error.empty());
  const Inflated zz = inflate(kZstd + kZstd, Compression::zstd);
  CHECK(zz.text == kLine + kLine);
}

TEST_CASE("truncated, corrupt and trailing data end the stream with an error") {
  CHECK(inflate(kGzipA.substr(0, kGzipA.size() - 3), Compression::gzip).error ==
        "the gzip file ends before its end marker (truncated?)");
  CHECK(inflate(kZstd.substr(0, kZstd.size() - 2), Compression::zstd).error ==
        "the zstd file ends before the end of its frame (truncated?)");
  std::string bad = kGzipA;
  bad[bad.size() - 6] ^= 0x55;  // the CRC-32
  CHECK(inflate(bad, Compression::gzip).error == "gzip data is corrupt: incorrect data check");
  CHECK(inflate(kGzipA + "junk", Compression::gzip).error ==
        "bytes after the end of the gzip data are not gzip (ignored)");
  // a frame header whose window descriptor asks for 2^31 bytes: more than the 128 MiB limit
  const Inflated huge = inflate(unhex("28b52ffd00a8") + std::string(64, '\0'), Compression::zstd);
  CHECK(huge.text.empty());
  CHECK(huge.error.starts_with("zstd data is corrupt: "));
}

TEST_CASE("what we compress is gzip and zstd, flushable, and reads back") {
  for (Compression c : {Compression::gzip, Compression::zstd}) {
    std::ostringstream out;
    auto z = make_compressing_buf(*out.rdbuf(), c);
    std::ostream os(z.get());
    std::string big;
    for (int i = 0; i < 20000; ++i) big += kLine;
    os << big.substr(0, 1000);
    os.flush();  // a sync flush: everything so far can be read already
    const Inflated partial = inflate(out.str(), c);
    CHECK(partial.text == big.substr(0, 1000));
    os << big.substr(1000);
    os.flush();
    z->finish();
    const std::string packed = out.str();
    CHECK(packed.size() < big.size() / 10);
    CHECK(detect_compression(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(packed.data()),
                                                           packed.size())) == c);
    const Inflated back = inflate(packed, c);
    CHECK(back.text == big);
    CHECK(back.error.empty());
  }
}

TEST_CASE("many buffers, odd reads, progress, and a reader that stops early") {
  // 3 MB of varied text, compressed both ways
  std::mt19937 rng(7);
  std::string big;
  while (big.size() < 3'000'000) big += "(" + std::to_string(rng()) + ") can0 " + std::to_string(rng() % 4096) + "#\n";
  for (Compression c : {Compression::gzip, Compression::zstd}) {
    std::ostringstream out;
    auto z = make_compressing_buf(*out.rdbuf(), c);
    std::ostream os(z.get());
    os << big;
    os.flush();
    z->finish();
    const std::string packed = out.str();
    std::istringstream in(packed);
    auto buf = make_decompressing_buf(*in.rdbuf(), c);
    std::string got;
    std::uint64_t last_progress = 0;
    bool monotonic = true;
    std::vector<char> piece(7777);
    for (;;) {
      const auto n = buf->sgetn(piece.data(), static_cast<std::streamsize>(1 + rng() % piece.size()));
      if (n <= 0) break;
      got.append(piece.data(), static_cast<std::size_t>(n));
      monotonic = monotonic && buf->compressed_bytes() >= last_progress;
      last_progress = buf->compressed_bytes();
    }
    CHECK(got == big);
    CHECK(buf->error().empty());
    CHECK(monotonic);
    CHECK(buf->compressed_bytes() == packed.size());
    // a reader that stops after a few bytes (no leak under ASan)
    std::istringstream again(packed);
    auto early = make_decompressing_buf(*again.rdbuf(), c);
    char first[16];
    CHECK(early->sgetn(first, 16) == 16);
    CHECK(std::string(first, 16) == big.substr(0, 16));
    early.reset();
  }
}
