// sombra — compiled programs on disk (program_cache.h).
#include "host/program_cache.h"

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#define XXH_INLINE_ALL
#include <xxhash.h>

namespace sombra::host {
namespace {

constexpr char kMagic[] = "sombra-program-cache 3\n";  // 3: XXH3 digests
// A cached binary larger than this is treated as damage (PoCL's are 0.1–2 MiB).
constexpr std::uint64_t kMaxBinaryBytes = std::uint64_t(1) << 30;
constexpr std::uint64_t kMaxNames = 1 << 16;
// The folder keeps the most recently used files: beyond kMaxFiles the oldest go down to kKeepFiles
// (every kernel edit makes new programs; PoCL's files are 0.1–0.3 MiB).
constexpr std::size_t kMaxFiles = 512, kKeepFiles = 384;

// Removes the least recently used cache files when there are too many (loads touch their file).
void prune(const std::string& folder) {
    std::error_code error;
    std::vector<std::pair<std::filesystem::file_time_type, std::filesystem::path>> files;
    for (auto it = std::filesystem::directory_iterator(folder, error); !error && it != std::filesystem::directory_iterator();
         it.increment(error))
        if (it->path().extension() == ".bin") files.emplace_back(it->last_write_time(error), it->path());
    if (files.size() <= kMaxFiles) return;
    std::sort(files.begin(), files.end());
    for (std::size_t i = 0; i + kKeepFiles < files.size(); ++i) std::filesystem::remove(files[i].second, error);
}

// XXH3's 128-bit hash of a byte string (Debian's libxxhash, inlined): it names the file, and the
// file repeats it. Every program load hashes its expanded source (render.cl: 0.9 MB) and its
// binary; the byte-at-a-time FNV-1a this replaced took 1.3 ms a megabyte, XXH3 well under 0.1.
std::string digest_of(const std::string& text) {
    const XXH128_hash_t hash = XXH3_128bits(text.data(), text.size());
    char out[33];
    std::snprintf(out, sizeof out, "%016llx%016llx", (unsigned long long)hash.high64, (unsigned long long)hash.low64);
    return out;
}

// Length-prefixed fields; a reader that runs off the end or meets an absurd length fails.
void put_u64(std::string& out, std::uint64_t v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); }
void put_string(std::string& out, const std::string& s) {
    put_u64(out, s.size());
    out += s;
}

struct Reader {
    const std::string& data;
    std::size_t at = 0;
    bool ok = true;
    std::uint64_t u64() {
        std::uint64_t v = 0;
        if (!ok || data.size() - at < sizeof v) return ok = false, 0;
        std::memcpy(&v, data.data() + at, sizeof v);
        at += sizeof v;
        return v;
    }
    std::string string(std::uint64_t limit) {
        std::uint64_t n = u64();
        if (!ok || n > limit || data.size() - at < n) return ok = false, std::string();
        std::string s = data.substr(at, std::size_t(n));
        at += std::size_t(n);
        return s;
    }
};

// Never destroyed: runtimes held in statics (a process-wide Context) unregister during exit, after
// a function-local static map would be gone.
std::mutex& registry_mutex() {
    static auto* mutex = new std::mutex;
    return *mutex;
}
std::map<cl_program, KernelArgNames>& registry() {
    static auto* names = new std::map<cl_program, KernelArgNames>;
    return *names;
}

}  // namespace

std::string user_cache_folder(const char* variable, const std::string& leaf) {
    if (const char* chosen = std::getenv(variable); chosen && *chosen) return std::string(chosen) == "off" ? std::string() : std::string(chosen);
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::string(xdg) + "/sombra/" + leaf;
    if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.cache/sombra/" + leaf;
    return std::string();
}

std::string default_kernel_cache_folder() { return user_cache_folder("SOMBRA_KERNEL_CACHE", "kernels"); }

std::string driver_settings() {
    std::vector<std::string> settings;
    for (char** variable = environ; variable && *variable; ++variable)
        if (std::strncmp(*variable, "CL_CONFIG_", 10) == 0) settings.emplace_back(*variable);
    std::sort(settings.begin(), settings.end());
    std::string lines;
    for (auto& setting : settings) lines += setting + '\n';
    return lines;
}

KernelArgNames read_arg_names(cl::Program& program) {
    KernelArgNames names;
    std::vector<cl::Kernel> kernels;
    program.createKernels(&kernels);
    for (auto& kernel : kernels) {
        std::vector<std::string>& args = names[kernel.getInfo<CL_KERNEL_FUNCTION_NAME>().c_str()];
        cl_uint count = kernel.getInfo<CL_KERNEL_NUM_ARGS>();
        for (cl_uint i = 0; i < count; ++i) args.push_back(kernel.getArgInfo<CL_KERNEL_ARG_NAME>(i).c_str());
    }
    return names;
}

void register_arg_names(cl_program program, KernelArgNames names) {
    std::lock_guard<std::mutex> lock(registry_mutex());
    registry()[program] = std::move(names);
}

void unregister_arg_names(cl_program program) {
    std::lock_guard<std::mutex> lock(registry_mutex());
    registry().erase(program);
}

std::optional<std::string> registered_arg_name(const cl::Kernel& kernel, cl_uint index) {
    cl_program program = kernel.getInfo<CL_KERNEL_PROGRAM>()();
    std::string name = kernel.getInfo<CL_KERNEL_FUNCTION_NAME>().c_str();
    std::lock_guard<std::mutex> lock(registry_mutex());
    auto found = registry().find(program);
    if (found == registry().end()) return std::nullopt;
    auto args = found->second.find(name);
    if (args == found->second.end() || index >= args->second.size()) return std::nullopt;
    return args->second[index];
}

