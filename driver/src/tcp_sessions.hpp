// rtukit driver (internal): TCP connections that no client can use to stall
// a server. Shared by the slave servers and the gateway.
//
//  - answers leave through a bounded buffer written asynchronously: a client
//    that sends and never reads is disconnected when the buffer passes
//    ServerOptions::max_pending_output, and nobody else ever waits for it;
//  - a connection that sends nothing for idle_timeout is closed;
//  - a request must be whole request_timeout after its first byte (a client
//    that trickles a frame, slowloris, is closed);
//  - at most max_connections at once. A new connection past the limit closes
//    the one idle longest (nothing being received, executed or answered:
//    the Modbus TCP implementation guide's rule) and takes its place;
//  - at most max_per_source from one client address. An address at its share
//    may only replace its own idle connection. When the table is full and
//    nothing is idle, a newcomer from an address with fewer connections
//    replaces the least active connection of the address holding the most
//    (one that trickles a request counts; one answering never): an attacker
//    with a few addresses cannot fill the table against everybody else;
//  - otherwise the newcomer is closed at once;
//  - a connection that ends (the client's end of stream, a stream out of
//    step) first answers every request it took: an executed write is always
//    confirmed;
//  - accept() failing (EMFILE: out of descriptors) pauses 100 ms instead of
//    spinning.
// Everything runs on the io_context's thread, except reply_from_any_thread().
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstring>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/mbap.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio.hpp"

namespace rtukit {

class TcpSession;

/// Memory for one asynchronous operation at a time: a connection's read or
/// its write. Asio allocates each operation's state per call; its own cache
/// keeps two blocks per thread, which a server with a read, a write and
/// timers in flight on every connection outruns, so every request cost two
/// heap allocations (measured: bench/README.md, issue 39). An operation that
/// does not fit, or comes while the block is taken, gets the heap as before.
class OperationMemory {
 public:
  OperationMemory() = default;
  OperationMemory(const OperationMemory&) = delete;
  OperationMemory& operator=(const OperationMemory&) = delete;
  void* allocate(size_t size) {
    if (!in_use_ && size <= sizeof(storage_)) {
      in_use_ = true;
      return storage_;
    }
    return ::operator new(size);
  }
  void deallocate(void* p) noexcept {
    if (p == storage_)
      in_use_ = false;
    else
      ::operator delete(p);
  }

 private:
  alignas(std::max_align_t) unsigned char storage_[512];
  bool in_use_ = false;
};

/// The allocator Asio finds on a handler (its nested allocator_type, Boost
/// 1.74's associated_allocator): allocates from an OperationMemory.
template <class T>
class OperationAllocator {
 public:
  using value_type = T;
  explicit OperationAllocator(OperationMemory& memory) noexcept : memory_(&memory) {}
  template <class U>
  OperationAllocator(const OperationAllocator<U>& other) noexcept : memory_(other.memory_) {}
  T* allocate(size_t n) { return static_cast<T*>(memory_->allocate(sizeof(T) * n)); }
  void deallocate(T* p, size_t) noexcept { memory_->deallocate(p); }
  template <class U>
  bool operator==(const OperationAllocator<U>& other) const noexcept {
    return memory_ == other.memory_;
  }

 private:
  template <class>
  friend class OperationAllocator;
  OperationMemory* memory_;
};

/// A completion handler whose operation's state lives in `memory`.
template <class Handler>
struct InMemory {
  using allocator_type = OperationAllocator<void>;
  OperationMemory* memory;
  Handler handler;
  allocator_type get_allocator() const noexcept { return allocator_type(*memory); }
  template <class... Args>
  void operator()(Args&&... args) {
    handler(std::forward<Args>(args)...);
  }
};
template <class Handler>
InMemory<std::decay_t<Handler>> in_memory(OperationMemory& memory, Handler&& handler) {
  return {&memory, std::forward<Handler>(handler)};
}

/// What an acceptor and its sessions share. Sessions hold it by shared_ptr,
/// so a session that outlives its server stays valid.
struct TcpShared {
  ServerOptions options;
  ServerStats stats;
  unsigned live = 0;                                 ///< connections open (a slot each)
  std::list<TcpSession*> sessions;                   ///< the open ones, to pick one to close for a newcomer
  std::map<asio::ip::address, unsigned> per_source;  ///< open connections of each client address
  uint64_t activity = 0;  ///< a counter, not a clock: orders the sessions' last activity
};

class TcpSession : public std::enable_shared_from_this<TcpSession> {
 public:
  TcpSession(asio::ip::tcp::socket socket, std::shared_ptr<TcpShared> shared)
      : socket_(std::move(socket)),
        idle_(socket_.get_executor()),
        deadline_(socket_.get_executor()),
        shared_(std::move(shared)),
        source_(source_of(socket_)) {
    ++shared_->live;
    ++shared_->per_source[source_];
    entry_ = shared_->sessions.insert(shared_->sessions.end(), this);
    touch();
  }

