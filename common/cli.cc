#include "common/cli.h"

#include <H5Cpp.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <opencv2/core/utility.hpp>
#include <system_error>
#include <thread>

#include "common/errors.h"
#include "common/progress.h"
#include "common/temporaries.h"
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

namespace {

// 0 when everything printed on stdout has reached it; else kCantCreate with
// a message (`> /dev/full`, a closed pipe's buffer): output that was lost is
// not a success, be it a result, --help or --version.
int StdoutStatus(const std::string& name) {
  std::cout.flush();
  if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::fprintf(stderr, "%s: error: cannot write to standard output\n", name.c_str());
    return static_cast<int>(ExitCode::kCantCreate);
  }
  return 0;
}

// CLI11 reads an unsigned option with strtoull, which takes "-1" as
// 18446744073709551615 (`rrslam-synth --seed -1`); every unsigned option of
// `app` and its subcommands refuses a minus sign instead.
void RefuseNegativeUnsigned(CLI::App* app) {
  const CLI::Validator no_minus(
      [](std::string& value) -> std::string {
        const size_t first = value.find_first_not_of(" \t");
        return first != std::string::npos && value[first] == '-' ? "must not be negative" : "";
      },
      "");
  for (CLI::Option* option : app->get_options()) {
    if (option->get_type_name() == "UINT") option->check(no_minus);
  }
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) {
    RefuseNegativeUnsigned(sub);
  }
}

// Prints "<tool>: <kind>: <message>" and returns `code`; but while an
// interruption removes the temporaries (which makes the tool's own writers
// fail), waits for the process to die of the signal instead of reporting.
int Fail(const std::string& name, ExitCode code, const char* message, const char* kind = "error") {
  while (Interrupted()) std::this_thread::sleep_for(std::chrono::seconds(1));
  std::fprintf(stderr, "%s: %s: %s\n", name.c_str(), kind, message);
  return static_cast<int>(code);
}

// CLI11's help, without the value a negated flag assigns: "--no-frusta{false}"
// and "--refine-map,--no-refine-map{false}" read as if the default were
// false; the flags' descriptions say their defaults in words.
class HelpFormatter : public CLI::Formatter {
 public:
  std::string make_option_name(const CLI::Option* option, bool is_positional) const override {
    std::string name = CLI::Formatter::make_option_name(option, is_positional);
    for (size_t open = name.find('{'); open != std::string::npos; open = name.find('{', open)) {
      const size_t close = name.find('}', open);
      if (close == std::string::npos) break;
      name.erase(open, close - open + 1);
    }
    return name;
  }
};

// With fallthrough, the common flags are accepted after a subcommand too
// (`rrslam-vocab build ... --quiet`): options a subcommand does not know fall
// through to the tool.
void FallThrough(CLI::App* parent) {
  for (CLI::App* sub : parent->get_subcommands([](CLI::App*) { return true; })) {
    sub->fallthrough();
    FallThrough(sub);
  }
}

}  // namespace

int RunTool(int argc, char** argv, const ToolInfo& info,
            const std::function<void(CLI::App&)>& add_options, const std::function<void()>& run) {
  const std::string name = "rrslam-" + info.stage;
  RemoveTemporariesOnSignals();  // Before any thread is started.
  CLI::App app(info.description, name);
  app.footer(ExitCodeHelp());
  app.formatter(std::make_shared<HelpFormatter>());
  app.get_formatter()->column_width(40);
  bool quiet = false;
  int verbose = 0;
  app.add_flag("-q,--quiet", quiet, "No progress bar and only warnings and errors on stderr");
  app.add_flag("-v,--verbose", verbose, "More log output on stderr (repeat for debug)");
  app.set_version_flag("--version", std::string(name) + " " + kVersion);
  try {
    add_options(app);
    FallThrough(&app);
    RefuseNegativeUnsigned(&app);
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    const int code = app.exit(e);
    return code != 0 ? code : StdoutStatus(name);
  } catch (const CLI::CallForAllHelp& e) {
    const int code = app.exit(e);
    return code != 0 ? code : StdoutStatus(name);
  } catch (const CLI::CallForVersion& e) {
    const int code = app.exit(e);
    return code != 0 ? code : StdoutStatus(name);
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
    while (Interrupted()) std::this_thread::sleep_for(std::chrono::seconds(1));
    return StdoutStatus(name);
  } catch (const Error& e) {
    return Fail(name, e.code(), e.what());
  } catch (const CLI::ParseError& e) {  // Raised by option checks inside run().
    return Fail(name, ExitCode::kUsage, e.what());
  } catch (const std::bad_alloc&) {
    return Fail(name, ExitCode::kSoftware, "out of memory");
  } catch (const std::system_error& e) {
    // std::thread's EAGAIN: the system refuses another thread (a process
    // or memory limit), where a tool starts one of its own.
    if (e.code() == std::errc::resource_unavailable_try_again) {
      const std::string what = std::string("cannot start a thread: ") + e.what();
      return Fail(name, ExitCode::kTempFail, what.c_str());
    }
    return Fail(name, ExitCode::kSoftware, e.what(), "internal error");
  } catch (const std::exception& e) {
    return Fail(name, ExitCode::kSoftware, e.what(), "internal error");
  }
}

}  // namespace rrslam
