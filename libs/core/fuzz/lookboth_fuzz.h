// Shared by the libFuzzer targets of libs/*/fuzz (doc/reliability.md,
// "Fuzzing and sanitizers"): a scratch folder for the files a reader needs,
// and the rule that bad input may only end in lookboth::Error.
//
// lookboth's command line reports lookboth::Error as "error" (exit 1) and any
// other exception as "internal error" (exit 3); bad input must never give an
// internal error. A target therefore catches lookboth::Error only: any other
// exception reaches std::terminate, whose handler here names it and aborts,
// and libFuzzer saves the input. An exception that no frame catches is not
// unwound, so the stack printed is the one of the throw (or of the last
// rethrow, when a frame on the way catches it and throws it on).
#pragma once

#include <unistd.h>

#include <cxxabi.h>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <typeinfo>

#include "lookboth/core/error.h"

namespace lookboth::fuzz {

namespace fs = std::filesystem;

inline std::string demangledName(const std::type_info& type) {
  int status = 0;
  char* name = abi::__cxa_demangle(type.name(), nullptr, nullptr, &status);
  std::string result = status == 0 && name ? name : type.name();
  std::free(name);
  return result;
}

/// Names the exception that is terminating the process, then aborts.
[[noreturn]] inline void reportEscapedException() {
  std::string what = "(not a std::exception)";
  std::string type = "(unknown type)";
  if (const std::type_info* t = abi::__cxa_current_exception_type()) type = demangledName(*t);
  if (const std::exception_ptr current = std::current_exception()) {
    try {
      std::rethrow_exception(current);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
  }
  std::fprintf(stderr,
               "lookboth-fuzz: an exception other than lookboth::Error escaped (the command line "
               "would report an internal error, exit 3): %s: %s\n",
               type.c_str(), what.c_str());
  std::abort();
}

/// A folder of its own under $TMPDIR (or /tmp) for the files of one fuzz
/// process, removed at normal exit (scripts/fuzz.sh gives each run its own
/// TMPDIR, so what a crash leaves behind goes too).
class ScratchDir {
 public:
  ScratchDir() {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/lookboth-fuzz-XXXXXX";
    if (!mkdtemp(pattern.data())) {
      std::perror("lookboth-fuzz: mkdtemp");
      std::abort();
    }
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

/// The one scratch folder of this process.
inline const fs::path& scratch() {
  static ScratchDir dir;
  return dir.path();
}

inline void writeBytes(const fs::path& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) {
    std::fprintf(stderr, "lookboth-fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
}

/// Call from LLVMFuzzerInitialize.
inline void installTerminateHandler() { std::set_terminate(reportEscapedException); }

/// Runs `body`; lookboth::Error is the expected outcome of bad input. With
/// LOOKBOTH_FUZZ_VERBOSE set, its message is printed (to see what an input
/// does: fuzz_<target> <input file>).
template <typename Body>
void expectOnlyLookbothErrors(Body&& body) {
  static const bool verbose = std::getenv("LOOKBOTH_FUZZ_VERBOSE") != nullptr;
  try {
    body();
  } catch (const lookboth::Error& e) {
    if (verbose) std::fprintf(stderr, "lookboth-fuzz: lookboth::Error: %s\n", e.what());
  }
}

}  // namespace lookboth::fuzz