  /// The client's address, an IPv4-mapped IPv6 one as its IPv4 address
  /// (the same client on a dual-stack listener). Unspecified when unknown.
  static asio::ip::address source_of(const asio::ip::tcp::socket& socket) {
    boost::system::error_code ec;
    const auto endpoint = socket.remote_endpoint(ec);
    if (ec) return {};
    const asio::ip::address a = endpoint.address();
    if (a.is_v6() && a.to_v6().is_v4_mapped())
      return asio::ip::make_address_v4(asio::ip::v4_mapped, a.to_v6());
    return a;
  }
  // A session is normally closed (on the io thread) long before it is
  // destroyed; one never closed (its loop stopped) gives its slot back here.
  virtual ~TcpSession() { release_slot(); }
  TcpSession(const TcpSession&) = delete;
  TcpSession& operator=(const TcpSession&) = delete;

  void start() {
    arm_idle();
    read();
  }

  /// Nothing being received, executed or answered: may be closed to make
  /// room for a new connection. One ending already (answered everything,
  /// waiting for the client's end of stream) counts as idle.
  bool idle() const {
    if (closed_) return false;
    if (lingering_) return true;
    return !finishing_ && !busy() && !writing_ && pending_.empty();
  }
  /// Answering a request: one taken and not yet answered (executed, or on
  /// the bus), an answer being written, or the answers of an ending
  /// connection. Such a connection is never closed to admit another: an
  /// executed write is always confirmed.
  bool answering() const {
    if (closed_) return false;
    return owed_ > 0 || writing_ || !pending_.empty() || (finishing_ && !lingering_) || answer_coming();
  }
  /// Orders sessions by their last activity (connect, bytes in, an answer out).
  uint64_t last_activity() const { return last_activity_; }
  const asio::ip::address& source() const { return source_; }
  /// Closes an idle session to admit a new one (the acceptor, io thread).
  void evict() {
    ++shared_->stats.idle_evicted;
    close();
  }
  /// Closes a session of an address over its fair share to admit a
  /// connection from an address with fewer (the acceptor, io thread).
  void evict_for_share() {
    ++shared_->stats.share_evicted;
    close();
  }

  /// Queues `bytes` for this client from any thread (the gateway's bus
  /// thread). Dropped if the connection has closed meanwhile.
  void reply_from_any_thread(std::vector<uint8_t> bytes) {
    std::weak_ptr<TcpSession> weak = shared_from_this();
    asio::post(socket_.get_executor(), [weak, bytes = std::move(bytes)] {
      if (auto self = weak.lock()) {
        self->queue(bytes);
        self->flush();
      }
    });
  }

 protected:
  /// `n` new bytes are at the end of rx_ (rx_len_ not yet counting them for
  /// MBAP users: each_mbap_adu does). False: out of step, close.
  virtual bool on_received(size_t n) = 0;

  /// Counts `n` new bytes and calls `f` for each complete MBAP ADU buffered.
  /// False when the stream is out of step.
  template <class F>
  bool each_mbap_adu(size_t n, F&& f) {
    rx_len_ += n;
    size_t pos = 0;
    for (;;) {
      const Result<size_t> size = mbap_adu_size({rx_.data() + pos, rx_len_ - pos});
      if (!size.ok()) {
        // Out of step: nothing after this can be framed. The requests before
        // it have run; finish() sends their answers before closing.
        rx_len_ = 0;
        return false;
      }
      if (*size == 0 || *size > rx_len_ - pos) break;
      ++owed_;  // until queue() or answered_nothing()
      f(std::span<const uint8_t>(rx_.data() + pos, *size));
      if (closed_) return true;
      pos += *size;
    }
    std::memmove(rx_.data(), rx_.data() + pos, rx_len_ - pos);
    rx_len_ -= pos;
    return true;
  }

