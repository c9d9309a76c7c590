// The Inverjet pool panel (`rtukit inverjet panel`): a web page for the
// swimmer's phone or tablet (web/assets/inverjet/), served with its JSON API
// over HTTP and WebSocket by the shared web layer (web/server.hpp).
//
// One bus thread owns the machine: it polls (2 Hz), runs the pages' commands
// in arrival order through the same command runner as the MQTT bridge
// (inverjet_command: the typed client's rules), keeps the run's history for
// the charts, and posts the results to the web thread. A page never waits
// for the bus and never slows the polling.
//
// WebSocket /ws. Server -> page: {"type":"state", ...machine_state_json...,
// "online"}, {"type":"sample","t","speed","current_a","mosfet_c","motor_c"},
// {"type":"history","samples":[...]}, {"type":"plans","plans":[[{speed,end}]x4]},
// {"type":"result","id","op","ok","error"}. Page -> server: {"op": start |
// pause | resume | stop | speed | plan | plans, "id", ...} (docs/inverjet.md).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "rtukit/io/link.hpp"
#include "rtukit/io/status.hpp"

namespace rtukit::programs {

struct PanelOptions {
  uint8_t unit = 21;
  std::string http = "127.0.0.1:8081";
  double poll_hz = 2;
  unsigned response_timeout_ms = 300;
};

class Panel {
 public:
  Panel(std::unique_ptr<io::Link> link, PanelOptions options);
  ~Panel();
  Panel(const Panel&) = delete;
  Panel& operator=(const Panel&) = delete;

  /// Binds the listener, starts the bus thread. Errors: the listener's.
  rtukit::Status start();
  void stop();
  std::string url() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit::programs
