// Writing outputs all at once: a file or directory appears complete or not at all.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace porthole {

// Writes `content` to `path` through a temporary file in the same directory, then renames it over
// `path`. Throws InvalidInput(field, ...) when the directory is missing or not writable; on any
// failure no file is left at `path` (an existing one is left untouched).
void WriteFileAtomically(const std::filesystem::path& path, std::string_view content,
                         const std::string& field = "output");

}  // namespace porthole