  /// Adds an answer to the output buffer (sent by flush()). One answer per
  /// request: it settles the oldest request still owed.
  void queue(std::span<const uint8_t> out) {
    if (closed_) return;
    settle();
    if (pending_.size() + in_flight_.size() + out.size() > shared_->options.max_pending_output) {
      ++shared_->stats.slow_closed;  // it sends but does not read: it would only grow
      close();
      return;
    }
    pending_.insert(pending_.end(), out.begin(), out.end());
  }
  /// A request taken through each_mbap_adu that gets no answer (the engine
  /// in listen-only mode): it is no longer owed.
  void answered_nothing() { settle(); }

  void close() {
    if (closed_) return;
    closed_ = true;
    boost::system::error_code ignored;
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
    idle_.cancel();
    deadline_.cancel();
    release_slot();
    on_closed();
  }
  /// Called once when the connection closes (the gateway drops its queue).
  virtual void on_closed() {}
  /// Sends what queue() added, outside a read (a timer's answer).
  void send_queued() { flush(); }

  /// A request is partly received or not yet answered: the connection is
  /// not idle. The default fits a session that answers later, from another
  /// thread (the gateway): MBAP requests owed an answer, a partial MBAP
  /// frame, or bytes received since the last answer (RTU frames, which
  /// this class does not see). A session that answers at once overrides it.
  virtual bool busy() const { return owed_ > 0 || heard_ || partial_request(); }
  /// Bytes of a request that is not whole yet (request_timeout runs).
  virtual bool partial_request() const { return rx_len_ > 0; }
  /// An answer will come without more input (an RTU frame that silence
  /// will close): an ending connection waits for it.
  virtual bool answer_coming() const { return false; }
  /// Starts or stops the request deadline after the buffered request
  /// changed outside a read (a silence timer).
  void request_progress() {
    if (closed_ || finishing_) return;
    const bool partial = partial_request();
    if (partial && !timing_request_) {
      timing_request_ = true;
      arm_deadline(shared_->options.request_timeout, Deadline::request);
    } else if (!partial && timing_request_) {
      timing_request_ = false;
      ++deadline_generation_;
      deadline_.cancel();
    }
  }
  /// Stops taking requests; answers every request taken (their answers
  /// sent), then closes: an executed write is always confirmed.
  void finish() {
    if (closed_ || finishing_) return;
    finishing_ = true;
    timing_request_ = false;
    rx_len_ = 0;
    // A bound for answers that never come (a request the bus never ends).
    const auto timeout = shared_->options.idle_timeout;
    arm_deadline(timeout.count() > 0 ? timeout : std::chrono::milliseconds(60000), Deadline::finish);
    flush();
  }
  /// The executor of the connection's loop (for a session's own timers).
  asio::any_io_executor executor() { return socket_.get_executor(); }
  bool closed() const { return closed_; }

  std::array<uint8_t, 2 * kMaxMbapAduSize> rx_{};
  size_t rx_len_ = 0;

 private:
  enum class Deadline { request, finish, linger };

  // The client closed its side. Compared by value and the category's
  // address, calling nothing on the category: UBSan checks the vptr of an
  // object a member call goes to by probing memory with a pipe, which fails
  // while a server is out of descriptors (EMFILE), a false "invalid vptr"
  // there (seen with `ec == asio::error::eof`, which calls operator== on the
  // categories, when we were on standalone Asio and std::error_code).
  static bool is_end_of_stream(const boost::system::error_code& ec) {
    return ec.value() == asio::error::eof && &ec.category() == &asio::error::get_misc_category();
  }

  void read() {
    auto self = shared_from_this();
    socket_.async_read_some(
        asio::buffer(rx_.data() + rx_len_, rx_.size() - rx_len_),
        in_memory(read_memory_, [this, self](const boost::system::error_code& ec, size_t n) {
          if (closed_) return;
          if (is_end_of_stream(ec)) {
            // The client has sent all it will; what it sent is still answered.
            peer_done_ = true;
            if (lingering_) return close();
            return finish();
          }
          if (ec) return close();
          if (finishing_) return read();  // after the end: read and dropped
          heard_ = true;
          touch();
          arm_idle();
          if (!on_received(n)) {
            finish();  // answers what ran before the bad header
            if (!closed_) read();
            return;
          }
          if (closed_) return;
          request_progress();
          flush();
          read();
        }));
  }

  void flush() {
    if (writing_ || closed_) return;
    if (pending_.empty()) return ending();
    writing_ = true;
    in_flight_.swap(pending_);
    pending_.clear();
    auto self = shared_from_this();
    asio::async_write(socket_, asio::buffer(in_flight_),
                      in_memory(write_memory_, [this, self](const boost::system::error_code& ec, size_t) {
                        writing_ = false;
                        in_flight_.clear();
                        if (ec) return close();
                        flush();
                      }));
  }

