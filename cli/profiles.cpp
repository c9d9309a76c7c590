// Commands built from device profiles: `rtukit devices`, `rtukit <device>
// registers|get|set|watch|status` for every registered device, and the same
// verbs for a map file (`rtukit map get|set|watch|status --map FILE`, `rtukit
// map check|registers FILE`). Everything a device is
// comes from its table; this file knows no device.
#include "profiles.hpp"

#include <fmt/core.h>

#include <cctype>
#include <csignal>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.hpp"
#include "common.hpp"
#include "rtukit/devices/profile/map_file.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/registry.hpp"
#include "rtukit/io/atomic_file.hpp"

namespace rtukit::cli {

using profile::Row;

namespace {

using profile::entry_name;

// The kit's selection; a bad key is a usage error.
std::vector<Selected> select_or_fail(const profile::Profile& p, std::span<const std::string> keys,
                                     bool for_write) {
  Outcome<std::vector<Selected>> selected = profile::select_rows(p, keys, for_write);
  if (!selected.ok()) throw Failure{kUsage, std::string(selected.error().reason())};
  return std::move(*selected);
}

}  // namespace

void print_values(const profile::Profile& p, UnitId unit, std::span<const ReadValue> values, bool json) {
  if (json) {
    profile::ValuesJson v = profile::values_json(values);
    Json out = json_document(p.name, unit.value);
    if (!v.ok) out["ok"] = false;
    out["values"] = std::move(v.values);
    print_json(out);
    return;
  }
  size_t width = 0;
  for (const ReadValue& v : values) width = std::max(width, entry_name(v.entry).size());
  for (const ReadValue& v : values) {
    fmt::print(
        "{:<{}} = {}\n", entry_name(v.entry), width,
        v.error ? fmt::format("error: {}", v.error.text()) : profile::format_value(*v.entry.row, v.raw));
  }
}

namespace {

struct DeviceArgs {
  LinkOptions link;
  std::string unit;
  std::vector<std::string> keys;
  std::string key;
  std::string value;
  bool json = false;
  bool yaml = false;
  std::string map_file;
  WatchOptions watch{1000};
  std::string check_docs, write_docs;  ///< `devices`: the source tree whose docs to check or rewrite
  std::map<std::string, std::string, std::less<>> verb_text;  ///< a device verb's arguments by name
  std::map<std::string, bool, std::less<>> verb_flag;
};

// Each registered device's doc, its generated sections made from the tables
// (the registry's doc_sections): checked (exit 5 when one is stale) or rewritten.
int run_docs(const std::string& root, bool write) {
  int stale = 0;
  for (const profile::DeviceEntry* e : devices::registered()) {
    if (e->doc.empty()) continue;
    const std::string path = root + "/" + std::string(e->doc);
    Outcome<std::string> text = io::read_regular_file(path, 1 << 20);
    if (!text.ok()) throw Failure{kIoError, fmt::format("{}: {}", path, text.error().reason())};
    Outcome<std::string> now = profile::regenerate_doc(*e, *text);
    if (!now.ok()) throw Failure{kUsage, fmt::format("{}: {}", path, now.error().reason())};
    if (*now == *text) {
      fmt::print("{}: up to date\n", e->doc);
    } else if (write) {
      if (rtukit::Status st = io::write_file_atomically(path, *now))
        throw Failure{kIoError, std::string(st.reason())};
      fmt::print("{}: regenerated\n", e->doc);
    } else {
      fmt::print("{}: stale: run scripts/gen-docs.sh\n", e->doc);
      ++stale;
    }
  }
  return stale ? kRefused : kOk;
}

// A verb's failure as one line and its exit code: `context` says where
// ("Inverjet unit 21 on /dev/ttyUSB0"), the device's reason what.
[[noreturn]] void verb_failed(const profile::DeviceEntry& entry, const std::string& context,
                              const rtukit::Status& e) {
  // No answer: in the device's own words when it has them.
  const bool no_answer = entry.no_answer && exit_code(e.error()) == kNoResponse;
  const std::string reason = no_answer ? entry.no_answer(e) : std::string(e.reason());
  const std::string line = context.empty() || reason.empty() ? (context.empty() ? reason : context)
                                                             : fmt::format("{}: {}", context, reason);
  if (e.code() == Errc::invalid_argument) throw Failure{kUsage, line};
  if (e.is_exception()) throw Failure{kModbusException, line};
  if (no_answer) throw Failure{kNoResponse, line};
  if (e.code() == Errc::refused) throw Failure{kRefused, line};
  fail(e.error(), line);
}

// A master on the link to a device that is what it claims: the entry's
// `identify` (the Rehand 6600's handshake) runs first, so a slave that is
// not the device is never read or written as one. A map file: no check.
std::unique_ptr<Master> device_master(const DeviceArgs& a, const profile::DeviceEntry* entry, UnitId unit) {
  auto master = a.link.make_master();
  if (entry && entry->identify) {
    if (const rtukit::Status e = entry->identify(*master, unit))
      verb_failed(*entry,
                  fmt::format("{} unit {} on {}", entry->label.empty() ? entry->profile->name : entry->label,
                              unit.value, master->describe()),
                  e);
  }
  return master;
}

int run_get(const DeviceArgs& a, const profile::Profile& p, const profile::DeviceEntry* entry = nullptr) {
  const std::vector<Selected> selected = select_or_fail(p, a.keys, false);
  const UnitId unit = device_unit(a.unit, p);
  auto master = device_master(a, entry, unit);
  const std::vector<ReadValue> values = profile::read_selected(*master, unit, selected);
  print_values(p, unit, values, a.json);
  for (const ReadValue& v : values) {
    if (!v.error) continue;
    json_requested() = false;  // the document above already says which entries failed
    fail(v.error, fmt::format("read {}", entry_name(v.entry)));
  }
  return kOk;
}

int run_set(const DeviceArgs& a, const profile::Profile& p, const profile::DeviceEntry* entry) {
  Outcome<profile::KeyWrite> w = profile::plan_key_write(p, a.key, a.value);
  if (!w)
    throw Failure{w.error().code() == Errc::refused ? kRefused : kUsage, std::string(w.error().reason())};
  const UnitId unit = device_unit(a.unit, p);
  auto master = device_master(a, entry, unit);
  const std::string name = entry_name(w->entry);
  if (const Error e = profile::write_entry(*master, unit, *w)) fail(e, fmt::format("write {}", name));
  if (a.json) {
    Json out = json_document(p.name, unit.value);
    out["values"][name] = profile::entry_json(*w->entry.row, w->raw);
    print_json(out);
  } else {
    fmt::print("{} = {}\n", name, profile::format_value(*w->entry.row, w->raw));
  }
  return kOk;
}

int run_watch(const DeviceArgs& a, const profile::Profile& p, const profile::DeviceEntry* entry) {
  const std::vector<Selected> selected = select_or_fail(p, a.keys, false);
  const UnitId unit = device_unit(a.unit, p);
  auto master = device_master(a, entry, unit);
  watch_loop(a.watch, [&](unsigned) {
    const std::vector<ReadValue> values = profile::read_selected(*master, unit, selected);
    print_values(p, unit, values, a.json);
    if (!a.json) fmt::print("\n");
    std::fflush(stdout);
  });
  return kOk;
}

void print_registers(const DeviceArgs& a, const profile::Profile& p,
                     const std::function<std::string()>& markdown) {
  if (a.json && a.yaml) throw Failure{kUsage, "choose one of --json and --yaml"};
  if (a.yaml)
    fmt::print("{}", profile::map_to_yaml(p));
  else if (a.json)
    fmt::print("{}", profile::map_to_json(p));
  else
    fmt::print("{}", markdown ? markdown() : profile::registers_markdown(p));
}

// Where a verb's device comes from: a registered device, or the map file
// its --map names (read when the command runs). Both take the same verbs,
// through the same code.
struct Source {
  const profile::DeviceEntry* entry = nullptr;  ///< nullptr: a map file

