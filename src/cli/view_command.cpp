#include "cli/view_command.h"

#include <csignal>
#include <iostream>
#include <pthread.h>
#include <thread>

#include "sombra/error.h"
#include "sombra/render.h"
#include "sombra/scene.h"
#include "view/view_server.h"

namespace sombra::cli {

void add_view_command(CLI::App& app, ViewCommand& c) {
    c.app = app.add_subcommand("view", "interactive viewer in the browser: drag the camera and the lights, switch techniques "
                                       "(a local HTTP server; docs/viewer.md)");
    c.app->add_option("scene", c.path, "scene file (JSON), or a volume file (rendered as `sombra render VOLUME` does)")->required();
    c.app->add_option("--port", c.port, "TCP port to serve on (0: any free port; the URL printed tells)")
        ->check(CLI::Range(0, 65535));
    c.app->add_option("--host", c.host,
                      "address to listen on; anything but the loopback default lets other machines drive the renderer (warned)");
    c.app->add_option("--device", c.device, "auto, cpu, gpu, or an index from `sombra devices`");
    c.app->add_option("--preset", c.preset, "a volume file's transfer function: ct, mri, fog, or auto")
        ->check(CLI::IsMember({"auto", "ct", "mri", "fog"}));
    c.app->add_flag("-q,--quiet", c.quiet, "print the URL and errors only (no line per frame)");
}

int run_view_command(const ViewCommand& c) {
    const bool volume_file = !is_scene_file(c.path);
    if (!volume_file && c.app->count("--preset") > 0)
        throw Error("--preset: applies to a volume file, not a scene (" + c.path + ")");
    Scene scene = volume_file ? volume_scene(c.path, parse_transfer_preset(c.preset)).scene : load_scene(c.path);
    RenderOptions options = scene_render_options(scene);
    if (c.host != "127.0.0.1" && c.host != "localhost" && c.host != "::1")
        std::cerr << "sombra view: warning: --host " << c.host
                  << ": the viewer has no authentication; anyone who can reach this address can drive the renderer\n";

    // SIGINT and SIGTERM stop the server from a thread of their own (the server's threads inherit the mask)
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

    view::ViewSession session(std::move(scene), options, c.device);
    view::ViewServerOptions server_options;
    server_options.host = c.host;
    server_options.port = c.port;
    server_options.log = !c.quiet;
    view::ViewServer server(session, server_options);
    const int port = server.bind();
    const std::string shown_host = c.host.find(':') != std::string::npos ? "[" + c.host + "]" : c.host;
    std::cout << "sombra view: " << c.path << " at http://" << shown_host << ":" << port << "/ (Ctrl-C stops)" << std::endl;
    std::thread stopper([&] {
        int signal = 0;
        sigwait(&stop_signals, &signal);
        server.stop();
    });
    server.serve();
    pthread_kill(stopper.native_handle(), SIGTERM);  // serve() ended on its own: wake the stopper
    stopper.join();
    return 0;
}

}  // namespace sombra::cli
