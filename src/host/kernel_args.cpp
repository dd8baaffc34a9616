// sombra — KernelArgs: binding by declared name (kernel_args.h).
#include "host/kernel_args.h"

#include "sombra/error.h"

namespace sombra::host {
namespace {

std::string kernel_name(const cl::Kernel& kernel) { return kernel.getInfo<CL_KERNEL_FUNCTION_NAME>().c_str(); }

}  // namespace

void KernelArgs::expect(const char* bound_name) const {
    std::string name = prefix_ + bound_name;
    cl_uint declared = kernel_.getInfo<CL_KERNEL_NUM_ARGS>();
    if (next_ >= declared)
        throw Error("kernel " + kernel_name(kernel_) + ": the host binds '" + name + "' as argument " + std::to_string(next_) +
                    " but the kernel declares " + std::to_string(declared) + " arguments");
    std::string actual = kernel_.getArgInfo<CL_KERNEL_ARG_NAME>(next_).c_str();
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
                    std::to_string(declared) + (next_ < declared ? " (next: '" + std::string(kernel_.getArgInfo<CL_KERNEL_ARG_NAME>(next_).c_str()) + "')" : ""));
}

}  // namespace sombra::host
