// Mistyped commands and options get a clear line with the closest match,
// before CLI11 would answer with something beside the point ("A subcommand
// is required" for `rtukit raed`, "--port is required" for `--prot`).
#include <fmt/core.h>

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"

namespace rtukit::cli {
namespace {

size_t distance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

// The closest candidate within a distance a typo could explain, or nothing.
std::optional<std::string> closest(std::string_view typed, const std::vector<std::string>& candidates) {
  std::optional<std::string> best;
  size_t best_distance = std::max<size_t>(2, typed.size() / 3) + 1;
  for (const std::string& c : candidates) {
    // A prefix is what people type too: `inverjet stat` -> status.
    const size_t d = c.starts_with(typed) && typed.size() >= 3 ? 1 : distance(typed, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best;
}

std::vector<std::string> subcommand_names(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* s : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (!s->get_name().empty()) names.push_back(s->get_name());
  }
  return names;
}

const CLI::App* find_sub(const CLI::App& app, const std::string& name) {
  for (const CLI::App* s : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (s->check_name(name)) return s;
  }
  return nullptr;
}

std::string path_of(const std::vector<std::string>& path) {
  std::string out = "rtukit";
  for (const std::string& p : path) out += " " + p;
  return out;
}

}  // namespace

std::vector<const CLI::Option*> all_options(const CLI::App& app) {
  std::vector<const CLI::Option*> out = app.get_options();
  // Option groups ("Link options") are nameless subcommands.
  for (const CLI::App* s : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (!s->get_name().empty()) continue;
    for (const CLI::Option* o : all_options(*s)) out.push_back(o);
  }
  return out;
}

std::optional<Failure> check_words(const CLI::App& app, const std::vector<std::string>& args) {
  const CLI::App* node = &app;
  std::vector<std::string> path;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& word = args[i];
    if (word == "--") break;
    if (word.starts_with("--")) {
      const std::string name =
          word.substr(2, word.find('=') == std::string::npos ? std::string::npos : word.find('=') - 2);
      if (name == "help" || name == "version") return std::nullopt;
      std::vector<std::string> options;
      bool known = false;
      for (const CLI::App* n = node; n != nullptr; n = n->get_parent()) {
        for (const CLI::Option* o : all_options(*n)) {
          for (const std::string& l : o->get_lnames()) {
            options.push_back("--" + l);
            known = known || l == name;
          }
        }
      }
      if (!known) {
        const std::optional<std::string> guess = closest(word.substr(0, word.find('=')), options);
        return Failure{kUsage,
                       fmt::format("unknown option '{}' for '{}'{} (see {} --help)", word, path_of(path),
                                   guess ? fmt::format(" (did you mean '{}'?)", *guess) : "", path_of(path))};
      }
      continue;
    }
    if (word.starts_with("-")) continue;  // short options and negative numbers: CLI11 decides
    const std::vector<std::string> subs = subcommand_names(*node);
    if (subs.empty()) continue;  // a positional argument of a leaf command
    if (const CLI::App* sub = find_sub(*node, word)) {
      node = sub;
      path.push_back(word);
      continue;
    }
    // A word where a command is expected. Options of the current command
    // take values, so only a word right after the command (or after another
    // command) is taken for a command name.
    if (i > 0 && args[i - 1].starts_with("-") && !args[i - 1].starts_with("--help")) continue;
    std::string list;
    for (const std::string& s : subs) list += (list.empty() ? "" : ", ") + s;
    const std::optional<std::string> guess = closest(word, subs);
    return Failure{kUsage, fmt::format("unknown command '{}'{}{} (commands: {})", word,
                                       path.empty() ? "" : fmt::format(" for '{}'", path_of(path)),
                                       guess ? fmt::format(" (did you mean '{}'?)", *guess) : "", list)};
  }
  return std::nullopt;
}

std::string mbpoll_hint(const std::vector<std::string>& args) {
  std::vector<std::string> found;
  const auto value = [&](size_t i) { return i + 1 < args.size() ? args[i + 1] : std::string("N"); };
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& w = args[i];
    if (w == "--") break;
    if (w == "-a") {
      found.push_back(fmt::format("-a {0} is --unit {0}", value(i)));
    } else if (w == "-r") {
      found.push_back(fmt::format(
          "-r {0} is the address after the command, counted from 0 (or --one-based {0})", value(i)));
    } else if (w == "-t" && i + 1 < args.size() && !args[i + 1].empty() &&
               std::string_view("0134").find(args[i + 1][0]) != std::string_view::npos &&
               (args[i + 1].size() == 1 || args[i + 1][1] == ':')) {
      // rtukit's -t is --type (u16...): mbpoll's names the table.
      static constexpr std::string_view kTables[] = {"--coils", "--discrete", "", "--input", "--holding"};
      found.push_back(fmt::format("-t {} is {}{}", args[i + 1], kTables[args[i + 1][0] - '0'],
                                  args[i + 1].size() > 1 ? " with --type u16|i16|u32|i32|f32" : ""));
    } else if (w == "-m") {
      found.push_back("-m is said by the port (--port /dev/ttyUSB0, --port tcp://HOST:502)");
    } else if (w == "-c") {
      found.push_back(fmt::format("-c {0} is the count after the address", value(i)));
    } else if (w == "-l") {
      found.push_back(fmt::format("-l {0} is `rtukit poll ... --interval {0}`", value(i)));
    } else if (w == "-1") {
      found.push_back("-1 is `rtukit read`");
    } else if (w == "-B") {
      found.push_back("-B is --word-order high-first (the default)");
    } else if (w == "-P") {
      found.push_back(fmt::format("-P {0} is --parity {0}", value(i)));
    } else if (w == "-p") {
      found.push_back(fmt::format("-p {0} is part of the port: --port tcp://HOST:{0}", value(i)));
    } else if (w == "-R") {
      found.push_back("-R is --rs485");
    } else if (w == "-o") {
      found.push_back("-o SECONDS is --timeout MILLISECONDS");
    } else if (w.starts_with("/dev/") && (i == 0 || !args[i - 1].starts_with("-"))) {
      found.push_back(fmt::format("the device is --port {}", w));
    }
  }
  if (found.empty()) return "";
  std::string text = "mbpoll's ";
  for (size_t i = 0; i < found.size(); ++i) text += (i ? "; " : "") + found[i];
  return text + " here (docs/coming-from-mbpoll.md)";
}

}  // namespace rtukit::cli
