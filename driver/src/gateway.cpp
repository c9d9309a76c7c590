#include "rtukit/driver/gateway.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <tuple>

#include "rtukit/core/mbap.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/driver/bus_worker.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/now.hpp"
#include "tcp_sessions.hpp"

namespace rtukit {

bool gateway_counts_as_write(uint8_t function) {
  return function == fc(Function::write_single_coil) || function == fc(Function::write_single_register) ||
         function == fc(Function::write_multiple_coils) ||
         function == fc(Function::write_multiple_registers) ||
         function == fc(Function::mask_write_register) ||
         function == fc(Function::read_write_multiple_registers);  // it writes before it reads
}

bool relays_when_read_only(const Request& r) {
  switch (r.function) {
    case fc(Function::read_coils):
    case fc(Function::read_discrete_inputs):
    case fc(Function::read_holding_registers):
    case fc(Function::read_input_registers):
    case fc(Function::get_comm_event_counter):
    case fc(Function::get_comm_event_log):
    case fc(Function::report_server_id):
      return true;
    case fc(Function::diagnostics):
      // Echo, the diagnostic register and the counters it reads (0B bus
      // messages .. 12 character overruns). Not: 01 restart, 03 ASCII
      // delimiter, 04 listen-only, 0A and 14 clears, anything unknown.
      return r.sub_function == static_cast<uint16_t>(Diagnostic::return_query_data) ||
             r.sub_function == static_cast<uint16_t>(Diagnostic::return_diagnostic_register) ||
             (r.sub_function >= static_cast<uint16_t>(Diagnostic::bus_message_count) &&
              r.sub_function <= static_cast<uint16_t>(Diagnostic::bus_character_overrun_count));
    case fc(Function::encapsulated_interface):
      return r.mei_type == kMeiDeviceIdentification;  // 2B/0E only, not 0D (CANopen) or others
    default:
      // Writes (05, 06, 0F, 10, 16, 17), 07, file records, anything not
      // listed, including a function added later: refused until someone
      // decides it reads only.
      return false;
  }
}

namespace {

bool is_write(uint8_t function) {
  return gateway_counts_as_write(function);
}

bool is_read(uint8_t function) {
  return function >= fc(Function::read_coils) && function <= fc(Function::read_input_registers);
}

// The read that a write may change: coils for FC05/0F, holding registers for FC06/10.
uint8_t read_function_changed_by(uint8_t write_function) {
  return write_function == fc(Function::write_single_coil) ||
                 write_function == fc(Function::write_multiple_coils)
             ? fc(Function::read_coils)
             : fc(Function::read_holding_registers);
}

std::vector<uint8_t> exception_pdu(uint8_t function, Errc e) {
  return {static_cast<uint8_t>(function | 0x80), static_cast<uint8_t>(e)};
}

// The response PDU in its standard form (a device quirk on the serial side,
// like the Rehand's 2-byte byte count, does not travel to TCP clients).
std::vector<uint8_t> response_pdu(const Request& req, const Response& r) {
  std::vector<uint8_t> out{r.function};
  if (!r.body.empty()) {
    // Diagnostics and identification: the response's fields as they came.
    out.insert(out.end(), r.body.begin(), r.body.end());
  } else if (r.function == fc(Function::mask_write_register)) {
    for (const uint16_t v : {req.address, req.and_mask, req.or_mask})
      out.insert(out.end(), {static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v)});
  } else if (is_read(r.function) || r.function == fc(Function::read_write_multiple_registers)) {
    out.push_back(static_cast<uint8_t>(r.data.size()));
    out.insert(out.end(), r.data.begin(), r.data.end());
  } else {
    const uint16_t second =
        r.function == fc(Function::write_single_coil) || r.function == fc(Function::write_single_register)
            ? r.value
            : req.quantity;
    out.insert(out.end(), {static_cast<uint8_t>(r.address >> 8), static_cast<uint8_t>(r.address),
                           static_cast<uint8_t>(second >> 8), static_cast<uint8_t>(second)});
  }
  return out;
}

}  // namespace

class GatewaySession;

