#include "common/temporaries.h"

#include <pthread.h>

#include <atomic>
#include <csignal>
#include <set>
#include <system_error>
#include <thread>

namespace rrslam {
namespace fs = std::filesystem;

namespace {

// Never destroyed: the signal thread may use it while the process exits.
struct Registry {
  std::recursive_mutex mutex;
  std::set<fs::path> paths;
};
Registry& TheRegistry() {
  static Registry* registry = new Registry;
  return *registry;
}

std::atomic<bool> g_interrupted{false};

// SIGINT, SIGTERM and SIGHUP, but not one the process was started with
// ignored: `nohup` ignores SIGHUP, a shell without job control SIGINT for a
// command run in the background; those must go on ignoring them.
sigset_t HandledSignals() {
  sigset_t set;
  sigemptyset(&set);
  for (const int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction action = {};
    if (sigaction(signal_number, nullptr, &action) == 0 && action.sa_handler == SIG_IGN) continue;
    sigaddset(&set, signal_number);
  }
  return set;
}

// Removes every registered temporary and keeps the lock for ever: nothing
// is committed or created after. A writer still adding files to a folder
// being removed can make one pass fail (not empty): a few passes.
void RemoveAllTemporaries() {
  Registry& registry = TheRegistry();
  registry.mutex.lock();
  for (const fs::path& path : registry.paths) {
    for (int pass = 0; pass < 5; ++pass) {
      std::error_code ec;
      fs::remove_all(path, ec);
      if (!ec) break;
    }
  }
}

void WaitForSignals(sigset_t set) {
  int signal_number = 0;
  if (sigwait(&set, &signal_number) != 0) return;
  g_interrupted.store(true);
  RemoveAllTemporaries();
  std::signal(signal_number, SIG_DFL);
  pthread_sigmask(SIG_UNBLOCK, &set, nullptr);
  std::raise(signal_number);  // Default action: the process ends here.
}

}  // namespace

void RegisterTemporary(const fs::path& path) {
  Registry& registry = TheRegistry();
  std::lock_guard<std::recursive_mutex> lock(registry.mutex);
  registry.paths.insert(path);
}

void ForgetTemporary(const fs::path& path) {
  Registry& registry = TheRegistry();
  std::lock_guard<std::recursive_mutex> lock(registry.mutex);
  registry.paths.erase(path);
}

std::unique_lock<std::recursive_mutex> LockTemporaries() {
  return std::unique_lock<std::recursive_mutex>(TheRegistry().mutex);
}

void RemoveTemporariesOnSignals() {
  static std::once_flag once;
  std::call_once(once, [] {
    const sigset_t set = HandledSignals();
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    try {
      std::thread(WaitForSignals, set).detach();
    } catch (const std::system_error&) {
      // No thread to spare: the signals keep their default action.
      pthread_sigmask(SIG_UNBLOCK, &set, nullptr);
    }
  });
}

bool Interrupted() { return g_interrupted.load(); }

}  // namespace rrslam
