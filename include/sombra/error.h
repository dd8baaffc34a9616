// sombra — error type shared by the whole library.
#pragma once
#include <stdexcept>
#include <string>

namespace sombra {

// Every error the library reports: one line that names the file (and the field or line) it is
// about. The CLI prints what() and exits non-zero.
class Error : public std::runtime_error {
public:
    explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// "FILE: FIELD: what" — the one format for errors about a file's content.
inline Error file_error(const std::string& file, const std::string& field, const std::string& what) {
    return Error(file + ": " + (field.empty() ? std::string() : field + ": ") + what);
}

}  // namespace sombra
