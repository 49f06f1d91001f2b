#include "penumbra/viewer/viewer_server.h"

#include <exception>
#include <functional>
#include <set>
#include <thread>

#include <httplib.h>

#include <fmt/format.h>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"

namespace penumbra::viewer {

using nlohmann::json;

bool is_loopback_address(std::string_view a) {
  if (a == "localhost" || a == "::1" || a == "[::1]") return true;
  if (a.rfind("::ffff:", 0) == 0) a.remove_prefix(7);
  return a.rfind("127.", 0) == 0;
}

bool is_loopback_host_header(std::string_view host) {
  // Strip the port: "[::1]:8421", "127.0.0.1:8421", "localhost".
  if (!host.empty() && host.front() == '[') {
    const size_t end = host.find(']');
    if (end == std::string_view::npos) return false;
    const std::string_view rest = host.substr(end + 1);
    if (!rest.empty() && rest.front() != ':') return false;
    return host.substr(0, end + 1) == "[::1]";
  }
  const size_t colon = host.find(':');
  if (colon != std::string_view::npos) host = host.substr(0, colon);
  return host == "localhost" || host == "127.0.0.1";
}

namespace {

void json_answer(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body.dump(), "application/json");
}

void error_answer(httplib::Response& res, int status, const std::string& message) {
  // One line, whatever the message held.
  std::string line = message;
  for (char& c : line)
    if (c == '\n' || c == '\r') c = ' ';
  json_answer(res, status, {{"error", line}});
}

// Runs a handler: penumbra's Errors (a bad request, named by the parser) become 400, anything
// else 500, each with one JSON line.
void guarded(httplib::Response& res, const std::function<void()>& body) {
  try {
    body();
  } catch (const Interrupted& e) {
    error_answer(res, 503, e.what());
  } catch (const Error& e) {
    error_answer(res, 400, e.what());
  } catch (const std::exception& e) {
    error_answer(res, 500, e.what());
  }
}

}  // namespace

struct ViewerServer::Impl {
  httplib::Server server;
  std::thread thread;
};