  const profile::Profile& of(const DeviceArgs& a) const {
    return entry ? *entry->profile : load_map_or_fail(a.map_file);
  }
  std::string command() const {
    return entry ? fmt::format("rtukit {}", entry->profile->name) : "rtukit map";
  }
  std::string device() const { return entry ? "" : " --map meter.yaml"; }
  // What every bus verb takes: (--map,) --unit, --json, the link.
  void add_common(CLI::App& cmd, DeviceArgs& a) const {
    if (entry) {
      cmd.add_option("--unit,-u", a.unit, device_unit_help(*entry->profile));
    } else {
      cmd.add_option("--map", a.map_file, "the device's register-map file (docs/register-maps.md)")
          ->required();
      cmd.add_option("--unit,-u", a.unit, "unit address (default: the map's)");
    }
    cmd.add_flag("--json", a.json, "print JSON (docs/json.md)");
    if (entry)
      a.link.add_to(cmd, false, profile::link_defaults(*entry->profile).baud);
    else
      a.link.add_to(cmd, false);
  }
};

// A device's status: its status rows (what it measures and reports); a
// device without any: every readable row.
int run_status(DeviceArgs a, const profile::Profile& p, const profile::DeviceEntry* entry) {
  a.keys.clear();
  for (const Row& r : p.rows)
    if (r.role == profile::Role::status && r.readable()) a.keys.emplace_back(r.key);
  return run_get(a, p, entry);
}

// The verbs every device has: get, set, watch, status. A device's own verb
// of the same name wins (the Rehand 6600's `set` goes through its host
// controller's rules; a bare register write must not).
void add_bus_verbs(CLI::App& dev, Action& action, Source source) {
  const auto has = [&dev](const char* name) {
    return !dev.get_subcommands([name](CLI::App* s) { return s->get_name() == name; }).empty();
  };
  if (!has("get"))
    add_command<DeviceArgs>(
        dev, action, "get", "read registers by name, decoded with units",
        [source](CLI::App& cmd, DeviceArgs& a) {
          cmd.add_option("keys", a.keys, "register keys (see `registers`); none: every readable register");
          source.add_common(cmd, a);
          examples(cmd, {fmt::format("{} get --port /dev/ttyUSB0{}", source.command(), source.device()),
                         fmt::format("{} get --port /dev/ttyUSB0{} KEY --json", source.command(),
                                     source.device())});
        },
        [source](const DeviceArgs& a) { return run_get(a, source.of(a), source.entry); });
  if (!has("set"))
    add_command<DeviceArgs>(
        dev, action, "set", "write one register by name (value with unit, name or mm:ss)",
        [source](CLI::App& cmd, DeviceArgs& a) {
          cmd.add_option("key", a.key, "register key (key[i] for an entry of a block)")->required();
          cmd.add_option("value", a.value, "the value: 80, 80%, outdoor, 30:00, 0x1F")->required();
          source.add_common(cmd, a);
          examples(cmd,
                   {fmt::format("{} set --port /dev/ttyUSB0{} KEY VALUE", source.command(), source.device()),
                    "values as people write them: 80, 80%, outdoor, 30:00, 0x1F; a link-address row "
                    "(address 5): the device answers at 5 from then on"});
        },
        [source](const DeviceArgs& a) { return run_set(a, source.of(a), source.entry); });
  if (!has("watch"))
    add_command<DeviceArgs>(
        dev, action, "watch", "poll registers by name until Ctrl-C",
        [source](CLI::App& cmd, DeviceArgs& a) {
          cmd.add_option("keys", a.keys, "register keys; none: every readable register");
          a.watch.add_to(cmd);
          source.add_common(cmd, a);
          examples(cmd, {fmt::format("{} watch --port /dev/ttyUSB0{} --interval 2000", source.command(),
                                     source.device())});
        },
        [source](const DeviceArgs& a) { return run_watch(a, source.of(a), source.entry); });
  if (!has("status"))
    add_command<DeviceArgs>(
        dev, action, "status", "read what the device reports (its status registers)",
        [source](CLI::App& cmd, DeviceArgs& a) {
          source.add_common(cmd, a);
          examples(cmd, {fmt::format("{} status --port /dev/ttyUSB0{}", source.command(), source.device()),
                         fmt::format("{} status --port /dev/ttyUSB0{} --json", source.command(),
                                     source.device())});
        },
        [source](const DeviceArgs& a) { return run_status(a, source.of(a), source.entry); });
}

// A device's own verb (profile/verb.hpp): the device checks the arguments,
// opens the link through `open` when it needs it, and says what it did; this
// prints it (a live verb: each refresh, as every watch does), or turns its
// refusal into one line and the exit code.
int run_device_verb(const DeviceArgs& a, const CLI::App& cmd, const profile::DeviceEntry& entry,
                    const profile::Verb& verb) {
  profile::VerbArgs args;
  for (const profile::VerbArg& v : verb.args) {
    const std::string name(v.name);
    if (v.form == profile::VerbArg::Form::flag) {
      if (a.verb_flag.at(name)) args[name] = "true";
    } else if (cmd.count(v.form == profile::VerbArg::Form::positional ? name : "--" + name) > 0) {
      args[name] = a.verb_text.at(name);
    }
  }
  const profile::Profile& p = *entry.profile;
  const UnitId unit = device_unit(a.unit, p);
  std::unique_ptr<Master> master;
  struct StatsAtEnd {  // --stats: the master's counters, however the verb ends
    const std::unique_ptr<Master>& master;
    bool wanted;
    ~StatsAtEnd() {
      if (master && wanted) print_stats(*master);
    }
  } stats{master, a.link.stats};
  std::string context;
  const auto name_link = [&](std::string_view port) {
    context = fmt::format("{} unit {} on {}", entry.label.empty() ? p.name : entry.label, unit.value, port);
  };
  // A lasting verb (a hold) gets Ctrl-C from the start, to end as it must.
  std::optional<Interruptible> interrupt;
  if (verb.lasting) interrupt.emplace(time_source());
  std::optional<Progress> progress;
  profile::VerbContext where{.unit = unit,
                             .open = [&]() -> Master& {
                               master = a.link.make_master();
                               name_link(master->describe());
                               return *master;
                             },
                             .open_link =
                                 [&] {
                                   auto link = io::make_link(a.link.spec(false));
                                   name_link(link->describe());
                                   return link;
                                 },
                             .response_timeout = std::chrono::milliseconds(a.link.timeout_ms),
                             .trace = a.link.tracer(),
                             .alert = [](std::string_view t) { return LivePanel::alert(t); },
                             .clock = &time_source(),
                             .wait =
                                 [&](std::chrono::milliseconds d) {
                                   if (!interrupt) interrupt.emplace(time_source());
                                   return interrupt->sleep(d);
                                 },
                             .progress =
                                 [&](std::string_view t) {
                                   if (!progress) progress.emplace();
                                   t.empty() ? progress->clear() : progress->show(t);
                                 }};
  Outcome<profile::VerbResult> r = entry.run_verb(verb, args, where);
  if (!r.ok()) verb_failed(entry, context, r.error());
  if (r->refresh) {
    watch_view(a.watch, a.json, p.name, where.unit, context, [&](unsigned n) {
      Outcome<profile::LiveFrame> f = r->refresh(n);
      if (!f.ok()) verb_failed(entry, context, f.error());
      return std::move(*f);
    });
    return kOk;
  }
  // Cut short (Ctrl-C, SIGTERM, SIGHUP): 128 + the signal, 130 for Ctrl-C.
  const int sig = r->interrupted && interrupt ? interrupt->signal() : 0;
  const int code = sig == 0 || sig == SIGPIPE ? kOk : 128 + sig;
  if (!a.json) {
    fmt::print("{}\n", r->text);
    if (!r->more.empty()) fmt::print("{}\n", r->more);
    return code;
  }
  Json out = json_document(p.name, verb.uses_link ? where.unit.value : -1);
  if (!r->action.empty() || (r->values.is_null() && r->extra.is_null())) {
    if (!r->action.empty()) out["action"] = r->action;
    out["text"] = r->text;
  }
  if (!r->values.is_null()) out["values"] = r->values;
  if (r->extra.is_object())
    for (const auto& [key, value] : r->extra.items()) out[key] = value;
  print_json(out);
  return code;
}

void add_own_verbs(CLI::App& dev, Action& action, const profile::DeviceEntry& entry) {
  for (const profile::Verb& verb : entry.verbs) {
    // "plan show": the verb `show` in the group `plan`.
    CLI::App* parent = &dev;
    std::string_view name = verb.name;
    if (const size_t space = name.find(' '); space != std::string_view::npos) {
      const std::string group(name.substr(0, space));
      parent = dev.get_subcommands([&group](CLI::App* s) { return s->get_name() == group; }).empty()
                   ? dev.add_subcommand(group, fmt::format("{} ...", group))
                   : dev.get_subcommand(group);
      parent->require_subcommand(1);
      name = name.substr(space + 1);
    }
    const std::string label = fmt::format("rtukit {} {}", entry.profile->name, verb.name);
    add_command<DeviceArgs>(
        *parent, action, std::string(name), verb.help,
        [&entry, &verb, label](CLI::App& cmd, DeviceArgs& a) {
          for (const profile::VerbArg& v : verb.args) {
            const std::string key(v.name);
            std::string help = v.help;
            if (!v.fallback.empty()) help += fmt::format(" (default {})", v.fallback);
            if (v.form == profile::VerbArg::Form::flag) {
              cmd.add_flag("--" + key, a.verb_flag[key], help);
            } else if (v.form == profile::VerbArg::Form::positional) {
              std::string shown;
              for (const char c : key)
                shown += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
              CLI::Option* o = cmd.add_option(key, a.verb_text[key], help);
              o->option_text(shown);
              if (v.required) o->required();
            } else {
              cmd.add_option("--" + key, a.verb_text[key], help);
            }
          }
          if (verb.live_interval_ms != 0) {
            a.watch.interval_ms = verb.live_interval_ms;
            a.watch.add_to(cmd);
          }
          if (verb.uses_link) {
            a.link.timeout_ms = entry.answer_timeout_ms;
            cmd.add_option("--unit,-u", a.unit, device_unit_help(*entry.profile));
            a.link.add_to(cmd, false, profile::link_defaults(*entry.profile).baud);
          }
          cmd.add_flag("--json", a.json,
                       verb.reads ? "print JSON (docs/json.md)" : "print the result as JSON (docs/json.md)");
          std::vector<std::string> lines;
          for (std::string_view e : verb.examples) {
            std::string line = label + " " + std::string(e);
            if (const size_t at = line.find("{port}"); at != std::string::npos)
              line.replace(at, 6, fmt::format("--port {}", entry.example_port));
            lines.push_back(line);
          }
          std::vector<std::string_view> views(lines.begin(), lines.end());
          examples(cmd, views);
        },
        [&entry, &verb](const DeviceArgs& a, const CLI::App& cmd) {
          return run_device_verb(a, cmd, entry, verb);
        });
  }
}

void add_device_verbs(CLI::App& dev, Action& action, const profile::DeviceEntry& entry) {
  add_own_verbs(dev, action, entry);
  const auto has = [&dev](const char* name) {
    return !dev.get_subcommands([name](CLI::App* s) { return s->get_name() == name; }).empty();
  };
  if (!has("registers"))
    add_command<DeviceArgs>(
        dev, action, "registers", "the register reference (Markdown; --json or --yaml: the map file)",
        [&entry](CLI::App& cmd, DeviceArgs& a) {
          cmd.add_flag("--json", a.json, "the profile as a JSON map file");
          cmd.add_flag("--yaml", a.yaml,
                       "the profile as a YAML map file (rtukit sim map / read --map take it)");
          examples(cmd, {fmt::format("rtukit {} registers", entry.profile->name),
                         fmt::format("rtukit {} registers --yaml > {}.yaml", entry.profile->name,
                                     entry.profile->name)});
        },
        [&entry](const DeviceArgs& a) {
          print_registers(a, *entry.profile, entry.markdown);
          return int{kOk};
        });
  add_bus_verbs(dev, action, Source{&entry});
}

}  // namespace

const profile::Profile& load_map_or_fail(const std::string& path) {
  static std::vector<std::unique_ptr<profile::MapProfile>> loaded;  // live until exit
  Outcome<std::unique_ptr<profile::MapProfile>> map = profile::load_map(path);
  if (!map.ok())
    throw Failure{map.error().code() == Errc::io_error ? kIoError : kUsage,
                  std::string(map.error().reason())};
  loaded.push_back(std::move(*map));
  return loaded.back()->profile();
}

void add_profile_commands(CLI::App& app, Action& action) {
  {
    add_command<DeviceArgs>(
        app, action, "devices", "the device profiles this rtukit knows",
        [](CLI::App& cmd, DeviceArgs& a) {
          cmd.add_flag("--json", a.json, "print JSON (docs/json.md)");
          cmd.add_option("--check-docs", a.check_docs,
                         "check each device's doc under this source tree: exit 5 when a generated "
                         "section is stale");
          cmd.add_option("--write-docs", a.write_docs,
                         "rewrite each device's generated doc sections under this source tree");
          examples(cmd, {"rtukit devices", "rtukit devices --json", "rtukit devices --check-docs ."});
        },
        [](const DeviceArgs& a) {
          if (!a.check_docs.empty() || !a.write_docs.empty())
            return run_docs(a.write_docs.empty() ? a.check_docs : a.write_docs, !a.write_docs.empty());
          const bool* json = &a.json;
          Json list = Json::array();
          for (const profile::DeviceEntry* e : devices::registered()) {
            const profile::Profile& p = *e->profile;
            const profile::LinkDefaults link = profile::link_defaults(p);
            if (*json) {
              list.push_back({{"name", p.name},
                              {"title", p.title},
                              {"unit", link.unit},
                              {"baud", link.baud},
                              {"parity", std::string(1, link.parity)},
                              {"registers", p.rows.size()}});
            } else {
              fmt::print("{:<12} {} (unit {}, {} {}{}{})\n", p.name, p.title, link.unit, link.baud, 8,
                         link.parity, link.stop_bits);
            }
          }
          if (*json) {
            Json out = json_document();
            out["devices"] = std::move(list);
            print_json(out);
          } else
            fmt::print(
                "any other device: a register-map file (rtukit map check FILE; docs/register-maps.md)\n");
          return int{kOk};
        });
  }
  for (const profile::DeviceEntry* e : devices::registered()) {
    const profile::DeviceEntry& entry = *e;
    const std::string name(entry.profile->name);
    CLI::App* dev = app.get_subcommands([&name](CLI::App* s) { return s->get_name() == name; }).empty()
                        ? app.add_subcommand(name, std::string(entry.profile->title))
                        : app.get_subcommand(name);
    dev->require_subcommand(1);
    add_device_verbs(*dev, action, entry);
  }
  auto* map = app.add_subcommand("map", "register-map files: any Modbus device described in YAML or JSON");
  map->require_subcommand(1);
  add_command<DeviceArgs>(
      *map, action, "check", "validate a map file (errors name the line)",
      [](CLI::App& cmd, DeviceArgs& a) {
        cmd.add_option("file", a.map_file, "the map file")->required();
        cmd.add_flag("--json", a.json, "print the result as JSON (docs/json.md)");
        examples(cmd, {"rtukit map check examples/maps/energy-meter.yaml"});
      },
      [](const DeviceArgs& a) {
        const profile::Profile& p = load_map_or_fail(a.map_file);
        size_t entries = 0;
        for (const Row& r : p.rows) entries += r.repeat;
        if (a.json) {
          Json out = json_document(p.name);
          out["file"] = a.map_file;
          out["registers"] = entries;
          out["rows"] = p.rows.size();
          print_json(out);
        } else {
          fmt::print("{}: ok: device '{}', {} registers in {} rows\n", a.map_file, p.name, entries,
                     p.rows.size());
        }
        return int{kOk};
      });
  add_command<DeviceArgs>(
      *map, action, "registers", "print a map file's register reference (Markdown, --json, --yaml)",
      [](CLI::App& cmd, DeviceArgs& a) {
        cmd.add_option("file", a.map_file, "the map file")->required();
        cmd.add_flag("--json", a.json, "as JSON");
        cmd.add_flag("--yaml", a.yaml, "as YAML");
        examples(cmd, {"rtukit map registers examples/maps/energy-meter.yaml"});
      },
      [](const DeviceArgs& a) {
        print_registers(a, load_map_or_fail(a.map_file), {});
        return int{kOk};
      });
  add_bus_verbs(*map, action, Source{});
}

int run_map_read(const LinkOptions& link, const std::string& unit, const std::string& map_file,
                 std::span<const std::string> keys, bool json) {
  const profile::Profile& p = load_map_or_fail(map_file);
  DeviceArgs a;
  a.link = link;
  a.unit = unit;
  a.keys.assign(keys.begin(), keys.end());
  a.json = json;
  return run_get(a, p);
}

}  // namespace rtukit::cli
