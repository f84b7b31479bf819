#include "lookboth/core/error.h"

namespace lookboth {

namespace {

/// A part of a message cut to `limit` characters: a field echoed from a bad
/// file may be a whole 200 MB line, and the user needs its start, not all of it.
std::string bounded(const std::string& text, std::size_t limit) {
  if (text.size() <= limit) return text;
  const std::size_t head = limit * 3 / 4;
  const std::size_t tail = limit - head;
  return text.substr(0, head) + " [... " + std::to_string(text.size() - head - tail) +
         " characters left out ...] " + text.substr(text.size() - tail);
}

}  // namespace

std::string formatErrorMessage(const ErrorContext& context, const std::string& message) {
  std::string out;
  if (!context.file.empty()) {
    out += bounded(context.file, kMaxMessagePart);
    if (context.line > 0) out += ":" + std::to_string(context.line);
    out += ": ";
  }
  if (!context.field.empty()) out += "'" + bounded(context.field, 200) + "': ";
  out += bounded(message, kMaxMessagePart);
  if (!context.subject.empty()) out += " [" + bounded(context.subject, 200) + "]";
  return out;
}

Error::Error(const std::string& message)
    : std::runtime_error(bounded(message, kMaxMessagePart)),
      message_(bounded(message, kMaxMessagePart)) {}

Error::Error(const ErrorContext& context, const std::string& message)
    : std::runtime_error(formatErrorMessage(context, message)),
      context_(context),
      message_(bounded(message, kMaxMessagePart)) {}

}  // namespace lookboth
