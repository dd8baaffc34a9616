// sombra — reading a binary file forward with every read checked against the bytes left, for the
// walks of library formats before the library reads them (OpenVDB, DICOM). Internal to src/scene.
#pragma once
#include <cstdint>
#include <fstream>
#include <string>

#include "sombra/error.h"

namespace sombra::detail {

// The file, read forward; every read first checks the bytes left. `where` prefixes fields in errors.
class ByteCursor {
public:
    ByteCursor(const std::string& path, std::uint64_t size) : in_(path, std::ios::binary), path_(path), size_(size) {
        if (!in_) throw file_error(path, "", "cannot open the file");
    }
    std::uint64_t left() const { return size_ - at_; }
    std::uint64_t at() const { return at_; }
    [[noreturn]] void fail(const std::string& field, const std::string& what) const {
        throw file_error(path_, where + field, what);
    }
    void need(std::uint64_t n, const std::string& field) const {
        if (n > left())
            fail(field, "needs " + std::to_string(n) + " bytes, the file has " + std::to_string(left()) + " left (truncated or corrupt)");
    }
    void read(void* out, std::size_t n, const char* field) {
        need(n, field);
        in_.read(static_cast<char*>(out), std::streamsize(n));
        if (!in_) fail(field, "a read came back short");
        at_ += n;
    }
    void skip(std::uint64_t n, const char* field) {
        need(n, field);
        in_.seekg(std::streamoff(n), std::ios::cur);
        at_ += n;
    }
    void seek(std::uint64_t offset, const char* field) {  // to an absolute offset inside the file
        if (offset > size_) fail(field, "an offset of " + std::to_string(offset) + " past the file's end (" + std::to_string(size_) + " bytes)");
        in_.clear();
        in_.seekg(std::streamoff(offset), std::ios::beg);
        at_ = offset;
    }
    void rewind(std::uint64_t n) {  // back over bytes just read
        in_.seekg(-std::streamoff(n), std::ios::cur);
        at_ -= n;
    }
    template <typename T>
    T get(const char* field) {
        T value;
        read(&value, sizeof value, field);
        return value;
    }
    // A string of a uint32 length (at most `max`), then its bytes.
    std::string string(std::uint32_t max, const char* field) {
        const std::uint32_t n = get<std::uint32_t>(field);
        if (n > max) fail(field, "a length of " + std::to_string(n) + " bytes (at most " + std::to_string(max) + ")");
        std::string s(n, '\0');
        read(s.data(), n, field);
        return s;
    }
    std::string where;

private:
    std::ifstream in_;
    std::string path_;
    std::uint64_t size_, at_ = 0;
};

}  // namespace sombra::detail
