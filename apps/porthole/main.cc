// porthole: the command-line front end. Exit codes: 0 success, 2 bad input or options (one line on
// stderr naming the field), 3 internal error (a bug: please report it).
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <new>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "common.h"
#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "porthole/core/input.h"

int main(int argc, char** argv) {
  CLI::App app{"porthole: optics and geometry of underwater camera housings (flat and dome ports).\n"
               "Lengths in mm, angles in degrees, wavelengths in nm. 'porthole <command> --help' for details."};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(PORTHOLE_VERSION));
  app.get_formatter()->column_width(36);

  porthole::cli::RegisterVirtualImage(app);
  porthole::cli::RegisterTrace(app);
  porthole::cli::RegisterMaterials(app);
  porthole::cli::RegisterPresets(app);
  porthole::cli::RegisterPlan(app);
  porthole::cli::RegisterFlat(app);
  porthole::cli::RegisterSimulate(app);
  porthole::cli::RegisterFit(app);
  porthole::cli::RegisterSynthScan(app);
  porthole::cli::RegisterAssemble(app);
  porthole::cli::RegisterTargetSheet(app);
  porthole::cli::RegisterDetect(app);
  porthole::cli::RegisterCalibrate(app);
  porthole::cli::RegisterCompare(app);
  porthole::cli::RegisterConvert(app);
  porthole::cli::RegisterReport(app);
  porthole::cli::RegisterMeasure(app);
  porthole::cli::RegisterRender(app);
  porthole::cli::RegisterUndistort(app);

  porthole::cli::SetCommandTree(&app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version (CallForHelp and CallForVersion derive from Success)
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    fmt::print(stderr, "porthole: error: {}\n", porthole::OneLineMessage(e.what()));
    return 2;
  } catch (const porthole::InvalidInput& e) {
    // Already one line. The last tables: the fields every command names alike (the water's
    // conditions, switches a rule asks for), then any field the command has a flag of that name for
    // (`pixel_pitch_mm` → --pixel-pitch-mm), in the CLI's words.
    const porthole::InvalidInput cli = porthole::RenameFieldsBy(
        porthole::cli::FlagOfField,
        porthole::RenameFields({{"temperature_c", "--temperature"}, {"salinity_psu", "--salinity"},
                                {"lambda_nm", "--lambda"}, {"pressure_dbar", "--pressure"}, {"depth_m", "--depth"},
                                {"extrapolate", "--extrapolate"}, {"allow_adapter", "--allow-adapter"},
                                {"every", "--every"}, {"max_frames", "--max-frames"}},
                               e, /*keep_unknown=*/true));
    fmt::print(stderr, "porthole: error: {}\n", cli.what());
    return 2;
  } catch (const porthole::InternalError& e) {
    fmt::print(stderr, "porthole: internal error (please report): {}\n", porthole::OneLineMessage(e.what()));
    return 3;
  } catch (const nlohmann::json::exception& e) {
    // A JSON value of the wrong type or a missing key that a reader did not check itself.
    fmt::print(stderr, "porthole: error: input JSON: {}\n", porthole::OneLineMessage(porthole::JsonMessage(e)));
    return 2;
  } catch (const std::bad_alloc&) {
    fmt::print(stderr, "porthole: error: out of memory: an input asks for more than this machine has\n");
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "porthole: error: {}\n", porthole::OneLineMessage(e.what()));
    return 2;
  }
  return 0;
}
