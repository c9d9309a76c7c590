// The Rehand 6600's verbs that print from the tables (profile/verb.hpp):
// `errors [CODE]` (table 3) and `stopping` (D-9). The verbs that command the
// chair (hold, pulse, set, watch) run the host controller and its rules.
#include <fmt/core.h>

#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/devices/rehand6600/reference.hpp"
#include "rtukit/devices/rehand6600/verbs.hpp"
#include "rtukit/devices/rehand6600/views.hpp"

namespace rtukit::rehand6600 {
namespace {

std::string without_final_newline(std::string text) {
  if (!text.empty() && text.back() == '\n') text.pop_back();
  return text;
}

// Table 3, or one code with what it means and what to check: four hex
// digits are the code as the chair shows it ("10C3"); anything else is a
// number (0x10C3, 65535).
Outcome<profile::VerbResult> errors(const profile::VerbArgs& args) {
  std::vector<uint16_t> codes(error_codes().begin(), error_codes().end());
  const std::string_view text = profile::arg(args, "code");
  if (!text.empty()) {
    const bool as_shown =
        text.size() == 4 && text.find_first_not_of("0123456789abcdefABCDEF") == std::string::npos;
    const Outcome<int64_t> code = profile::parse_number(
        as_shown ? "0x" + std::string(text) : std::string(text), "error code", 1, 0xFFFF);
    if (!code) return code.error();
    codes = {static_cast<uint16_t>(*code)};
  }
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const uint16_t c : codes) list.push_back(error_json(c));
  return profile::VerbResult{"",
                             text.empty()
                                 ? without_final_newline(errors_markdown())
                                 : fmt::format("{}: {}", error_text(codes[0]), error_advice(codes[0])),
                             nullptr, nlohmann::json{{"errors", list}}};
}

}  // namespace

const std::vector<profile::Verb>& verb_table() {
  static const std::vector<profile::Verb> verbs{
      {.name = "errors",
       .help = "table 3: error codes, functions, UI texts, what each means and what to check",
       .args = {{"code", profile::VerbArg::Form::positional, "one code, as the chair shows it (10C3)"}},
       .examples = {"", "10C3", "--json"},
       .uses_link = false,
       .reads = true},
      {.name = "stopping",
       .help = "D-9: stopping time and distance per speed level and drive mode (model clock)",
       .examples = {""},
       .uses_link = false,
       .reads = true},
  };
  return verbs;
}

Outcome<profile::VerbResult> run_verb(const profile::Verb& verb, const profile::VerbArgs& args,
                                      profile::VerbContext&) {
  if (verb.name == "errors") return errors(args);
  if (verb.name == "stopping")
    return profile::VerbResult{"", without_final_newline(stopping_markdown()), nullptr, nullptr};
  return rtukit::Status(Errc::invalid_argument, fmt::format("rehand6600 has no verb '{}'", verb.name));
}

}  // namespace rtukit::rehand6600
