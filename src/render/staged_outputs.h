// sombra — the outputs of one command (image, stats, DSM faces), written under temporary names and
// renamed to their own names together only when every one was written: a failure leaves none.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace sombra::detail {

class StagedOutputs {
public:
    StagedOutputs() = default;
    StagedOutputs(const StagedOutputs&) = delete;
    StagedOutputs& operator=(const StagedOutputs&) = delete;
    ~StagedOutputs();  // removes every staged file that was not committed

    // Throws "FINAL: cannot write: …" when final_path is a directory, names something other than a
    // regular file (a device, a FIFO: links resolved), is a file this process read as an input
    // (scene/input_file.h inputs_read(): compared by device and inode), or its folder does not
    // exist, so that a command can refuse an impossible output before its work.
    static void check_target(const std::string& final_path);
    // check_target for each non-empty path, and no two naming the same file.
    static void check_targets(const std::vector<std::string>& final_paths);

    // A temporary path next to `final_path` with the same extension (writers pick the format by
    // it); write the output there. Checks the target first (check_target) and that no other
    // output of this command names the same file.
    std::string stage(const std::string& final_path);

    // Stages final_path and calls write(staged path); errors name final_path, not the staged one.
    template <typename Write>
    void write(const std::string& final_path, Write write) {
        const std::string staged = stage(final_path);
        try {
            write(staged);
        } catch (const std::exception& e) {
            throw_renamed(e.what(), staged, final_path);
        }
    }

    // Checks every target again (inputs read after staging count), then renames every staged file
    // to its final name. Throws "FINAL: cannot write: …" (and removes
    // what it had renamed) when one cannot be renamed.
    void commit();

private:
    // Throws "FINAL: named twice as an output" when `earlier` (non-empty) names the same file.
    static void check_distinct(const std::string& earlier, const std::string& final_path);
    [[noreturn]] static void throw_renamed(std::string message, const std::string& staged, const std::string& final_path);
    std::vector<std::pair<std::string, std::string>> files_;  // (staged, final)
};

}  // namespace sombra::detail
