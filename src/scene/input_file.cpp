#include "scene/input_file.h"

#include <cerrno>
#include <cstring>
#include <mutex>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sombra/error.h"

namespace sombra::detail {
namespace {

std::mutex inputs_mutex;
std::vector<std::pair<FileIdentity, std::string>> inputs;  // in the order first read

void note_input(const struct stat& st, const std::string& path) {
    const FileIdentity id{std::uint64_t(st.st_dev), std::uint64_t(st.st_ino)};
    std::lock_guard<std::mutex> lock(inputs_mutex);
    for (const auto& known : inputs)
        if (known.first == id) return;
    inputs.emplace_back(id, path);
}

// An open, regular file; closes itself.
class RegularFile {
public:
    explicit RegularFile(const std::string& path) : path_(path) {
        // O_NONBLOCK: opening a FIFO without a writer would block for ever.
        fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
        if (fd_ < 0) throw file_error(path, "", std::string("cannot open for reading: ") + std::strerror(errno));
        struct stat st {};
        if (::fstat(fd_, &st) != 0) fail(std::string("cannot stat: ") + std::strerror(errno));
        if (!S_ISREG(st.st_mode)) fail(std::string("not a regular file (") + file_kind(st.st_mode) + ")");
        note_input(st, path);
        size_ = std::uint64_t(st.st_size);
    }
    ~RegularFile() { ::close(fd_); }
    RegularFile(const RegularFile&) = delete;
    RegularFile& operator=(const RegularFile&) = delete;

    [[noreturn]] void fail(const std::string& what) {
        ::close(fd_);
        fd_ = -1;
        throw file_error(path_, "", what);
    }
    std::uint64_t size() const { return size_; }
    int fd() const { return fd_; }

private:
    std::string path_;
    int fd_ = -1;
    std::uint64_t size_ = 0;
};

}  // namespace

const char* file_kind(std::uint32_t mode) {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISFIFO(mode)) return "a FIFO";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a plain file";
}

std::vector<std::pair<FileIdentity, std::string>> inputs_read() {
    std::lock_guard<std::mutex> lock(inputs_mutex);
    return inputs;
}

std::uint64_t regular_file_size(const std::string& path) { return RegularFile(path).size(); }

std::vector<unsigned char> read_regular_file(const std::string& path, std::uint64_t max_bytes) {
    RegularFile file(path);
    if (file.size() > max_bytes)
        file.fail("file too large: " + std::to_string(file.size()) + " bytes (at most " + std::to_string(max_bytes) + ")");
    bool overrun = false, failed = false;
    std::vector<unsigned char> bytes = read_declared(
        file.size(),
        [&](unsigned char* to, std::size_t n) -> long long {
            ssize_t got;
            do got = ::read(file.fd(), to, n); while (got < 0 && errno == EINTR);
            return got;
        },
        &overrun, &failed);
    if (failed) file.fail(std::string("read error: ") + std::strerror(errno));
    if (bytes.size() != file.size() || overrun) file.fail("the file changed size while it was read");
    return bytes;
}

}  // namespace sombra::detail
