// pnsplat: refine, render, compare, evaluate and benchmark oriented point sets (see README.md).
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <exception>
#include <numeric>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "commands.h"

namespace {

// Edits (insertions, deletions, substitutions, swaps of neighbours) that turn a into b.
std::size_t editDistance(std::string_view a, std::string_view b) {
    std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
    for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i)
        for (std::size_t j = 1; j <= b.size(); ++j) {
            d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] != b[j - 1])});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
        }
    return d[a.size()][b.size()];
}

// The nearest of `names` to `word`, where it is near enough to be a slip of the keys (at most 2
// edits, or a third of the name); empty otherwise.
std::string nearestName(std::string_view word, const std::vector<std::string>& names) {
    const auto nearest = std::min_element(names.begin(), names.end(), [&](const auto& a, const auto& b) {
        return editDistance(word, a) < editDistance(word, b);
    });
    if (nearest == names.end() ||
        editDistance(word, *nearest) > std::max<std::size_t>(2, nearest->size() / 3))
        return {};
    return *nearest;
}

// The options words[from...] name at `level` (or above it, as --help) must be options there: an
// unknown long one near an option's name is reported with it ("did you mean '--levels'?"), any other
// unknown one by its name alone, where CLI11 would say "The following arguments were not expected:
// 3 --levle" (or "x.json -o"). Values never start with "--", nor with "-" and a letter (negative
// numbers start with a digit or a point); "--" alone ends the options.
void checkOptionWords(const CLI::App& level, int from, int argc, char** argv) {
    std::vector<std::string> names, shortNames;
    for (const CLI::App* at = &level; at != nullptr; at = at->get_parent())
        for (const CLI::Option* option : at->get_options()) {
            for (const std::string& name : option->get_lnames()) names.push_back("--" + name);
            for (const std::string& name : option->get_snames()) shortNames.push_back("-" + name);
        }
    for (int i = from; i < argc; ++i) {
        const std::string_view word = argv[i];
        if (word == "--") return;
        const bool isLong = word.starts_with("--");
        if (!isLong &&
            !(word.size() >= 2 && word[0] == '-' && std::isalpha(static_cast<unsigned char>(word[1]))))
            continue;
        // A short option's value may follow it in the same word ("-l3").
        const std::string_view name = isLong ? word.substr(0, word.find('=')) : word.substr(0, 2);
        const std::vector<std::string>& known = isLong ? names : shortNames;
        if (std::ranges::find(known, name) != known.end()) continue;
        std::string command;
        for (const CLI::App* at = &level; at->get_parent() != nullptr; at = at->get_parent())
            command = " " + at->get_name() + command;
        const std::string nearest = isLong ? nearestName(name, names) : std::string();
        throw CLI::ValidationError(
            fmt::format("'{}' is not an option of pnsplat{}{}", name, command,
                        nearest.empty() ? "" : fmt::format("; did you mean '{}'?", nearest)));
    }
}

// The words of the command line that select subcommands must name them: the first word that is
// not an option, at a level that has subcommands, and is none of them, is reported with the
// nearest name ("did you mean 'render'?") or the list of names. CLI11 alone would say
// "A subcommand is required" or "arguments were not expected". Then the long options
// (checkOptionWords).
void checkSubcommandWords(const CLI::App& app, int argc, char** argv) {
    const CLI::App* level = &app;
    for (int i = 1; i < argc; ++i) {
        const std::string word = argv[i];
        const std::vector<const CLI::App*> subcommands = level->get_subcommands(nullptr);
        if (word.starts_with('-') || subcommands.empty()) return checkOptionWords(*level, i, argc, argv);
        const auto named = std::find_if(subcommands.begin(), subcommands.end(),
                                        [&](const CLI::App* sub) { return sub->check_name(word); });
        if (named != subcommands.end()) {
            level = *named;
            continue;
        }
        std::vector<std::string> names;
        for (const CLI::App* sub : subcommands) names.push_back(sub->get_name());
        const std::string where = level == &app ? "pnsplat" : "pnsplat " + level->get_name();
        if (const std::string nearest = nearestName(word, names); !nearest.empty())
            throw CLI::ValidationError(
                fmt::format("'{}' is not a {} command; did you mean '{}'?", word, where, nearest));
        throw CLI::ValidationError(fmt::format(
            "'{}' is not a {} command (commands: {})", word, where,
            std::accumulate(std::next(names.begin()), names.end(), names.front(),
                            [](std::string list, const std::string& n) { return list + ", " + n; })));
    }
}

} // namespace

int main(int argc, char** argv) {
    using pnsplat::tools::kExitFailure;
    CLI::App app{"pnsplat: interpolatory sqrt(3)-like refinement of point-based geometry "
                 "(Guennebaud, Barthe, Paulin 2005)"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "pnsplat 0.1.0");
    app.footer(
        fmt::format("Exit status: 0 success; {} `diff` found the images differ past --max-rmse; {} usage "
                    "error\n(an unknown command or option, a bad value); {} failure (a bad or missing file, "
                    "a device error).\nErrors are one line on standard error.\n",
                    pnsplat::tools::kExitDiffers, pnsplat::tools::kExitUsage, kExitFailure));
    pnsplat::tools::addRefineCommand(app);
    pnsplat::tools::addEvalCommand(app);
    pnsplat::tools::addRenderCommand(app);
    pnsplat::tools::addViewCommand(app);
    pnsplat::tools::addDiffCommand(app);
    pnsplat::tools::addBenchCommand(app);
    try {
        checkSubcommandWords(app, argc, argv);
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // One line, like every other error.
        fmt::print(stderr, "pnsplat: {} (see --help)\n", e.what());
        return pnsplat::tools::kExitUsage;
    } catch (const pnsplat::tools::CommandError& e) {
        fmt::print(stderr, "pnsplat: {}\n", e.what());
        return e.status();
    } catch (const std::bad_alloc&) {
        fmt::print(stderr, "pnsplat: out of memory\n");
        return kExitFailure;
    } catch (const std::exception& e) {
        fmt::print(stderr, "pnsplat: {}\n", e.what());
        return kExitFailure;
    }
    return 0;
}
