#include "view/view_server.h"

#include <httplib.h>

#include <arpa/inet.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <iostream>
#include <thread>
#include <vector>

#include "sombra/error.h"

namespace sombra::view {
namespace {

using nlohmann::json;

// httplib's own pool queues every accepted connection without bound; this one holds at most
// `capacity` waiting connections and makes the accepting thread wait beyond that (the kernel's
// listen backlog then holds the rest), so a burst of requests costs bounded memory.
class BoundedPool : public httplib::TaskQueue {
public:
    BoundedPool(int threads, int capacity) : capacity_(std::size_t(std::max(capacity, 1))) {
        for (int i = 0; i < std::max(threads, 1); ++i) threads_.emplace_back([this] { work(); });
    }
    void enqueue(std::function<void()> fn) override {
        std::unique_lock<std::mutex> lock(mutex_);
        room_.wait(lock, [&] { return jobs_.size() < capacity_ || shutdown_; });
        jobs_.push_back(std::move(fn));
        lock.unlock();
        ready_.notify_one();
    }
    void shutdown() override {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            shutdown_ = true;
        }
        ready_.notify_all();
        room_.notify_all();
        for (std::thread& t : threads_) t.join();
    }

private:
    void work() {
        for (;;) {
            std::function<void()> fn;
            {
                std::unique_lock<std::mutex> lock(mutex_);
                ready_.wait(lock, [&] { return !jobs_.empty() || shutdown_; });
                if (jobs_.empty()) return;  // shut down with nothing left
                fn = std::move(jobs_.front());
                jobs_.pop_front();
            }
            room_.notify_one();
            fn();
        }
    }
    const std::size_t capacity_;
    std::vector<std::thread> threads_;
    std::deque<std::function<void()>> jobs_;
    std::mutex mutex_;
    std::condition_variable ready_, room_;
    bool shutdown_ = false;
};

std::string base64(const std::vector<unsigned char>& bytes) {
    static const char digits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
        const unsigned n = unsigned(bytes[i]) << 16 | (i + 1 < bytes.size() ? unsigned(bytes[i + 1]) << 8 : 0u) |
                           (i + 2 < bytes.size() ? unsigned(bytes[i + 2]) : 0u);
        out += digits[n >> 18 & 63];
        out += digits[n >> 12 & 63];
        out += i + 1 < bytes.size() ? digits[n >> 6 & 63] : '=';
        out += i + 2 < bytes.size() ? digits[n & 63] : '=';
    }
    return out;
}

void reply_json(httplib::Response& res, int status, const json& body) {
    res.status = status;
    res.set_content(body.dump(), "application/json");
}

void reply_error(httplib::Response& res, int status, const std::string& message) { reply_json(res, status, {{"error", message}}); }

// The request body as JSON; a malformed one throws sombra::Error.
json request_json(const httplib::Request& req) {
    json j = json::parse(req.body, nullptr, false);
    if (j.is_discarded()) throw Error("request: the body is not JSON");
    return j;
}

}  // namespace

