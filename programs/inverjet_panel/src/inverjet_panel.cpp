// The pool panel: a bus thread (polls, commands, history) and the web
// thread (pages). Commands cross from the web thread to the bus thread in a
// queue; states, samples and results cross back with Server::post.
#include "rtukit/programs/inverjet_panel.hpp"

#include <fmt/core.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/programs/inverjet_bridge.hpp"
#include "rtukit/web/assets.hpp"
#include "rtukit/web/server.hpp"

namespace rtukit::programs {
namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;
namespace ij = inverjet;

constexpr size_t kHistory = 2 * 60 * 60 * 2;  // two hours at 2 Hz

struct Job {
  uint64_t socket = 0;
  Json message;
};

}  // namespace

struct Panel::Impl {
  Impl(std::unique_ptr<io::Link> link, PanelOptions o)
      : options(std::move(o)),
        master(std::move(link),
               MasterOptions{.response_timeout = std::chrono::milliseconds(options.response_timeout_ms)}),
        client(master, UnitId{options.unit}),
        server(web::ServerOptions{.listen = {web::Listener::from(options.http)}}, handlers()) {}

  PanelOptions options;
  Master master;
  ij::Client client;
  web::Server server;

  // Bus thread <- web thread.
  std::mutex mutex;
  std::condition_variable wake;
  std::deque<Job> jobs;
  bool stopping = false;
  std::thread thread;

  // Web thread only.
  std::map<uint64_t, web::SocketPtr> sockets;
  std::string last_state;
  std::vector<Json> history;
  std::string plans;

  web::Handlers handlers() {
    web::Handlers h;
    h.http = [](const web::HttpRequest& r) -> web::HttpResponse {
      const std::string path = r.path == "/" ? "/inverjet/panel.html" : r.path;
      if (auto a = web::asset_response(path)) return *a;
      return {.status = 404, .content_type = "text/plain; charset=utf-8", .body = "not found\n"};
    };
    h.upgrade = [](const web::HttpRequest& r) -> std::optional<web::HttpResponse> {
      if (r.path != "/ws") return web::HttpResponse{.status = 404, .body = R"({"error":"no such endpoint"})"};
      return std::nullopt;
    };
    h.opened = [this](const web::SocketPtr& s) {
      sockets[s->id()] = s;
      if (!last_state.empty()) s->send(last_state);
      s->send(Json{{"type", "history"}, {"samples", history}}.dump());
      if (!plans.empty()) s->send(plans);
    };
    h.closed = [this](const web::SocketPtr& s) { sockets.erase(s->id()); };
    h.message = [this](const web::SocketPtr& s, std::string_view text) {
      Json m = Json::parse(text, nullptr, false);
      if (m.is_discarded() || !m.is_object() || !m.contains("op") || !m["op"].is_string()) {
        s->send(Json{{"type", "error"}, {"error", "expected a JSON object with \"op\""}}.dump());
        return;
      }
      std::lock_guard lock(mutex);
      if (jobs.size() >= 16) {  // a page that floods the bus waits for nobody: refused
        s->send(Json{{"type", "result"},
                     {"op", m["op"]},
                     {"id", m.value("id", Json())},
                     {"ok", false},
                     {"error", "busy: too many commands waiting"}}
                    .dump());
        return;
      }
      jobs.push_back({s->id(), std::move(m)});
      wake.notify_all();
    };
    return h;
  }

  // ---------------------------------------------------------- web thread

  void broadcast(const std::string& text) {
    for (auto& [id, s] : sockets) s->send(text);
  }

  // ---------------------------------------------------------- bus thread

  Json read_plans() {
    Json all = Json::array();
    for (unsigned p = 1; p <= 4; ++p) {
      Outcome<std::vector<ij::Segment>> segments = client.read_plan(p);
      Json list = Json::array();
      if (segments)
        for (const ij::Segment& s : *segments) list.push_back({{"speed", s.speed}, {"end", s.end}});
      all.push_back(list);
    }
    return Json{{"type", "plans"}, {"plans", all}};
  }

