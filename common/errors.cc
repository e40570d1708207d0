#include "common/errors.h"

namespace rrslam {

const char* ExitCodeHelp() {
  return "Exit codes:\n"
         "  0   success\n"
         "  64  usage error (bad flag or option value)\n"
         "  65  bad input data (malformed, inconsistent or unsupported file)\n"
         "  66  missing or unreadable input\n"
         "  70  internal error\n"
         "  73  cannot create or write an output\n"
         "  75  algorithm failure on this input (e.g. tracking lost everywhere), or a\n"
         "      temporary lack of resources (a worker thread could not be started)\n"
         "Interrupted (SIGINT, SIGTERM, SIGHUP), a run removes its unfinished outputs\n"
         "and ends by the signal (a shell shows 130, 143, 129); existing outputs stay.\n";
}

}  // namespace rrslam
