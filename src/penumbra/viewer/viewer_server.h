// The HTTP side of `penumbra view` (docs/viewer.md): cpp-httplib serving the page (compiled
// in from viewer/web/) and the JSON API over a ViewerSession. Every handler answers; a bad
// request gets 400 with {"error": "one line"}, never a crash.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "penumbra/viewer/viewer_session.h"

namespace penumbra::viewer {

struct ServerOptions {
  std::string bind = "127.0.0.1";
  int port = 8421;
  // Whether the next free port (up to port + 99) is taken when `port` is in use.
  bool next_free_port = true;
};

class ViewerServer {
 public:
  // Binds the socket (throws Error naming the address when no port can be had) and starts
  // serving on a thread of its own.
  ViewerServer(ViewerSession& session, ServerOptions options);
  ~ViewerServer();  // stop()
  ViewerServer(const ViewerServer&) = delete;
  ViewerServer& operator=(const ViewerServer&) = delete;

  int port() const { return port_; }
  // "http://127.0.0.1:8421/" ([...] around an IPv6 address).
  std::string url() const;
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  ServerOptions options_;
  int port_ = 0;
};

// Whether `address` (a bind address or a peer's) is a loopback one: 127.0.0.0/8, ::1,
// ::ffff:127.x.y.z or "localhost".
bool is_loopback_address(std::string_view address);
// Whether a Host header names this machine's loopback ("localhost", "127.0.0.1", "[::1]",
// with or without a port): what a page served from 127.0.0.1 sends, and what a DNS-rebinding
// page from another site does not.
bool is_loopback_host_header(std::string_view host);

// The page's files, compiled in (viewer/web/, embedded by CMake).
struct WebAsset {
  std::string_view path;  // "/index.html", "/viewer.js", ...
  std::string_view content_type;
  std::string_view data;
};
const WebAsset* find_web_asset(std::string_view path);

}  // namespace penumbra::viewer
