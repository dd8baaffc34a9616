// sombra — OpenCL runtime: device choice, program build with -D feature defines and a per-process
// program cache, kernel timing with profiling events.
#pragma once
#include <CL/opencl.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "host/program_cache.h"
#include "host/progress.h"
#include "sombra/device.h"

namespace sombra::host {

class Runtime {
public:
    explicit Runtime(const std::string& selector);
    ~Runtime();
    Runtime(const Runtime&) = delete;
    Runtime& operator=(const Runtime&) = delete;

    const DeviceInfo& info() const { return info_; }
    cl::Context& context() { return context_; }
    cl::Device& device() { return device_; }
    const cl::Device& device() const { return device_; }
    cl::CommandQueue& queue() { return queue_; }

    // Builds (once per process) the program made of `source` (a file under cl/, its #includes
    // resolved from the embedded sources) with the given -D defines, or loads it from the on-disk
    // cache (host/program_cache.h). A compile error throws sombra::Error carrying the build log.
    cl::Program& program(const std::string& source, const std::vector<std::string>& defines);

    // Programs this runtime compiled from source and loaded from the on-disk cache so far.
    int programs_compiled() const { return programs_compiled_; }
    int programs_loaded() const { return programs_loaded_; }
    const std::string& program_cache_folder() const { return program_cache_->folder(); }

    // Milliseconds between an event's start and end (profiling queue).
    static double event_ms(const cl::Event& event);

    // The progress of the current call (host/progress.h), and the bands long kernels run in
    // (host/tiled_launch.h): 0 sized by time, n > 0 n equal bands (1: one launch; tests, bench).
    Progress& progress() { return progress_; }
    int launch_tiles() const { return launch_tiles_; }
    void set_launch_tiles(int tiles) { launch_tiles_ = tiles; }
    // How many ways the camera pass interleaves a launch's rows of groups (render.cl
    // interleaved_launch_row): 0 as the device asks (its threads on a CPU with packets, else 1),
    // n > 0 n ways (tests).
    int camera_row_interleave() const { return camera_row_interleave_; }
    void set_camera_row_interleave(int ways) { camera_row_interleave_ = ways; }

private:
    Progress progress_;
    int launch_tiles_ = 0;
    int camera_row_interleave_ = 0;
    DeviceInfo info_;
    std::string build_options_;  // every program's: OpenCL C 1.2, argument names, exact division
    cl::Context context_;
    cl::Device device_;
    cl::CommandQueue queue_;
    std::mutex cache_mutex_;
    std::map<std::string, cl::Program> programs_;
    std::unique_ptr<ProgramCache> program_cache_;
    int programs_compiled_ = 0, programs_loaded_ = 0;
};

// Rays per work-item of the packet kernels (cl/lanes.h): `requested` (1, 4, 8 or 16; else an
// Error naming --lanes), or when it is 0, 8 on CPU devices and 1 on GPUs.
int packet_lanes(const Runtime& runtime, int requested);
// The same for DSM generation (cl/dsm_build.cl), whose packets gain from wider vectors than the
// camera pass's: when `requested` is 0, on CPU devices the native float vector width, 16 with
// AVX-512 (CT 512² maps 446 → 417 ms, smoke 278 → 230 ms; the camera pass is 7–10 % slower at
// 16), else 8; 1 on GPUs.
int generation_lanes(const Runtime& runtime, int requested);

// Runs a packet kernel over width × height pixels or texels, `lanes` neighbours of a row per
// work-item: ⌈width / lanes⌉ × height work-items, and with packets 4×4 work-groups over a grid
// padded to them (PoCL keeps a group's private state on one stack and its default group size
// overflows it for 8- and 16-lane packets; 4×4 measured fastest). Kernels ignore the padding.
// Runs it in bands of rows (host/tiled_launch.h, advancing the progress stage by `units`) and
// returns the profiled time in ms. first_row > 0: rows first_row … first_row + height − 1 only
// (the kernels read get_global_id, which includes the offset). `group`: the work-groups' side in
// packets; 1 for a launch of packets far apart (auto's probe, whose neighbours share no reads):
// there a 4 × 4 group held few packets, and PoCL ran a 64² probe launch's two groups of 4 packets
// as slowly on 2 threads as on 1 (18 ms either way, 10 ms in groups of one packet).
constexpr int kPacketGroupSide = 4;  // the frame's work-groups: 4 × 4 neighbouring packets
double run_packets(Runtime& runtime, cl::Kernel& kernel, int width, int height, int lanes, double units = 1, int first_row = 0,
                   int group = kPacketGroupSide);

// The same grid as one launch, enqueued without waiting (no bands, no progress), `depth` deep
// (get_global_id(2): auto's probe fills the small lattices of all cache entries in one launch, 48
// on the cup array). Returns the launch's event.
cl::Event enqueue_packets(Runtime& runtime, cl::Kernel& kernel, int width, int height, int lanes, int depth = 1);

// The source of a cl/ file with every #include "…" replaced by the file's text.
std::string expand_kernel_source(const std::string& path);

// Throws "WHAT: needs N MiB in one buffer, the device allows M MiB (DEVICE, …)" when `bytes` exceed
// the device's largest allocation or its global memory: the same line on every device, checked
// before the implementation sees the request (PoCL asserts on an oversized buffer).
void check_allocation(const Runtime& runtime, std::uint64_t bytes, const std::string& what);

// Allocation helpers that turn CL_MEM_OBJECT_ALLOCATION_FAILURE and friends into one clear line.
cl::Buffer make_buffer(Runtime& runtime, cl_mem_flags flags, std::size_t bytes, const void* host_data,
                       const std::string& what);

}  // namespace sombra::host