struct Gateway::Impl : std::enable_shared_from_this<Gateway::Impl> {
  struct Job {
    std::weak_ptr<GatewaySession> session;
    uint16_t transaction;
    uint8_t unit;
    std::vector<uint8_t> pdu;
    /// Already answered by the gateway (a refusal, a cache hit), queued only
    /// to keep an RTU-over-TCP client's answers in the order of its requests.
    std::optional<std::vector<uint8_t>> ready;
  };
  // A cached read: (unit, function, address, quantity).
  using CacheKey = std::tuple<uint8_t, uint8_t, uint16_t, uint16_t>;
  struct Cached {
    std::vector<uint8_t> pdu;
    Clock::time_point at;
  };
  // What the gateway knows of a unit's health (quarantine).
  struct UnitHealth {
    unsigned silent = 0;  // requests in a row it left without an answer
    bool quarantined = false;
    std::chrono::milliseconds backoff{0};
    Clock::time_point probe_at{};  // quarantined: the next request from then on is a probe
  };

  Impl(Master& m, GatewayOptions o)
      : bus(m), options(std::move(o)), clock(options.clock ? *options.clock : SteadyClock::instance()) {}

  // On the io thread: check, answer from the cache, or queue. `ordered`:
  // the client has no transaction ids (RTU over TCP), so even the answers
  // the gateway gives at once go through its queue, behind its earlier requests.
  void on_request(const std::shared_ptr<GatewaySession>& session, uint64_t client, bool ordered,
                  uint16_t transaction, uint8_t unit, std::span<const uint8_t> pdu);
  void forget(uint64_t client) {
    std::lock_guard lock(mutex);
    queues.erase(client);
    told_of_unit_0.erase(client);
  }
  // The bus worker's step: serves one queued request (round robin between
  // clients); returns now when more wait, else never (a request wakes it).
  Clock::time_point bus_step();
  void serve(Job& job);
  void invalidate(uint8_t unit, const Request& write);
  // A request for `unit` now: answered 0x0B at once (quarantined, no probe
  // due)? Called with the lock held.
  bool held_in_quarantine(uint8_t unit, Clock::time_point now) const {
    const UnitHealth& h = health[unit];
    return h.quarantined && now < h.probe_at;
  }
  // The outcome of a bus transaction to `unit`; returns the event to report,
  // if any. Called with the lock held.
  std::optional<GatewayUnitEvent> note_outcome(uint8_t unit, const Error& e, bool probe);

  Master& bus;
  GatewayOptions options;
  DriverClock& clock;
  std::vector<std::unique_ptr<TcpAcceptor>> acceptors;
  std::vector<std::string> schemes;  // each acceptor's: "tcp://", "rtu+tcp://"
  BusWorker worker{[this](Clock::time_point) { return bus_step(); }, {.clock = &clock}};

  std::mutex mutex;                            // everything below
  std::map<uint64_t, std::deque<Job>> queues;  // per client, served round robin
  uint64_t last_served = 0;
  uint64_t next_client = 1;
  std::map<CacheKey, Cached> cache;
  std::array<UnitHealth, 256> health{};
  GatewayStats stats;
  std::set<uint64_t> told_of_unit_0;  // clients whose request to unit 0 the notice explained
};

// One client connection: Modbus TCP (MBAP) or RTU frames over TCP in,
// answers whenever the bus has them.
class GatewaySession final : public TcpSession {
 public:
  GatewaySession(asio::ip::tcp::socket socket, std::shared_ptr<TcpShared> shared,
                 std::shared_ptr<Gateway::Impl> gateway, uint64_t client, Framing framing)
      : TcpSession(std::move(socket), std::move(shared)),
        gateway_(std::move(gateway)),
        client_(client),
        framing_(framing),
        // TCP keeps frames apart by itself; a frame whose length cannot be
        // predicted is closed by the next chunk or the silence floor.
        framer_(FrameShape::request, RtuTiming{0, io::kLinuxSilenceFloorUs}),
        silence_(executor()) {}

