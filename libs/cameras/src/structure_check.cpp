#include "structure_check.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lookboth/core/error.h"

namespace lookboth {
namespace {

ErrorContext at(const std::string& file, int line, const std::string& field = "") {
  ErrorContext context;
  context.file = file;
  context.line = line;
  context.field = field;
  return context;
}

[[noreturn]] void throwTooDeep(const std::string& file, int line, int max_depth) {
  throw Error(at(file, line), "nesting deeper than " + std::to_string(max_depth) + " levels");
}

/// The keys of one map with the line of each, in the order a parser meets them.
class KeyLines {
 public:
  void add(const std::string& key, int line, const std::string& file) {
    const auto [first, inserted] = lines_.emplace(key, line);
    if (!inserted) {
      throw Error(at(file, line, shortenedName(key)),
                  "duplicate key (first at line " + std::to_string(first->second) + ")");
    }
  }

 private:
  std::map<std::string, int> lines_;
};

// ---------------------------------------------------------------------------
// yaml-cpp: the parser's events, which name every collection and key in order
// (aliases are not expanded, so the pass stays linear).

class YamlStructure : public YAML::EventHandler {
 public:
  YamlStructure(const std::string& file, int max_depth) : file_(file), max_depth_(max_depth) {}

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override { node(nullptr, 0); }
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override { node(nullptr, 0); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                const std::string& value) override {
    node(&value, lineOf(mark));
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    open(mark, false);
  }
  void OnSequenceEnd() override { levels_.pop_back(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    open(mark, true);
  }
  void OnMapEnd() override { levels_.pop_back(); }

 private:
  struct Level {
    bool map = false;
    bool next_is_key = true;
    KeyLines keys;
  };

  static int lineOf(const YAML::Mark& mark) { return mark.is_null() ? 0 : mark.line + 1; }

  /// A node in the current collection: in a map, every other one is a key.
  /// Only scalar keys are compared (a collection as a key is never a
  /// calibration field).
  void node(const std::string* scalar, int line) {
    if (levels_.empty() || !levels_.back().map) return;
    Level& level = levels_.back();
    if (level.next_is_key && scalar) level.keys.add(*scalar, line, file_);
    level.next_is_key = !level.next_is_key;
  }

  void open(const YAML::Mark& mark, bool map) {
    node(nullptr, 0);
    if (static_cast<int>(levels_.size()) >= max_depth_) {
      throwTooDeep(file_, lineOf(mark), max_depth_);
    }
    levels_.emplace_back();
    levels_.back().map = map;
  }

  const std::string& file_;
  int max_depth_;
  std::vector<Level> levels_;
};

// ---------------------------------------------------------------------------
// cv::FileStorage
//
// The readers below follow OpenCV 4.x's own (modules/core/src/persistence.cpp,
// persistence_yml.cpp, persistence_xml.cpp, persistence_json.cpp) step by
// step, with an explicit stack where OpenCV recurses. Following OpenCV rather
// than the formats' specifications is the point: a bracket in a quoted string
// or in an XML entity ("&<x;") opens nothing, while "a: b: c:" or "-----" on
// one line nests in OpenCV's YAML; a check that guessed from brackets could be
// steered past. Where OpenCV throws a parse error, the check stops (nothing
// after it is read) and leaves the report to OpenCV. Where OpenCV would go
// wrong instead (read past a line into what earlier lines left in its buffer,
// dereference a null pointer, loop forever), the check throws.

/// OpenCV reports a parse error here: it reads nothing further.
struct ReaderStops {};

[[noreturn]] void readerStops() { throw ReaderStops{}; }

// Character classes as OpenCV's readers define them.
bool isPrint(char c) { return static_cast<unsigned char>(c) >= ' '; }
bool isPrintOrTab(char c) { return isPrint(c) || c == '\t'; }
bool isDigit(char c) { return c >= '0' && c <= '9'; }
bool isAlpha(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool isAlnum(char c) { return isDigit(c) || isAlpha(c); }
bool isSpace(char c) { return (c >= 9 && c <= 13) || c == ' '; }

/// The start of a number in OpenCV's YAML and XML readers; `next` is the
/// character the reader looks at after `c` (not always the one in the text).
bool startsNumber(char c, char next) {
  return isDigit(c) || ((c == '-' || c == '+') && (isDigit(next) || next == '.')) ||
         (c == '.' && isAlnum(next));
}

/// The text as OpenCV's in-memory reader hands it out, line by line
/// (FileStorage::Impl::gets): the text ends at its first NUL, a UTF-8 byte
/// order mark is skipped, each line keeps its '\n' and is followed by a NUL.
/// Past that NUL, OpenCV's buffer holds what longer lines left there; reading
/// it is refused.
class Lines {
 public:
  Lines(const std::string& text, const std::string& file) : text_(text.c_str()), file_(file) {
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") next_ = 3;
  }

  /// Loads the next line; false when the text has no more.
  bool next() {
    if (next_ >= text_.size()) return false;
    const size_t newline = text_.find('\n', next_);
    const size_t end = newline == std::string_view::npos ? text_.size() : newline + 1;
    line_.assign(text_.substr(next_, end - next_));
    next_ = end;
    ++number_;
    return true;
  }
  /// OpenCV's eof(): the last line has been handed out, or the end stood in.
  bool atEnd() const { return ended_ || next_ >= text_.size(); }
  /// The YAML reader's stand-in for the end of the text: a line "...".
  void markEnd() {
    line_ = "...";
    ended_ = true;
  }

  char operator[](size_t i) const {
    if (i < line_.size()) return line_[i];
    if (i == line_.size()) return '\0';
    throw Error(at(file_, number_),
                "OpenCV's reader would read past the end of this line, into memory the text "
                "never filled");
  }
  /// Whether the line holds `prefix` at `i`; like memcmp, it reads only up to
  /// the first difference (at the latest the NUL).
  bool holds(size_t i, std::string_view prefix) const {
    for (const char c : prefix) {
      if ((*this)[i++] != c) return false;
    }
    return true;
  }
  std::string text(size_t begin, size_t end) const { return line_.substr(begin, end - begin); }
  /// The line from `i` on, NUL-terminated (for strtol).
  const char* from(size_t i) const { return line_.c_str() + i; }
  void set(size_t i, char c) { line_[i] = c; }
  /// Ends the line at `i` (OpenCV writes a NUL there).
  void cut(size_t i) { line_.resize(i); }

  int number() const { return number_; }
  const std::string& file() const { return file_; }

 private:
  std::string_view text_;
  const std::string& file_;
  size_t next_ = 0;
  std::string line_;  // empty: OpenCV's readers start on an empty buffer
  int number_ = 0;
  bool ended_ = false;
};

/// A nesting level opened at `line`: throws past `max_depth`.
void checkDepth(size_t open_levels, const Lines& in, int max_depth) {
  if (static_cast<int>(open_levels) >= max_depth) throwTooDeep(in.file(), in.number(), max_depth);
}

// Base64 data ("!!binary" in YAML, type_id="binary" in XML, "$base64$" in
// JSON). OpenCV decodes a 24-byte header into a type spec, then reads
// elements of those types until the data ends; a spec that names no type
// ("", "12") yields no element, so the data never ends and the reader loops
// forever (FileStorage::Impl::parseBase64).

constexpr unsigned char kBase64Value[128] = {
    0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,
    0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  0,  62,
    0,  0,  0,  63, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 0,  0,  0,  0,  0,  0,  0,  0,
    1,  2,  3,  4,  5,  6,  7,  8,  9,  10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22,
    23, 24, 25, 0,  0,  0,  0,  0,  0,  26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38,
    39, 40, 41, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 0,  0,  0,  0,  0};

/// The next row of base64 data as the reader takes it (its getBase64Row);
/// false where the rows end.
using Base64Rows = std::function<bool(std::string& row)>;

/// Reads base64 data as OpenCV's decoder does (Base64Decoder, parseBase64):
/// rows are taken one per refill, each decoded by whole groups of four
/// characters. Throws where the header would leave the reader looping
/// forever; otherwise takes every row, as the reader goes on to do.
void readBase64(const Base64Rows& next_row, const Lines& in) {
  std::string encoded;
  std::string decoded;
  size_t taken = 0;  // bytes of `decoded` already read
  size_t total_chars = 0;
  bool ended = false;
  auto refill = [&]() {
    if (ended) return false;
    decoded.erase(0, taken);
    taken = 0;
    std::string row;
    if (next_row(row) && !row.empty()) {
      encoded += row;
      total_chars += row.size();
    } else {
      ended = true;
      for (size_t count = total_chars; count % 4 != 0; ++count) encoded += '=';
    }
    auto value = [](char c) {
      const auto index = static_cast<unsigned char>(c);
      return index < 128 ? kBase64Value[index] : static_cast<unsigned char>(0);
    };
    size_t i = 0;
    for (; i + 4 <= encoded.size(); i += 4) {
      const unsigned d = value(encoded[i]), c = value(encoded[i + 1]);
      const unsigned b = value(encoded[i + 2]), a = value(encoded[i + 3]);
      decoded += static_cast<char>((d << 2) | (c >> 4));
      decoded += static_cast<char>((c << 4) | (b >> 2));
      decoded += static_cast<char>((b << 6) | a);
    }
    if (i > 0 && encoded[i - 1] == '=') {
      if (i > 1 && encoded[i - 2] == '=' && !decoded.empty()) decoded.pop_back();
      if (!decoded.empty()) decoded.pop_back();
    }
    encoded.erase(0, i);
    return !decoded.empty();
  };
  // The header: 24 bytes, of which the type spec runs to the first space or NUL.
  std::string spec;
  bool spec_done = false;
  for (int k = 0; k < 24; ++k) {
    char byte = 0;
    if (taken < decoded.size() || refill()) byte = decoded[taken++];
    if (byte == '\0' || std::isspace(static_cast<unsigned char>(byte))) spec_done = true;
    if (!spec_done) spec += byte;
  }
  // With the data ended inside the header, OpenCV fails an assertion.
  bool never_ends = false;
  if (!ended) {
    // A spec of digits alone is a count with no type: OpenCV rejects a count
    // that is not positive as an int, loops on any other.
    never_ends = spec.empty() || (std::all_of(spec.begin(), spec.end(), isDigit) &&
                                  static_cast<int>(std::strtol(spec.c_str(), nullptr, 10)) > 0);
  }
  if (never_ends) {
    throw Error(at(in.file(), in.number()),
                "base64 data whose header names no element type: OpenCV's reader would never "
                "finish reading it");
  }
  std::string row;
  while (!ended && next_row(row) && !row.empty()) {
  }
}

// ---------------------------------------------------------------------------
// OpenCV YAML (persistence_yml.cpp)

class OpenCvYaml {
 public:
  OpenCvYaml(Lines& in, int max_depth) : in_(in), max_depth_(max_depth) {}

  void read() {
    bool first = true;
    for (;;) {
      // Directives and the start of the next document.
      for (;;) {
        skipSpaces(0);
        const char c = in_[p_];
        if (c == '%') {
          if (in_.holds(p_, "%YAML") && !in_.holds(p_, "%YAML:1.") && !in_.holds(p_, "%YAML 1.")) {
            readerStops();
          }
          in_.cut(p_);
        } else if (c == '-') {
          if (in_.holds(p_, "---")) {
            p_ += 3;
            break;
          }
          if (first) break;
          throw Error(at(in_.file(), in_.number()),
                      "OpenCV's reader would never finish here: a document after the first must "
                      "start with '---'");
        } else if (isAlnum(c) || c == '_') {
          if (!first) readerStops();
          break;
        } else if (in_.atEnd()) {
          break;
        } else {
          readerStops();
        }
      }
      skipSpaces(0);
      if (!in_.holds(p_, "...")) {
        readRoot();
        skipSpaces(0);
      }
      if (in_.atEnd()) return;
      p_ += 3;  // past "---" or "...", whatever is there
      first = false;
    }
  }

 private:
  enum class Step { kValue, kAfterValue, kBlockItem, kFlowItem, kRootDone };
  enum class Type { kNone, kString, kNumber };

  struct Frame {
    bool flow = false;
    bool map = false;
    int indent = 0;          ///< block: the column of its items
    int min_indent = 0;      ///< flow: the lowest column a line inside may start at
    bool has_items = false;  ///< flow: the next item must follow a ','
    KeyLines keys;
  };

  void skipSpaces(int min_indent) {
    for (;;) {
      while (in_[p_] == ' ') ++p_;
      const char c = in_[p_];
      if (c == '#') {
        in_.cut(p_);
      } else if (isPrint(c)) {
        if (static_cast<int>(p_) < min_indent) readerStops();
        return;
      } else if (c == '\0' || c == '\n' || c == '\r') {
        p_ = 0;
        if (!in_.next()) {
          in_.markEnd();
          return;
        }
      } else {
        readerStops();  // a tab or another control character
      }
    }
  }

  void open(bool flow, bool map) {
    checkDepth(frames_.size(), in_, max_depth_);
    if (frames_.empty()) root_is_collection_ = true;
    Frame frame;
    frame.flow = flow;
    frame.map = map;
    if (flow) {
      frame.min_indent = value_min_indent_ + (value_in_flow_ ? 0 : 1);
    } else {
      frame.indent = static_cast<int>(p_);
    }
    frames_.push_back(std::move(frame));
  }

  void readRoot() {
    root_is_collection_ = false;
    value_min_indent_ = 0;
    value_in_flow_ = false;
    Step step = Step::kValue;
    while (step != Step::kRootDone) {
      switch (step) {
        case Step::kValue:
          step = value();
          break;
        case Step::kAfterValue:
          step = afterValue();
          break;
        case Step::kBlockItem:
          step = blockItem();
          break;
        case Step::kFlowItem:
          step = flowItem();
          break;
        case Step::kRootDone:
          break;
      }
    }
    if (!root_is_collection_) readerStops();
  }

  Step value() {
    char c = in_[p_];
    char next = in_[p_ + 1];
    Type type = Type::kNone;
    bool user_type = false;
    bool binary = false;
    if (c == '!') {
      if (next == '!' || next == '^') {
        ++p_;
        user_type = true;
      }
      if (next == '<') {
        size_t end = ++p_;
        do {
          next = in_[++end];
        } while (isPrint(next) && next != ' ' && next != '>');
        constexpr std::string_view kHeading = "<tag:yaml.org,2002:";
        if (next == '>' && end - p_ > kHeading.size() && in_.holds(p_, kHeading)) {
          in_.set(end, ' ');
          p_ += kHeading.size() - 1;
          user_type = true;
        }
      }
      size_t end = p_++;
      do {
        next = in_[++end];
      } while (isPrint(next) && next != ' ');
      if (end == p_) readerStops();  // an empty type name
      const std::string name = in_.text(p_, end);
      if (!user_type && name == "str") type = Type::kString;
      if (!user_type && (name == "int" || name == "float")) type = Type::kNumber;
      if (user_type && name == "binary") {
        binary = true;
        do {
          next = in_[++end];
          if (next == '|') break;
        } while (next == ' ');
        next = in_[++end];
      }
      p_ = end;
      skipSpaces(value_min_indent_);
      c = in_[p_];
      if (type == Type::kString && c != '\'' && c != '"') return plain(true);
      if (type == Type::kNumber) return number();
    }
    if (binary) return base64();
    if (startsNumber(c, next)) return number();
    if (c == '\'' || c == '"') return quoted(c);
    if (c == '[' || c == '{') {
      open(true, c == '{');
      ++p_;
      return Step::kFlowItem;
    }
    if (value_in_flow_ || c != '-') {
      if (!value_in_flow_ && (c == '?' || c == '|' || c == '>')) readerStops();
      return plain(false);
    }
    open(false, false);
    return Step::kBlockItem;
  }

  /// OpenCV reads a number with strtol or strtod, which stop at or before the
  /// first of these characters; text between the two is a parse error.
  Step number() {
    for (;;) {
      const char c = in_[p_];
      if (!isPrint(c) || c == ' ' || c == '#') break;
      if (value_in_flow_ && (c == ',' || c == ']' || c == '}')) break;
      ++p_;
    }
    return Step::kAfterValue;
  }

  Step quoted(char quote) {
    constexpr size_t kMaxLength = 4096;  // CV_FS_MAX_LEN
    size_t length = 0;
    if (quote == '\'') {
      while (length < kMaxLength) {
        char c = in_[++p_];
        if (isAlnum(c) || (c != '\'' && isPrint(c))) {
          ++length;
        } else if (c == '\'') {
          c = in_[++p_];
          if (c != '\'') break;
          ++length;
        } else {
          readerStops();
        }
      }
    } else {
      while (length < kMaxLength) {
        const char c = in_[++p_];
        if (isAlnum(c) || (c != '\\' && c != '"' && isPrint(c))) {
          ++length;
        } else if (c == '"') {
          ++p_;
          break;
        } else if (c == '\\') {
          const char escaped = in_[++p_];
          if (escaped == '\'' || escaped == '"' || escaped == '\\' || escaped == 'n' ||
              escaped == 'r' || escaped == 't') {
            ++length;
          } else if (escaped == 'x' || (isDigit(escaped) && escaped < '8')) {
            // OpenCV runs strtol over the characters up to three past the
            // backslash and moves to where it stopped; the loop then skips one
            // more character, whatever it is.
            const size_t from = p_ + (escaped == 'x' ? 1 : 0);
            std::string digits;
            for (size_t i = from; i < p_ + 3 && in_[i] != '\0'; ++i) digits += in_[i];
            char* end = nullptr;
            std::strtol(digits.c_str(), &end, escaped == 'x' ? 8 : 16);
            ++length;
            if (end != digits.c_str()) p_ = from + static_cast<size_t>(end - digits.c_str());
          }
        } else {
          readerStops();
        }
      }
    }
    if (length >= kMaxLength) readerStops();
    return Step::kAfterValue;
  }

  /// A plain value, or the first key of a block map (a plain value followed
  /// by ':' anywhere on its line).
  Step plain(bool string_type) {
    size_t end = p_;
    for (;;) {
      const char c = in_[end];
      if (!isPrint(c)) break;
      if (value_in_flow_ && (c == ',' || c == '}' || c == ']')) break;
      if (!value_in_flow_ && c == ':' && !string_type) break;
      ++end;
    }
    if (end == p_) readerStops();
    if (value_in_flow_ || in_[end] != ':') {
      p_ = end;
      return Step::kAfterValue;
    }
    open(false, true);
    return Step::kBlockItem;
  }

  /// Rows at the column of the first one.
  Step base64() {
    const int indent = static_cast<int>(p_);
    readBase64(
        [&](std::string& row) {
          skipSpaces(0);
          if (static_cast<int>(p_) != indent) return false;
          const size_t begin = p_;
          while (isPrint(in_[p_])) ++p_;
          if (in_[p_] == '\0') readerStops();
          row = in_.text(begin, p_);
          return true;
        },
        in_);
    return Step::kAfterValue;
  }

  void readKey(Frame& map) {
    if (in_[p_] == '-') readerStops();
    size_t end = p_;
    while (isPrint(in_[end]) && in_[end] != ':') ++end;
    if (in_[end] != ':') readerStops();
    if (end == p_) {
      // OpenCV walks back over the spaces before the ':' to find the key's
      // end and, with no key, past its start: a negative length, or a read
      // before the line.
      throw Error(at(in_.file(), in_.number()), "a key is missing before ':'");
    }
    size_t key_end = end;
    while (in_[key_end - 1] == ' ') --key_end;
    map.keys.add(in_.text(p_, key_end), in_.number(), in_.file());
    p_ = end + 1;
  }

  Step afterValue() {
    if (frames_.empty()) return Step::kRootDone;
    Frame& frame = frames_.back();
    if (frame.flow) {
      frame.has_items = true;
      return Step::kFlowItem;
    }
    skipSpaces(0);
    const int column = static_cast<int>(p_);
    if (column > frame.indent) readerStops();
    if (column < frame.indent || in_.holds(p_, "...")) {
      frames_.pop_back();
      return Step::kAfterValue;
    }
    return Step::kBlockItem;
  }

  Step blockItem() {
    Frame& frame = frames_.back();
    const int indent = frame.indent;
    if (frame.map) {
      readKey(frame);
    } else {
      if (in_[p_] != '-') readerStops();
      ++p_;
    }
    skipSpaces(indent + 1);
    value_min_indent_ = indent + 1;
    value_in_flow_ = false;
    return Step::kValue;
  }

  Step flowItem() {
    Frame& frame = frames_.back();
    const int min_indent = frame.min_indent;
    skipSpaces(min_indent);
    const char c = in_[p_];
    if (c == '}' || c == ']') {
      if (c != (frame.map ? '}' : ']')) readerStops();
      ++p_;
      frames_.pop_back();
      return Step::kAfterValue;
    }
    if (frame.has_items) {
      if (c != ',') readerStops();
      ++p_;
      skipSpaces(min_indent);
    }
    if (frame.map) {
      readKey(frame);
      skipSpaces(min_indent);
    } else if (in_[p_] == ']') {
      // After a trailing ',' OpenCV ends the list without taking the ']',
      // which then closes the collection around it too.
      frames_.pop_back();
      return Step::kAfterValue;
    }
    value_min_indent_ = min_indent;
    value_in_flow_ = true;
    return Step::kValue;
  }

  Lines& in_;
  int max_depth_;
  size_t p_ = 0;
  std::vector<Frame> frames_;
  bool root_is_collection_ = false;
  // Where the value being read sits.
  int value_min_indent_ = 0;
  bool value_in_flow_ = false;
};

// ---------------------------------------------------------------------------
// OpenCV XML (persistence_xml.cpp)

class OpenCvXml {
 public:
  OpenCvXml(Lines& in, int max_depth) : in_(in), max_depth_(max_depth) {}

  void read() {
    if (!skipSpaces(kInsideTag)) readerStops();
    if (!in_.holds(p_, "<?xml")) readerStops();
    readTag();
    for (;;) {
      if (in_[p_] == '\0') return;
      if (!skipSpaces(kOutside)) readerStops();
      const Tag storage = readTag();
      if (storage.kind != Tag::kOpening || storage.name != "opencv_storage") readerStops();
      readElement(storage.name, kMap);
      closeTag(storage.name);
      if (!skipSpaces(kOutside)) return;
    }
  }

 private:
  static constexpr int kOutside = 0;
  static constexpr int kInsideComment = 1;
  static constexpr int kInsideTag = 2;
  enum ValueType { kNone, kString, kMap, kSeq };

  struct Tag {
    enum Kind { kOpening, kClosing, kEmpty, kHeader, kDirective } kind = kOpening;
    std::string name;
    std::string type_id;
    int line = 0;
  };
  struct Element {
    std::string name;
    ValueType type = kNone;
    bool have_space = true;
    KeyLines children;
  };

  /// False where OpenCV's skip returns a null pointer: the text ended.
  bool skipSpaces(int mode) {
    for (;;) {
      char c;
      if (mode == kInsideComment) {
        for (;;) {
          c = in_[p_];
          if (!isPrintOrTab(c) || (c == '-' && in_[p_ + 1] == '-' && in_[p_ + 2] == '>')) break;
          ++p_;
        }
        if (c == '-') {
          mode = kOutside;
          p_ += 3;
        }
      } else {
        for (;;) {
          c = in_[p_];
          if (c != ' ' && c != '\t') break;
          ++p_;
        }
        if (c == '<' && in_[p_ + 1] == '!' && in_[p_ + 2] == '-' && in_[p_ + 3] == '-') {
          if (mode != kOutside) readerStops();  // no comments inside a tag
          mode = kInsideComment;
          p_ += 4;
        } else if (isPrint(c)) {
          return true;
        }
      }
      const char here = in_[p_];
      if (!isPrint(here)) {
        if (here != '\0' && here != '\n' && here != '\r') readerStops();
        p_ = 0;
        if (!in_.next()) return false;
      }
    }
  }

  Tag readTag() {
    Tag tag;
    tag.line = in_.number();
    if (in_[p_] != '<') readerStops();
    const char c = in_[++p_];
    if (isAlnum(c) || c == '_') {
      tag.kind = Tag::kOpening;
    } else if (c == '/') {
      tag.kind = Tag::kClosing;
      ++p_;
    } else if (c == '?') {
      tag.kind = Tag::kHeader;
      ++p_;
    } else if (c == '!') {
      if (in_[p_ + 1] == '-' && in_[p_ + 2] == '-') readerStops();  // an assertion
      tag.kind = Tag::kDirective;
      ++p_;
    } else {
      readerStops();
    }
    for (;;) {
      if (!isAlpha(in_[p_]) && in_[p_] != '_') readerStops();
      size_t end = p_;
      while (isAlnum(in_[end]) || in_[end] == '_' || in_[end] == '-') ++end;
      const std::string name = in_.text(p_, end);
      p_ = end;
      if (tag.name.empty()) {
        tag.name = name;
      } else {
        readAttribute(tag, name);
      }
      char after = in_[p_];
      const bool have_space = isSpace(after) || after == '\0';
      if (after != '>') {
        if (!skipSpaces(kInsideTag)) readerStops();
        after = in_[p_];
      }
      if (after == '>') {
        if (tag.kind == Tag::kHeader) readerStops();
        ++p_;
        return tag;
      }
      if (after == '?' && tag.kind == Tag::kHeader) {
        if (in_[p_ + 1] != '>') readerStops();
        p_ += 2;
        return tag;
      }
      if (after == '/' && in_[p_ + 1] == '>' && tag.kind == Tag::kOpening) {
        tag.kind = Tag::kEmpty;
        p_ += 2;
        return tag;
      }
      if (!have_space) readerStops();
    }
  }

  void readAttribute(Tag& tag, const std::string& name) {
    if (tag.kind == Tag::kClosing) readerStops();
    if (in_[p_] != '=') {
      if (!skipSpaces(kInsideTag)) readerStops();
      if (in_[p_] != '=') readerStops();
    }
    const char c = in_[++p_];
    if (c != '"' && c != '\'') {
      if (!skipSpaces(kInsideTag)) {
        // OpenCV does not check for the end of the text here.
        throw Error(at(in_.file(), in_.number()),
                    "the text ends inside a tag, where OpenCV's reader would crash");
      }
      if (in_[p_] != '"' && in_[p_] != '\'') readerStops();
    }
    const char quote = in_[p_++];
    size_t end = p_;
    for (;;) {
      const char q = in_[end++];
      if (q == quote) break;
      if (q == '\0') readerStops();
    }
    if (name == "type_id") {
      if (!tag.type_id.empty()) readerStops();  // an assertion
      tag.type_id = in_.text(p_, end - 1);
    }
    p_ = end;
  }

  /// The contents of the element `name` whose opening tag was just read, up
  /// to and with its closing tag for all but the outermost.
  void readElement(const std::string& name, ValueType type) {
    std::vector<Element> stack;
    auto push = [&](const std::string& element_name, ValueType element_type) {
      checkDepth(stack.size(), in_, max_depth_);
      stack.emplace_back();
      stack.back().name = element_name;
      stack.back().type = element_type;
    };
    // Ends the innermost element; its parent reads the closing tag. False
    // when that was the outermost.
    auto close = [&]() {
      const std::string closed = stack.back().name;
      stack.pop_back();
      if (stack.empty()) return false;
      closeTag(closed);
      stack.back().have_space = true;
      return true;
    };
    push(name, type);
    for (;;) {
      Element& element = stack.back();
      char c = in_[p_];
      if (isSpace(c) || c == '\0' || (c == '<' && in_[p_ + 1] == '!' && in_[p_ + 2] == '-')) {
        if (!skipSpaces(kOutside)) readerStops();
        element.have_space = true;
        c = in_[p_];
      }
      const char next = in_[p_ + 1];
      if (c == '<') {
        if (next == '/') {
          if (!close()) return;
          continue;
        }
        const Tag tag = readTag();
        if (tag.kind != Tag::kOpening) readerStops();
        ValueType child_type = kNone;
        if (tag.type_id == "str") child_type = kString;
        if (tag.type_id == "map") child_type = kMap;
        if (tag.type_id == "seq") child_type = kSeq;
        if (tag.name != "_") element.children.add(tag.name, tag.line, in_.file());
        if (tag.type_id == "binary") {
          if (!base64() || !skipSpaces(kOutside)) readerStops();
          closeTag(tag.name);
          element.have_space = true;
        } else {
          push(tag.name, child_type);
        }
        continue;
      }
      if (!element.have_space) readerStops();
      if (element.type != kString && startsNumber(c, next)) {
        // strtol or strtod stop at or before these; text between is an error.
        while (!isSpace(in_[p_]) && in_[p_] != '\0' && in_[p_] != '<') ++p_;
      } else {
        readString();
      }
      if (element.type == kString) {
        if (!close()) return;
        continue;
      }
      element.have_space = false;
    }
  }

  void closeTag(const std::string& name) {
    const Tag tag = readTag();
    if (tag.kind != Tag::kClosing || tag.name != name) readerStops();
  }

  void readString() {
    const bool quoted = in_[p_] == '"';
    size_t i = quoted ? p_ + 1 : p_;
    for (;; ++i) {
      char c = in_[i];
      if (isAlnum(c)) continue;
      if (c == '"') {
        if (!quoted) readerStops();
        p_ = i + 1;
        return;
      }
      if (!isPrint(c) || c == '<' || (!quoted && isSpace(c))) {
        if (quoted) readerStops();
        p_ = i;
        return;
      }
      if (c == '\'' || c == '>') readerStops();
      if (c != '&') continue;
      // An entity: "&#65;", "&#x41;", or a name ("&lt;"; OpenCV takes any
      // character after the '&', then letters and digits, then ';').
      if (in_[++i] == '#') {
        ++i;
        int base = 10;
        if (in_[i] == 'x') {
          base = 16;
          ++i;
        }
        const char* digits = in_.from(i);
        char* end = nullptr;
        const long value = std::strtol(digits, &end, base);
        i += static_cast<size_t>(end - digits);
        if (static_cast<unsigned>(static_cast<int>(value)) > 255u || in_[i] != ';') readerStops();
      } else {
        do {
          c = in_[++i];
        } while (isAlnum(c));
        if (c != ';') readerStops();
      }
    }
  }

  /// Rows up to the next tag; false when the text ended instead.
  bool base64() {
    bool text_ended = false;
    readBase64(
        [&](std::string& row) {
          if (!skipSpaces(kInsideTag)) {
            text_ended = true;
            return false;
          }
          if (in_[p_] == '<') return false;
          const size_t begin = p_;
          while (isPrint(in_[p_])) ++p_;
          if (in_[p_] == '\0') readerStops();
          row = in_.text(begin, p_);
          return true;
        },
        in_);
    return !text_ended;
  }

  Lines& in_;
  int max_depth_;
  size_t p_ = 0;
};

// ---------------------------------------------------------------------------
// OpenCV JSON (persistence_json.cpp)

class OpenCvJson {
 public:
  OpenCvJson(Lines& in, int max_depth) : in_(in), max_depth_(max_depth) {}

  void read() {
    skipSpaces();
    const char c = in_[p_];
    if (c != '{' && c != '[') readerStops();
    open(c == '{');
    ++p_;
    // What follows the outermost collection is not read.
    while (!frames_.empty()) {
      Frame& frame = frames_.back();
      skipSpaces();
      const char closing = frame.map ? '}' : ']';
      bool item_opened = false;
      if (frame.map ? in_[p_] == '"' : in_[p_] != ']') {
        if (frame.map) {
          readKey(frame);
          skipSpaces();
        }
        item_opened = item();
      }
      if (item_opened) continue;
      separator(closing);
    }
  }

 private:
  struct Frame {
    bool map = false;
    KeyLines keys;
  };

  void open(bool map) {
    checkDepth(frames_.size(), in_, max_depth_);
    frames_.emplace_back();
    frames_.back().map = map;
  }

  /// After an item: a ',' before the next item, or the end of the
  /// collection, which was an item of the enclosing one.
  void separator(char closing) {
    for (;;) {
      skipSpaces();
      const char c = in_[p_];
      if (c == ',') {
        ++p_;
        return;
      }
      if (c != closing) readerStops();
      ++p_;
      frames_.pop_back();
      if (frames_.empty()) return;
      closing = frames_.back().map ? '}' : ']';
    }
  }

  void skipSpaces() {
    for (;;) {
      const char c = in_[p_];
      if (c == '/') {
        skipComment();
      } else if (c == ' ' || c == '\t') {
        ++p_;
      } else if (c == '\0' || c == '\n' || c == '\r') {
        nextLine();
      } else {
        if (!isPrint(c)) readerStops();
        return;
      }
    }
  }

  /// The text ending inside a JSON value is a parse error.
  void nextLine() {
    p_ = 0;
    if (!in_.next()) readerStops();
  }

  void skipComment() {
    ++p_;
    if (in_[p_] == '\0') nextLine();
    if (in_[p_] == '/') {
      while (in_[p_] != '\n' && in_[p_] != '\r') {
        if (in_[p_] == '\0') {
          nextLine();
        } else {
          ++p_;
        }
      }
    } else if (in_[p_] == '*') {
      ++p_;
      for (;;) {
        if (in_[p_] == '\0') {
          nextLine();
        } else if (in_[p_] == '*') {
          ++p_;
          if (in_[p_] == '\0') nextLine();
          if (in_[p_] == '/') {
            ++p_;
            return;
          }
        } else {
          ++p_;
        }
      }
    } else {
      readerStops();
    }
  }

  void readKey(Frame& map) {
    const size_t begin = p_ + 1;
    size_t end = begin;
    while (isPrint(in_[end]) && in_[end] != '"') ++end;
    if (in_[end] != '"' || end == begin) readerStops();
    map.keys.add(in_.text(begin, end), in_.number(), in_.file());
    p_ = end + 1;
    skipSpaces();
    if (in_[p_] != ':') readerStops();
    ++p_;
  }

  /// One item; true when it opened a collection (read next).
  bool item() {
    skipSpaces();
    const char c = in_[p_];
    if (c == '[' || c == '{') {
      open(c == '{');
      ++p_;
      return true;
    }
    if (c == '"') {
      readString();
    } else {
      // A number, true, false or null: strtod and friends stop at or before
      // these, and text between is an error.
      for (;;) {
        const char d = in_[p_];
        if (!isPrint(d) || d == ' ' || d == '\t' || d == '/' || d == ',' || d == ']' || d == '}') {
          break;
        }
        ++p_;
      }
    }
    return false;
  }

  void readString() {
    const size_t begin = p_ + 1;
    size_t length = 0;
    while ((isAlnum(in_[begin + length]) || in_[begin + length] == '$') && length <= 9) ++length;
    if (length >= 8 && in_.holds(begin, "$base64$")) {
      // Rows run to a ',' or '"' (the first one only: the next starts there).
      size_t end = begin + 8;
      readBase64(
          [&](std::string& row) {
            if (in_[end] == '\0') return false;
            const size_t row_begin = end;
            while (isPrint(in_[end]) && in_[end] != ',' && in_[end] != '"') ++end;
            if (in_[end] == '\0') readerStops();
            row = in_.text(row_begin, end);
            return true;
          },
          in_);
      if (in_[end] != '"') readerStops();
      p_ = end + 1;
      return;
    }
    for (size_t i = begin;; ++i) {
      const char c = in_[i];
      if (c == '\\') {
        const char escaped = in_[++i];
        if (escaped != '\\' && escaped != '"' && escaped != '\'' && escaped != 'n' &&
            escaped != 'r' && escaped != 't' && escaped != 'b' && escaped != 'f') {
          readerStops();
        }
      } else if (c == '"') {
        p_ = i + 1;
        return;
      } else if (c == '\0' || c == '\n' || c == '\r') {
        readerStops();  // a string does not go on past its line
      }
    }
  }

  Lines& in_;
  int max_depth_;
  size_t p_ = 0;
  std::vector<Frame> frames_;
};

}  // namespace

std::string shortenedName(const std::string& name) {
  constexpr size_t kMaxChars = 60;
  if (name.size() <= kMaxChars) return name;
  size_t cut = kMaxChars;
  // Not in the middle of a UTF-8 sequence.
  while (cut > 0 && (static_cast<unsigned char>(name[cut]) & 0xC0) == 0x80) --cut;
  return name.substr(0, cut) + "...";
}

void checkYamlStructure(const std::string& text, const std::string& file, int max_depth) {
  std::istringstream stream(text);
  YAML::Parser parser(stream);
  YamlStructure handler(file, max_depth);
  parser.HandleNextDocument(handler);
}

void checkFileStorageStructure(const std::string& text, const std::string& file, int max_depth) {
  Lines in(text, file);
  // OpenCV tells the format from the start of the first line (its first 16
  // characters, after a byte order mark).
  std::string_view head(text.c_str());
  if (head.substr(0, 3) == "\xEF\xBB\xBF") head.remove_prefix(3);
  head = head.substr(0, std::min(head.find('\n'), size_t{16}));
  try {
    if (head.substr(0, 5) == "%YAML") {
      OpenCvYaml(in, max_depth).read();
    } else if (head.substr(0, 1) == "{") {
      OpenCvJson(in, max_depth).read();
    } else if (head.substr(0, 5) == "<?xml") {
      OpenCvXml(in, max_depth).read();
    }
  } catch (const ReaderStops&) {
    // OpenCV's parse error, reported by OpenCV.
  }
}

}  // namespace lookboth
