// Locale-independent number parsing and formatting: a decimal point is a
// point whatever LC_NUMERIC says (the desktop app runs under user locales).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lookboth {

/// Parses a whole string as a double ("1.5", "-2e-3", " 3 "). Surrounding
/// whitespace is allowed; anything else makes it fail. Locale-independent.
std::optional<double> parseDouble(std::string_view text);

/// Parses a whole string as a signed 64-bit integer.
std::optional<long long> parseInt(std::string_view text);

/// Splits on runs of whitespace; no empty tokens.
std::vector<std::string> splitWhitespace(std::string_view text);

/// Shortest text that reads back as the same double ("%.17g" trimmed), with
/// a point as decimal separator.
std::string formatDouble(double value);

/// Fixed notation with `decimals` digits after the point.
std::string formatFixed(double value, int decimals);

/// `text` in single quotes for a message, cut to `max_chars` with "..." (a
/// value echoed from a bad file may be a whole 200 MB line).
std::string excerpt(std::string_view text, std::size_t max_chars = 60);

/// `text` for a terminal or a log: each sentence (ending in ". ") starts a
/// line, lines are wrapped at spaces to at most `width` characters where the
/// words allow, and each line begins with `indent`. No trailing newline.
std::string wrapSentences(std::string_view text, std::string_view indent = "",
                          std::size_t width = 100);

}  // namespace lookboth