  // Finishing, everything answered and written: the end of our stream
  // (the client reads its last answers, then EOF), then wait briefly for the
  // client's own end, so that closing does not reset what it has not read.
  void ending() {
    if (!finishing_ || lingering_ || closed_ || owed_ > 0 || answer_coming()) return;
    lingering_ = true;
    if (peer_done_) return close();
    boost::system::error_code ignored;
    socket_.shutdown(asio::ip::tcp::socket::shutdown_send, ignored);
    arm_deadline(std::chrono::milliseconds(2000), Deadline::linger);
  }

  void settle() {
    if (owed_ > 0) --owed_;
    if (owed_ == 0) heard_ = false;
    touch();
  }
  void touch() { last_activity_ = ++shared_->activity; }
  void release_slot() {
    if (!counted_) return;
    counted_ = false;
    --shared_->live;
    if (--shared_->per_source[source_] == 0) shared_->per_source.erase(source_);
    shared_->sessions.erase(entry_);
  }

  // One timer for whichever deadline applies: the request's, then, once
  // finishing, the bound on the answers still owed and on the linger.
  void arm_deadline(std::chrono::milliseconds after, Deadline what) {
    const uint64_t generation = ++deadline_generation_;
    if (after.count() <= 0) return;  // request_timeout 0: never
    deadline_.expires_after(after);
    auto self = shared_from_this();
    deadline_.async_wait([this, self, generation, what](const boost::system::error_code& ec) {
      // Stale: stopped or replaced (cancel() cannot stop a handler already queued).
      if (ec || closed_ || generation != deadline_generation_) return;
      if (what == Deadline::request) ++shared_->stats.request_timeouts;
      close();
    });
  }

  // The idle timeout runs from the last bytes received. Each read only
  // notes when it came; the one timer, armed at the start, looks when it
  // fires and waits again for what is left. Re-arming it at every request
  // cost a system call (timerfd_settime) and a cancelled wait per request.
  void arm_idle() {
    const auto timeout = shared_->options.idle_timeout;
    if (timeout.count() <= 0) return;
    heard_at_ = clock_.now();
    if (idle_armed_) return;
    idle_armed_ = true;
    wait_idle(timeout);
  }
  void wait_idle(Clock::duration after) {
    idle_.expires_after(after);
    auto self = shared_from_this();
    idle_.async_wait([this, self](const boost::system::error_code& ec) {
      if (ec || closed_) return;
      const auto quiet_until = heard_at_ + shared_->options.idle_timeout;
      const auto now = clock_.now();
      if (now < quiet_until) return wait_idle(quiet_until - now);  // heard from since: what is left
      ++shared_->stats.idle_closed;
      close();
    });
  }

  asio::ip::tcp::socket socket_;
  asio::steady_timer idle_;
  asio::steady_timer deadline_;
  std::shared_ptr<TcpShared> shared_;
  asio::ip::address source_;
  std::list<TcpSession*>::iterator entry_;
  bool counted_ = true;  // holds a slot (live, sessions)
  uint64_t last_activity_ = 0;
  // The idle timeout is time on Asio's timer, which runs on the steady
  // clock: so is this (as the stream server's turnaround).
  DriverClock& clock_ = SteadyClock::instance();
  Clock::time_point heard_at_{};  // the last bytes received (idle_timeout runs from it)
  bool idle_armed_ = false;
  uint64_t deadline_generation_ = 0;
  unsigned owed_ = 0;            // MBAP requests taken, not yet answered
  bool heard_ = false;           // bytes received since the last answer
  bool timing_request_ = false;  // request_timeout runs for a partial request
  bool finishing_ = false;       // takes no more requests; closes once they are answered
  bool lingering_ = false;       // all answered, our end sent; waiting for the client's
  bool peer_done_ = false;       // the client's end of stream came
  std::vector<uint8_t> pending_;
  std::vector<uint8_t> in_flight_;
  bool writing_ = false;
  bool closed_ = false;
  // One read and one write in flight at a time: each has its own memory.
  OperationMemory read_memory_;
  OperationMemory write_memory_;
};

/// Accepts connections and makes a session of each, within the limits.
class TcpAcceptor {
 public:
  using MakeSession =
      std::function<std::shared_ptr<TcpSession>(asio::ip::tcp::socket, std::shared_ptr<TcpShared>)>;

