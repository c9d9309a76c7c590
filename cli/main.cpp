// rtukit: one binary, subcommands. Exit codes: 0 ok, 1 Modbus exception,
// 2 usage, 3 no response, 4 I/O error, 5 refused (wrong device, device rules). Errors are one line on stderr.
#include <fmt/core.h>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "common.hpp"

int main(int argc, char** argv) {
  using namespace rtukit::cli;
  catch_broken_output();
  CLI::App app{"rtukit: talk Modbus-RTU / Modbus TCP to real or simulated devices", "rtukit"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "rtukit " RTUKIT_VERSION " (" RTUKIT_GIT_REVISION ")");
  Action action;
  add_generic_commands(app, action);
  add_diag_commands(app, action);
  add_inverjet_commands(app, action);
  add_rehand6600_commands(app, action);
  add_profile_commands(app, action);
  add_sim_commands(app, action);
  add_gateway_command(app, action);
  add_bus_command(app, action);
  add_relay_command(app, action);
  add_sniff_command(app, action);
  add_doctor_command(app, action);
  add_completion_command(app, action);
  add_manpage_command(app, action);
  std::string codes = "Exit codes:";
  for (const ExitCodeText& e : kExitCodes) codes += fmt::format("\n  {}  {}", e.code, e.meaning);
  app.footer(codes +
             "\n  128+N  ended by signal N (130: Ctrl-C)\nrtukit help COMMAND: the help of a command; "
             "man rtukit: every command");
  // `rtukit help [COMMAND...]`: the help of that command.
  std::vector<std::string> args(argv + 1, argv + argc);
  if (!args.empty() && args[0] == "help") {
    args.erase(args.begin());
    if (const std::optional<Failure> f = check_words(app, args)) {
      fmt::print(stderr, "rtukit: {}\n", f->message);
      return f->code;
    }
    const CLI::App* node = &app;
    std::string prefix;  // the command path before the last word, as --help shows it
    for (const std::string& word : args) {
      prefix += (prefix.empty() ? "" : " ") + node->get_name();
      node = node->get_subcommand(word);
    }
    fmt::print("{}", node->help(prefix));
    return kOk;
  }
  if (const std::optional<Failure> f = check_words(app, args)) {
    fmt::print(stderr, "rtukit: {}\n", f->message);
    return f->code;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // Name the command the error belongs to, so its --help is one copy away.
    std::string where = "rtukit";
    for (const CLI::App* sub = &app; !sub->get_subcommands().empty();) {
      sub = sub->get_subcommands().front();
      where += " " + sub->get_name();
    }
    const std::string mbpoll = mbpoll_hint(args);
    fmt::print(stderr, "rtukit: {} (see {} --help){}\n", e.what(), where,
               mbpoll.empty() ? "" : "; " + mbpoll);
    return kUsage;
  }
  // --json anywhere on the chosen command path: failures are JSON too.
  for (const CLI::App* sub = &app; sub;) {
    if (const CLI::Option* o = sub->get_option_no_throw("--json"); o && o->count() > 0)
      json_requested() = true;
    const auto chosen = sub->get_subcommands();
    sub = chosen.empty() ? nullptr : chosen.front();
  }
  try {
    const int code = action ? action() : kUsage;
    return output_broken() ? kOk : code;
  } catch (const Failure& f) {
    if (output_broken()) return kOk;  // its reader ended first (`| head`): nothing is wrong
    // A usage error with mbpoll's words in it (`read /dev/ttyUSB0 ...`): where they go here.
    const std::string mbpoll = f.code == kUsage ? mbpoll_hint(args) : "";
    fmt::print(stderr, "rtukit: {}{}\n", f.message, mbpoll.empty() ? "" : "; " + mbpoll);
    if (json_requested()) print_json(json_failure(f));
    return f.code;
  } catch (const std::exception& e) {
    if (output_broken()) return kOk;  // a write that failed as its reader left
    fmt::print(stderr, "rtukit: {}\n", e.what());
    return kIoError;
  }
}
