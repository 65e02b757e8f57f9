// pnsplat: refine, render, compare, evaluate and benchmark oriented point sets (see README.md).
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "commands.h"

int main(int argc, char** argv) {
    CLI::App app{"pnsplat: interpolatory sqrt(3)-like refinement of point-based geometry "
                 "(Guennebaud, Barthe, Paulin 2005)"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "pnsplat 0.1.0");
    pnsplat::tools::addRefineCommand(app);
    pnsplat::tools::addEvalCommand(app);
    pnsplat::tools::addRenderCommand(app);
    pnsplat::tools::addDiffCommand(app);
    pnsplat::tools::addBenchCommand(app);
    try {
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
        return e.get_exit_code();
    } catch (const pnsplat::tools::CommandError& e) {
        fmt::print(stderr, "pnsplat: {}\n", e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        fmt::print(stderr, "pnsplat: out of memory\n");
        return 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "pnsplat: {}\n", e.what());
        return 1;
    }
    return 0;
}
