// sombra — the host/kernel argument contract: arguments are bound in order, each under the name
// the kernel's signature gives it. Every program is built with -cl-kernel-arg-info (runtime.cpp),
// so a binding whose name differs from the one the kernel declares at that position — an argument
// added, dropped or reordered on one side only — throws an Error naming the kernel, the position
// and both names instead of running with shifted arguments. done() checks that none is left out.
#pragma once
#include <CL/opencl.hpp>

#include <string>

namespace sombra::host {

class KernelArgs {
public:
    explicit KernelArgs(cl::Kernel& kernel) : kernel_(kernel) {}

    template <class T>
    KernelArgs& operator()(const char* name, const T& value) {
        expect(name);
        kernel_.setArg(next_++, value);
        return *this;
    }
    // A __local buffer of `bytes`.
    KernelArgs& local(const char* name, std::size_t bytes);

    // Prepends `prefix` to the names of the following bindings (a kernel that reads a second set
    // of a backend's buffers declares them as prefix + the backend's names).
    KernelArgs& prefix(std::string prefix) {
        prefix_ = std::move(prefix);
        return *this;
    }

    cl_uint bound() const { return next_; }
    // Throws unless every argument the kernel declares has been bound.
    void done() const;

private:
    void expect(const char* name) const;
    cl::Kernel& kernel_;
    cl_uint next_ = 0;
    std::string prefix_;
};

}  // namespace sombra::host
