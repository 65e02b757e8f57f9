// Running the `pnsplat` program in tests: private temporary folders, the program's run with its
// standard output and error captured, and checks of what it printed. The program runs through
// std::system with stdout and stderr redirected to files of a private temporary folder.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "temp_dir.h"
#include "test_data.h"

namespace pnsplat::test {

namespace fs = std::filesystem;

inline std::string quote(const std::string& s) {
    std::string q = "'";
    for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}
inline std::string quote(const fs::path& p) {
    return quote(p.string());
}

// The whole file ("" when it cannot be read).
inline std::string readText(const fs::path& path) {
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    if (ec) return {};
    std::string bytes(static_cast<std::size_t>(size), '\0');
    std::ifstream in(path, std::ios::binary);
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    bytes.resize(static_cast<std::size_t>(in.gcount()));
    return bytes;
}

inline void writeText(const fs::path& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary);
    out << text;
}

struct RunResult {
    bool exited = false;  // ended by exit(), not by a signal
    int exitCode = -1;    // valid when exited
    std::string out, err; // standard output and standard error
};

// Runs the shell command line `commandLine`, capturing its standard output and error.
inline RunResult runShell(const std::string& commandLine) {
    static const TempDir captures; // outside every test's own folder
    static std::atomic<unsigned> counter{0};
    const unsigned k = counter++;
    const fs::path out = captures / ("out-" + std::to_string(k)),
                   err = captures / ("err-" + std::to_string(k));
    const std::string command = "{ " + commandLine + "; } >" + quote(out) + " 2>" + quote(err);
    const int status = std::system(command.c_str());
    RunResult r;
    // The shell may exec the program (a signal shows in the status) or report it as 128 + signal.
    r.exited = status != -1 && WIFEXITED(status) && WEXITSTATUS(status) < 128;
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = readText(out);
    r.err = readText(err);
    fs::remove(out);
    fs::remove(err);
    return r;
}

// The program, quoted for the shell.
inline std::string program() {
    return quote(programPath());
}

// Runs `pnsplat <args>` (args already quoted as needed); `before` goes before the program on the
// shell's command line: shell commands ("ulimit -v 3000000;") or an environment ("DISPLAY=:5",
// "env -u DISPLAY").
inline RunResult run(const std::string& args, const std::string& before = "") {
    return runShell(before + " " + program() + " " + args);
}

inline std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> result;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) result.push_back(line);
    return result;
}

// The program's exit statuses (README, "Exit status"; tools/commands.h).
enum class Exit { Differs = 1, Usage = 2, Failure = 3 };

// A clean failure: a normal exit with the expected status (usage errors 2, failures 3) and on
// stderr exactly one line "pnsplat: ...".
inline ::testing::AssertionResult failsCleanly(const RunResult& r, Exit expected = Exit::Failure) {
    if (!r.exited) return ::testing::AssertionFailure() << "crashed or killed by a signal; stderr: " << r.err;
    if (r.exitCode != int(expected))
        return ::testing::AssertionFailure()
               << "exit status " << r.exitCode << ", not " << int(expected) << "; stderr: " << r.err;
    const std::vector<std::string> l = lines(r.err);
    if (l.size() == 1 && l[0].rfind("pnsplat: ", 0) == 0 && l[0].size() > 9)
        return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "stderr is not one error line (" << l.size() << " lines):\n"
                                         << r.err;
}

// The value of `key` in a one-line JSON object: a string's text without its quotes, or a number's
// or literal's text ("" when absent).
inline std::string jsonField(const std::string& json, const std::string& key) {
    const std::size_t at = json.find("\"" + key + "\": ");
    if (at == std::string::npos) return "";
    std::size_t begin = at + key.size() + 4;
    if (json[begin] == '"') return json.substr(begin + 1, json.find('"', begin + 1) - begin - 1);
    return json.substr(begin, json.find_first_of(",}", begin) - begin);
}

} // namespace pnsplat::test
