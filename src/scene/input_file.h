// sombra — opening input files safely: only regular files (a FIFO, a device or a directory would
// block, never end or read as garbage), never more than the file's real size.
#pragma once
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace sombra::detail {

// The identity of a file: its device and inode (links resolved), as stat(2) gives them.
struct FileIdentity {
    std::uint64_t device = 0, inode = 0;
    bool operator==(const FileIdentity& o) const { return device == o.device && inode == o.inode; }
};

// What a non-regular file is, from its stat(2) mode: "a directory", "a FIFO", "a character
// device", "a block device", "a socket" or "not a plain file".
const char* file_kind(std::uint32_t mode);

// Every file this process opened through regular_file_size / read_regular_file (every reader goes
// through them), with the path it was opened by: outputs are checked against them so that no
// command ever writes over one of its own inputs (render/staged_outputs.h). Thread-safe.
std::vector<std::pair<FileIdentity, std::string>> inputs_read();

// Requires a regular file, opened without blocking; throws "PATH: cannot open for reading: …" or
// "PATH: not a regular file (a directory)". Returns its size in bytes.
std::uint64_t regular_file_size(const std::string& path);

// The whole regular file; throws "PATH: file too large: …" when it exceeds max_bytes.
std::vector<unsigned char> read_regular_file(const std::string& path, std::uint64_t max_bytes);

// Reads a stream whose length is only declared (compressed data): at most `declared` bytes, with
// memory growing as bytes arrive, never allocated up front from the declaration. `read` fills up
// to n bytes and returns how many it read (0 at the end, < 0 on error). Returns the bytes read
// (fewer than declared when the stream is short); sets *overrun when more bytes followed.
template <typename Read>
std::vector<unsigned char> read_declared(std::uint64_t declared, Read read, bool* overrun, bool* failed) {
    constexpr std::uint64_t kChunk = std::uint64_t(1) << 24;
    std::vector<unsigned char> bytes;
    *overrun = *failed = false;
    while (bytes.size() < declared) {
        const std::uint64_t want = std::min<std::uint64_t>(kChunk, declared - bytes.size());
        const std::size_t at = bytes.size();
        bytes.resize(at + std::size_t(want));
        const long long got = read(bytes.data() + at, std::size_t(want));
        if (got < 0) *failed = true;
        bytes.resize(at + std::size_t(got > 0 ? got : 0));
        if (got <= 0) return bytes;
    }
    unsigned char probe;
    *overrun = read(&probe, 1) > 0;
    return bytes;
}

}  // namespace sombra::detail
