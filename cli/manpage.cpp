// `rtukit manpage`: the manual page (roff, man(7)) generated from the
// command definitions, as shell completion is: every command with its
// arguments, options and examples, the exit codes from their one table, so
// the page never disagrees with the binary. The build writes it (cli/rtukit.1)
// and the .deb installs it. A build without the example device has none of
// its commands, in the page as in the binary.
#include <fmt/core.h>

#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"

namespace rtukit::cli {
namespace {

// Text as roff shows it: backslashes and minus signs escaped, no line that
// starts with a control character.
std::string roff(std::string_view text) {
  std::string out;
  bool line_start = true;
  for (const char c : text) {
    if (line_start && (c == '.' || c == '\'')) out += "\\&";
    if (c == '\\')
      out += "\\e";
    else if (c == '-')
      out += "\\-";
    else
      out += c;
    line_start = c == '\n';
  }
  return out;
}

std::string synopsis_of(const CLI::App& cmd, const std::string& path) {
  std::string text = "\\fB" + roff(path) + "\\fR";
  bool has_options = false;
  for (const CLI::Option* o : all_options(cmd)) {
    if (o->get_positional())
      text += o->get_required() ? fmt::format(" \\fI{}\\fR", roff(o->get_name()))
                                : fmt::format(" [\\fI{}\\fR]", roff(o->get_name()));
    else
      has_options = true;
  }
  if (has_options) text.insert(text.find("\\fR") + 3, " [\\fIOPTIONS\\fR]");
  return text;
}

// An option as its help shows it: "--port, -p PORT".
std::string option_label(const CLI::Option& o) {
  std::string names;
  for (const std::string& l : o.get_lnames()) names += (names.empty() ? "" : ", ") + ("--" + l);
  for (const std::string& s : o.get_snames()) names += (names.empty() ? "" : ", ") + ("-" + s);
  if (o.get_expected_min() > 0 && !o.get_type_name().empty()) names += " " + o.get_type_name();
  return names;
}

void command_section(const CLI::App& cmd, const std::string& path, std::string& out) {
  std::vector<const CLI::App*> subs;
  for (const CLI::App* s : cmd.get_subcommands([](const CLI::App*) { return true; }))
    if (!s->get_name().empty()) subs.push_back(s);
  if (cmd.get_parent() != nullptr) {  // the top level is the page's own sections
    out += fmt::format(".SS \"{}\"\n", roff(path));
    out += fmt::format("{}\n.PP\n{}\n", synopsis_of(cmd, path), roff(cmd.get_description()));
    for (const CLI::Option* o : all_options(cmd)) {
      if (o->get_name() == "--help" || o->get_name() == "-h,--help") continue;
      const std::string label = o->get_positional() ? o->get_name() : option_label(*o);
      if (label.empty() || label == "--help, -h") continue;
      std::string help = o->get_description();
      if (!o->get_default_str().empty() && o->get_expected_min() > 0)
        help += " (default: " + o->get_default_str() + ")";
      out += fmt::format(".TP\n\\fB{}\\fR\n{}\n", roff(label), roff(help));
    }
    const std::string footer = cmd.get_footer();
    if (!footer.empty()) {
      // "Examples:\n  rtukit read ...": each example a line of its own.
      out += ".PP\n";
      std::string_view rest = footer;
      for (bool first = true; !rest.empty(); first = false) {
        const size_t nl = rest.find('\n');
        std::string_view line = rest.substr(0, nl);
        rest = nl == std::string_view::npos ? std::string_view() : rest.substr(nl + 1);
        while (!line.empty() && line.front() == ' ') line.remove_prefix(1);
        if (line.empty()) continue;
        out += first ? fmt::format("{}\n.RS\n", roff(line)) : fmt::format(".nf\n{}\n.fi\n", roff(line));
      }
      out += ".RE\n";
    }
  }
  for (const CLI::App* s : subs) command_section(*s, path + " " + s->get_name(), out);
}

}  // namespace

std::string manual_page(const CLI::App& app) {
  std::string out = fmt::format(".TH RTUKIT 1 \"\" \"rtukit {}\" \"User Commands\"\n", RTUKIT_VERSION);
  out += ".SH NAME\nrtukit \\- Modbus\\-RTU and Modbus TCP tool for real and simulated devices\n";
  out +=
      ".SH SYNOPSIS\n\\fBrtukit\\fR \\fICOMMAND\\fR [\\fIOPTIONS\\fR] [\\fIARGUMENTS\\fR]\n.br\n"
      "\\fBrtukit help\\fR [\\fICOMMAND\\fR...]\n";
  out += ".SH DESCRIPTION\n" + roff(app.get_description()) +
         ". Every command that talks to a device takes the link options (\\fB\\-\\-port\\fR, "
         "\\fB\\-\\-baud\\fR, "
         "\\fB\\-\\-parity\\fR, \\fB\\-\\-timeout\\fR...); a port is a serial device (/dev/ttyUSB0), a pty, "
         "tcp://HOST:PORT (Modbus TCP) or rtu+tcp://HOST:PORT. A failure is one line on standard error; "
         "\\fB\\-\\-json\\fR makes it, and every result, one JSON document.\n";
  out += ".SH COMMANDS\n";
  command_section(app, "rtukit", out);
  out += ".SH EXIT STATUS\n";
  for (const ExitCodeText& e : kExitCodes)
    out += fmt::format(".TP\n\\fB{}\\fR\n{}\n", e.code, roff(e.meaning));
  out +=
      ".TP\n\\fB128+N\\fR\nended by signal N (130: Ctrl\\-C) while a command that lasts ran; what it held "
      "was released first\n";
  out += ".SH ENVIRONMENT\n.TP\n\\fBNO_COLOR\\fR\nset: live panels print without colour\n";
  out +=
      ".SH SEE ALSO\n\\fBmbpoll\\fR(1). The guides in the source tree's docs/: inverjet.md, rehand6600.md, "
      "register\\-maps.md, coming\\-from\\-mbpoll.md, gateway.md, security.md.\n";
  return out;
}

void add_manpage_command(CLI::App& app, Action& action) {
  struct Args {};
  add_command<Args>(
      app, action, "manpage", "print the manual page (roff), generated from the commands themselves",
      [](CLI::App& cmd, Args&) { examples(cmd, {"rtukit manpage > rtukit.1 && man -l rtukit.1"}); },
      [&app](const Args&) {
        fmt::print("{}", manual_page(app));
        return int{kOk};
      });
}

}  // namespace rtukit::cli
