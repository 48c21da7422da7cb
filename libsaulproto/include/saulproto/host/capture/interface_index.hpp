// Interface names numbered in order of first appearance, for the writers that number them (pcapng interface ids,
// ASC and BLF channels) and for copy_frames(): a frame's name is looked up in O(1), the last one first (a log's
// frames come in runs of one interface), so that a log of many names does not convert in quadratic time.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace saul::host {

class InterfaceIndex {
 public:
  /// The name's number (0, 1, ... in order of first appearance); a new name is added unless `max` names are known
  /// already, which gives nullopt. Cost: one comparison for the last name looked up, else one hash lookup.
  std::optional<std::size_t> find_or_add(std::string_view name, std::size_t max) {
    if (last_ < names_.size() && names_[last_] == name) return last_;
    const auto it = index_.find(name);
    if (it != index_.end()) return last_ = it->second;
    if (names_.size() >= max) return std::nullopt;
    names_.emplace_back(name);
    index_.emplace(names_.back(), names_.size() - 1);
    return last_ = names_.size() - 1;
  }
  /// The names, by number.
  [[nodiscard]] const std::vector<std::string>& names() const noexcept { return names_; }
  [[nodiscard]] std::size_t size() const noexcept { return names_.size(); }
  void clear() {
    names_.clear();
    index_.clear();
    last_ = kNone;
  }

 private:
  struct Hash {
    using is_transparent = void;
    std::size_t operator()(std::string_view s) const noexcept { return std::hash<std::string_view>{}(s); }
  };
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::vector<std::string> names_;
  std::unordered_map<std::string, std::size_t, Hash, std::equal_to<>> index_;
  std::size_t last_ = kNone;
};

}  // namespace saul::host
