// One Register function per subcommand, each in its own cmd_<name>.cc. A subcommand parses and
// validates its options, calls one library function, and prints or writes the result; all logic
// lives in the libraries (docs/architecture.md).
#pragma once

#include <CLI/CLI.hpp>

namespace porthole::cli {

void RegisterVirtualImage(CLI::App& app);
void RegisterTrace(CLI::App& app);
void RegisterMaterials(CLI::App& app);
void RegisterPresets(CLI::App& app);
void RegisterPlan(CLI::App& app);
void RegisterFlat(CLI::App& app);
void RegisterSimulate(CLI::App& app);
void RegisterFit(CLI::App& app);
void RegisterSynthScan(CLI::App& app);
void RegisterAssemble(CLI::App& app);
void RegisterTargetSheet(CLI::App& app);
void RegisterDetect(CLI::App& app);
void RegisterCalibrate(CLI::App& app);
void RegisterCompare(CLI::App& app);
void RegisterConvert(CLI::App& app);
void RegisterReport(CLI::App& app);
void RegisterRender(CLI::App& app);
void RegisterMeasure(CLI::App& app);
void RegisterUndistort(CLI::App& app);

}  // namespace porthole::cli