ViewerServer::ViewerServer(ViewerSession& session, ServerOptions options)
    : impl_(std::make_unique<Impl>()), options_(std::move(options)) {
  httplib::Server& svr = impl_->server;
  const bool loopback_only = is_loopback_address(options_.bind);
  svr.set_payload_max_length(1 << 20);  // a view or settings body is a few hundred bytes
  svr.set_keep_alive_max_count(1000);

  // Loopback only, unless --bind says otherwise: other peers, and pages of other sites that
  // reach 127.0.0.1 through a DNS name of theirs (rebinding), get 403.
  svr.set_pre_routing_handler([loopback_only](const httplib::Request& req, httplib::Response& res) {
    if (!loopback_only) return httplib::Server::HandlerResponse::Unhandled;
    if (!is_loopback_address(req.remote_addr)) {
      error_answer(res, 403, fmt::format("{}: only this machine may connect (start with --bind to allow others)",
                                         req.remote_addr));
      return httplib::Server::HandlerResponse::Handled;
    }
    if (!is_loopback_host_header(req.get_header_value("Host"))) {
      error_answer(res, 403, fmt::format("Host: {}: not a loopback name", req.get_header_value("Host")));
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  svr.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
    try {
      std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      error_answer(res, 500, e.what());
    } catch (...) {
      error_answer(res, 500, "internal error");
    }
  });
  svr.set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;  // a handler's own error answer
    if (res.status == 404) error_answer(res, 404, fmt::format("{}: no such page or endpoint", req.path));
    else if (res.status == 413) error_answer(res, 413, "request body too large (at most 1 MiB)");
    else error_answer(res, res.status, fmt::format("HTTP {}", res.status));
  });

  // The page.
  auto serve_asset = [](const std::string& path) {
    return [path](const httplib::Request&, httplib::Response& res) {
      const WebAsset* a = find_web_asset(path);
      if (!a) return error_answer(res, 404, path + ": not compiled in");
      res.set_header("Cache-Control", "no-store");
      res.set_content(a->data.data(), a->data.size(), std::string(a->content_type));
    };
  };
  svr.Get("/", serve_asset("/index.html"));
  svr.Get("/index.html", serve_asset("/index.html"));
  svr.Get("/viewer.js", serve_asset("/viewer.js"));
  svr.Get("/viewer.css", serve_asset("/viewer.css"));

  // The API (docs/viewer.md).
  svr.Get("/api/scene", [&session](const httplib::Request&, httplib::Response& res) {
    guarded(res, [&] { json_answer(res, 200, session.scene_document()); });
  });
  svr.Get("/api/scene-file", [&session](const httplib::Request&, httplib::Response& res) {
    guarded(res, [&] {
      json_answer(res, 200, session.scene_file_document());
      // A file name may hold any byte: keep the header's quoted string plain.
      std::string name = session.scene_file_name();
      for (char& c : name)
        if (c == '"' || c == '\\' || static_cast<unsigned char>(c) < 0x20) c = '_';
      res.set_header("Content-Disposition", fmt::format("attachment; filename=\"{}\"", name));
    });
  });
  svr.Get("/api/methods", [&session](const httplib::Request&, httplib::Response& res) {
    guarded(res, [&] { json_answer(res, 200, session.methods_json()); });
  });
  svr.Get("/api/state", [&session](const httplib::Request&, httplib::Response& res) {
    guarded(res, [&] { json_answer(res, 200, session.state()); });
  });
  svr.Post("/api/view", [&session](const httplib::Request& req, httplib::Response& res) {
    guarded(res, [&] {
      const json body = parse_request_body(req.body, "POST /api/view");
      json_answer(res, 200, {{"generation", session.update_view(body)}});
    });
  });
  svr.Post("/api/settings", [&session](const httplib::Request& req, httplib::Response& res) {
    guarded(res, [&] { json_answer(res, 200, session.update_settings(parse_request_body(req.body, "POST /api/settings"))); });
  });
  svr.Post("/api/refine", [&session](const httplib::Request&, httplib::Response& res) {
    guarded(res, [&] { json_answer(res, 200, {{"generation", session.refine_now()}}); });
  });
  svr.Post("/api/reset", [&session](const httplib::Request&, httplib::Response& res) {
    guarded(res, [&] { json_answer(res, 200, {{"generation", session.reset_view()}}); });
  });
  svr.Get("/api/poll", [&session](const httplib::Request& req, httplib::Response& res) {
    guarded(res, [&] {
      uint64_t after = 0;
      int timeout_ms = 10000;
      for (const auto& [key, value] : parse_query_string(req.target)) {
        if (key == "after") after = static_cast<uint64_t>(parse_query_integer(key, value, 0, INT64_MAX));
        else if (key == "timeout_ms") timeout_ms = static_cast<int>(parse_query_integer(key, value, 0, 30000));
        else throw Error("{}: unknown query key (allowed: after, timeout_ms)", key);
      }
      std::string body;
      if (!session.poll(after, timeout_ms, &body)) {
        res.status = 204;
        return;
      }
      res.set_header("Cache-Control", "no-store");
      res.set_content(std::move(body), "application/octet-stream");
    });
  });
  svr.Get("/api/frame", [&session](const httplib::Request& req, httplib::Response& res) {
    guarded(res, [&] {
      FrameRequest r = parse_frame_request(parse_query_string(req.target), session.settings());
      FrameFile f = session.render_frame(r);
      res.set_header("Cache-Control", "no-store");
      res.set_header("X-Penumbra-Stats", f.stats.dump());
      res.set_header("Content-Disposition", fmt::format("inline; filename=\"frame.{}\"", r.format));
      res.set_content(std::move(f.bytes), f.content_type);
    });
  });
  // The right path with the wrong HTTP method: 405, not 404.
  static const std::set<std::string> kGet = {"/api/scene", "/api/scene-file", "/api/methods", "/api/state",
                                             "/api/poll", "/api/frame"};
  static const std::set<std::string> kPost = {"/api/view", "/api/settings", "/api/refine", "/api/reset"};
  auto wrong_method = [](const std::set<std::string>& other, const char* allowed) {
    return [&other, allowed](const httplib::Request& req, httplib::Response& res) {
      if (other.count(req.path)) {
        res.set_header("Allow", allowed);
        error_answer(res, 405, fmt::format("{} {}: use {}", req.method, req.path, allowed));
      } else {
        error_answer(res, 404, fmt::format("{}: no such page or endpoint", req.path));
      }
    };
  };
  svr.Get("/api/.*", wrong_method(kPost, "POST"));
  svr.Post(".*", wrong_method(kGet, "GET"));

  // The port: the one asked for, else the next free one.
  const int last = options_.next_free_port ? options_.port + 99 : options_.port;
  for (int p = options_.port; p <= last && p <= 65535; ++p) {
    if (svr.bind_to_port(options_.bind, p)) {
      port_ = p;
      break;
    }
  }
  if (port_ == 0)
    throw Error("--bind {} --port {}: cannot listen there{}", options_.bind, options_.port,
                options_.next_free_port ? fmt::format(" (nor on ports up to {})", last) : std::string());
  impl_->thread = std::thread([this] { impl_->server.listen_after_bind(); });
}

ViewerServer::~ViewerServer() { stop(); }

void ViewerServer::stop() {
  if (!impl_->thread.joinable()) return;
  impl_->server.stop();
  impl_->thread.join();
}

std::string ViewerServer::url() const {
  const bool v6 = options_.bind.find(':') != std::string::npos;
  return fmt::format("http://{}{}{}:{}/", v6 ? "[" : "", options_.bind, v6 ? "]" : "", port_);
}

}  // namespace penumbra::viewer
