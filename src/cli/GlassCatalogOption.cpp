#include "GlassCatalogOption.h"

#include <string>
#include <vector>

#include "flare/optics/AgfCatalog.h"

namespace flare::cli {

void addGlassCatalogOptions(CLI::App& app) {
    const std::vector<std::vector<std::string>> commands = {{"lens", "info"},  {"lens", "check"}, {"lens", "export"},
                                                            {"lens", "draw"},  {"ghosts"},        {"preview"},
                                                            {"render"}};
    for (const std::vector<std::string>& path : commands) {
        CLI::App* command = &app;
        for (const std::string& name : path) command = command->get_subcommand(name);
        command
            ->add_option_function<std::vector<std::string>>(
                "--glass-catalog",
                [](const std::vector<std::string>& files) {
                    for (const std::string& file : files) useGlassCatalog(file);
                },
                "a Zemax glass catalogue (.agf) of your own, searched before the shipped ones (repeatable; a .zmx "
                "file's GCAT finds it by its file name)")
            ->type_name("FILE.agf");
    }
}

}  // namespace flare::cli
