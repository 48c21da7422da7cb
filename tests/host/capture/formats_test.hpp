// What the tests of issue 16's formats share on top of test_captures.hpp: reading with a reader of a given type,
// errors as "LINE:COLUMN message" or as messages, and a scratch folder of their own that is removed afterwards.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "test_captures.hpp"

namespace capture_test {

/// Every record of `bytes` read by a `Reader` constructed on them (with `args` after the stream).
template <class Reader, class... Args>
Read read_with(const std::string& bytes, Args&&... args) {
  std::istringstream in(bytes);
  Reader reader(in, std::forward<Args>(args)...);
  return read_all(reader);
}

/// The errors of a text reader as "LINE:COLUMN message" (column 1-based).
inline std::vector<std::string> located(const Read& r) {
  std::vector<std::string> out;
  for (const auto& e : r.errors) out.push_back(std::to_string(e.position) + ":" + std::to_string(e.column + 1) + " " + e.message);
  return out;
}

/// The errors' messages alone.
inline std::vector<std::string> messages(const Read& r) {
  std::vector<std::string> out;
  for (const auto& e : r.errors) out.push_back(e.message);
  return out;
}

/// A folder for one test case, removed when it ends.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& name)
      : path(std::filesystem::temp_directory_path() / ("saul_" + name + "_" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  /// Writes `content` into a file of that name; its path.
  std::string write(const std::string& name, const std::string& content) const {
    const auto p = (path / name).string();
    std::ofstream(p, std::ios::binary) << content;
    return p;
  }
};

}  // namespace capture_test
