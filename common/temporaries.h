// The temporary files and folders a process is writing (AtomicOutput's
// `<name>.XXXXXX.tmp`), removed when the process is interrupted.
//
// Ctrl-C (SIGINT), `kill` (SIGTERM) or a closed terminal (SIGHUP) while a
// tool writes an output would otherwise leave its temporary behind, a folder
// of gigabytes for rrslam-synth (issue 36). RemoveTemporariesOnSignals()
// waits for those signals in a thread of its own; on one it removes every
// registered temporary and the process then dies of the signal, as it would
// have without the handler (a shell shows 128 + n: 130 for SIGINT, 143 for
// SIGTERM). SIGKILL cannot be caught: its temporaries stay (see
// atomic_file.h).
//
// Thread-safe. The registry's lock is recursive: AtomicOutput holds it over
// the renames of a commit, so an interruption waits for a commit under way
// to end and never removes a temporary that has just become the output.
#pragma once

#include <filesystem>
#include <mutex>

namespace rrslam {

// Records `path` (a file or folder) as a temporary to remove on
// interruption; ForgetTemporary() takes it back once it was committed or
// removed.
void RegisterTemporary(const std::filesystem::path& path);
void ForgetTemporary(const std::filesystem::path& path);

// Holding it, no interruption removes anything: the caller may create,
// rename or remove registered temporaries as one step.
std::unique_lock<std::recursive_mutex> LockTemporaries();

// Blocks SIGINT, SIGTERM and SIGHUP (those not ignored: `nohup`, a
// background command of a shell without job control) in the calling thread (every thread it
// starts later inherits the mask) and waits for them in a new thread, which
// removes the registered temporaries and re-raises the signal with its
// default action. Call it once, first thing in main, before any other thread
// is started (RunTool does for every rrslam tool); later calls do nothing.
// A process started from then on (none in the tools) would inherit the
// blocked mask.
void RemoveTemporariesOnSignals();

// True once an interruption is being handled: the process is about to die of
// it. The tool's main thread then stops instead of reporting errors that the
// removal causes in its own writers (RunTool waits).
bool Interrupted();

}  // namespace rrslam
