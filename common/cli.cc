#include "common/cli.h"

#include <H5Cpp.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <iostream>
#include <opencv2/core/utility.hpp>

#include "common/errors.h"
#include "common/progress.h"
#include "common/version.h"

namespace rrslam {

std::string Producer(const std::string& stage) { return "rrslam-" + stage + " " + kVersion; }

void InitLogging(int verbosity) {
  auto logger = spdlog::get("rrslam");
  if (!logger) logger = spdlog::stderr_color_mt("rrslam");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  spdlog::set_level(verbosity <= 0   ? spdlog::level::warn
                    : verbosity == 1 ? spdlog::level::info
                                     : spdlog::level::debug);
}

int RunTool(int argc, char** argv, const ToolInfo& info,
            const std::function<void(CLI::App&)>& add_options, const std::function<void()>& run) {
  const std::string name = "rrslam-" + info.stage;
  CLI::App app(info.description, name);
  app.footer(ExitCodeHelp());
  app.get_formatter()->column_width(40);
  bool quiet = false;
  int verbose = 0;
  app.add_flag("-q,--quiet", quiet, "No progress bar and only warnings and errors on stderr");
  app.add_flag("-v,--verbose", verbose, "More log output on stderr (repeat for debug)");
  app.set_version_flag("--version", std::string(name) + " " + kVersion);
  try {
    add_options(app);
    // The common flags are accepted after a subcommand too
    // (`rrslam-vocab build ... --quiet`): options a subcommand does not
    // know fall through to the tool.
    std::function<void(CLI::App*)> fall_through = [&](CLI::App* parent) {
      for (CLI::App* sub : parent->get_subcommands([](CLI::App*) { return true; })) {
        sub->fallthrough();
        fall_through(sub);
      }
    };
    fall_through(&app);
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "%s: error: %s\nRun with --help for usage.\n", name.c_str(), e.what());
    return static_cast<int>(ExitCode::kUsage);
  }

  InitLogging(quiet ? 0 : 1 + verbose);
  SetProgressQuiet(quiet);
  H5::Exception::dontPrint();  // HDF5 errors surface as exceptions, not stack dumps.
  cv::redirectError([](int, const char*, const char*, const char*, int, void*) { return 0; });
  try {
    run();
    // Results printed on stdout must have reached it (`> /dev/full`, a
    // closed pipe's buffer): a run whose output was lost is not a success.
    std::cout.flush();
    if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout)) {
      std::fprintf(stderr, "%s: error: cannot write to standard output\n", name.c_str());
      return static_cast<int>(ExitCode::kCantCreate);
    }
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: error: %s\n", name.c_str(), e.what());
    return static_cast<int>(e.code());
  } catch (const CLI::ParseError& e) {  // Raised by option checks inside run().
    std::fprintf(stderr, "%s: error: %s\n", name.c_str(), e.what());
    return static_cast<int>(ExitCode::kUsage);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: error: out of memory\n", name.c_str());
    return static_cast<int>(ExitCode::kSoftware);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: internal error: %s\n", name.c_str(), e.what());
    return static_cast<int>(ExitCode::kSoftware);
  }
}

}  // namespace rrslam