  // Called with the answer's PDU for the request `transaction` to `unit`.
  void answer(uint16_t transaction, uint8_t unit, std::span<const uint8_t> pdu, bool from_bus_thread) {
    std::vector<uint8_t> adu(std::max(kMbapHeaderSize, size_t{3}) + pdu.size());
    const Result<size_t> n =
        framing_ == Framing::tcp ? mbap_encode(transaction, unit, pdu, adu) : rtu_encode(unit, pdu, adu);
    if (!n.ok()) return;
    adu.resize(*n);
    if (from_bus_thread)
      reply_from_any_thread(std::move(adu));
    else
      queue(adu);
  }

  /// Closes the connection (on the io thread).
  void cut() { close(); }

 private:
  bool on_received(size_t n) override {
    auto self = std::static_pointer_cast<GatewaySession>(shared_from_this());
    if (framing_ == Framing::rtu) {
      const uint64_t now = io::now_us();
      for (size_t fed = 0; fed < n;) {
        fed += framer_.feed({rx_.data() + fed, n - fed}, now);
        take_frames(now);
      }
      arm_silence();
      return true;
    }
    return each_mbap_adu(n, [&](std::span<const uint8_t> adu) {
      const MbapHeader h = mbap_header(adu);
      gateway_->on_request(self, client_, /*ordered=*/false, h.transaction, h.unit, mbap_pdu(adu));
    });
  }
  void on_closed() override {
    silence_.cancel();
    gateway_->forget(client_);
  }

  // Every whole frame to the gateway; one with a bad CRC is dropped, as a
  // slave on the line would drop it.
  void take_frames(uint64_t now) {
    auto self = std::static_pointer_cast<GatewaySession>(shared_from_this());
    while (const std::optional<RtuFrame> f = framer_.next(now))
      gateway_->on_request(self, client_, /*ordered=*/true, 0, f->unit(), f->pdu());
  }

  // A frame whose length its function does not tell (an unknown function, a
  // byte count that disagrees with its bytes) ends at silence, as on a line.
  void arm_silence() {
    const std::optional<uint64_t> deadline = framer_.silence_deadline();
    if (!deadline) return;
    const uint64_t now = io::now_us();
    silence_.expires_after(std::chrono::microseconds(*deadline > now ? *deadline - now : 0) +
                           std::chrono::microseconds(100));
    silence_.async_wait([this, self = shared_from_this()](const boost::system::error_code& ec) {
      if (ec || closed()) return;
      take_frames(io::now_us());
      send_queued();
    });
  }

  std::shared_ptr<Gateway::Impl> gateway_;
  uint64_t client_;
  Framing framing_;
  RtuFramer framer_;
  asio::steady_timer silence_;
};

GatewayAdmission admit_gateway_request(const GatewayOptions& options, uint8_t unit,
                                       std::span<const uint8_t> pdu, bool ordered) {
  using Action = GatewayAdmission::Action;
  const Result<Request> req = decode_request(pdu);
  if (!req.ok()) {
    // A function the gateway does not relay, or a request no device could
    // take: the same exception a slave gives. A PDU too short for its
    // function's fields (the MBAP length says it is whole): 03, as a slave
    // over Modbus TCP answers; before, it was dropped and the client waited.
    // RTU frames (`ordered`): a truncated frame, dropped as the line drops it.
    if (req.error().is_exception()) return {Action::refuse, req.error().code(), {}};
    if (!ordered) return {Action::refuse, Errc::illegal_data_value, {}};
    return {Action::drop, Errc::ok, {}};
  }
  const bool allowed =
      options.allowed_units.empty()
          ? (unit >= 1 && unit <= 247) || (unit == kBroadcast.value && is_broadcastable(req->function))
          : unit != kBroadcast.value && std::find(options.allowed_units.begin(), options.allowed_units.end(),
                                                  unit) != options.allowed_units.end();
  if (!allowed) return {Action::refuse, Errc::gateway_path_unavailable, {}};
  // Read-only: an allow-list, so whatever it does not name is refused (fails closed).
  if (options.read_only && !relays_when_read_only(*req)) return {Action::refuse, Errc::illegal_function, {}};
  return {Action::relay, Errc::ok, *req};
}

