#include "lookboth/core/text.h"

#include <cctype>
#include <charconv>
#include <clocale>
#include <cstdio>
#include <cstring>
#include <locale>
#include <sstream>

namespace lookboth {
namespace {

std::string_view trim(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front())))
    text.remove_prefix(1);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
    text.remove_suffix(1);
  return text;
}

}  // namespace

std::optional<double> parseDouble(std::string_view text) {
  text = trim(text);
  if (text.empty()) return std::nullopt;
  // from_chars for double is locale-independent (C++17, libstdc++ >= 11).
  if (text.front() == '+') text.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

std::optional<long long> parseInt(std::string_view text) {
  text = trim(text);
  if (text.empty()) return std::nullopt;
  if (text.front() == '+') text.remove_prefix(1);
  long long value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

std::vector<std::string> splitWhitespace(std::string_view text) {
  std::vector<std::string> tokens;
  size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    const size_t start = i;
    while (i < text.size() && !std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i > start) tokens.emplace_back(text.substr(start, i - start));
  }
  return tokens;
}

std::string formatDouble(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  if (ec != std::errc()) return "nan";
  return std::string(buffer, end);
}

std::string formatFixed(double value, int decimals) {
  char buffer[64];
  const auto [end, ec] =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::fixed, decimals);
  if (ec != std::errc()) return "nan";
  return std::string(buffer, end);
}

std::string excerpt(std::string_view text, std::size_t max_chars) {
  if (text.size() <= max_chars) return "'" + std::string(text) + "'";
  return "'" + std::string(text.substr(0, max_chars)) + "...' (" + std::to_string(text.size()) +
         " characters)";
}

std::string wrapSentences(std::string_view text, std::string_view indent, std::size_t width) {
  std::string out;
  std::string line;
  const auto endLine = [&] {
    if (line.empty()) return;
    out += (out.empty() ? "" : "\n") + std::string(indent) + line;
    line.clear();
  };
  for (const std::string& word : splitWhitespace(text)) {
    if (!line.empty() && indent.size() + line.size() + 1 + word.size() > width) endLine();
    line += (line.empty() ? "" : " ") + word;
    if (word.back() == '.') endLine();
  }
  endLine();
  return out;
}

}  // namespace lookboth