  TcpAcceptor(asio::io_context& ctx, ServerOptions options, MakeSession make)
      : acceptor_(ctx), retry_(ctx), shared_(std::make_shared<TcpShared>()), make_(std::move(make)) {
    shared_->options = std::move(options);
  }
  ~TcpAcceptor() {
    boost::system::error_code ignored;
    acceptor_.close(ignored);
    retry_.cancel();
  }

  /// Binds and starts accepting. `host` empty: 127.0.0.1. Errors: invalid_argument, io_error.
  Status listen(const std::string& host, uint16_t port) {
    boost::system::error_code ec;
    const auto address = asio::ip::make_address(host.empty() ? "127.0.0.1" : host, ec);
    if (ec) return Status(Errc::invalid_argument, "not an IP address: " + host);
    const asio::ip::tcp::endpoint endpoint(address, port);
    acceptor_.open(endpoint.protocol(), ec);
    if (!ec) acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor_.bind(endpoint, ec);
    if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
      return Status(Error(Errc::io_error, ec.value()),
                    "cannot listen on " + io::host_port_text(host, port) + ": " + ec.message());
    accept();
    return {};
  }

  /// "127.0.0.1:1502", "[::1]:1502".
  std::string endpoint_text() const {
    const auto ep = acceptor_.local_endpoint();
    return io::host_port_text(ep.address().to_string(), ep.port());
  }
  uint16_t port() const { return acceptor_.local_endpoint().port(); }
  ServerStats stats() const { return shared_->stats; }
  unsigned connections() const { return shared_->live; }

 private:
  void accept() {
    acceptor_.async_accept([this](const boost::system::error_code& ec, asio::ip::tcp::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (ec) {
        // Out of descriptors (EMFILE/ENFILE) or a transient error: the
        // pending connection stays in the backlog, so accepting again at once
        // would fail again at once. Pause instead of spinning.
        ++shared_->stats.accept_errors;
        retry_.expires_after(std::chrono::milliseconds(100));
        retry_.async_wait([this](const boost::system::error_code& e) {
          if (!e) accept();
        });
        return;
      }
      boost::system::error_code ignored;
      if (!make_room(TcpSession::source_of(socket))) {
        ++shared_->stats.connections_refused;  // a clean close: the client sees at once it was refused
        socket.close(ignored);
      } else {
        socket.set_option(asio::ip::tcp::no_delay(true), ignored);
        make_(std::move(socket), shared_)->start();
      }
      accept();
    });
  }

  // Room for a connection from `source`, made if need be; false: none.
  bool make_room(const asio::ip::address& source) {
    const ServerOptions& o = shared_->options;
    const auto held = [&](const asio::ip::address& a) {
      const auto it = shared_->per_source.find(a);
      return it == shared_->per_source.end() ? 0u : it->second;
    };
    // At its share: only in place of its own connection idle longest.
    if (o.max_per_source > 0 && held(source) >= o.max_per_source) {
      if (TcpSession* own = least_active([&](TcpSession* s) { return s->source() == source && s->idle(); }))
        own->evict();
      return held(source) < o.max_per_source;
    }
    if (shared_->live < o.max_connections) return true;
    // Full: the connection idle longest, whoever holds it (never one whose
    // request is being received, executed or answered).
    if (TcpSession* idle = least_active([](TcpSession* s) { return s->idle(); })) {
      idle->evict();
      return shared_->live < o.max_connections;
    }
    // Nothing idle: the address holding the most gives up its least active
    // connection that is not answering, if it holds more than the newcomer's
    // address would (so no address can evict one with as many or fewer).
    const asio::ip::address* largest = nullptr;
    for (const auto& [address, n] : shared_->per_source)
      if (!largest || n > held(*largest)) largest = &address;
    if (!largest || held(*largest) <= held(source) + 1) return false;
    const asio::ip::address donor = *largest;
    if (TcpSession* s = least_active([&](TcpSession* x) { return x->source() == donor && !x->answering(); }))
      s->evict_for_share();
    return shared_->live < o.max_connections;
  }

  template <class Pred>
  TcpSession* least_active(Pred pred) const {
    TcpSession* found = nullptr;
    for (TcpSession* s : shared_->sessions)
      if (pred(s) && (!found || s->last_activity() < found->last_activity())) found = s;
    return found;
  }

  asio::ip::tcp::acceptor acceptor_;
  asio::steady_timer retry_;
  std::shared_ptr<TcpShared> shared_;
  MakeSession make_;
};

}  // namespace rtukit