void Gateway::Impl::on_request(const std::shared_ptr<GatewaySession>& session, uint64_t client, bool ordered,
                               uint16_t transaction, uint8_t unit, std::span<const uint8_t> pdu) {
  struct {
    uint16_t transaction;
    uint8_t unit;
  } const h{transaction, unit};
  const uint8_t function = pdu[0];
  // The gateway's own answer: at once, or behind the client's earlier requests.
  const auto reply = [&](std::vector<uint8_t> answer) {
    if (!ordered) return session->answer(h.transaction, h.unit, answer, false);
    std::lock_guard lock(mutex);
    queues[client].push_back(Job{session, h.transaction, h.unit, {}, std::move(answer)});
    worker.wake();
  };
  const auto refuse = [&](Errc e) {
    {
      std::lock_guard lock(mutex);
      ++stats.refused;
    }
    reply(exception_pdu(function, e));
  };
  {
    std::lock_guard lock(mutex);
    ++stats.requests;
  }
  const GatewayAdmission admission = admit_gateway_request(options, h.unit, pdu, ordered);
  if (admission.action == GatewayAdmission::Action::drop) return;
  if (admission.action == GatewayAdmission::Action::refuse) {
    // A bare 0A leaves an integrator whose client says "unit 0" guessing:
    // say once per client what unit 0 is on the serial side.
    if (h.unit == kBroadcast.value && admission.exception == Errc::gateway_path_unavailable &&
        options.notice) {
      bool first = false;
      {
        std::lock_guard lock(mutex);
        first = told_of_unit_0.insert(client).second;
      }
      if (first)
        options.notice(fmt::format(
            "a client asked unit 0 for an answer (function {:02X}): answered 0A. Unit 0 is the serial line's "
            "broadcast address: it takes writes (05, 06, 0F, 10, 16), which every unit executes and none "
            "answers{}; to read, name the device's unit (1..247)",
            function, options.allowed_units.empty() ? "" : ", and not with --allow-units"));
    }
    return refuse(admission.exception);
  }
  const Request* req = &admission.request;
  const Clock::time_point now = clock.now();
  std::lock_guard lock(mutex);
  // An ordered client's cached read is served by the bus thread in its turn.
  if (options.cache.count() > 0 && is_read(function) && !ordered) {
    const auto hit = cache.find(CacheKey{h.unit, function, req->address, req->quantity});
    if (hit != cache.end() && now - hit->second.at < options.cache) {
      ++stats.cache_hits;
      session->answer(h.transaction, h.unit, hit->second.pdu, false);
      return;
    }
  }
  std::deque<Job>& q = queues[client];
  // A quarantined unit: 0x0B at once, nothing queued for the bus (an ordered
  // client's answer waits behind its earlier requests, as every answer does).
  if (held_in_quarantine(h.unit, now)) {
    ++stats.quarantined_answers;
    if (!ordered)
      return session->answer(h.transaction, h.unit, exception_pdu(function, Errc::gateway_target_failed),
                             false);
    q.push_back(
        Job{session, h.transaction, h.unit, {}, exception_pdu(function, Errc::gateway_target_failed)});
    worker.wake();
    return;
  }
  if (q.size() >= options.max_queued_per_client) {
    ++stats.refused;
    // An ordered client past its limit is out of step: its answers could
    // only come back out of order, so it is cut off.
    if (ordered) return session->cut();
    session->answer(h.transaction, h.unit, exception_pdu(function, Errc::server_device_busy), false);
    return;
  }
  q.push_back(Job{session, h.transaction, h.unit, {pdu.begin(), pdu.end()}});
  worker.wake();
}

// Cached reads of `unit` that `write` may change. Called with the lock held.
void Gateway::Impl::invalidate(uint8_t unit, const Request& write) {
  const uint8_t changed = read_function_changed_by(write.function);
  const bool fc17 = write.function == fc(Function::read_write_multiple_registers);
  const uint32_t first = fc17 ? write.write_address : write.address;
  const uint32_t end = first + (fc17 ? write.write_quantity : write.quantity);
  for (auto it = cache.begin(); it != cache.end();) {
    const auto& [u, f, address, quantity] = it->first;
    const bool overlaps = address < end && first < uint32_t{address} + quantity;
    it = (u == unit || unit == 0) && f == changed && overlaps ? cache.erase(it) : std::next(it);
  }
}

