// sombra — Context: the OpenCL runtime and what the renderer keeps between calls on it.
#include "host/runtime.h"
#include "render/preparation.h"

namespace sombra {

Context::Context(const std::string& selector)
    : runtime_(std::make_unique<host::Runtime>(selector)), kept_(std::make_unique<detail::KeptScenes>()) {}
// the kept device data go before the runtime whose context holds them
Context::~Context() { kept_.reset(); }
const DeviceInfo& Context::device() const { return runtime_->info(); }
host::Runtime& Context::runtime() { return *runtime_; }
detail::KeptScenes& Context::kept_scenes() { return *kept_; }
void Context::release_prepared_scenes() {
    auto held = exclusive();
    *kept_ = detail::KeptScenes();
}

}  // namespace sombra
