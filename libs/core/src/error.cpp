#include "lookboth/core/error.h"

namespace lookboth {

std::string formatErrorMessage(const ErrorContext& context, const std::string& message) {
  std::string out;
  if (!context.file.empty()) {
    out += context.file;
    if (context.line > 0) out += ":" + std::to_string(context.line);
    out += ": ";
  }
  if (!context.field.empty()) out += "'" + context.field + "': ";
  out += message;
  if (!context.subject.empty()) out += " [" + context.subject + "]";
  return out;
}

Error::Error(const std::string& message) : std::runtime_error(message), message_(message) {}

Error::Error(const ErrorContext& context, const std::string& message)
    : std::runtime_error(formatErrorMessage(context, message)),
      context_(context),
      message_(message) {}

}  // namespace lookboth