Clock::time_point Gateway::Impl::bus_step() {
  Job job;
  {
    std::lock_guard lock(mutex);
    if (std::none_of(queues.begin(), queues.end(), [](const auto& q) { return !q.second.empty(); }))
      return Clock::time_point::max();
    // Round robin: the next client after the one served last that has work.
    auto it = queues.upper_bound(last_served);
    while (it != queues.end() && it->second.empty()) ++it;
    if (it == queues.end()) {
      it = queues.begin();
      while (it->second.empty()) ++it;
    }
    last_served = it->first;
    job = std::move(it->second.front());
    it->second.pop_front();
  }
  serve(job);
  return clock.now();  // another may wait: look again at once
}

void Gateway::Impl::serve(Job& job) {
  const std::shared_ptr<GatewaySession> session = job.session.lock();
  if (!session) return;  // the client left; its request needs no answer
  if (job.ready) {
    session->answer(job.transaction, job.unit, *job.ready, true);
    return;
  }
  const Result<Request> req = decode_request(job.pdu);  // checked on arrival
  if (!req.ok()) return;
  const bool write = is_write(req->function);
  if (!write && options.cache.count() > 0) {
    // Queued behind an identical read that has just been answered: share it.
    std::vector<uint8_t> cached;
    {
      std::lock_guard lock(mutex);
      const auto hit = cache.find(CacheKey{job.unit, req->function, req->address, req->quantity});
      if (hit != cache.end() && clock.now() - hit->second.at < options.cache) {
        ++stats.cache_hits;
        cached = hit->second.pdu;
      }
    }
    if (!cached.empty()) {
      session->answer(job.transaction, job.unit, cached, true);
      return;
    }
  }
  bool probe = false;
  {
    std::lock_guard lock(mutex);
    UnitHealth& health_of = health[job.unit];
    if (health_of.quarantined) {
      // Quarantined since it was queued, or a probe already went out: 0x0B
      // at once. Else this request is the probe; until its outcome, the
      // unit's other requests get 0x0B at once.
      if (clock.now() < health_of.probe_at) {
        ++stats.quarantined_answers;
        session->answer(job.transaction, job.unit, exception_pdu(req->function, Errc::gateway_target_failed),
                        true);
        return;
      }
      probe = true;
      ++stats.probes;
      health_of.probe_at = Clock::time_point::max();
    }
    if (write) invalidate(job.unit, *req);
  }
  std::vector<uint8_t> answer;
  const Error e =
      bus.transact(UnitId{job.unit}, *req, [&](const Response& r) { answer = response_pdu(*req, r); });
  std::optional<GatewayUnitEvent> event;
  {
    std::lock_guard lock(mutex);
    ++stats.bus_transactions;
    event = note_outcome(job.unit, e, probe);
    // A write that timed out may still have been applied: invalidate again.
    if (write) invalidate(job.unit, *req);
    if (e.ok() && answer.empty() && write) {
      // A broadcast write: nobody answers on the bus; the client gets the echo.
      const size_t echo = req->function == fc(Function::mask_write_register) ? 7 : 5;
      answer.assign(job.pdu.begin(),
                    job.pdu.begin() + static_cast<std::ptrdiff_t>(std::min(job.pdu.size(), echo)));
    } else if (e.is_exception()) {
      answer = exception_pdu(req->function, e.code());
    } else if (e.code() == Errc::timeout || e.code() == Errc::unexpected_response ||
               e.code() == Errc::malformed || e.code() == Errc::bad_crc) {
      ++stats.no_answer;
      answer = exception_pdu(req->function, Errc::gateway_target_failed);
    } else if (!e.ok()) {
      ++stats.bus_down;
      answer = exception_pdu(req->function, Errc::gateway_path_unavailable);
    } else if (options.cache.count() > 0 && is_read(req->function)) {
      cache[CacheKey{job.unit, req->function, req->address, req->quantity}] = Cached{answer, clock.now()};
    }
  }
  if (event && options.on_quarantine) options.on_quarantine(*event);
  if (answer.empty()) return;  // FC08 force listen only: nobody answers it
  session->answer(job.transaction, job.unit, answer, true);
}

