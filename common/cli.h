// The shared frame of every rrslam executable's main().
//
// A stage's main.cc binds its options struct to CLI11 flags and hands its body
// to RunTool(), which adds the common flags (--quiet, --verbose, --version),
// appends the exit-code table to --help, sets up logging on stderr, and maps
// every exception to a one-line message and a sysexits code (errors.h):
//
//   int main(int argc, char** argv) {
//     ExtractOptions options;
//     return rrslam::RunTool(argc, argv, {"extract", "Extracts ORB features."},
//         [&](CLI::App& app) { BindExtractOptions(app, &options); },
//         [&] { RunExtract(options); });
//   }
#pragma once

#include <functional>
#include <string>

// CLI11 is only declared here: its header costs about 6 s of compilation per
// file that includes it (g++ -O3), so only the files that bind options do.
namespace CLI {
class App;
}  // namespace CLI

namespace rrslam {

struct ToolInfo {
  std::string stage;        // "extract": the executable is rrslam-<stage>.
  std::string description;  // One or two sentences for --help.
};

// Parses argv, runs `run`, returns the process exit code (never throws).
// `add_options` declares the tool's flags and subcommands on `app`.
int RunTool(int argc, char** argv, const ToolInfo& info,
            const std::function<void(CLI::App&)>& add_options, const std::function<void()>& run);

// "rrslam-<stage> <version>": the producer recorded in every output file.
std::string Producer(const std::string& stage);

// Sets the stderr log level: 0 warnings and errors, 1 info (default), 2 debug.
void InitLogging(int verbosity);

}  // namespace rrslam
