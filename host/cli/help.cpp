// `microshadow help [COMMAND]`, and "did you mean" for mistyped options and commands.
#include <algorithm>
#include <iostream>
#include <vector>

#include "cli/common.hpp"

namespace ms::cli {

namespace {

// Levenshtein distance: the number of single-character edits between two words.
std::size_t edit_distance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

// Every spelling the command line accepts: subcommand names and their long options.
std::vector<std::string> known_words(CLI::App& app) {
    std::vector<std::string> words;
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
        words.push_back(sub->get_name());
        for (const CLI::Option* o : sub->get_options())
            for (const std::string& name : o->get_lnames()) words.push_back("--" + name);
    }
    for (const CLI::Option* o : app.get_options())
        for (const std::string& name : o->get_lnames()) words.push_back("--" + name);
    return words;
}

}  // namespace

void add_help_command(CLI::App& app) {
    auto* cmd = app.add_subcommand("help", "show the commands, or one command's options: microshadow help [COMMAND]");
    auto topic = std::make_shared<std::string>();
    cmd->add_option("command", *topic, "the command to describe");
    cmd->callback([&app, topic] {
        if (topic->empty()) {
            // app.help() would describe the running subcommand (help itself); format the top level.
            std::cout << app.get_formatter()->make_help(&app, "microshadow", CLI::AppFormatMode::Normal);
            return;
        }
        CLI::App* sub = nullptr;
        for (CLI::App* s : app.get_subcommands([](CLI::App*) { return true; }))
            if (s->get_name() == *topic) sub = s;
        if (!sub) throw std::invalid_argument("no command '" + *topic + "'" + suggestion(app, *topic));
        std::cout << sub->help();
    });
}

std::string suggestion(CLI::App& app, const std::string& word) {
    std::string best;
    // A typo is a few edits of a word, and fewer than half its letters ("1" is not a typo of "ibl").
    std::size_t best_distance = std::min<std::size_t>(4, word.size() / 2 + 1);
    for (const std::string& w : known_words(app)) {
        const std::size_t d = edit_distance(word, w);
        if (d < best_distance) best = w, best_distance = d;
    }
    return best.empty() ? "" : "; did you mean " + best + "?";
}

}  // namespace ms::cli