std::optional<GatewayUnitEvent> Gateway::Impl::note_outcome(uint8_t unit, const Error& e, bool probe) {
  if (unit == 0 || options.quarantine_after == 0) return std::nullopt;  // a broadcast has no answer
  UnitHealth& h = health[unit];
  const bool answered = e.ok() || e.is_exception();
  if (answered) {
    h.silent = 0;
    if (!h.quarantined) return std::nullopt;
    h.quarantined = false;
    return GatewayUnitEvent{unit, false, 0, {}};
  }
  if (probe) {
    // No answer to the probe (or garbage, or the bus failed): try again later.
    h.backoff = std::min(h.backoff * 2, std::max(options.probe_backoff_max, options.probe_backoff));
    h.probe_at = clock.now() + h.backoff;
    return std::nullopt;
  }
  // Only silence counts: garbage means something answers, a failed bus is not the unit's.
  if (e.code() != Errc::timeout) return std::nullopt;
  if (++h.silent < options.quarantine_after) return std::nullopt;
  h.quarantined = true;
  h.backoff = options.probe_backoff;
  h.probe_at = clock.now() + h.backoff;
  ++stats.quarantines;
  return GatewayUnitEvent{unit, true, h.silent, h.backoff};
}

Gateway::Gateway(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}

Gateway::~Gateway() {
  impl_->worker.stop();
  impl_->acceptors.clear();
}

Outcome<std::unique_ptr<Gateway>> Gateway::start(asio::io_context& ctx, Master& bus,
                                                 std::span<const io::PortSpec> listen,
                                                 GatewayOptions options) {
  if (listen.empty()) return Status(Errc::invalid_argument, "the gateway needs a --listen tcp://HOST:PORT");
  for (const io::PortSpec& spec : listen)
    if (!spec.is_tcp())
      return Status(
          Errc::invalid_argument,
          "the gateway listens on tcp://HOST:PORT (Modbus TCP) or rtu+tcp://HOST:PORT (RTU frames)");
  // The bus is opened before anything listens: a port that does not exist (or
  // is no serial port) is a start failure, not a gateway that looks served
  // and answers every request 0A. Once open, a port that fails is reopened by
  // the next request, as before.
  if (Error e = bus.open())
    return Status(Errc::io_error, "port " + bus.describe() + ": " +
                                      (e.os_error() == ENOTTY ? std::string("not a serial port")
                                       : e.os_error() != 0    ? std::string(std::strerror(e.os_error()))
                                                              : std::string(e.text())));
  auto impl = std::make_shared<Impl>(bus, std::move(options));
  for (const io::PortSpec& spec : listen) {
    const Framing framing = spec.kind == io::PortSpec::Kind::tcp ? Framing::tcp : Framing::rtu;
    std::weak_ptr<Impl> weak = impl;
    auto acceptor = std::make_unique<TcpAcceptor>(
        ctx, impl->options.server,
        [weak, framing](asio::ip::tcp::socket socket, std::shared_ptr<TcpShared> shared) {
          std::shared_ptr<Impl> gw = weak.lock();
          uint64_t client = 0;
          {
            std::lock_guard lock(gw->mutex);
            client = gw->next_client++;
          }
          return std::make_shared<GatewaySession>(std::move(socket), std::move(shared), gw, client, framing);
        });
    if (Status s = acceptor->listen(spec.host, spec.port)) return s;
    impl->acceptors.push_back(std::move(acceptor));
    impl->schemes.push_back(framing == Framing::tcp ? "tcp://" : "rtu+tcp://");
  }
  impl->worker.start();
  return std::unique_ptr<Gateway>(new Gateway(std::move(impl)));
}

std::vector<std::string> Gateway::where() const {
  std::vector<std::string> out;
  for (size_t i = 0; i < impl_->acceptors.size(); ++i)
    out.push_back(impl_->schemes[i] + impl_->acceptors[i]->endpoint_text());
  return out;
}

uint16_t Gateway::tcp_port() const {
  return impl_->acceptors.front()->port();
}

GatewayStats Gateway::stats() const {
  std::lock_guard lock(impl_->mutex);
  GatewayStats s = impl_->stats;
  for (unsigned u = 0; u < impl_->health.size(); ++u)
    if (impl_->health[u].quarantined) s.quarantined_units.push_back(static_cast<uint8_t>(u));
  return s;
}

}  // namespace rtukit
