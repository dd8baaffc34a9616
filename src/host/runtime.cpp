#include "host/runtime.h"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string_view>

#include "host/embedded_kernels.h"
#include "host/tiled_launch.h"
#include "sombra/error.h"

namespace sombra::host {
namespace {

// PoCL links kernels with `ld` and aborts the process when it is not on PATH (docs/architecture.md "Facts about PoCL").
void ensure_linker_on_path() {
    const char* path = std::getenv("PATH");
    std::string value = path ? path : "";
    if (value.find("/usr/bin") == std::string::npos) {
        value = value.empty() ? "/usr/bin:/bin" : value + ":/usr/bin:/bin";
        setenv("PATH", value.c_str(), 1);
    }
}

// PoCL's settings, where the user set none (docs/architecture.md "Facts about PoCL"):
// - POCL_WORK_GROUP_SPECIALIZATION=0. PoCL compiles each kernel's work-group function once per
//   launch shape it meets: for offset-0 and other global offsets (the tiled launches' first band
//   and the rest), for each local size, and once more without specialization for the binary the
//   program cache stores. Without specialization it compiles one function per kernel, used by
//   every launch: the default scene's first render with both caches cold 10.6 → 6.2 s, the same
//   images, kernel times within run-to-run noise.
// - POCL_AFFINITY=1: its worker threads pinned, one per CPU. Unpinned, the short launches of
//   auto's probe ran at about half speed in most processes (two_smokes_wall's AO at 256²: its
//   four camera launches 4.3–5.0 ms in 7 of 8 processes, pinned 2.8–3.6 ms in 7 of 8), and whole
//   frames ran 2.5–4.5 % slower in the median (bench/README.md "At least four blocks along each
//   axis").
// Once per process, so that later Runtimes never write the environment while other threads may
// read it.
void set_pocl_defaults() {
    static std::once_flag once;
    std::call_once(once, [] {
        setenv("POCL_WORK_GROUP_SPECIALIZATION", "0", 0);  // 0: a set value stays
        setenv("POCL_AFFINITY", "1", 0);
    });
}

struct DeviceEntry {
    cl::Platform platform;
    cl::Device device;
    DeviceInfo info;
};

std::vector<DeviceEntry> enumerate() {
    ensure_linker_on_path();
    set_pocl_defaults();
    std::vector<DeviceEntry> entries;
    std::vector<cl::Platform> platforms;
    try {
        cl::Platform::get(&platforms);
    } catch (const cl::Error&) {
        return entries;  // no ICD / no platform: an empty list
    }
    for (auto& platform : platforms) {
        std::vector<cl::Device> devices;
        try {
            platform.getDevices(CL_DEVICE_TYPE_ALL, &devices);
        } catch (const cl::Error&) {
            continue;
        }
        for (auto& device : devices) {
            DeviceInfo info;
            info.index = int(entries.size());
            info.platform = platform.getInfo<CL_PLATFORM_NAME>();
            info.name = device.getInfo<CL_DEVICE_NAME>();
            info.is_gpu = (device.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_GPU) != 0;
            info.opencl_c_version = device.getInfo<CL_DEVICE_OPENCL_C_VERSION>();
            info.global_memory_bytes = device.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
            info.max_allocation_bytes = device.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
            entries.push_back({platform, device, info});
        }
    }
    return entries;
}

std::string describe(const std::vector<DeviceEntry>& entries) {
    std::ostringstream out;
    for (auto& e : entries) out << (e.info.index ? ", " : "") << e.info.index << ": " << e.info.name;
    return entries.empty() ? "none" : out.str();
}

const DeviceEntry& choose(const std::vector<DeviceEntry>& entries, const std::string& selector) {
    if (entries.empty())
        throw Error("--device: no OpenCL device found (is pocl-opencl-icd installed? run scripts/install-deps.sh)");
    if (selector.empty() || selector == "auto") {
        for (auto& e : entries) if (e.info.is_gpu) return e;
        return entries.front();
    }
    if (selector == "gpu" || selector == "cpu") {
        for (auto& e : entries) if (e.info.is_gpu == (selector == "gpu")) return e;
        throw Error("--device: no " + selector + " device found; devices are: " + describe(entries));
    }
    char* end = nullptr;
    long index = std::strtol(selector.c_str(), &end, 10);
    if (end == selector.c_str() || *end != '\0')
        throw Error("--device: '" + selector + "' is not auto, cpu, gpu or a device index");
    if (index < 0 || index >= long(entries.size()))
        throw Error("--device: no device " + selector + "; devices are: " + describe(entries));
    return entries[std::size_t(index)];
}

}  // namespace

Runtime::Runtime(const std::string& selector) {
    auto entries = enumerate();
    const DeviceEntry& chosen = choose(entries, selector);
    info_ = chosen.info;
    device_ = chosen.device;
    context_ = cl::Context(device_);
    queue_ = cl::CommandQueue(context_, device_, CL_QUEUE_PROFILING_ENABLE);
    // -cl-kernel-arg-info: argument names for the binding contract (kernel_args.h). Division and
    // sqrt correctly rounded where the device offers it: OpenCL allows 2.5 ulp by default, which
    // NVIDIA's compiler takes and PoCL's does not (the closed-form tests compare with both).
    // Two diagnostics for a device check (docs/gpu-check.md), both in the program cache's key:
    // SOMBRA_CORRECT_DIVISION=0 leaves division at the device's default precision, and
    // SOMBRA_BUILD_OPTIONS is appended to every program's options (e.g. -cl-opt-disable).
    build_options_ = "-cl-std=CL1.2 -cl-kernel-arg-info";
    const char* correct_division = std::getenv("SOMBRA_CORRECT_DIVISION");
    if (device_.getInfo<CL_DEVICE_SINGLE_FP_CONFIG>() & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT &&
        !(correct_division && std::string(correct_division) == "0"))
        build_options_ += " -cl-fp32-correctly-rounded-divide-sqrt";
    if (const char* extra = std::getenv("SOMBRA_BUILD_OPTIONS"); extra && *extra) build_options_ += std::string(" ") + extra;
    const cl::Platform platform(device_.getInfo<CL_DEVICE_PLATFORM>());
    program_cache_ = std::make_unique<ProgramCache>(
        context_, device_,
        platform.getInfo<CL_PLATFORM_NAME>() + '|' + platform.getInfo<CL_PLATFORM_VERSION>() + '|' + info_.name + '|' +
            device_.getInfo<CL_DEVICE_VERSION>() + '|' + device_.getInfo<CL_DRIVER_VERSION>());
}

Runtime::~Runtime() {
    for (auto& [key, program] : programs_) unregister_arg_names(program());
}

std::string expand_kernel_source(const std::string& path) {
    // once per file and process: every program built from a file needs it (each variant of
    // render.cl: 0.9 MB expanded), and the embedded sources do not change
    static std::mutex mutex;
    static std::map<std::string, std::string> expanded;
    {
        std::lock_guard<std::mutex> lock(mutex);
        if (auto found = expanded.find(path); found != expanded.end()) return found->second;
    }
    const auto& sources = embedded_kernel_sources();
    std::set<std::string> open_files;
    std::string out;
    // Recursive textual include. Every inclusion is expanded, as the C preprocessor would (an
    // #include inside #if must not hide a later one: the headers' guards keep them single); a
    // file already being expanded is an include cycle and is skipped.
    auto expand = [&](const std::string& file, auto& self) -> void {
        if (!open_files.insert(file).second) return;
        auto it = sources.find(file);
        if (it == sources.end()) throw Error("cl/" + file + ": kernel source not embedded in this build");
        const std::string_view text = it->second;
        out += "#line 1 \"" + file + "\"\n";
        int number = 0;
        for (std::size_t at = 0; at < text.size();) {
            const std::size_t end = std::min(text.find('\n', at), text.size());
            const std::string_view line = text.substr(at, end - at);
            at = end + 1;
            ++number;
            const std::size_t pos = line.find("#include \"");
            if (pos != std::string_view::npos && line.find_first_not_of(" \t") == pos) {
                const std::size_t begin = pos + 10, close = line.find('"', begin);
                self(std::string(line.substr(begin, close - begin)), self);
                out += "#line " + std::to_string(number + 1) + " \"" + file + "\"\n";
            } else {
                out.append(line).push_back('\n');
            }
        }
        open_files.erase(file);
    };
    expand(path, expand);
    std::lock_guard<std::mutex> lock(mutex);
    return expanded.emplace(path, std::move(out)).first->second;
}

cl::Program& Runtime::program(const std::string& source, const std::vector<std::string>& defines) {
    std::string options = build_options_;
    for (auto& d : defines) options += " -D" + d;
    std::lock_guard<std::mutex> lock(cache_mutex_);
    std::string key = source + "|" + options;
    auto found = programs_.find(key);
    if (found != programs_.end()) return found->second;
    ProgressStage stage(progress_, "kernel build", 1);
    ProgramCache::Built built;
    try {
        built = program_cache_->build(expand_kernel_source(source), options);
    } catch (const ProgramBuildError& failure) {
        throw Error("cl/" + source + ": kernel build failed on " + info_.name + " with options '" + options +
                    "':\n" + failure.log);
    }
    ++(built.from_cache ? programs_loaded_ : programs_compiled_);
    register_arg_names(built.program(), std::move(built.arg_names));
    return programs_.emplace(key, std::move(built.program)).first->second;
}

double Runtime::event_ms(const cl::Event& event) {
    // Profiling data is defined once the command has completed (OpenCL 1.2 §5.12: reading it
    // earlier is CL_PROFILING_INFO_NOT_AVAILABLE); a blocking write may return before that.
    event.wait();
    auto start = event.getProfilingInfo<CL_PROFILING_COMMAND_START>();
    auto end = event.getProfilingInfo<CL_PROFILING_COMMAND_END>();
    return double(end - start) * 1e-6;
}

int packet_lanes(const Runtime& runtime, int requested) {
    int lanes = requested > 0 ? requested : (runtime.info().is_gpu ? 1 : 8);
    if (lanes != 1 && lanes != 4 && lanes != 8 && lanes != 16) throw Error("--lanes: must be 1, 4, 8 or 16");
    return lanes;
}

int generation_lanes(const Runtime& runtime, int requested) {
    if (requested > 0 || runtime.info().is_gpu) return packet_lanes(runtime, requested);
    const cl_uint native = runtime.device().getInfo<CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT>();
    return native >= 16 ? 16 : 8;
}

namespace {

// run_packets' work-items and groups (above run_packets in runtime.h)
struct PacketGrid {
    cl::NDRange global, local;
};

PacketGrid packet_grid(int width, int height, int lanes, int group_side = kPacketGroupSide) {
    std::size_t columns = std::size_t((width + lanes - 1) / lanes), rows = std::size_t(height);
    cl::NDRange local = cl::NullRange;
    if (lanes > 1) {
        const std::size_t group = std::size_t(std::max(1, group_side));
        columns = (columns + group - 1) / group * group;
        rows = (rows + group - 1) / group * group;
        local = cl::NDRange(group, group);
    }
    return {cl::NDRange(columns, rows), local};
}

}  // namespace

double run_packets(Runtime& runtime, cl::Kernel& kernel, int width, int height, int lanes, double units, int first_row, int group) {
    const PacketGrid grid = packet_grid(width, height, lanes, group);
    return run_tiled(runtime, kernel, grid.global, grid.local, units, std::size_t(first_row));
}

cl::Event enqueue_packets(Runtime& runtime, cl::Kernel& kernel, int width, int height, int lanes, int depth) {
    const PacketGrid grid = packet_grid(width, height, lanes);
    const cl::NDRange global(grid.global[0], grid.global[1], std::size_t(depth));
    const cl::NDRange local = lanes > 1 ? cl::NDRange(grid.local[0], grid.local[1], 1) : cl::NullRange;
    cl::Event event;
    runtime.queue().enqueueNDRangeKernel(kernel, cl::NullRange, global, local, nullptr, &event);
    return event;
}

void check_allocation(const Runtime& runtime, std::uint64_t bytes, const std::string& what) {
    const DeviceInfo& device = runtime.info();
    const auto mib = [](std::uint64_t b) { return std::to_string((b + (1u << 20) - 1) >> 20) + " MiB"; };
    if (bytes > device.max_allocation_bytes)
        throw Error(what + ": needs " + mib(bytes) + " in one buffer, the device allows " + mib(device.max_allocation_bytes) +
                    " (" + device.name + ", CL_DEVICE_MAX_MEM_ALLOC_SIZE)");
    if (bytes > device.global_memory_bytes)
        throw Error(what + ": needs " + mib(bytes) + ", the device has " + mib(device.global_memory_bytes) + " (" + device.name + ")");
}

cl::Buffer make_buffer(Runtime& runtime, cl_mem_flags flags, std::size_t bytes, const void* host_data,
                       const std::string& what) {
    if (bytes == 0) {  // OpenCL forbids empty buffers; kernels never read past their counts
        bytes = 16;
        host_data = nullptr;
    }
    // checked here rather than left to the implementation, which may assert (PoCL) instead of failing
    check_allocation(runtime, bytes, what);
    try {
        if (host_data) flags |= CL_MEM_COPY_HOST_PTR;
        return cl::Buffer(runtime.context(), flags, bytes, const_cast<void*>(host_data));
    } catch (const cl::Error& e) {
        throw Error(what + ": cannot allocate " + std::to_string(bytes >> 20) + " MiB on " + runtime.info().name +
                    " (" + e.what() + " error " + std::to_string(e.err()) + ")");
    }
}

}  // namespace sombra::host

namespace sombra {

std::vector<DeviceInfo> list_devices() {
    std::vector<DeviceInfo> out;
    for (auto& e : host::enumerate()) out.push_back(e.info);
    return out;
}


}  // namespace sombra
