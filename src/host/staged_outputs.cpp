#include "host/staged_outputs.h"

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

void StagedOutputs::throw_renamed(std::string message, const std::string& staged, const std::string& final_path) {
    for (std::size_t at = message.find(staged); at != std::string::npos; at = message.find(staged, at + final_path.size()))
        message.replace(at, staged.size(), final_path);
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