  void run_job(const Job& job, bool& poll_now) {
    const Json& m = job.message;
    const std::string op = m["op"].get<std::string>();
    Json result{{"type", "result"}, {"op", op}};
    if (m.contains("id")) result["id"] = m["id"];
    rtukit::Status e;
    if (op == "plans") {
      Json p = read_plans();
      server.post([this, text = p.dump()] {
        plans = text;
        broadcast(text);
      });
    } else {
      e = inverjet_command(client, op, m, result);
      if (!e && op == "plan") {
        Json p = read_plans();  // read back what the machine stored
        server.post([this, text = p.dump()] {
          plans = text;
          broadcast(text);
        });
      }
    }
    result["ok"] = !e;
    if (e)
      result["error"] = e.is_exception() ? fmt::format("Modbus exception {:02X} ({}): {}",
                                                       e.error().exception_code(), e.name(), e.reason())
                                         : std::string(e.reason());
    server.post([this, socket = job.socket, text = result.dump()] {
      if (auto it = sockets.find(socket); it != sockets.end()) it->second->send(text);
    });
    poll_now = true;
  }

  void run() {
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options.poll_hz));
    const auto began = Clock::now();
    Clock::time_point next_poll = began;
    bool plans_read = false;
    bool running_before = false;
    bool online = false;
    unsigned failures = 0;
    for (;;) {
      std::deque<Job> todo;
      {
        std::unique_lock lock(mutex);
        wake.wait_until(lock, next_poll, [this] { return stopping || !jobs.empty(); });
        if (stopping) return;
        todo.swap(jobs);
      }
      bool poll_now = false;
      for (const Job& j : todo) run_job(j, poll_now);
      if (!poll_now && Clock::now() < next_poll) continue;
      next_poll = Clock::now() + period;
      const Result<ij::MachineStatus> s = client.status();
      if (!s) {
        if (++failures >= 2 && online) {
          online = false;
          server.post([this] {
            Json st = last_state.empty() ? Json{{"type", "state"}} : Json::parse(last_state);
            st["online"] = false;
            last_state = st.dump();
            broadcast(last_state);
          });
        }
        next_poll = Clock::now() + std::min<Clock::duration>(period * (1u << std::min(failures, 3u)),
                                                             std::chrono::seconds(4));
        continue;
      }
      failures = 0;
      online = true;
      if (!plans_read) {
        plans_read = true;
        Json p = read_plans();
        server.post([this, text = p.dump()] {
          plans = text;
          broadcast(text);
        });
      }
      Json st = machine_state_json(*s);
      st["type"] = "state";
      st["online"] = true;
      const bool running = s->phase() == ij::Phase::running || s->phase() == ij::Phase::starting ||
                           s->phase() == ij::Phase::paused;
      const bool new_run = running && !running_before;
      running_before = running;
      Json sample{{"type", "sample"},
                  {"t", std::chrono::duration<double>(Clock::now() - began).count()},
                  {"speed", s->phase() == ij::Phase::running ? s->speed : 0},
                  {"current_a", s->current_a},
                  {"mosfet_c", s->mosfet_c},
                  {"motor_c", s->motor_c}};
      server.post([this, text = st.dump(), sample = std::move(sample), new_run, running] {
        if (new_run) {
          history.clear();  // a new run: new charts
          broadcast(Json{{"type", "history"}, {"samples", history}}.dump());
        }
        if (running) {  // the run's samples; kept after it ends, for a look back
          if (history.size() >= kHistory) history.erase(history.begin());
          history.push_back(sample);
          broadcast(sample.dump());
        }
        if (text != last_state) {
          last_state = text;
          broadcast(text);
        }
      });
    }
  }
};

Panel::Panel(std::unique_ptr<io::Link> link, PanelOptions options)
    : impl_(std::make_unique<Impl>(std::move(link), std::move(options))) {}

Panel::~Panel() {
  stop();
}

rtukit::Status Panel::start() {
  if (rtukit::Status e = impl_->server.start()) return e;
  impl_->thread = std::thread([this] { impl_->run(); });
  return {};
}

void Panel::stop() {
  Impl& p = *impl_;
  if (!p.thread.joinable()) return;
  {
    std::lock_guard lock(p.mutex);
    p.stopping = true;
  }
  p.wake.notify_all();
  p.thread.join();
  p.server.stop();
}

std::string Panel::url() const {
  return web::url_of(impl_->options.http, impl_->server.ports().at(0));
}

}  // namespace rtukit::programs
