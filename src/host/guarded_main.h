// sombra — the main() of every executable: runs `run` and turns any error into one line
// "PROGRAM: error: …" on stderr and exit code 1.
#pragma once
#include <CL/opencl.hpp>

#include <iostream>

#include "sombra/error.h"

namespace sombra::host {

inline int guarded_main(const char* program, int (*run)(int, char**), int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const sombra::Error& e) {
        std::cerr << program << ": error: " << e.what() << "\n";
    } catch (const cl::Error& e) {
        std::cerr << program << ": error: OpenCL: " << e.what() << " failed with error " << e.err() << "\n";
    } catch (const std::exception& e) {
        std::cerr << program << ": error: " << e.what() << "\n";
    }
    return 1;
}

}  // namespace sombra::host
