#include "grammar.hpp"

#include <memory>
#include <stdexcept>

#include "saulproto/core/quantity.hpp"

namespace saulctl {

namespace {
std::string link_forms(bool serial_too) {
  return std::string("can0 | socketcan:can0 | slcan:/dev/ttyACM0[@500000]") +
         (serial_too ? " | serial:/dev/ttyUSB0@460800" : "") +
         " (default: $SAUL_LINK, else ~/.config/saulctl/link)";
}

// "400-40F": the ids from A to B as the fewest ID:MASK blocks (each a power-of-two run aligned to its size, as a
// CAN controller's filters match), in the width the ends are written in; "400" and "400:7F0" as parse_id_filter.
std::vector<saul::host::CanFilter> parse_id_selection(const std::string& text) {
  const auto dash = text.find('-');
  if (dash == std::string::npos) return {saul::host::parse_id_filter(text)};
  if (text.find(':') != std::string::npos)
    throw std::invalid_argument("bad id range '" + text + "': a range has no mask (400-40F, or 400:7F0)");
  const auto lo = saul::host::parse_id_filter(text.substr(0, dash));
  const auto hi = saul::host::parse_id_filter(text.substr(dash + 1));
  if (lo.id > hi.id) throw std::invalid_argument("bad id range '" + text + "': the first id is above the last");
  const bool extended = lo.extended || hi.extended;
  const std::uint32_t all = extended ? saul::CanFrame::kMaxExtendedId : saul::CanFrame::kMaxStandardId;
  std::vector<saul::host::CanFilter> out;
  for (std::uint64_t id = lo.id; id <= hi.id;) {
    std::uint64_t size = 1;  // the largest aligned block from id that stays within the range
    while ((id & (size * 2 - 1)) == 0 && id + size * 2 - 1 <= hi.id && size * 2 <= std::uint64_t{all} + 1) size *= 2;
    out.push_back({static_cast<std::uint32_t>(id), static_cast<std::uint32_t>(all & ~(size - 1)), extended});
    id += size;
  }
  return out;
}

std::string bad_duration(const std::string& text) {
  return "bad duration '" + text + "' (use e.g. 500ms, 2s, 1.5 = seconds, 2m)";
}
}  // namespace

void add_link_option(CLI::App* cmd, std::string& link, bool serial_too) {
  cmd->add_option("-l,--link", link, (serial_too ? "the link: " : "the CAN link: ") + link_forms(serial_too));
}

void add_link_option_and_positional(CLI::App* cmd, std::string& link) {
  add_link_option(cmd, link, true);
  auto positional = std::make_shared<std::string>();
  cmd->add_option("LINK", *positional, "the link as a plain word, the same as --link LINK: " + link_forms(true));
  cmd->parse_complete_callback([positional, &link] {
    if (positional->empty()) return;
    if (!link.empty() && link != *positional)
      throw CLI::ValidationError("LINK", "two links given: --link " + link + " and " + *positional + "; give one");
    link = *positional;
  });
}

CLI::Option* add_id_option(CLI::App* cmd, std::vector<std::string>& ids, const std::string& what, const char* name) {
  return cmd
      ->add_option(name, ids,
                   what + ": ID, ID:MASK or FIRST-LAST in hex as candump writes ids (400 = 0x400, 0x accepted; more "
                          "than 3 digits = 29-bit), comma separated or repeated")
      ->delimiter(',')
      ->allow_extra_args(false)
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            try {
              (void)parse_id_selection(text);
            } catch (const std::invalid_argument& e) {
              return e.what();
            }
            return "";
          },
          "ID[:MASK]", "hex CAN id"));
}

std::vector<saul::host::CanFilter> id_filters(const std::vector<std::string>& ids) {
  std::vector<saul::host::CanFilter> out;
  for (const auto& text : ids) {
    try {
      const auto some = parse_id_selection(text);
      out.insert(out.end(), some.begin(), some.end());
    } catch (const std::invalid_argument& e) {
      throw CLI::ValidationError("--id", e.what());
    }
  }
  return out;
}

std::chrono::milliseconds parse_duration(const std::string& text) {
  const auto us = saul::quantity::parse_duration_us(text);  // as bench suites read "500ms", "2s", "1m"
  if (!us) throw CLI::ValidationError("duration", bad_duration(text));
  return std::chrono::milliseconds(static_cast<long long>(*us / 1000));
}

CLI::Validator duration_check() {
  return CLI::Validator(
      [](std::string& text) { return saul::quantity::parse_duration_us(text) ? std::string() : bad_duration(text); },
      "DURATION", "duration");
}

CLI::Option* add_duration_option(CLI::App* cmd, std::string& duration, const std::string& what) {
  return cmd->add_option("--duration,--for", duration, what + " (500ms, 10s, 1.5 = seconds, 2m)")
      ->check(duration_check());
}

saul::host::TimeMode time_mode(const std::string& time) {
  using saul::host::TimeMode;
  return time == "rel" ? TimeMode::relative : time == "delta" ? TimeMode::delta : TimeMode::absolute;
}

}  // namespace saulctl
