#include "host/staged_outputs.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include <unistd.h>

#include "sombra/error.h"

namespace sombra::host {

namespace fs = std::filesystem;

StagedOutputs::~StagedOutputs() {
    for (const auto& file : files_) {
        std::error_code ec;
        fs::remove(file.first, ec);
    }
}

void StagedOutputs::check_target(const std::string& final_path) {
    const fs::path target(final_path), folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    std::error_code ec;
    if (fs::is_directory(target, ec)) throw Error(final_path + ": cannot write: is a directory");
    if (!fs::is_directory(folder, ec)) throw Error(final_path + ": cannot write: no folder " + folder.string());
}

std::string StagedOutputs::stage(const std::string& final_path) {
    check_target(final_path);
    const fs::path target(final_path);
    for (const auto& file : files_)
        if (file.second == final_path) throw Error(final_path + ": named twice as an output");
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

}  // namespace sombra::host
