// The on-disk program cache (src/host/program_cache.h): a second runtime loads what the first
// compiled, binds arguments by name without the driver's argument info, renders the same image,
// and treats every damaged, foreign or unwritable cache file as absent.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <thread>
#include <nlohmann/json.hpp>

#include "host/kernel_args.h"
#include "host/runtime.h"
#include "sombra/device.h"
#include "test_support.h"

using namespace sombra;
namespace fs = std::filesystem;

namespace {

// Sets an environment variable for the scope of one test (each test case runs in its own process
// under ctest; restored for runs of the whole binary).
struct Variable {
    std::string name, value, previous;
    bool had_previous;
    Variable(std::string name_, const std::string& value_) : name(std::move(name_)), value(value_) {
        const char* old = std::getenv(name.c_str());
        had_previous = old != nullptr;
        previous = old ? old : "";
        setenv(name.c_str(), value.c_str(), 1);
    }
    ~Variable() {
        if (had_previous) setenv(name.c_str(), previous.c_str(), 1);
        else unsetenv(name.c_str());
    }
};

// SOMBRA_KERNEL_CACHE (the cache folder, or off) for the scope of one test.
struct CacheFolder : Variable {
    std::string& path = value;
    explicit CacheFolder(const std::string& folder) : Variable("SOMBRA_KERNEL_CACHE", folder) {}
};

std::vector<fs::path> cache_files(const std::string& folder) {
    std::vector<fs::path> files;
    if (fs::exists(folder))
        for (auto& entry : fs::directory_iterator(folder)) files.push_back(entry.path());
    return files;
}

// Builds segments.cl in a fresh runtime; returns {compiled, loaded}. Checks name binding on every
// kernel: the names KernelArgs binds by are those a build from source reports, and another name
// is refused before anything is set.
std::pair<int, int> build_once() {
    host::Runtime runtime(test::device_selector());
    cl::Program& program = runtime.program("segments.cl", {});
    std::vector<cl::Kernel> kernels;
    program.createKernels(&kernels);
    REQUIRE(!kernels.empty());
    static host::KernelArgNames from_source;  // of the first build in this process, from source
    if (from_source.empty()) {
        CacheFolder off("off");
        host::Runtime fresh(test::device_selector());
        from_source = host::read_arg_names(fresh.program("segments.cl", {}));
    }
    for (auto& kernel : kernels) {
        const std::string name = kernel.getInfo<CL_KERNEL_FUNCTION_NAME>().c_str();
        const std::vector<std::string>& declared = from_source.at(name);
        REQUIRE(declared.size() == kernel.getInfo<CL_KERNEL_NUM_ARGS>());
        for (cl_uint i = 0; i < declared.size(); ++i) CHECK(host::registered_arg_name(kernel, i) == declared[i]);
        if (declared.empty()) continue;
        host::KernelArgs wrong(kernel);
        std::string message = test::error_of([&] { wrong("not_an_argument", cl_uint(0)); });
        CHECK(message.find("argument 0 is '" + declared[0] + "' in the kernel but the host binds 'not_an_argument'") != std::string::npos);
    }
    return {runtime.programs_compiled(), runtime.programs_loaded()};
}

}  // namespace

TEST_CASE("program cache: a second runtime loads the first one's binary and binds arguments by name", "[program_cache]") {
    CacheFolder cache(test::temp_dir() + "/kernels-reload");
    CHECK(build_once() == std::pair<int, int>{1, 0});
    auto files = cache_files(cache.path);
    REQUIRE(files.size() == 1);
    CHECK(files[0].extension() == ".bin");
    CHECK(build_once() == std::pair<int, int>{0, 1});
    CHECK(cache_files(cache.path).size() == 1);
}

TEST_CASE("program cache: other defines are another program", "[program_cache]") {
    CacheFolder cache(test::temp_dir() + "/kernels-defines");
    host::Runtime runtime(test::device_selector());
    runtime.program("segments.cl", {});
    runtime.program("segments.cl", {"SOMBRA_UNUSED_DEFINE=1"});
    CHECK(runtime.programs_compiled() == 2);
    CHECK(cache_files(cache.path).size() == 2);
}

