// rtukit CLI: each group of subcommands registers itself on the app.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace rtukit::cli {

/// A subcommand's body; returns the exit code. Set by the register functions.
using Action = std::function<int()>;

/// read, write, scan, slave.
void add_generic_commands(CLI::App& app, Action& action);

/// inverjet bridge|panel|panel-password: the programs (the machine's verbs are its table's).
void add_inverjet_commands(CLI::App& app, Action& action);

/// rehand6600 host: the RK3588 daemon (the chair's verbs are its table's).
void add_rehand6600_commands(CLI::App& app, Action& action);

/// gateway: one process owns the serial bus, Modbus TCP clients share it.
/// `rtukit diag` (FC07/08/0B/0C) and `rtukit ident` (FC2B/0E, FC11).
void add_diag_commands(CLI::App& app, Action& action);

void add_gateway_command(CLI::App& app, Action& action);

/// bus: a virtual RS-485 line on ptys.
void add_bus_command(CLI::App& app, Action& action);

/// relay: a man in the middle of an RTU line, with faults chosen frame by frame.
void add_relay_command(CLI::App& app, Action& action);

/// sniff: listen to a line, transactions in device terms.
void add_sniff_command(CLI::App& app, Action& action);

/// doctor: measure the line to a device and say what to set.
void add_doctor_command(CLI::App& app, Action& action);

/// sim <device>, sim map FILE (device simulators on the one simulator host).
void add_sim_commands(CLI::App& app, Action& action);
/// rtukit devices; rtukit <device> registers|get|set|watch|status for every
/// registered device (devices/registry); rtukit map check|registers; the
/// map-file verbs.
void add_profile_commands(CLI::App& app, Action& action);

struct Failure;
/// A mistyped command or option in `args` (argv without the program name):
/// "unknown command 'raed' (did you mean 'read'?) (commands: ...)", or nothing.
std::optional<Failure> check_words(const CLI::App& app, const std::vector<std::string>& args);

/// What an mbpoll user typed that rtukit spells otherwise, for a command
/// line that did not parse: "mbpoll's -a 21 is --unit 21 here" for each
/// mbpoll option found (-a, -r, -t 0..4, -m, -c, -l, -1, -B, -P, -p, -R, -o)
/// and for a device given as a bare argument, then where the whole mapping
/// is (docs/coming-from-mbpoll.md). Empty: nothing looks like mbpoll.
std::string mbpoll_hint(const std::vector<std::string>& args);

/// Every option of a command, those in its option groups included.
std::vector<const CLI::Option*> all_options(const CLI::App& app);

/// completion bash|zsh (generated from the command definitions).
void add_completion_command(CLI::App& app, Action& action);

/// manpage: the manual page (roff) of every command of `app`, its
/// options, examples and the exit codes, generated from the definitions.
void add_manpage_command(CLI::App& app, Action& action);
std::string manual_page(const CLI::App& app);

}  // namespace rtukit::cli
