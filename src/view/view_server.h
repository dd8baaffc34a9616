// sombra view — the HTTP side of the viewer: the embedded page (src/view/page.html) and its JSON API
// (docs/viewer.md), served by cpp-httplib on loopback unless told otherwise. Frames render one at a
// time on the session's Context; a frame request that a newer one overtook while it waited is
// answered 409 without rendering (the newest input wins).
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "view/view_session.h"

namespace httplib {
class Server;
}

namespace sombra::view {

struct ViewServerOptions {
    std::string host = "127.0.0.1";
    int port = 8080;  // 0: any free port (bound_port() tells)
    int threads = 8;  // requests handled at once (one renders, the others wait, answer or are dropped)
    int max_waiting_connections = 64;  // accepted connections waiting for a thread; beyond, accepting waits
    std::size_t max_request_bytes = std::size_t(1) << 20;
    bool log = true;  // one line per frame on stderr
};

// The page, embedded at build time (cmake/EmbedFile.cmake).
const char* page_html();

class ViewServer {
public:
    ViewServer(ViewSession& session, ViewServerOptions options);
    ~ViewServer();
    // Binds the address; throws sombra::Error naming it when that fails (port in use, bad host).
    int bind();
    int bound_port() const { return port_; }
    void serve();  // until stop()
    void stop();   // from any thread

private:
    void add_routes();
    // Whether a request's Host header names this server: an IP address, localhost or --host, with its port.
    bool host_names_this_server(const std::string& host) const;
    ViewSession& session_;
    ViewServerOptions options_;
    std::unique_ptr<httplib::Server> server_;
    int port_ = 0;
    std::string state_json_;
    std::mutex render_mutex_;
    std::atomic<std::uint64_t> newest_frame_{0};
};

}  // namespace sombra::view
