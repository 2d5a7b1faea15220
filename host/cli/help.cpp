// `microshadow help [COMMAND]`, and "did you mean" for mistyped options and commands.
#include <algorithm>
#include <iostream>
#include <vector>

#include "cli/common.hpp"
#include "io/text.hpp"

namespace ms::cli {

namespace {

// The spellings a mistyped word may have meant: the subcommands of `scope`, or its long options.
std::vector<std::string> known_words(CLI::App& scope, bool options) {
    std::vector<std::string> words;
    if (options) {
        for (const CLI::Option* o : scope.get_options())
            for (const std::string& name : o->get_lnames()) words.push_back("--" + name);
    } else {
        for (CLI::App* sub : scope.get_subcommands([](CLI::App*) { return true; })) words.push_back(sub->get_name());
    }
    return words;
}

}  // namespace

void add_help_command(CLI::App& app) {
    auto* cmd = app.add_subcommand("help", "show the commands, or one command's options: microshadow help [COMMAND [SUBCOMMAND]]");
    auto topic = std::make_shared<std::vector<std::string>>();
    cmd->add_option("command", *topic, "the command to describe, with its subcommand for nested ones (help repr bake)");
    cmd->callback([&app, topic] {
        if (topic->empty()) {
            // app.help() would describe the running subcommand (help itself); format the top level.
            std::cout << app.get_formatter()->make_help(&app, "microshadow", CLI::AppFormatMode::Normal);
            return;
        }
        // Walk down the words: "help ibl prefilter" describes prefilter, a subcommand of ibl.
        CLI::App* at = &app;
        std::string path;
        for (const std::string& word : *topic) {
            CLI::App* sub = nullptr;
            for (CLI::App* s : at->get_subcommands([](CLI::App*) { return true; }))
                if (s->get_name() == word) sub = s;
            if (!sub) {
                std::string names;
                for (CLI::App* s : at->get_subcommands([](CLI::App*) { return true; }))
                    names += (names.empty() ? "" : ", ") + s->get_name();
                throw std::invalid_argument(path.empty() ? "no command '" + word + "'" + suggestion(app, word, false)
                                                         : "'" + path + "' has no subcommand '" + word + "' (it has " + names + ")");
            }
            path += (path.empty() ? "" : " ") + word;
            at = sub;
        }
        // Named with its whole path ("Usage: microshadow repr bake"): at->help() would say "bake" alone.
        std::cout << at->get_formatter()->make_help(at, "microshadow " + path, CLI::AppFormatMode::Normal);
    });
}

std::string suggestion(CLI::App& scope, const std::string& word, bool options) {
    std::string best;
    // A typo is a few edits of a word, and fewer than half its letters ("1" is not a typo of "ibl").
    std::size_t best_distance = std::min<std::size_t>(4, word.size() / 2 + 1);
    for (const std::string& w : known_words(scope, options)) {
        const std::size_t d = edit_distance(word, w);
        if (d < best_distance) best = w, best_distance = d;
    }
    return best.empty() ? "" : "; did you mean " + best + "?";
}

}  // namespace ms::cli
