// flare: the command-line front end. Each command is a thin layer over the engine library; user
// input errors print one line "file:line: problem" and exit with code 2.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "CompareCommand.h"
#include "CompositeCommand.h"
#include "DatasetCommand.h"
#include "GhostCommands.h"
#include "GlassCatalogOption.h"
#include "LensCommands.h"
#include "PreviewCommand.h"
#include "RenderCommand.h"
#include "VolumeCommand.h"
#include "flare/core/Error.h"

int main(int argc, char** argv) {
    CLI::App app{"flare: physically based lens flare simulation"};
    app.require_subcommand(1);
    flare::cli::addLensCommands(app);
    flare::cli::addGhostCommands(app);
    flare::cli::addPreviewCommand(app);
    flare::cli::addRenderCommand(app);
    flare::cli::addCompareCommand(app);
    flare::cli::addDatasetCommand(app);
    flare::cli::addCompositeCommand(app);
    flare::cli::addVolumeCommands(app);
    flare::cli::addGlassCatalogOptions(app);
    try {
        app.parse(argc, argv);
    } catch (const CLI::RuntimeError& e) {
        return e.get_exit_code();  // a command's own exit status (e.g. 130: interrupted)
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : flare::kExitInputError;
    } catch (const flare::InputError& e) {
        std::fprintf(stderr, "flare: error: %s\n", e.what());
        return flare::kExitInputError;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "flare: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
