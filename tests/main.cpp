#define CATCH_CONFIG_MAIN
#include <CL/opencl.hpp>
#include <catch2/catch.hpp>

#include <string>

// An OpenCL call that fails names itself and its error code (what() alone is the call's name:
// "clWaitForEvents" said nothing about why a kernel failed on a GPU).
CATCH_TRANSLATE_EXCEPTION(const cl::Error& e) { return std::string(e.what()) + " failed with OpenCL error " + std::to_string(e.err()); }