ProgramCache::ProgramCache(cl::Context context, cl::Device device, std::string device_identity)
    : context_(std::move(context)), device_(std::move(device)), identity_(std::move(device_identity)),
      folder_(default_kernel_cache_folder()) {
    if (const char* dump = std::getenv("SOMBRA_DUMP_PROGRAMS"); dump && *dump) dump_folder_ = dump;
}

ProgramCache::Built ProgramCache::build(const std::string& source, const std::string& options) {
    const std::string digest = digest_of(identity_ + '\0' + driver_settings() + '\0' + options + '\0' + source);
    const std::string path = folder_.empty() ? std::string() : folder_ + "/" + digest + ".bin";
    if (!dump_folder_.empty()) {  // every program asked for, whether built or loaded below
        std::error_code ignored;
        std::filesystem::create_directories(dump_folder_, ignored);
        std::ofstream(dump_folder_ + "/" + digest + ".cl", std::ios::binary) << source;
        std::ofstream(dump_folder_ + "/" + digest + ".options", std::ios::binary) << options << '\n';
    }
    if (!path.empty())
        if (auto cached = load(path, digest)) return std::move(*cached);
    Built built{cl::Program(context_, source), {}, false};
    try {
        built.program.build(std::vector<cl::Device>{device_}, options.c_str());
    } catch (const cl::Error&) {
        throw ProgramBuildError{built.program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_)};
    }
    built.arg_names = read_arg_names(built.program);
    if (!path.empty()) store(path, digest, built);
    return built;
}

std::optional<ProgramCache::Built> ProgramCache::load(const std::string& path, const std::string& digest) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (data.compare(0, sizeof kMagic - 1, kMagic) != 0) return std::nullopt;
    Reader read{data, sizeof kMagic - 1};
    if (read.string(64) != digest || read.string(1 << 16) != identity_) return std::nullopt;
    Built built;
    std::uint64_t kernels = read.u64();
    if (!read.ok || kernels > kMaxNames) return std::nullopt;
    for (std::uint64_t k = 0; k < kernels && read.ok; ++k) {
        std::vector<std::string>& args = built.arg_names[read.string(4096)];
        std::uint64_t count = read.u64();
        if (count > kMaxNames) return std::nullopt;
        for (std::uint64_t a = 0; a < count && read.ok; ++a) args.push_back(read.string(4096));
    }
    std::string checksum = read.string(64);
    std::string binary = read.string(kMaxBinaryBytes);
    // the driver never sees damaged bytes: PoCL aborts the process on some (a zeroed stretch)
    if (!read.ok || read.at != data.size() || binary.empty() || checksum != digest_of(binary)) return std::nullopt;
    try {
        cl::Program::Binaries binaries{std::vector<unsigned char>(binary.begin(), binary.end())};
        std::vector<cl_int> status;
        built.program = cl::Program(context_, std::vector<cl::Device>{device_}, binaries, &status);
        built.program.build(std::vector<cl::Device>{device_});
        // the kernels the names describe must be the program's (a damaged binary may still load)
        std::vector<cl::Kernel> made;
        built.program.createKernels(&made);
        if (made.size() != built.arg_names.size()) return std::nullopt;
        for (auto& kernel : made) {
            auto args = built.arg_names.find(kernel.getInfo<CL_KERNEL_FUNCTION_NAME>().c_str());
            if (args == built.arg_names.end() || args->second.size() != kernel.getInfo<CL_KERNEL_NUM_ARGS>())
                return std::nullopt;
        }
    } catch (const cl::Error&) {
        return std::nullopt;  // the driver refuses it: build from source and overwrite
    }
    built.from_cache = true;
    std::error_code ignored;  // most recently used (prune)
    std::filesystem::last_write_time(path, std::filesystem::file_time_type::clock::now(), ignored);
    return built;
}

void ProgramCache::store(const std::string& path, const std::string& digest, const Built& built) const {
    std::vector<std::vector<unsigned char>> binaries;
    try {
        binaries = built.program.getInfo<CL_PROGRAM_BINARIES>();
    } catch (const cl::Error&) {
        return;
    }
    if (binaries.size() != 1 || binaries[0].empty()) return;
    std::string data = kMagic;
    put_string(data, digest);
    put_string(data, identity_);
    put_u64(data, built.arg_names.size());
    for (auto& [kernel, args] : built.arg_names) {
        put_string(data, kernel);
        put_u64(data, args.size());
        for (auto& a : args) put_string(data, a);
    }
    std::string binary(binaries[0].begin(), binaries[0].end());
    put_string(data, digest_of(binary));
    put_string(data, binary);
    std::error_code error;
    std::filesystem::create_directories(folder_, error);
    if (error) return;
    // unique per process and thread: Runtimes in several threads may store the same program
    std::ostringstream temporary;
    temporary << path << ".tmp." << ::getpid() << '.' << static_cast<const void*>(&data);
    {
        std::ofstream out(temporary.str(), std::ios::binary | std::ios::trunc);
        if (!out.write(data.data(), std::streamsize(data.size()))) {
            out.close();
            std::filesystem::remove(temporary.str(), error);
            return;
        }
    }
    std::filesystem::rename(temporary.str(), path, error);
    if (error) std::filesystem::remove(temporary.str(), error);
    prune(folder_);
}

}  // namespace sombra::host
