#include "fuzz_support.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

namespace sombra::fuzz {
namespace {

// Removed when the process ends normally.
struct Folder {
    std::string path;
    Folder() {
        const char* base = std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : "/tmp";
        std::string pattern = std::string(base) + "/sombra-fuzz-XXXXXX";
        if (!::mkdtemp(pattern.data())) {
            std::perror("sombra fuzz: mkdtemp");
            std::abort();
        }
        path = pattern;
    }
    ~Folder() {
        std::error_code ec;
        std::filesystem::remove_all(path, ec);
    }
};

}  // namespace

std::string input_file(const std::string& name, const std::uint8_t* data, std::size_t size) {
    static const Folder folder;
    const std::string path = folder.path + "/" + name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
    if (!out) {
        std::perror("sombra fuzz: cannot write the input file");
        std::abort();
    }
    return path;
}

}  // namespace sombra::fuzz
