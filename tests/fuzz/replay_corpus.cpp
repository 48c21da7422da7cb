// Runs every fuzz target's entry point over the inputs kept in the repository — the seed corpus
// (tests/fuzz/corpus/<target>/) and every input that once crashed (tests/fuzz/regression/<target>/) — inside the
// normal test build, which scripts/test.sh compiles with ASan + UBSan. So a fixed bug stays fixed even on a
// machine without clang, and the seeds are checked by the same properties the fuzzer checks (a property failure
// aborts, a sanitizer report ends the program with an error).
//
//   saul_fuzz_replay CORPUS_ROOT REGRESSION_ROOT [TARGET...]     default: every target
//
// Each target is a function saul_fuzz_<target> of its source (tests/fuzz/fuzz_*.cpp), as in the libFuzzer program.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string_view>
#include <vector>

#include "fuzz_targets.hpp"

namespace {

using saul::fuzz::kTargets;
using saul::fuzz::Target;

/// The files under dir (sorted, so the order and the log are the same on every machine); none when it is absent.
std::vector<std::filesystem::path> inputs_in(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> files;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().filename() != "README.md") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s CORPUS_ROOT REGRESSION_ROOT [TARGET...]\n", argv[0]);
    return 2;
  }
  const std::filesystem::path corpus = argv[1], regression = argv[2];
  std::vector<std::string_view> only(argv + 3, argv + argc);
  int unknown = 0;
  for (auto name : only) {
    if (!saul::fuzz::find_target(name)) {
      std::fprintf(stderr, "saul_fuzz_replay: no target '%.*s'\n", static_cast<int>(name.size()), name.data());
      ++unknown;
    }
  }
  if (unknown) return 2;

  std::size_t total = 0;
  for (const Target& t : kTargets) {
    if (!only.empty() && std::find(only.begin(), only.end(), t.name) == only.end()) continue;
    std::size_t seeds = 0, regressions = 0;
    for (int kind = 0; kind < 2; ++kind) {
      for (const auto& file : inputs_in((kind == 0 ? corpus : regression) / std::string(t.name))) {
        std::ifstream in(file, std::ios::binary);
        const std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
        if (!in.eof() && in.fail()) {
          std::fprintf(stderr, "saul_fuzz_replay: cannot read %s\n", file.c_str());
          return 1;
        }
        // A crash names its input: the last path on stderr (unbuffered) before the report.
        std::fprintf(stderr, "%s\n", file.c_str());
        t.run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
        ++(kind == 0 ? seeds : regressions);
      }
    }
    if (seeds == 0) {
      std::fprintf(stderr, "saul_fuzz_replay: %s has no seed inputs under %s\n", std::string(t.name).c_str(),
                   corpus.c_str());
      return 1;
    }
    std::printf("%-22s %4zu seeds %4zu regression inputs: ok\n", std::string(t.name).c_str(), seeds, regressions);
    total += seeds + regressions;
  }
  std::printf("%zu inputs replayed\n", total);
  return 0;
}
