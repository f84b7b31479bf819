// An environment variable set for a scope (tests that point a library at
// another share folder through LOOKBOTH_SHARE_DIR), restored on leaving it.
#pragma once

#include <cstdlib>
#include <optional>
#include <string>
#include <utility>

namespace lookboth {

class ScopedEnvironment {
 public:
  ScopedEnvironment(std::string name, const std::string& value) : name_(std::move(name)) {
    if (const char* before = std::getenv(name_.c_str())) before_ = before;
    ::setenv(name_.c_str(), value.c_str(), 1);
  }
  ~ScopedEnvironment() {
    if (before_) {
      ::setenv(name_.c_str(), before_->c_str(), 1);
    } else {
      ::unsetenv(name_.c_str());
    }
  }
  ScopedEnvironment(const ScopedEnvironment&) = delete;
  ScopedEnvironment& operator=(const ScopedEnvironment&) = delete;

 private:
  std::string name_;
  std::optional<std::string> before_;  ///< Its value before, if it had one.
};

}  // namespace lookboth
