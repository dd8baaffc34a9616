// sombra — compiled OpenCL programs kept on disk between processes (issue 33: a cold driver such as
// Intel's CPU runtime compiles each program in 2.6–14 s and caches nothing).
//
// One file per program under the cache folder, named by a 128-bit digest of everything the binary
// depends on: the expanded source, the build options, the platform, device and driver versions, and
// the driver's compile settings in the environment (driver_settings(): Intel's CPU runtime compiles
// by CL_CONFIG_* variables, e.g. CL_CONFIG_CPU_VECTORIZER_MODE).
// The file holds that digest again, the kernels' argument names (OpenCL keeps them only for
// programs built from source; KernelArgs binds by name), the binary's digest and the binary. A
// file that is short, damaged (the driver never sees bytes whose digest differs: PoCL aborts the
// process on some) or from another build is ignored and rewritten; a folder that cannot be
// written only costs the next run a build. Files are written under a temporary name and renamed,
// so processes sharing the folder never read half a file.
//
// Folder: $SOMBRA_KERNEL_CACHE, else $XDG_CACHE_HOME/sombra/kernels, else ~/.cache/sombra/kernels;
// SOMBRA_KERNEL_CACHE=off disables it.
//
// SOMBRA_DUMP_PROGRAMS=DIR also writes each program the process asks for (built from source or
// loaded from the cache) as DIR/<digest>.cl (the expanded source) and DIR/<digest>.options (its
// build options): the input of the portability checks that compile every variant with another
// compiler (tests/portability/ptx_check.sh, no_fp64.sh).
#pragma once
#include <CL/opencl.hpp>

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace sombra::host {

// Argument names of every kernel in a program, in declaration order.
using KernelArgNames = std::map<std::string, std::vector<std::string>>;

// A compile error: the driver's build log.
struct ProgramBuildError {
    std::string log;
};

class ProgramCache {
public:
    // `device_identity`: platform, device and driver versions (what makes a binary valid).
    ProgramCache(cl::Context context, cl::Device device, std::string device_identity);

    struct Built {
        cl::Program program;
        KernelArgNames arg_names;
        bool from_cache = false;
    };
    // The program built from `source` (expanded) with `options`: loaded from the cache folder when
    // a valid binary is there, else compiled (a compile error throws ProgramBuildError) and stored.
    Built build(const std::string& source, const std::string& options);

    // The folder in use; empty when the cache is off.
    const std::string& folder() const { return folder_; }

private:
    std::optional<Built> load(const std::string& path, const std::string& digest);
    void store(const std::string& path, const std::string& digest, const Built& built) const;
    cl::Context context_;
    cl::Device device_;
    std::string identity_;
    std::string folder_;
    std::string dump_folder_;
};

// A folder of sombra's under the user's cache: $variable when set ("off": none, empty), else
// $XDG_CACHE_HOME/sombra/leaf, else ~/.cache/sombra/leaf; empty when none of them is set.
std::string user_cache_folder(const char* variable, const std::string& leaf);

// The folder the cache uses in this environment (see above; SOMBRA_KERNEL_CACHE, "kernels"); empty when off.
std::string default_kernel_cache_folder();

// Every CL_CONFIG_* environment variable as sorted NAME=value lines (empty when none): part
// of the cache key, so that a binary built under one setting is never loaded under another.
std::string driver_settings();

// Every kernel's argument names, read from a program built with -cl-kernel-arg-info.
KernelArgNames read_arg_names(cl::Program& program);

// The argument names of the programs the runtimes of this process hold, for KernelArgs (a program
// loaded from a binary may not report them). Runtime registers each program it builds and
// unregisters them when it is destroyed (OpenCL may reuse a released handle).
void register_arg_names(cl_program program, KernelArgNames names);
void unregister_arg_names(cl_program program);
// The name of `kernel`'s argument `index` as registered; nullopt when its program is not registered.
std::optional<std::string> registered_arg_name(const cl::Kernel& kernel, cl_uint index);

}  // namespace sombra::host
