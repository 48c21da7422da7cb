#include "saulproto/host/report/wireshark.hpp"

#include <fmt/format.h>

#include <string_view>

#include "saulproto/core/signals.hpp"
#include "saulproto/host/report/format.hpp"

namespace saul::host {
namespace {

using namespace signals;

/// The ProtoField type of a signal's field: what its JSON value is.
const char* field_type(const SignalDesc& s) {
  if (s.kind == Kind::string || s.text == Text::name) return "string";
  if (s.text == Text::physical || s.kind == Kind::float32) return "double";
  return s.kind == Kind::signed_int || s.offset != 0 ? "int32" : "uint32";  // the robot's signals: 32 bits at most
}

/// An enum's value as the script names it: names[] in the enum's order.
template <class Enum, std::size_t N>
const char* name_in(const char* const (&names)[N], Enum e) {
  return names[static_cast<std::size_t>(e)];
}

/// The key of the value shown() gives: the signal's name, or for a scaled wire integer (whose physical value is
/// under the name, a second field) its raw_key(), as decode --json names them.
std::string shown_key(const SignalDesc& s) { return signals::text_in_unit(s) ? raw_key(s) : s.name; }

/// Each (message, key) with its ProtoField type.
template <class F>
void each_field(F&& f) {
  for (Protocol p : {Protocol::saul_can, Protocol::vesc_can})
    for (const MessageDesc& m : signals::messages(p))
      for (const SignalDesc& s : m.signals) {
        f(m, shown_key(s), field_type(s));
        if (signals::text_in_unit(s)) f(m, std::string(s.name), signals::text_decimals(s) > 0 ? "double" : "int32");
      }
}

std::string field_name(const MessageDesc& m, std::string_view key) { return fmt::format("saul.{}.{}", m.name, key); }

std::string signal_table(const SignalDesc& s) {
  std::string values;
  for (const auto& v : s.values) values += fmt::format("[{}] = {}, ", v.value, c_literal(v.name));
  return fmt::format(
      "      {{ name = {}, key = {}, physical = {}, whole = {}, unit = {}, at = \"{}\", start = {}, bits = {}, kind = \"{}\", order = \"{}\",\n"
      "        num = {}, den = {}, offset = {:.17g}, min = {}, max = {}, checked = {}, text = \"{}\", mux = \"{}\",\n"
      "        mux_value = {}, values = {{ {}}}, value_bits = {} }},\n",
      c_literal(s.name), c_literal(shown_key(s)), c_literal(signals::text_in_unit(s) ? s.name : ""),
      signals::text_decimals(s) < 0 ? "true" : "false", c_literal(s.unit),
      s.place == Place::can_id ? "can_id" : "payload", s.start_bit, s.length,
      name_in({"unsigned", "signed", "float32", "string"}, s.kind), s.order == ByteOrder::little_endian ? "le" : "be",
      s.scale_num, s.scale_den, s.offset, s.min, s.max, s.check == Check::decoder ? "true" : "false",
      name_in({"raw", "name", "physical", "physical_int"}, s.text),
      name_in({"none", "multiplexer", "multiplexed"}, s.mux), s.mux_value, values, s.value_bits ? "true" : "false");
}

// The part of the script that does not depend on the descriptions: reading bits, values, the tree.
constexpr std::string_view kEngine = R"LUA(
-- Bits are numbered as in a DBC file (core/signals.hpp): little-endian fields start at their least significant
-- bit (8 * byte + bit) and grow upwards; big-endian ones start at their most significant bit and go down the
-- byte, then on to bit 7 of the next byte.
local function read_raw(s, bytes)
  local p = s.order == "le" and (s.start + s.bits - 1) or s.start
  local u = 0
  for i = s.bits - 1, 0, -1 do
    local b = bytes[math.floor(p / 8) + 1]
    if b == nil then return nil end
    if math.floor(b / 2 ^ (p % 8)) % 2 == 1 then u = u + 2 ^ i end
    if s.order == "le" then p = p - 1 elseif p % 8 == 0 then p = p + 15 else p = p - 1 end
  end
  if s.kind == "signed" and u >= 2 ^ (s.bits - 1) then u = u - 2 ^ s.bits end
  return u
end

local function float32(u)
  local sign = u >= 2 ^ 31 and -1 or 1
  local e = math.floor(u / 2 ^ 23) % 256
  local m = u % 2 ^ 23
  if e == 0 then return sign * m * 2 ^ -149 end
  if e == 255 then return m == 0 and sign * math.huge or 0 / 0 end
  return sign * (1 + m / 2 ^ 23) * 2 ^ (e - 127)
end

local function physical(s, raw)
  if s.kind == "float32" then return float32(raw) end
  return raw * s.num / s.den + s.offset
end

local function round(x)  -- halves away from zero, as saulctl's llround
  if x >= 0 then return math.floor(x + 0.5) end
  return -math.floor(-x + 0.5)
end

-- The value saulctl decode --json gives, and the words for the tree.
local function shown(s, raw)
  if s.text == "name" then return s.values[raw] or tostring(raw) end
  if s.text == "physical" then return physical(s, raw) end
  if s.text == "physical_int" then return round(physical(s, raw)) end
  if s.kind == "float32" then return float32(raw) end
  return raw
end

local function number_text(x)
  if x == math.floor(x) and math.abs(x) < 2 ^ 53 then return string.format("%d", x) end
  return string.format("%.6g", x)
end

local function label(s, raw)
  local text
  if s.value_bits then
    local set = {}
    for bit = 0, s.bits - 1 do
      if math.floor(raw / 2 ^ bit) % 2 == 1 then set[#set + 1] = s.values[bit] or ("bit " .. bit) end
    end
    text = number_text(raw) .. (#set > 0 and (" (" .. table.concat(set, ", ") .. ")") or " (none)")
  elseif s.text == "name" or next(s.values) ~= nil then
    text = (s.values[raw] or "?") .. " (" .. number_text(raw) .. ")"
  else
    text = number_text(physical(s, raw)) .. (s.unit ~= "" and (" " .. s.unit) or "")
  end
  if s.key ~= s.name then text = text .. "  [" .. s.key .. " = " .. tostring(shown(s, raw)) .. "]" end
  return s.name .. ": " .. text
end

local f_id = Field.new("can.id")
local f_xtd = Field.new("can.flags.xtd")
local f_rtr = Field.new("can.flags.rtr")
local f_err = Field.new("can.flags.err")
local f_len = Field.new("can.len")

function saul.dissector(tvb, pinfo, tree)
  local id = f_id()
  if id == nil or f_len() == nil then return end
  if (f_rtr() and f_rtr().value) or (f_err() and f_err().value) then return end
  id = id.value
  local extended = f_xtd() and f_xtd().value
  local m, protocol
  if extended then
    local command = math.floor(id / 256)
    if command <= 255 then m = VESC[command] end
    protocol = "VESC"
  else
    m = SAUL[id]
    protocol = "SAUL"
  end
  if m == nil then return end
  local length = f_len().value
  if tvb:len() < 8 + length then return end
  local range = tvb(8, length)
  local bytes = {}
  for i = 0, length - 1 do bytes[i + 1] = range:range(i, 1):uint() end
  local id_bytes = {}
  for i = 0, 3 do id_bytes[i + 1] = math.floor(id / 2 ^ (8 * i)) % 256 end

  pinfo.cols.protocol:set(protocol)
  pinfo.cols.info:append(" " .. m.name)
  local t = tree:add(saul, range, "SAUL-TEE " .. protocol .. " " .. m.name)
  t:add(F.message, range, m.name)
  local problem
  if (m.exact and length ~= m.length) or length < m.length then problem = "wrong_dlc" end
  local mux
  for _, s in ipairs(m.signals) do
    if s.mux == "multiplexer" then mux = read_raw(s, s.at == "can_id" and id_bytes or bytes) end
  end
  for _, s in ipairs(m.signals) do
    if s.mux ~= "multiplexed" or mux == s.mux_value then
      local raw = read_raw(s, s.at == "can_id" and id_bytes or bytes)
      if raw ~= nil then
        if s.checked and (raw < s.min or raw > s.max) then problem = problem or "out_of_range" end
        local item = t:add(FIELDS[m.name][s.key], range, shown(s, raw))
        item:set_text(label(s, raw))
        if s.physical ~= "" then  -- the physical value under its own key, as decode --json has it beside the raw
          local x = physical(s, raw)
          item:add(FIELDS[m.name][s.physical], range, s.whole and math.floor(x) or x)
        end
      end
    end
  end
  if problem then
    t:add(F.problem, range, problem)
    t:add_proto_expert_info(E.rejected, "saulctl rejects this frame: " .. problem)
  end
end

register_postdissector(saul)
)LUA";

}  // namespace

std::vector<std::string> wireshark_field_names() {
  std::vector<std::string> names = {"saul.message", "saul.problem"};
  each_field([&](const MessageDesc& m, const std::string& key, const char*) { names.push_back(field_name(m, key)); });
  return names;
}

std::string wireshark_dissector_lua() {
  std::string out =
      "-- SAUL-TEE robot: its SAUL frames (0x300-0x303, 0x400-0x402) and VESC frames in Wireshark, a Lua\n"
      "-- post-dissector for SocketCAN captures (pcap/pcapng, link type 227).\n"
      "-- Generated by `saulctl wireshark` from libsaulproto's message descriptions (core/signals*.hpp): do not\n"
      "-- edit, generate it again. Use: wireshark -X lua_script:saul.lua run.pcapng, or copy it into\n"
      "-- ~/.local/lib/wireshark/plugins/. Fields: saul.message, saul.problem, saul.<message>.<key> (the values\n"
      "-- `saulctl decode --json` prints: a scaled integer both physical, saul.telemetry_a.pitch, and raw,\n"
      "-- saul.telemetry_a.pitch_raw); the tree shows every signal in physical units.\n"
      "local saul = Proto(\"saul\", \"SAUL-TEE robot CAN (SAUL and VESC frames)\")\n"
      "local F = {\n"
      "  message = ProtoField.string(\"saul.message\", \"Message\"),\n"
      "  problem = ProtoField.string(\"saul.problem\", \"Rejected by saulctl\"),\n"
      "}\n"
      "local FIELDS = {}\n";
  each_field([&](const MessageDesc& m, const std::string& key, const char* type) {
    out += fmt::format("FIELDS[{0}] = FIELDS[{0}] or {{}}\n", c_literal(m.name));
    out += fmt::format("FIELDS[{}][{}] = ProtoField.{}({}, {})\n", c_literal(m.name), c_literal(key), type,
                       c_literal(field_name(m, key)), c_literal(fmt::format("{} {}", m.name, key)));
  });
  out +=
      "local all = { F.message, F.problem }\n"
      "for _, fields in pairs(FIELDS) do for _, f in pairs(fields) do all[#all + 1] = f end end\n"
      "saul.fields = all\n"
      "local E = { rejected = ProtoExpert.new(\"saul.rejected\", \"Frame rejected by saulctl's decoder\",\n"
      "                                     expert.group.MALFORMED, expert.severity.WARN) }\n"
      "saul.experts = { E.rejected }\n\n"
      "-- The messages, from core/signals*.hpp. SAUL by 11-bit id, VESC by command (29-bit id bits 15..8).\n";
  for (Protocol p : {Protocol::saul_can, Protocol::vesc_can}) {
    out += p == Protocol::saul_can ? "local SAUL = {\n" : "local VESC = {\n";
    for (const MessageDesc& m : signals::messages(p)) {
      out += fmt::format("  [0x{:X}] = {{ name = {}, length = {}, exact = {}, signals = {{\n", m.id,
                         c_literal(m.name), m.length, m.exact_length ? "true" : "false");
      for (const SignalDesc& s : m.signals) out += signal_table(s);
      out += "  } },\n";
    }
    out += "}\n";
  }
  out += kEngine;
  return out;
}

}  // namespace saul::host