TEST_CASE("program cache: damaged, foreign and truncated files are rebuilt and replaced", "[program_cache]") {
    CacheFolder cache(test::temp_dir() + "/kernels-damaged");
    REQUIRE(build_once() == std::pair<int, int>{1, 0});
    fs::path file = cache_files(cache.path).at(0);
    std::string good;
    {
        std::ifstream in(file, std::ios::binary);
        good.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    REQUIRE(good.size() > 1000);
    std::vector<std::pair<std::string, std::string>> damages = {
        {"empty", ""},
        {"magic only", good.substr(0, 23)},
        {"truncated in the names", good.substr(0, 120)},
        {"truncated in the binary", good.substr(0, good.size() - 100)},
        {"one byte more", good + "x"},
        {"another file's digest", [&] { std::string s = good; s[31] ^= 1; return s; }()},
        {"a length of 2^63", [&] { std::string s = good; s[23 + 7] = char(0x80); return s; }()},
        {"binary bytes flipped", [&] {
             std::string s = good;
             for (std::size_t i = s.size() - 64; i < s.size(); ++i) s[i] = char(~s[i]);
             return s;
         }()},
        {"the middle zeroed", [&] {
             std::string s = good;
             std::fill(s.begin() + std::ptrdiff_t(s.size() / 2), s.begin() + std::ptrdiff_t(s.size() / 2 + 4096 < s.size() ? s.size() / 2 + 4096 : s.size()), '\0');
             return s;
         }()},
    };
    for (auto& [name, content] : damages) {
        INFO(name);
        { std::ofstream(file, std::ios::binary | std::ios::trunc) << content; }
        std::pair<int, int> counts{-1, -1};
        REQUIRE_NOTHROW(counts = build_once());
        // a damaged binary the driver still accepts is caught by the names check or used as is
        // only when it builds the same kernels; what matters is that nothing throws or crashes
        CHECK(counts.first + counts.second == 1);
        if (counts.first == 1) CHECK(build_once() == std::pair<int, int>{0, 1});  // replaced by a good file
    }
}

TEST_CASE("program cache: the driver settings (CL_CONFIG_ variables) are part of the key", "[program_cache]") {
    // Intel's CPU runtime compiles by these variables: a binary built with its vectoriser off must
    // not be loaded with it on, nor the other way round
    CacheFolder cache(test::temp_dir() + "/kernels-settings");
    CHECK(build_once() == std::pair<int, int>{1, 0});
    {
        Variable mode("CL_CONFIG_CPU_VECTORIZER_MODE", "1");
        CHECK(build_once() == std::pair<int, int>{1, 0});
        CHECK(build_once() == std::pair<int, int>{0, 1});
        CHECK(cache_files(cache.path).size() == 2);
        Variable math("CL_CONFIG_USE_FAST_RELAXED_MATH", "False");
        CHECK(build_once() == std::pair<int, int>{1, 0});
    }
    CHECK(build_once() == std::pair<int, int>{0, 1});  // the first binary again
    CHECK(cache_files(cache.path).size() == 3);
    {
        Variable other("SOMBRA_NOT_A_DRIVER_SETTING", "1");  // other variables are not
        CHECK(build_once() == std::pair<int, int>{0, 1});
    }
}

TEST_CASE("program cache: driver_settings lists every CL_CONFIG_ variable, sorted", "[program_cache]") {
    Variable b("CL_CONFIG_SOMBRA_TEST_B", "2"), a("CL_CONFIG_SOMBRA_TEST_A", "x=1"), not_one("NOT_CL_CONFIG_SOMBRA_TEST", "3");
    const std::string settings = host::driver_settings();
    INFO(settings);
    const auto at_a = settings.find("CL_CONFIG_SOMBRA_TEST_A=x=1\n"), at_b = settings.find("CL_CONFIG_SOMBRA_TEST_B=2\n");
    REQUIRE(at_a != std::string::npos);
    REQUIRE(at_b != std::string::npos);
    CHECK(at_a < at_b);
    CHECK(settings.find("NOT_CL_CONFIG") == std::string::npos);
    std::string previous;  // every line a CL_CONFIG_ variable, in order
    for (std::size_t at = 0, end; at < settings.size(); at = end + 1) {
        end = settings.find('\n', at);
        REQUIRE(end != std::string::npos);
        const std::string line = settings.substr(at, end - at);
        CHECK(line.rfind("CL_CONFIG_", 0) == 0);
        CHECK(previous < line);
        previous = line;
    }
}

TEST_CASE("program cache: off writes nothing, and an unwritable folder only costs a build", "[program_cache]") {
    std::string dir = test::temp_dir() + "/unwritable";
    fs::create_directories(dir);
    {
        CacheFolder cache("off");
        CHECK(build_once() == std::pair<int, int>{1, 0});
        CHECK(build_once() == std::pair<int, int>{1, 0});
    }
    {
        std::ofstream(dir + "/a_file") << "not a folder";
        CacheFolder cache(dir + "/a_file/kernels");
        CHECK(build_once() == std::pair<int, int>{1, 0});
        CHECK(build_once() == std::pair<int, int>{1, 0});
    }
}

TEST_CASE("program cache: the CLI renders the same image from cached programs and reports them", "[program_cache][cli]") {
    std::string dir = test::temp_dir();
    std::string device = " --device " + test::device_selector();
    auto render = [&](const std::string& name) {
        auto run = test::run_cli_output("render " + test::data_path("scenes/smoke.json") + " -o " + dir + "/" + name +
                                        ".png --width 24 --height 24 --dsm-res 32 --shadow-cache off --stats " + dir + "/" + name + ".json" +
                                        device);  // off: auto's measured choice (and its programs) may differ run to run
        INFO(run.err);
        REQUIRE(run.exit_code == 0);
        std::ifstream in(dir + "/" + name + ".json");
        return nlohmann::json::parse(in)["programs"];
    };
    // run_cli_output runs the command through the shell: the variable goes in front
    setenv("SOMBRA_KERNEL_CACHE", (dir + "/kernels").c_str(), 1);
    auto first = render("first");
    auto second = render("second");
    unsetenv("SOMBRA_KERNEL_CACHE");
    CHECK(first["compiled"].get<int>() >= 2);  // the DSM build and the camera pass at least
    CHECK(first["loaded_from_cache"].get<int>() == 0);
    CHECK(second["compiled"].get<int>() == 0);
    CHECK(second["loaded_from_cache"].get<int>() == first["compiled"].get<int>());
    std::ifstream a(dir + "/first.png", std::ios::binary), b(dir + "/second.png", std::ios::binary);
    std::string bytes_a((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
    std::string bytes_b((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
    CHECK(!bytes_a.empty());
    CHECK((bytes_a == bytes_b));  // (parenthesised: Catch would print the bytes)
}

// PoCL compiles a kernel's work-group function once per launch shape it meets unless its
// specialization is off (docs/architecture.md "Facts about PoCL"); sombra turns it off before it
// looks for platforms, once per process, and keeps a value the user set. Checked on what PoCL
// compiled: a CLI render with both caches empty leaves one work-group function per kernel, the
// generic one ("0-0-0"), where a tiled launch's bands add one for a global offset of 0 and one for
// the others ("4-4-1-goffs0-smallgrid", "4-4-1-smallgrid") when the user asks for specialization.
TEST_CASE("runtime: PoCL's work-group specialization is turned off unless the user set it", "[program_cache]") {
    bool pocl = false;
    for (const auto& d : list_devices()) pocl = pocl || d.platform.find("Portable Computing Language") != std::string::npos;
    if (!pocl) {
        WARN("no PoCL platform: not checked");
        return;
    }
    // the compiled variants of each kernel after a render with both caches empty, the variable
    // unset (empty `user`) or set to `user` in the CLI's environment
    auto variants_after_render = [](const std::string& user) {
        const std::string dir = test::temp_dir();
        Variable pocl_cache("POCL_CACHE_DIR", dir + "/pocl"), kernels("SOMBRA_KERNEL_CACHE", dir + "/kernels");
        Variable specialization("POCL_WORK_GROUP_SPECIALIZATION", user);
        if (user.empty()) unsetenv("POCL_WORK_GROUP_SPECIALIZATION");  // (restored when the scope ends)
        auto run = test::run_cli_output("render " + test::data_path("scenes/smoke.json") + " -o " + dir +
                                        "/smoke.png --width 24 --height 24 --dsm-res 32 --shadow-cache off --device " +
                                        test::device_selector());
        INFO(run.err);
        REQUIRE(run.exit_code == 0);
        std::map<std::string, std::set<std::string>> variants;  // by kernel folder
        for (const auto& entry : fs::recursive_directory_iterator(dir + "/pocl")) {
            if (!entry.is_directory() || !fs::exists(entry.path() / "program.bc")) continue;  // a program's folder
            for (const auto& kernel : fs::directory_iterator(entry.path()))
                if (kernel.is_directory())
                    for (const auto& variant : fs::directory_iterator(kernel.path()))
                        variants[kernel.path().string()].insert(variant.path().filename().string());
        }
        return variants;
    };
    const auto generic = variants_after_render("");
    CHECK(generic.size() >= 3);  // the DSM build, its packing and the camera pass at least
    for (const auto& [kernel, names] : generic) {
        INFO(kernel);
        CHECK(names == std::set<std::string>{"0-0-0"});
    }
    std::size_t specialized = 0;  // kernels with more than the generic function
    for (const auto& [kernel, names] : variants_after_render("1")) specialized += names.size() > 1;
    CHECK(specialized >= 2);  // the DSM build and the camera pass, launched in bands
}

// PoCL's worker threads are pinned, one per CPU, unless the user set POCL_AFFINITY (src/host/
// runtime.cpp set_pocl_defaults; unpinned, auto's short probe launches ran at about half speed in
// most processes). Checked on the threads themselves: after a render, PoCL's workers each allow
// one CPU, and together more than one (/proc/self/task/*/status Cpus_allowed_list).
TEST_CASE("runtime: PoCL's threads are pinned unless the user set POCL_AFFINITY", "[program_cache]") {
    const char* before = std::getenv("POCL_AFFINITY");
    if (before && std::string(before) != "1") {
        WARN("POCL_AFFINITY=" << before << " set by the user: kept, not checked");
        return;
    }
    bool pocl = false;
    for (const auto& d : list_devices()) pocl = pocl || d.platform.find("Portable Computing Language") != std::string::npos;
    if (!pocl || std::thread::hardware_concurrency() < 2) {
        WARN("no PoCL platform or one CPU: not checked");
        return;
    }
    REQUIRE(std::getenv("POCL_AFFINITY") != nullptr);
    CHECK(std::string(std::getenv("POCL_AFFINITY")) == "1");
    Context context(test::device_selector());
    RenderOptions o = test::unshadowed();
    o.width = o.height = 16;
    render(context, test::overlapping_scene(), o);  // PoCL starts its workers at its first launch
    std::set<std::string> single_cpus;  // the CPUs of threads allowed on one CPU only
    for (const auto& task : fs::directory_iterator("/proc/self/task")) {
        std::ifstream status(task.path() / "status");
        for (std::string line; std::getline(status, line);) {
            const std::string key = "Cpus_allowed_list:";
            if (line.compare(0, key.size(), key) != 0) continue;
            std::string cpus = line.substr(key.size());
            cpus.erase(0, cpus.find_first_not_of(" \t"));
            if (cpus.find_first_of(",-") == std::string::npos) single_cpus.insert(cpus);
        }
    }
    CHECK(single_cpus.size() >= 2);
}
