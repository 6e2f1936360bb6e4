// Running gnuplot on a script, for every module that draws figures (report, undistort): no shell,
// its messages kept in the folder's gnuplot.log, and it dies with porthole (a killed run leaves no
// gnuplot working on its temporary folder).
#pragma once

#include <filesystem>
#include <string>

namespace porthole {

// Runs `gnuplot script` in `dir`. Throws InvalidInput("gnuplot", …) when gnuplot is missing ("install
// Debian's gnuplot-nox") or fails (its first 400 characters of messages, on one line); the log is
// removed when it succeeds.
void RunGnuplot(const std::string& gnuplot, const std::filesystem::path& dir, const std::string& script);

// Whether `program` runs: a path to an executable file, or a name found executable on PATH. For
// checking before long work that the figure can be drawn.
bool Executable(const std::string& program);

}  // namespace porthole