ViewServer::ViewServer(ViewSession& session, ViewServerOptions options)
    : session_(session), options_(std::move(options)), server_(std::make_unique<httplib::Server>()) {
    state_json_ = session_.state().dump();
    server_->new_task_queue = [threads = options_.threads, capacity = options_.max_waiting_connections] {
        return new BoundedPool(threads, capacity);
    };
    // httplib's default also sets SO_REUSEPORT, which lets a second server (any program of the same
    // user) bind the same port and take half the connections: address reuse only
    server_->set_socket_options([](socket_t sock) {
        int yes = 1;
        setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    server_->set_payload_max_length(options_.max_request_bytes);
    server_->set_read_timeout(5);
    server_->set_write_timeout(10);
    server_->set_keep_alive_max_count(100);
    add_routes();
}

ViewServer::~ViewServer() = default;

void ViewServer::add_routes() {
    auto& s = *server_;
    s.set_default_headers({{"Cache-Control", "no-store"}, {"X-Content-Type-Options", "nosniff"}});
    // Against other web pages the user's browser visits: a request must name this server by an IP
    // address, localhost or the --host name (DNS rebinding — a foreign name resolved to this
    // machine — is refused), and a POST must be JSON (a cross-origin JSON POST needs a CORS
    // preflight, which this server never grants).
    s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        const std::string host = req.get_header_value("Host");
        if (!host_names_this_server(host)) {
            reply_error(res, 403, "Host '" + host + "' does not name this server (an IP address, localhost or " + options_.host +
                                      ", port " + std::to_string(port_) + ")");
            return httplib::Server::HandlerResponse::Handled;
        }
        if (req.method == "POST" && req.get_header_value("Content-Type").rfind("application/json", 0) != 0) {
            reply_error(res, 415, "a POST body must be Content-Type: application/json");
            return httplib::Server::HandlerResponse::Handled;
        }
        return httplib::Server::HandlerResponse::Unhandled;
    });
    s.Get("/", [](const httplib::Request&, httplib::Response& res) {
        // everything the page needs is in it: no request leaves for another host
        res.set_header("Content-Security-Policy",
                       "default-src 'self'; img-src 'self' data: blob:; style-src 'unsafe-inline'; script-src 'unsafe-inline'");
        res.set_content(page_html(), "text/html; charset=utf-8");
    });
    s.Get("/api/state", [this](const httplib::Request&, httplib::Response& res) { res.set_content(state_json_, "application/json"); });
    s.Post("/api/frame", [this](const httplib::Request& req, httplib::Response& res) {
        ViewFrame frame;
        try {
            frame = session_.frame(request_json(req));
        } catch (const Error& e) {
            return reply_error(res, 400, e.what());
        }
        const std::uint64_t ticket = ++newest_frame_;
        std::lock_guard<std::mutex> lock(render_mutex_);
        if (ticket != newest_frame_.load()) return reply_json(res, 409, {{"stale", true}, {"error", "a newer frame was asked for"}});
        try {
            ViewSession::Rendered rendered = session_.render(frame);
            if (options_.log)
                std::cerr << "sombra view: frame " << ticket << " " << frame.scene.width << "×" << frame.scene.height << " "
                          << shadow_technique_name(frame.options.shadows) << " in " << rendered.stats["frame_ms"].get<double>()
                          << " ms" << (rendered.stats["reused_preparation"].get<bool>() ? " (reused the scene's preparation)" : "")
                          << "\n";
            reply_json(res, 200, {{"frame", ticket}, {"width", frame.scene.width}, {"height", frame.scene.height},
                                  {"png", base64(rendered.png)}, {"stats", rendered.stats}});
        } catch (const Error& e) {  // what the library refuses at render time (device memory, sizes)
            reply_error(res, 400, e.what());
        }
    });
    s.Post("/api/scene", [this](const httplib::Request& req, httplib::Response& res) {
        try {
            const std::string text = ViewSession::scene_text(session_.frame(request_json(req)));
            res.set_header("Content-Disposition", "attachment; filename=\"sombra-view.json\"");
            res.set_content(text + "\n", "application/json");
        } catch (const Error& e) {
            reply_error(res, 400, e.what());
        }
    });
    s.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr error) {
        std::string what = "internal error";
        try {
            if (error) std::rethrow_exception(error);
        } catch (const std::exception& e) {
            what += std::string(": ") + e.what();
        } catch (...) {
        }
        reply_error(res, 500, what);
    });
    s.set_error_handler(httplib::Server::HandlerWithResponse([](const httplib::Request& req, httplib::Response& res) {
        if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;  // a reply of ours
        const std::string what = res.status == 404   ? "no such page: " + req.path
                                 : res.status == 413 ? "request too large"
                                                     : "bad request";
        reply_error(res, res.status, what);
        return httplib::Server::HandlerResponse::Handled;
    }));
}

bool ViewServer::host_names_this_server(const std::string& host) const {
    const std::size_t colon = host.rfind(':');
    if (colon == std::string::npos || host.substr(colon + 1) != std::to_string(port_)) return false;
    std::string name = host.substr(0, colon);
    unsigned char address[16];
    if (name.size() > 2 && name.front() == '[' && name.back() == ']')
        return inet_pton(AF_INET6, name.substr(1, name.size() - 2).c_str(), address) == 1;
    return inet_pton(AF_INET, name.c_str(), address) == 1 || name == "localhost" || name == options_.host;
}

int ViewServer::bind() {
    port_ = options_.port == 0 ? server_->bind_to_any_port(options_.host) : (server_->bind_to_port(options_.host, options_.port) ? options_.port : -1);
    if (port_ <= 0)
        throw Error("--port: cannot listen on " + options_.host + ":" + std::to_string(options_.port) +
                    " (in use, or not an address of this machine)");
    return port_;
}

void ViewServer::serve() { server_->listen_after_bind(); }

void ViewServer::stop() { server_->stop(); }

}  // namespace sombra::view
