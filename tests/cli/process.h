/// @file process.h
/// @brief Test helpers: run a program and capture what it says, temporary folders, listing a folder.
#pragma once

#include <filesystem>
#include <string>
#include <sys/types.h>
#include <vector>

namespace raylife::test {

/// A temporary folder, removed with everything in it when the object dies.
class TempDir {
public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  /// The folder's path.
  const std::filesystem::path& path() const { return path_; }

private:
  std::filesystem::path path_;
};

/// A program started by start(); its standard output and error go to files read by wait().
struct Child {
  pid_t pid = -1;                      ///< Process id.
  std::filesystem::path outFile, errFile; ///< Where its stdout and stderr go.
};

/// What a finished program did.
struct Outcome {
  int status = -1;        ///< Exit status (0..255), or -1 when it was killed by a signal.
  int signal = 0;         ///< The signal that killed it, or 0.
  std::string out;        ///< All it wrote on standard output.
  std::string err;        ///< All it wrote on standard error.
};

/// Starts `program` with `args` in folder `cwd`, with `env` (NAME=VALUE) added to this process's environment.
/// SIGINT and SIGTERM have their default actions in the child, and no signal is blocked. Its stdout and stderr
/// are captured in files of `captureDir` (not `cwd`, which keeps only what the program writes).
Child start(const std::string& program, const std::vector<std::string>& args, const std::filesystem::path& cwd,
            const std::filesystem::path& captureDir, const std::vector<std::string>& env = {});

/// Waits for `child` to end and collects its status and output.
Outcome wait(const Child& child);

/// Runs a program to its end: start() then wait(), capturing into a folder of its own.
Outcome run(const std::string& program, const std::vector<std::string>& args, const std::filesystem::path& cwd,
            const std::vector<std::string>& env = {});

/// True once `pid` has a handler installed for signal `sig` (read from /proc/PID/status, "SigCgt").
bool catchesSignal(pid_t pid, int sig);

/// The names of the entries of `folder`, hidden ones included, sorted.
std::vector<std::string> entries(const std::filesystem::path& folder);

/// The whole content of a file ("" if it cannot be read).
std::string readFile(const std::filesystem::path& path);

/// Writes `text` to `path`, replacing it.
void writeFile(const std::filesystem::path& path, const std::string& text);

} // namespace raylife::test
