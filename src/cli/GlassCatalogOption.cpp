#include "GlassCatalogOption.h"

#include <string>
#include <vector>

#include "flare/optics/AgfCatalog.h"

namespace flare::cli {

void addGlassCatalogOptions(CLI::App& app) {
    const std::vector<std::vector<std::string>> commands = {{"lens", "info"},  {"lens", "check"}, {"lens", "export"},
                                                            {"lens", "draw"},  {"ghosts"},        {"preview"},
                                                            {"render"}};
    // A child by name, or null (get_subcommand throws, and a renamed command must not stop the
    // program from starting).
    auto child = [](CLI::App* parent, const std::string& name) -> CLI::App* {
        for (CLI::App* sub : parent->get_subcommands([](CLI::App*) { return true; }))
            if (sub->get_name() == name) return sub;
        return nullptr;
    };
    for (const std::vector<std::string>& path : commands) {
        CLI::App* command = &app;
        for (const std::string& name : path)
            if (command) command = child(command, name);
        if (!command) continue;
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
