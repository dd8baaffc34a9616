// sombra fuzzing — shared by the harnesses (fuzz_*.cpp). Each harness defines
// LLVMFuzzerTestOneInput; libFuzzer drives it (scripts/fuzz.sh), and replay_main.cpp runs the same
// function over files in the normal build (the fuzz-regressions ctests).
//
// The contract under test: bad input may only end in a sombra::Error. Any other exception
// (std::bad_alloc, a filesystem or JSON exception) escapes the harness and aborts: a finding, as are
// crashes, sanitizer reports, hangs (-timeout) and large allocations (-malloc_limit_mb).
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "sombra/error.h"

namespace sombra::fuzz {

// Writes the bytes to NAME in this process's private temporary folder (the readers take paths) and
// returns the path; the file replaces the previous input of the same name.
std::string input_file(const std::string& name, const std::uint8_t* data, std::size_t size);

// Runs f; a sombra::Error is the expected answer to bad input and is swallowed (printed when the
// environment sets SOMBRA_FUZZ_VERBOSE, as "error: …", or "loaded" when f returned).
template <typename F>
void expect_clean(F&& f) {
    const bool verbose = std::getenv("SOMBRA_FUZZ_VERBOSE") != nullptr;
    try {
        f();
        if (verbose) std::fprintf(stderr, "loaded\n");
    } catch (const sombra::Error& e) {
        if (verbose) std::fprintf(stderr, "error: %s\n", e.what());
    }
}

}  // namespace sombra::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
