// sombra — keeping C libraries' messages (fprintf to stderr) from the user while a reader runs.
// Internal to src/scene.
#pragma once
#include <cstdio>
#include <iostream>
#include <mutex>
#include <string>

#include <unistd.h>

namespace sombra::detail {

// Everything written to the process's stderr while it lives (std::cerr, and what C libraries print
// with fprintf: libtiff's warnings, libjpeg's and OpenJPEG's messages), captured at the file
// descriptor into a temporary file instead of reaching the user before sombra's own one line.
// One at a time (a process has one fd 2): readers hold the lock for their whole read.
class StderrCapture {
public:
    StderrCapture() : lock_(mutex()) {
        std::cerr.flush();
        std::fflush(stderr);
        file_ = std::tmpfile();
        saved_ = file_ ? ::dup(2) : -1;
        if (saved_ < 0 || ::dup2(::fileno(file_), 2) < 0) restore();
    }
    ~StderrCapture() { restore(); }
    StderrCapture(const StderrCapture&) = delete;
    StderrCapture& operator=(const StderrCapture&) = delete;
    // What was written so far.
    std::string text() {
        if (!file_) return "";
        std::cerr.flush();
        std::fflush(stderr);
        std::string out;
        std::rewind(file_);
        char buffer[4096];
        for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, file_)) > 0 && out.size() < (1u << 20);) out.append(buffer, n);
        std::fseek(file_, 0, SEEK_END);
        return out;
    }

private:
    static std::mutex& mutex() {
        static std::mutex m;
        return m;
    }
    void restore() {
        std::cerr.flush();
        std::fflush(stderr);
        if (saved_ >= 0) ::dup2(saved_, 2), ::close(saved_), saved_ = -1;
        if (file_) std::fclose(file_), file_ = nullptr;
    }
    std::unique_lock<std::mutex> lock_;
    std::FILE* file_ = nullptr;
    int saved_ = -1;
};

}  // namespace sombra::detail
