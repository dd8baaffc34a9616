// External consumer of the installed sombra package: builds a procedural scene (a ball of smoke
// under a directional light), renders a 16×16 image with shadow rays and checks the result.
// Uses only the public headers; the OpenCL kernels come from inside the library.
#include <sombra/sombra.h>

#include <cstdio>
#include <exception>
#include <memory>

int main() {
    try {
        std::printf("devices: %zu\n", sombra::list_devices().size());
        sombra::Scene scene;
        sombra::VolumeInstance ball;
        ball.volume = std::make_shared<const sombra::Volume>(sombra::make_sphere(16));
        ball.transform = sombra::make_transform({0, 0, 0}, {0, 0, 0}, {1.f / 16, 1.f / 16, 1.f / 16});
        ball.transfer_function.color_points = {{0.f, 1.f, 1.f, 1.f}, {1.f, 1.f, 1.f, 1.f}};
        ball.transfer_function.opacity_points = {{0.f, 0.f}, {1.f, 0.3f}};
        scene.volumes.push_back(ball);
        scene.lights.push_back(sombra::Light{});
        scene.camera.position = {0, 0, 2.5f};

        sombra::Context context("auto");
        sombra::RenderOptions options;
        options.width = options.height = 16;
        options.shadows = sombra::ShadowTechnique::Rays;
        sombra::RenderResult result = sombra::render(context, scene, options);
        const sombra::Image& image = result.image;
        if (image.width != 16 || image.height != 16 || image.rgba.size() != 16u * 16u * 4u) {
            std::fprintf(stderr, "consumer: wrong image size\n");
            return 1;
        }
        const float centre_alpha = image.rgba[(8 * 16 + 8) * 4 + 3];
        const float corner_alpha = image.rgba[3];
        std::printf("device: %s  centre alpha %.3f  corner alpha %.3f\n", result.stats.device.c_str(),
                    centre_alpha, corner_alpha);
        if (!(centre_alpha > 0.05f) || !(corner_alpha < 1e-3f)) {
            std::fprintf(stderr, "consumer: the ball is not where it should be\n");
            return 1;
        }
        std::printf("sombra consumer: OK\n");
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "consumer: %s\n", e.what());
        return 1;
    }
}
