// The verb table's helpers: argument lookup and the docs' table.
#include "rtukit/devices/profile/verb.hpp"

#include <fmt/core.h>

namespace rtukit::profile {

std::string_view arg(const VerbArgs& args, std::string_view name, std::string_view fallback) {
  const auto it = args.find(name);
  return it == args.end() ? fallback : std::string_view(it->second);
}

bool given(const VerbArgs& args, std::string_view name) {
  return args.find(name) != args.end();
}

bool wait(VerbContext& context, std::chrono::milliseconds d) {
  if (context.wait) return context.wait(d);
  clock_or_steady(context.clock).sleep_for(d);
  return true;
}

void progress(VerbContext& context, std::string_view text) {
  if (context.progress) context.progress(text);
}

const Verb* find_verb(std::span<const Verb> verbs, std::string_view name) {
  for (const Verb& v : verbs)
    if (v.name == name) return &v;
  return nullptr;
}

namespace {
// "SPEED", "[--speed S]", "--free": as a command line takes it.
std::string usage(const VerbArg& a) {
  std::string upper;
  for (const char c : a.name) upper += static_cast<char>(c >= 'a' && c <= 'z' ? c - 'a' + 'A' : c);
  std::string word = upper;
  if (a.form != VerbArg::Form::positional) {
    word = fmt::format("--{}", a.name);
    if (a.form == VerbArg::Form::option) word += " " + upper;
  }
  return a.required ? word : fmt::format("[{}]", word);
}
// A table cell takes no '|': alternatives are written "or" ("a | b", "a|b" -> "a or b").
std::string cell_text(std::string_view text) {
  std::string cell;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '|')
      cell += text[i];
    else if (i > 0 && text[i - 1] == ' ' && i + 1 < text.size() && text[i + 1] == ' ')
      cell += "or";  // " | " -> " or "
    else
      cell += " or ";
  }
  return cell;
}

}  // namespace

std::string verbs_markdown(std::string_view device, std::span<const Verb> verbs) {
  std::string out = "| command | what it does | arguments |\n|---|---|---|\n";
  for (const Verb& v : verbs) {
    std::string line = fmt::format("`rtukit {} {}", device, v.name);
    for (const VerbArg& a : v.args) line += " " + usage(a);
    std::string args;
    for (const VerbArg& a : v.args) {
      if (!args.empty()) args += "; ";
      args += fmt::format("{}: {}", usage(a), a.help);
      if (!a.fallback.empty()) args += fmt::format(" (default {})", a.fallback);
    }
    if (v.live_interval_ms != 0) {  // what every front-end's live view takes
      line += " [--interval MS] [--count N]";
      args += fmt::format(
          "{}[--interval MS]: ms between refreshes (default {}); [--count N]: stop after N "
          "(default 0: until Ctrl-C)",
          args.empty() ? "" : "; ", v.live_interval_ms);
    }
    out +=
        fmt::format("| {}` | {} | {} |\n", line, cell_text(v.help), args.empty() ? "none" : cell_text(args));
  }
  return out;
}

}  // namespace rtukit::profile
