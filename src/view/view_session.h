// sombra view — one viewer's scene, options and Context, driven by JSON requests (the HTTP server in
// view_server.h is only transport). A request names the frame wholly (image size, camera, every
// light's direction and position, the transfer functions' opacity scale, the render options), so
// any request can be rendered, saved as a scene file or refused on its own; the Context keeps what
// the previous frame built, and render() reuses what the request did not change.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sombra/render.h"
#include "sombra/scene.h"

namespace sombra::view {

// A request's fields (docs/viewer.md "Requests"):
//   options        render options by key, as a scene file's "render" block holds them; each must
//                  apply to the request's technique (its "shadows", else the scene's)
//   camera         {position, look_at, up, fov_y_deg}
//   lights         one object per scene light: {direction} (directional, spot), {position} (spot, point)
//   opacity_scale  σ × s for every volume's transfer function: each opacity α becomes 1 − (1 − α)^s, in (0, 100]
// Every field may be left out (the scene's own). Anything else, or a value the CLI and scene files
// would refuse, throws sombra::Error naming the field ("camera.up: …", "options.dsm_resolution: …").
struct ViewFrame {
    Scene scene;
    RenderOptions options;
    nlohmann::json render_block;  // the options that differ from the defaults, as a scene file writes them
};

// The frame a request asks of `scene` with its render block's `options` (no device needed: the
// request fuzz harness calls it); throws sombra::Error naming the field.
ViewFrame view_frame(const Scene& scene, const RenderOptions& options, const nlohmann::json& request);

class ViewSession {
public:
    // `scene` as loaded (a scene file, or volume_scene's), `options` its render block's.
    ViewSession(Scene scene, RenderOptions options, const std::string& device);

    // What the page builds its controls from: the scene's camera, lights, bounds and image size,
    // the techniques, and every render option's declaration with its value (sombra/options.h).
    nlohmann::json state();
    ViewFrame frame(const nlohmann::json& request) const { return view_frame(scene_, options_, request); }

    struct Rendered {
        std::vector<unsigned char> png;
        nlohmann::json stats;  // RenderStats::to_json, plus "frame_ms" (render and encode, wall clock)
    };
    Rendered render(const ViewFrame& frame);
    // The scene file that `sombra render` turns into this frame at its full size (edited_scene_file_text).
    static std::string scene_text(const ViewFrame& frame);

private:
    Scene scene_;
    RenderOptions options_;
    Context context_;
};

}  // namespace sombra::view
