// sombra — KernelArgs: binding by declared name (kernel_args.h).
#include "host/kernel_args.h"

#include "host/program_cache.h"
#include "sombra/error.h"

namespace sombra::host {
namespace {

std::string kernel_name(const cl::Kernel& kernel) { return kernel.getInfo<CL_KERNEL_FUNCTION_NAME>().c_str(); }

// The declared name: as registered when the program was built (a program loaded from a binary may
// not report it), else as the program reports it.
std::string arg_name(const cl::Kernel& kernel, cl_uint index) {
    if (auto registered = registered_arg_name(kernel, index)) return *registered;
    return kernel.getArgInfo<CL_KERNEL_ARG_NAME>(index).c_str();
}

}  // namespace

void KernelArgs::expect(const char* bound_name) const {
    std::string name = prefix_ + bound_name;
    cl_uint declared = kernel_.getInfo<CL_KERNEL_NUM_ARGS>();
    if (next_ >= declared)
        throw Error("kernel " + kernel_name(kernel_) + ": the host binds '" + name + "' as argument " + std::to_string(next_) +
                    " but the kernel declares " + std::to_string(declared) + " arguments");
    std::string actual = arg_name(kernel_, next_);
    if (actual != name)
        throw Error("kernel " + kernel_name(kernel_) + ": argument " + std::to_string(next_) + " is '" + actual +
                    "' in the kernel but the host binds '" + name + "'");
}

KernelArgs& KernelArgs::local(const char* name, std::size_t bytes) {
    expect(name);
    kernel_.setArg(next_++, cl::Local(bytes));
    return *this;
}

void KernelArgs::done() const {
    cl_uint declared = kernel_.getInfo<CL_KERNEL_NUM_ARGS>();
    if (next_ != declared)
        throw Error("kernel " + kernel_name(kernel_) + ": the host binds " + std::to_string(next_) + " arguments, the kernel declares " +
                    std::to_string(declared) + (next_ < declared ? " (next: '" + arg_name(kernel_, next_) + "')" : ""));
}

}  // namespace sombra::host
