// The one simulator runtime. A device brings its model and its console
// verbs; everything else (time, ticking, link changes after the response,
// the state file, the built-in console verbs) is here, once.
#include "rtukit/devices/profile/sim_host.hpp"

#include <fmt/core.h>

#include <algorithm>

#include "rtukit/devices/profile/device.hpp"
#include "rtukit/devices/profile/state_file.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/io/asio.hpp"

namespace rtukit::profile {

// The model as the engine sees it: every request first brings the model to
// the device time, and the response's departure is reported back.
struct SimHost::Bank final : RegisterBank {
  SimHost& host;
  explicit Bank(SimHost& h) : host(h) {}
  Model& m() { return *host.device_.model; }
  void sync() { m().advance_to(host.device_ms()); }

  FunctionSet functions() const noexcept override { return host.device_.model->functions(); }
  FrameQuirks quirks() const noexcept override { return host.device_.model->quirks(); }
  Errc read_coils(uint16_t a, uint16_t n, std::span<uint8_t> out) override {
    sync();
    return m().read_coils(a, n, out);
  }
  Errc read_discrete_inputs(uint16_t a, uint16_t n, std::span<uint8_t> out) override {
    sync();
    return m().read_discrete_inputs(a, n, out);
  }
  Errc read_holding_registers(uint16_t a, std::span<uint16_t> out) override {
    sync();
    return m().read_holding_registers(a, out);
  }
  Errc read_input_registers(uint16_t a, std::span<uint16_t> out) override {
    sync();
    return m().read_input_registers(a, out);
  }
  Errc write_coils(uint16_t a, uint16_t n, std::span<const uint8_t> packed) override {
    sync();
    return m().write_coils(a, n, packed);
  }
  Errc write_holding_registers(uint16_t a, std::span<const uint16_t> values) override {
    sync();
    return m().write_holding_registers(a, values);
  }
  uint8_t exception_status() override {
    sync();
    return m().exception_status();
  }
  std::string_view device_object(uint8_t id) override {
    sync();
    return m().device_object(id);
  }
  void after_response() override {
    m().after_response();
    host.after_response();
  }
};

namespace {

// The persisted words of an image, to notice a change after a request.
std::vector<uint16_t> persisted_words(const Image& image) {
  std::vector<uint16_t> out;
  const RegisterMap& map = image.map();
  for (const Row& r : map.rows()) {
    if (!r.has(kPersisted)) continue;
    const size_t first = map.slot_of(r);
    const size_t n = size_t{r.repeat} * r.words();
    out.insert(out.end(), image.words().begin() + static_cast<ptrdiff_t>(first),
               image.words().begin() + static_cast<ptrdiff_t>(first + n));
  }
  return out;
}

}  // namespace

SimHost::SimHost(SimDevice device, SimOptions options)
    : device_(std::move(device)),
      options_(std::move(options)),
      clock_(options_.time_scale, clock_or_steady(options_.clock)) {}

SimHost::~SimHost() = default;

Outcome<std::unique_ptr<SimHost>> SimHost::start(asio::io_context& ctx, SimDevice device,
                                                 SimOptions options) {
  if (!device.model) return Status(Errc::invalid_argument, "no device model");
  if (!DeviceClock::valid_scale(options.time_scale))
    return Status(Errc::invalid_argument, "--time-scale must be > 0 (and at most 100000)");
  const Profile& profile = device.model->profile();
  const UnitRange units = unit_range(profile);
  if (options.unit && !units.contains(*options.unit))
    return Status(Errc::invalid_argument,
                  fmt::format("the {}'s address is {}..{}", profile.name, units.min, units.max));

  std::unique_ptr<SimHost> host(new SimHost(std::move(device), std::move(options)));
  Model& model = *host->device_.model;
  SimOptions& o = host->options_;
  const auto notice = [&o](const std::string& line) {
    if (o.notice) o.notice(line);
  };

  bool loaded_from_file = false;
  if (!o.state_file.empty()) {
    const LoadedState loaded = load_state(o.state_file, profile, model.image());
    if (loaded.foreign && !o.force_state)
      return Status(Errc::refused, loaded.warning +
                                       ": it is left untouched; choose another --state-file, or "
                                       "--force-state to replace it");
    if (loaded.foreign)
      notice("warning: " + loaded.warning + "; replacing it (--force-state)");
    else if (!loaded.warning.empty())
      notice("warning: " + loaded.warning);
    loaded_from_file = loaded.from_file;
    model.restored();
  }
  const std::vector<uint16_t> stored = persisted_words(model.image());
  if (o.unit || o.baud) {
    if (model.override_link(o.unit, o.baud)) {
      // Only a baud rate the link-baud row cannot hold gets here (the unit
      // was checked above): name the rates it can.
      std::string rates;
      if (const Row* r = row_with(profile, kLinkBaud)) {
        for (const Named& n : r->names) rates += (rates.empty() ? "" : ", ") + std::string(n.name);
      }
      return Status(Errc::invalid_argument, fmt::format("the {} runs at {} baud", profile.name,
                                                        rates.empty() ? std::string("other rates") : rates));
    }
  }
  const LinkDefaults link = model.stored_link();
  host->unit_ = o.unit.value_or(link.unit);
  // The link runs at the device's baud rate unless the command line chose one.
  o.listen.serial.baud = o.baud.value_or(link.baud);
  host->saved_ = persisted_words(model.image());
  // First start (no file yet) or options that changed what is stored: write it now.
  if (!o.state_file.empty() && (!loaded_from_file || stored != host->saved_)) {
    if (const Status s = save_state(o.state_file, profile, model.image()))
      notice(fmt::format("warning: state not saved: {}", s.reason()));
  }

  host->bank_ = std::make_unique<Bank>(*host);
  if (const Error e = host->engine_.add_unit(UnitId{host->unit_}, *host->bank_))
    return Status(e, "cannot host that unit address");
  ServerOptions server = o.server;
  if (!server.notice && o.notice) server.notice = o.notice;
  auto listener = SlaveListener::start(ctx, host->engine_, o.listen, o.log, std::move(server));
  if (!listener.ok()) return listener.error();
  host->listener_ = std::move(*listener);
  // Advance the model regularly, so a timer ends (and a watchdog trips) even
  // when nobody polls.
  SimHost* self = host.get();
  host->ticker_ = std::make_unique<PeriodicTimer>(
      ctx, o.tick, [self] { self->device_.model->advance_to(self->device_ms()); });
  return host;
}

std::string SimHost::banner() const {
  const Profile& p = device_.model->profile();
  return fmt::format("{} simulator: unit {}, {} baud, time x{:g}, state {}{}\nlistening on {}", p.title,
                     unit_, baud(), options_.time_scale,
                     options_.state_file.empty() ? "not saved" : options_.state_file, device_.banner,
                     where());
}

std::string SimHost::where() const {
  return listener_->where();
}

Model& SimHost::model() {
  device_.model->advance_to(device_ms());
  return *device_.model;
}

// The response to the write went out with the old address and rate; now
// the device moves.
void SimHost::after_response() {
  const LinkChange change = device_.model->take_link_change();
  const auto notice = [this](const std::string& line) {
    if (options_.notice) options_.notice(line);
  };
  if (change.address && *change.address != unit_) {
    if (!engine_.change_unit_address(UnitId{unit_}, UnitId{*change.address})) {
      notice(fmt::format("address changed: {} -> {}", unit_, *change.address));
      unit_ = *change.address;
    }
  }
  if (change.baud) {
    const Error e = listener_->set_baud(*change.baud);
    if (!e) options_.listen.serial.baud = *change.baud;
    notice(e ? fmt::format("cannot switch to {} baud: {}", *change.baud, e.name())
             : fmt::format("baud rate changed to {}", *change.baud));
  }
  save_if_changed();
}

void SimHost::save_if_changed() {
  std::vector<uint16_t> now = persisted_words(device_.model->image());
  if (now == saved_) return;
  saved_ = std::move(now);
  if (options_.state_file.empty()) return;
  if (const Status s = save_state(options_.state_file, device_.model->profile(), device_.model->image());
      s && options_.notice)
    options_.notice(fmt::format("warning: state not saved: {}", s.reason()));
}

std::string SimHost::help() const {
  struct Line {
    std::string_view usage, help;
  };
  std::vector<Line> lines = {
      {"status", "print the device"},
      {"get KEY...", "read registers by name, decoded (see 'registers')"},
      {"registers", "list the register keys"},
  };
  for (const ConsoleVerb& v : device_.verbs) lines.push_back({v.usage, v.help});
  lines.push_back({"help", "this list"});
  lines.push_back({"quit", "stop the simulator"});
  size_t width = 0;
  for (const Line& l : lines) width = std::max(width, l.usage.size());
  std::string out = "commands:\n";
  for (const Line& l : lines) out += fmt::format("  {:<{}}  {}\n", l.usage, width, l.help);
  return out;
}

std::string SimHost::command(std::string_view line) {
  const std::vector<std::string> words = split_words(line);
  if (words.empty()) return {};
  Model& m = model();
  const std::string& verb = words[0];
  const std::span<const std::string> args(words.data() + 1, words.size() - 1);
  if (verb == "help" || verb == "?") return help();
  if (verb == "quit" || verb == "exit") {
    quit_ = true;
    return "bye";
  }
  if (verb == "status") {
    std::string out =
        fmt::format("device time {} (x{:g})\n", format_mm_ss(static_cast<unsigned>(device_ms() / 1000)),
                    options_.time_scale);
    for (const Row& r : m.map().rows()) {
      if (r.repeat > 1 || !r.readable()) continue;
      std::array<uint16_t, 2> w{};
      if (m.read(r.space, r.address, std::span<uint16_t>(w.data(), r.words())) != Errc::ok) continue;
      out += fmt::format("  {:<32} {}\n", r.title, format_value(r, RegisterMap::decode(r, w)));
    }
    if (device_.status_extra) out += device_.status_extra();
    return out;
  }
  if (verb == "registers") {
    std::string out;
    for (const Row& r : m.map().rows()) out += fmt::format("  {:<24} {}\n", r.key, r.title);
    return out;
  }
  if (verb == "get") {
    if (args.empty()) return "usage: get KEY... (see 'registers')";
    std::string out;
    for (const std::string& key : args) {
      const Row* r = find_row(m.map(), key);
      if (!r) {
        const Row* near = nearest_row(m.map(), key);
        return fmt::format("error: no register '{}'{} (see 'registers')", key,
                           near ? fmt::format(": did you mean '{}'?", near->key) : std::string());
      }
      // The device's view, not a bus read: write-only rows show what is stored.
      for (unsigned i = 0; i < std::min<unsigned>(r->repeat, 8); ++i) {
        const std::string name = r->repeat > 1 ? fmt::format("{}[{}]", r->key, i) : std::string(r->key);
        out += fmt::format("{} = {}\n", name, format_value(*r, m.image().get(*r, i)));
      }
      if (r->repeat > 8) out += fmt::format("{}[8..{}] ...\n", r->key, r->repeat - 1);
    }
    return out;
  }
  for (const ConsoleVerb& v : device_.verbs) {
    if (v.verb != verb) continue;
    Outcome<std::string> reply = v.run(args);
    // A console verb may change persisted rows (a device's own flash).
    save_if_changed();
    if (!reply.ok()) return fmt::format("error: {}", reply.error().reason());
    return *reply;
  }
  return fmt::format("unknown command '{}' (try help)", verb);
}

}  // namespace rtukit::profile

namespace rtukit::profile {

std::string_view setting(const SimSettings& settings, std::span<const SimOption> options,
                         std::string_view name) {
  if (const auto it = settings.find(name); it != settings.end()) return it->second;
  for (const SimOption& o : options)
    if (o.name == name) return o.default_value;
  return {};
}

}  // namespace rtukit::profile
