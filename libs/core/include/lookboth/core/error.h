// Errors that are the user's or the data's fault (a bad file, a missing field,
// a camera never detected). Programmer errors are assertions, not these.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace lookboth {

/// Where in the user's input an error was found. Every field is optional;
/// what is set is printed, so a message names the file, the line, the field
/// or the camera the user has to look at.
struct ErrorContext {
  std::string file;     ///< Path of the offending file, as the user gave it.
  int line = 0;         ///< 1-based line number; 0 when unknown.
  std::string field;    ///< Field or key, e.g. "camera_matrix.data".
  std::string subject;  ///< Camera label, sensor, marker id... when relevant.
};

/// Each part of a message is cut to this many characters (its start and end
/// kept): a value echoed from a corrupt file may be megabytes long.
inline constexpr std::size_t kMaxMessagePart = 2000;

/// An error in input data or configuration. `what()` is a complete message
/// in the form "file:line: field: message [subject]" with the unknown parts
/// left out.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message);
  Error(const ErrorContext& context, const std::string& message);

  const ErrorContext& context() const { return context_; }
  /// The message without the location prefix.
  const std::string& message() const { return message_; }

 private:
  ErrorContext context_;
  std::string message_;
};

/// Formats "file:line: field: message (subject)", leaving out what is unset.
std::string formatErrorMessage(const ErrorContext& context, const std::string& message);

}  // namespace lookboth
