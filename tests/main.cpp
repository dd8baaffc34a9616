#define CATCH_CONFIG_RUNNER
#include <CL/opencl.hpp>
#include <catch2/catch.hpp>

#include <cstdlib>
#include <string>

// An OpenCL call that fails names itself and its error code (what() alone is the call's name:
// "clWaitForEvents" said nothing about why a kernel failed on a GPU).
CATCH_TRANSLATE_EXCEPTION(const cl::Error& e) { return std::string(e.what()) + " failed with OpenCL error " + std::to_string(e.err()); }

// The shadow cache's auto keeps measured times across processes (src/render/shadow_cache_history.h):
// the tests run without that history unless told otherwise (SOMBRA_AUTO_HISTORY), so that a test
// that expects auto to probe probes whatever an earlier run measured; the history's own tests
// point it at a folder of their own. The CLI processes the tests start inherit it.
int main(int argc, char* argv[]) {
    setenv("SOMBRA_AUTO_HISTORY", "off", 0);
    return Catch::Session().run(argc, argv);
}
