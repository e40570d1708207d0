// Typed errors for user-facing failures and the exit codes they map to.
//
// Library code throws one of these with a message that names the file and the
// problem ("rgb.txt line 12: expected 'timestamp filename'"). Every rrslam
// executable catches them in RunTool() (cli.h), prints the message as one line
// on stderr and exits with the error's code. Exit codes follow sysexits.h.
// Broken internal invariants are not errors of this kind: they are assertions.
#pragma once

#include <stdexcept>
#include <string>

namespace rrslam {

// Process exit codes of every rrslam executable (sysexits.h values).
enum class ExitCode : int {
  kOk = 0,
  kUsage = 64,       // Bad command line: unknown flag, invalid option value.
  kDataError = 65,   // Input exists but is malformed, inconsistent or unsupported.
  kNoInput = 66,     // An input file or folder is missing or unreadable.
  kSoftware = 70,    // Internal error (a bug): please report it.
  kCantCreate = 73,  // An output file cannot be created or written.
  kTempFail = 75,    // The algorithm failed on this input (e.g. tracking lost everywhere).
};

// Text for --help footers: the table of exit codes above.
const char* ExitCodeHelp();

// Base of all rrslam errors. what() is the one-line message shown to the user.
class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

// Invalid options or command line (exit 64).
class UsageError : public Error {
 public:
  explicit UsageError(const std::string& message) : Error(ExitCode::kUsage, message) {}
};

// Malformed, inconsistent or unsupported input data, including format and
// version mismatches and failed checksums (exit 65).
class DataError : public Error {
 public:
  explicit DataError(const std::string& message) : Error(ExitCode::kDataError, message) {}
};

// A required input file or folder is missing or cannot be opened (exit 66).
class NoInputError : public Error {
 public:
  explicit NoInputError(const std::string& message) : Error(ExitCode::kNoInput, message) {}
};

// An output cannot be created or written (exit 73).
class CantCreateError : public Error {
 public:
  explicit CantCreateError(const std::string& message) : Error(ExitCode::kCantCreate, message) {}
};

// The algorithm could not produce a result on valid input (exit 75).
class AlgorithmError : public Error {
 public:
  explicit AlgorithmError(const std::string& message) : Error(ExitCode::kTempFail, message) {}
};

// The machine lacks a resource for now: a thread cannot be started (the
// system's thread or address-space limit). Retrying with fewer threads or
// higher limits may succeed (exit 75, a temporary failure).
class ResourceError : public Error {
 public:
  explicit ResourceError(const std::string& message) : Error(ExitCode::kTempFail, message) {}
};

}  // namespace rrslam
