#include "grammar.hpp"

#include <memory>
#include <stdexcept>

#include "saulproto/host/bench/bench_test.hpp"
#include "saulproto/host/replay/replay.hpp"

namespace saulctl {

namespace {
std::string link_forms(bool serial_too) {
  return std::string("can0 | socketcan:can0 | slcan:/dev/ttyACM0[@500000]") +
         (serial_too ? " | serial:/dev/ttyUSB0@460800" : "") +
         " (default: $SAUL_LINK, else ~/.config/saulctl/link)";
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

CLI::Option* add_id_option(CLI::App* cmd, std::vector<std::string>& ids, const std::string& what) {
  return cmd
      ->add_option("--id", ids,
                   what + ": ID or ID:MASK in hex as candump writes ids (400 = 0x400, 0x accepted; more than 3 "
                          "digits = 29-bit), comma separated or repeated")
      ->delimiter(',')
      ->allow_extra_args(false)
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            try {
              (void)saul::host::parse_id_filter(text);
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
      out.push_back(saul::host::parse_id_filter(text));
    } catch (const std::invalid_argument& e) {
      throw CLI::ValidationError("--id", e.what());
    }
  }
  return out;
}

std::chrono::milliseconds parse_duration(const std::string& text) {
  const auto us = saul::host::benchtest::parse_duration_us(text);  // the bench suites' reading of "500ms", "2s", "1m"
  if (!us) throw CLI::ValidationError("duration", "bad duration '" + text + "' (use e.g. 500ms, 2s, 1.5 = seconds, 2m)");
  return std::chrono::milliseconds(static_cast<long long>(*us / 1000));
}

CLI::Validator duration_check() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        try {
          (void)parse_duration(text);
        } catch (const CLI::ValidationError&) {
          return "bad duration '" + text + "' (use e.g. 500ms, 2s, 1.5 = seconds, 2m)";
        }
        return "";
      },
      "DURATION", "duration");
}

CLI::Option* add_duration_option(CLI::App* cmd, std::string& duration, const std::string& what) {
  return cmd->add_option("--duration,--for", duration, what + " (500ms, 10s, 1.5 = seconds, 2m)")
      ->check(duration_check());
}

CLI::Option* add_json_flag(CLI::App* cmd, bool& json, const std::string& what) {
  return cmd->add_flag("--json", json, what);
}

}  // namespace saulctl
