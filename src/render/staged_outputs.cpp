#include "render/staged_outputs.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include <sys/stat.h>
#include <unistd.h>

#include "scene/input_file.h"
#include "sombra/error.h"

namespace sombra::detail {

namespace fs = std::filesystem;

StagedOutputs::~StagedOutputs() {
    for (const auto& file : files_) {
        std::error_code ec;
        fs::remove(file.first, ec);
    }
}

namespace {

// Whether two paths name one file: the same device and inode when both exist (links resolved),
// else the same path once made absolute and normal.
bool same_file(const std::string& a, const std::string& b) {
    std::error_code ec;
    if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec) && !ec;
    const fs::path ca = fs::weakly_canonical(a, ec), cb = fs::weakly_canonical(b, ec);
    return ca == cb;
}

}  // namespace

void StagedOutputs::check_target(const std::string& final_path) {
    const fs::path target(final_path), folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    struct stat info {};
    if (::stat(final_path.c_str(), &info) == 0) {  // follows links: what the name leads to
        if (S_ISDIR(info.st_mode)) throw Error(final_path + ": cannot write: is a directory");
        if (!S_ISREG(info.st_mode))
            throw Error(final_path + ": cannot write: " + file_kind(info.st_mode) +
                        ", not a regular file (outputs replace only regular files)");
        const FileIdentity id{std::uint64_t(info.st_dev), std::uint64_t(info.st_ino)};
        for (const auto& [input, input_path] : inputs_read())
            if (input == id)
                throw Error(final_path + ": cannot write: it is an input of this command (" + input_path + "); name another output");
    }
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) throw Error(final_path + ": cannot write: no folder " + folder.string());
}

void StagedOutputs::check_distinct(const std::string& earlier, const std::string& final_path) {
    if (!earlier.empty() && same_file(earlier, final_path))
        throw Error(final_path + ": named twice as an output" + (earlier == final_path ? "" : " (also as " + earlier + ")"));
}

void StagedOutputs::check_targets(const std::vector<std::string>& final_paths) {
    for (std::size_t i = 0; i < final_paths.size(); ++i) {
        if (final_paths[i].empty()) continue;
        check_target(final_paths[i]);
        for (std::size_t k = 0; k < i; ++k) check_distinct(final_paths[k], final_paths[i]);
    }
}

std::string StagedOutputs::stage(const std::string& final_path) {
    const fs::path target(final_path);
    check_target(final_path);
    for (const auto& file : files_) check_distinct(file.second, final_path);
    // hidden, unique to this process, same extension: NAME.png → .NAME.sombra-PID-K.png
    const std::string staged = (target.parent_path() / ("." + target.stem().string() + ".sombra-" +
                                                        std::to_string(::getpid()) + "-" + std::to_string(files_.size()) +
                                                        target.extension().string()))
                                   .string();
    files_.emplace_back(staged, final_path);
    return staged;
}

namespace {
void replace_all(std::string& text, const std::string& from, const std::string& to) {
    if (from.empty()) return;
    for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
        text.replace(at, from.size(), to);
}
}  // namespace

// No temporary name reaches a message: the writers' own temporaries (write_image and write_deep_exr
// write STAGED.part.ext, ext lowercase), the staged path, then its bare file name (as libraries
// quote it) all become the final name.
void StagedOutputs::throw_renamed(std::string message, const std::string& staged, const std::string& final_path) {
    std::string ext = fs::path(staged).extension().string();
    replace_all(message, staged + ".part" + ext, final_path);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    replace_all(message, staged + ".part" + ext, final_path);
    replace_all(message, staged, final_path);
    replace_all(message, fs::path(staged).filename().string(), fs::path(final_path).filename().string());
    throw Error(message);
}

void StagedOutputs::commit() {
    for (const auto& file : files_) check_target(file.second);  // inputs read since staging count too
    for (std::size_t i = 0; i < files_.size(); ++i) {
        std::error_code ec;
        fs::rename(files_[i].first, files_[i].second, ec);
        if (ec) {
            const std::string message = files_[i].second + ": cannot write: " + ec.message();
            for (std::size_t k = 0; k < i; ++k) fs::remove(files_[k].second, ec);  // all or none
            throw Error(message);
        }
    }
    files_.clear();
}

}  // namespace sombra::detail
