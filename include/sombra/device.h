// sombra — OpenCL platforms and devices as the library user sees them.
#pragma once
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace sombra {

struct DeviceInfo {
    int index;             // position in list_devices(), usable as a --device value
    std::string platform;
    std::string name;
    bool is_gpu;
    std::string opencl_c_version;
    unsigned long long global_memory_bytes;
    unsigned long long max_allocation_bytes;  // CL_DEVICE_MAX_MEM_ALLOC_SIZE: the largest one buffer
};

std::vector<DeviceInfo> list_devices();

namespace host { class Runtime; }
class RankExchange;
namespace detail { struct KeptScenes; }

// An OpenCL context, device, queue and program cache. Create one per process and share it: it is
// safe to share between threads, which take turns (every call on it — render, shadow_transmittance,
// build_deep_shadow_maps, release_prepared_scenes — holds its lock for the whole call; calls on
// different Contexts run in parallel).
// selector: "" or "auto" (first GPU, else the first CPU device, i.e. PoCL), "cpu", "gpu", or an
// index from list_devices(). Throws sombra::Error if no such device exists.
class Context {
public:
    explicit Context(const std::string& selector = "auto");
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;
    const DeviceInfo& device() const;
    host::Runtime& runtime();
    // Frees the device data kept between calls (uploaded volumes, deep shadow maps); the next
    // render prepares everything anew. Compiled programs stay.
    void release_prepared_scenes();
    detail::KeptScenes& kept_scenes();  // the renderer's (src/render/preparation.h)
    // The ranks a distributed render exchanges its maps with (render_distributed sets it for the
    // call; sombra/distributed.h); nullptr: a render of one process.
    RankExchange* rank_exchange() const { return rank_exchange_; }
    void set_rank_exchange(RankExchange* exchange) { rank_exchange_ = exchange; }
    // Held by each call on this Context for its duration (recursive: a call may make another).
    std::unique_lock<std::recursive_mutex> exclusive() { return std::unique_lock<std::recursive_mutex>(mutex_); }

private:
    std::recursive_mutex mutex_;
    std::unique_ptr<host::Runtime> runtime_;
    std::unique_ptr<detail::KeptScenes> kept_;
    RankExchange* rank_exchange_ = nullptr;
};

}  // namespace sombra
