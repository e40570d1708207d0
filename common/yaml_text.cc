#include "common/yaml_text.h"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <exception>
#include <regex>
#include <unordered_set>
#include <vector>

#include "common/errors.h"

namespace rrslam {

void CheckYamlIsOneMap(std::string_view text, const std::string& name, const std::string& shape) {
  bool first = true;    // No key line yet.
  bool opened = false;  // The "---" marker was seen.
  int line = 0;
  for (size_t begin = 0; begin < text.size();) {
    size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    std::string_view l = text.substr(begin, end - begin);
    begin = end + 1;
    ++line;
    while (!l.empty() && (l.back() == '\r' || l.back() == ' ')) l.remove_suffix(1);
    const size_t content = l.find_first_not_of(' ');
    if (content == std::string_view::npos || l[content] == '#' || l.front() == '%') continue;
    auto fail = [&](const std::string& what) {
      throw DataError(name + ": line " + std::to_string(line) + ": '" +
                      std::string(l.substr(0, 24)) + "' " + what + " (" + shape + ")");
    };
    if (first && !opened && l.substr(0, 3) == "---" &&
        (l.size() == 3 || l.find_first_not_of(' ', 3) == std::string_view::npos ||
         l[l.find_first_not_of(' ', 3)] == '#')) {
      opened = true;  // The document's opening marker.
      continue;
    }
    if (first && content > 0) fail("is indented");
    if (l.front() == '-') fail("starts with '-' (a list or a second document)");
    if (l.substr(0, 3) == "...") fail("ends the document");
    first = false;
  }
}

namespace {

// Thrown inside YamlNestingScanner where OpenCV's parser reports a syntax
// error: it stops there, so nothing after can nest deeper.
struct ParserStops {};

// How deep OpenCV's YAML parser (modules/core/src/persistence_yml.cpp,
// YAMLParser; OpenCV 4.6) recurses on a text, found without recursing: a
// port of its control flow (skipSpaces, parseKey, parseValue, parse) that
// keeps an explicit stack of the collections parseValue is inside instead
// of building nodes. Where OpenCV reports an error the scan stops (nothing
// after is parsed); where the port cannot follow OpenCV exactly it goes on
// scanning, which can only find more depth, never less.
class YamlNestingScanner {
 public:
  YamlNestingScanner(std::string_view text, const std::string& name) : text_(text), name_(name) {
    StartLine(0);
  }

  void Run() {
    try {
      Documents();
    } catch (const ParserStops&) {
    }
  }

 private:
  struct Collection {
    bool flow = false;
    char kind = 0;        // '[' or '{' (flow), '-' or ':' (block sequence or map).
    int indent = 0;       // Flow: min_indent of its elements; block: its column.
    size_t elements = 0;  // Flow: elements read so far.
    // Maps: the keys read so far, as written (OpenCV keeps the first of two
    // equal keys and drops the second without a word).
    std::unordered_set<std::string_view> keys;
  };

  static bool Printable(char c) { return static_cast<unsigned char>(c) >= ' '; }
  static bool Digit(char c) { return c >= '0' && c <= '9'; }
  static bool Alnum(char c) {  // OpenCV's cv_isalnum: ASCII only, whatever the locale.
    return Digit(c) || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
  }

  // OpenCV reads line by line (FileStorage::gets); its buffer holds the line,
  // its '\n' and a '\0', and a column is an offset into that buffer.
  void StartLine(size_t begin) {
    line_begin_ = begin;
    const size_t newline = text_.find('\n', begin);
    has_newline_ = newline != std::string_view::npos;
    line_end_ = has_newline_ ? newline : text_.size();
    pos_ = begin;
  }
  char At(size_t p) const {
    if (p < line_end_) return text_[p];
    return p == line_end_ && has_newline_ ? '\n' : '\0';
  }
  int Column(size_t p) const { return static_cast<int>(p - line_begin_); }
  bool LooksAt(size_t p, std::string_view s) const {
    for (size_t i = 0; i < s.size(); ++i) {
      if (At(p + i) != s[i]) return false;
    }
    return true;
  }
  // Moves to the next line; false at the end of the text (OpenCV then
  // parses a made-up "..." that closes every collection: nothing nests).
  bool NextLine() {
    if (!has_newline_ || line_end_ + 1 >= text_.size()) return false;
    ++line_;
    StartLine(line_end_ + 1);
    return true;
  }

  // YAMLParser::skipSpaces (max_comment_indent is INT_MAX in every call, so
  // '#' starts a comment wherever a token may start). Throws ParserStops at
  // the end of the text.
  void SkipSpaces(int min_indent) {
    for (;;) {
      while (At(pos_) == ' ') ++pos_;
      const char c = At(pos_);
      if (c == '#' || c == '\0' || c == '\n' || c == '\r') {
        if (!NextLine()) throw ParserStops();
      } else if (Printable(c)) {
        if (Column(pos_) < min_indent) throw ParserStops();  // "Incorrect indentation".
        return;
      } else {
        throw ParserStops();  // A tab or a control character.
      }
    }
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw DataError(name_ + ": line " + std::to_string(line_) + ": " + what);
  }

  // YAMLParser::parseKey: the key runs to the first ':' on the line. A key
  // given twice in one map is refused.
  void ParseKey(Collection* map) {
    if (At(pos_) == '-') throw ParserStops();
    size_t end = pos_;
    while (Printable(At(end)) && At(end) != ':') ++end;
    if (At(end) != ':') throw ParserStops();
    size_t last = end;
    while (last > pos_ && At(last - 1) == ' ') --last;
    if (last == pos_) throw ParserStops();  // An empty key.
    const std::string_view key = text_.substr(pos_, last - pos_);
    if (!map->keys.insert(key).second) Fail("key '" + std::string(key) + "' is given twice");
    pos_ = end + 1;
  }

  void Push(const Collection& c) {
    stack_.push_back(c);
    if (static_cast<int>(stack_.size()) > kMaxYamlNesting) {
      Fail("YAML nested deeper than " + std::to_string(kMaxYamlNesting) + " levels");
    }
  }

  // The characters from `p` on that strtod / strtol might read: letters,
  // digits and ".+-_()" (hex, exponents, "inf", "nan(...)"), on this line.
  std::string NumberFrom(size_t p) const {
    size_t end = p;
    while (end < line_end_ && (Alnum(text_[end]) || std::string_view(".+-_()").find(text_[end]) !=
                                                        std::string_view::npos)) {
      ++end;
    }
    return std::string(text_.substr(p, end - p));
  }

  // YAMLParser::parseValue up to where it would recurse: a scalar is read
  // (pos_ after it; returns false) or a collection is pushed (true).
  bool Value(int min_indent, bool parent_flow) {
    char c = At(pos_), d = At(pos_ + 1);
    enum { kNone, kString, kInt, kReal } type = kNone;
    if (c == '!') {
      bool user = false;
      if (d == '<') Fail("YAML tags of the form !<...> are not supported");
      if (d == '!' || d == '^') {
        ++pos_;
        user = true;
      }
      size_t end = pos_ + 1;
      while (Printable(At(end)) && At(end) != ' ') ++end;
      const std::string_view tag = text_.substr(pos_ + 1, end - pos_ - 1);
      if (tag.empty()) throw ParserStops();  // "Empty type name".
      if (!user && tag == "str") type = kString;
      if (!user && tag == "int") type = kInt;
      if (!user && tag == "float") type = kReal;
      if (user && tag == "binary") Fail("binary YAML data (!!binary) is not supported");
      d = At(end);  // OpenCV keeps this stale `d` for the number test below.
      pos_ = end;
      SkipSpaces(min_indent);
      c = At(pos_);
    }
    if (type == kString && c != '\'' && c != '"') return PlainScalar(parent_flow, type == kString);
    if (type == kInt || type == kReal || Digit(c) ||
        ((c == '-' || c == '+') && (Digit(d) || d == '.')) || (c == '.' && Alnum(d))) {
      size_t end = pos_ + (c == '-' || c == '+');
      while (Digit(At(end))) ++end;
      const std::string rest = NumberFrom(pos_);
      char* stop = nullptr;
      if (type == kReal || (type != kInt && (At(end) == '.' || At(end) == 'e'))) {
        std::strtod(rest.c_str(), &stop);
      } else {
        // OpenCV keeps an int: a larger value would wrap (4294967316 -> 20).
        errno = 0;
        const long value = std::strtol(rest.c_str(), &stop, 0);
        if (stop != rest.c_str() && (errno == ERANGE || value < INT_MIN || value > INT_MAX)) {
          Fail("integer " + rest.substr(0, static_cast<size_t>(stop - rest.c_str())) +
               " does not fit in 32 bits");
        }
      }
      if (stop == rest.c_str()) throw ParserStops();  // "Invalid numeric value".
      pos_ += static_cast<size_t>(stop - rest.c_str());
      return false;
    }
    if (c == '\'' || c == '"') {
      QuotedScalar(c);
      return false;
    }
    if (c == '[' || c == '{') {
      Push({true, c, min_indent + !parent_flow, 0, {}});
      ++pos_;
      return true;
    }
    if (!parent_flow && c == '-') {
      Push({false, '-', Column(pos_), 0, {}});
      return true;
    }
    if (!parent_flow && (c == '?' || c == '|' || c == '>')) throw ParserStops();
    return PlainScalar(parent_flow, false);
  }

  // parseValue's implicit string, or the block map whose first key it is.
  bool PlainScalar(bool parent_flow, bool string_type) {
    size_t end = pos_;
    for (char c = At(end); Printable(c) && (!parent_flow || (c != ',' && c != '}' && c != ']')) &&
                           (parent_flow || c != ':' || string_type);
         c = At(++end)) {
    }
    if (end == pos_) throw ParserStops();  // "Invalid character".
    if (parent_flow || At(end) != ':') {
      pos_ = end;
      return false;
    }
    Push({false, ':', Column(pos_), 0, {}});
    return true;
  }

  void QuotedScalar(char quote) {
    size_t p = pos_;
    for (;;) {
      const char c = At(++p);
      if (quote == '\'') {
        if (c == '\'') {
          if (At(++p) != '\'') break;  // '' stands for one quote.
        } else if (!Printable(c)) {
          throw ParserStops();
        }
        continue;
      }
      if (c == '"') {
        ++p;
        break;
      }
      if (c == '\\') {
        const char e = At(++p);
        if (e == 'x' || (Digit(e) && e < '8')) {
          // OpenCV reads up to 3 characters with strtol (its bases swapped)
          // and goes on one past where strtol stopped.
          const bool hex = e == 'x';
          const char digits[4] = {At(p), At(p + 1), At(p + 2), '\0'};
          char* stop = nullptr;
          std::strtol(digits + hex, &stop, hex ? 8 : 16);
          if (stop != digits + hex) p += static_cast<size_t>(stop - digits);
        }
      } else if (!Printable(c)) {
        throw ParserStops();
      }
    }
    pos_ = p;
  }

  // The loop of the innermost collection, from where its last element's
  // value ended (or, new, from its start), until it needs another value
  // (returns) or closes (popped; the loop goes on in its parent). Returns
  // false when the outermost collection closed.
  bool NextElement(bool fresh) {
    while (!stack_.empty()) {
      Collection& top = stack_.back();
      if (top.flow) {
        SkipSpaces(top.indent);
        char c = At(pos_);
        if (c == '}' || c == ']') {
          if (c != (top.kind == '[' ? ']' : '}')) throw ParserStops();
          ++pos_;
          stack_.pop_back();
          fresh = false;
          continue;
        }
        if (top.elements != 0) {
          if (c != ',') throw ParserStops();  // "Missing , between the elements".
          ++pos_;
          SkipSpaces(top.indent);
        }
        if (top.kind == '{') {
          ParseKey(&top);
          SkipSpaces(top.indent);
        } else if (At(pos_) == ']') {
          stack_.pop_back();  // "[a, ]": the ']' is left for the parent.
          fresh = false;
          continue;
        }
        ++top.elements;
        return true;
      }
      if (!fresh) {
        SkipSpaces(0);
        if (Column(pos_) != top.indent) {
          if (Column(pos_) > top.indent) throw ParserStops();  // "Incorrect indentation".
          stack_.pop_back();
          continue;
        }
        if (LooksAt(pos_, "...")) {
          stack_.pop_back();
          continue;
        }
      }
      if (top.kind == ':') {
        ParseKey(&top);
      } else if (At(pos_++) != '-') {
        throw ParserStops();
      }
      SkipSpaces(top.indent + 1);
      return true;
    }
    return false;
  }

  // One value and everything nested in it.
  void NestedValue(int min_indent, bool parent_flow) {
    const size_t outer = stack_.size();
    if (!Value(min_indent, parent_flow)) return;
    bool fresh = true;
    for (;;) {
      if (!NextElement(fresh) || stack_.size() <= outer) return;
      const Collection& top = stack_.back();
      fresh = Value(top.flow ? top.indent : top.indent + 1, top.flow);
    }
  }

  // YAMLParser::parse: directives, "---", then one collection per document.
  void Documents() {
    bool first = true;
    for (;;) {
      SkipSpaces(0);
      if (At(pos_) == '%') {
        if (!NextLine()) return;
        continue;
      }
      if (LooksAt(pos_, "---")) {
        pos_ += 3;
      } else if (At(pos_) == '-' && !first) {
        return;  // OpenCV loops here for ever; CheckYamlIsOneMap refuses it.
      }
      SkipSpaces(0);
      if (!LooksAt(pos_, "...")) NestedValue(0, false);
      SkipSpaces(0);
      pos_ += 3;
      first = false;
    }
  }

  std::string_view text_;
  const std::string& name_;
  size_t line_begin_ = 0, line_end_ = 0, pos_ = 0;
  bool has_newline_ = false;
  int line_ = 1;
  std::vector<Collection> stack_;
};

}  // namespace

void CheckYamlStructure(std::string_view text, const std::string& name) {
  YamlNestingScanner(text, name).Run();
}

cv::FileStorage ParseYamlText(const std::string& text, const std::string& name,
                              const std::string& shape) {
  CheckYamlIsOneMap(text, name, shape);
  CheckYamlStructure(text, name);
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw DataError(name + ": not a valid YAML file: " + YamlSyntaxError(e));
  } catch (const std::exception& e) {
    // OpenCV's parser lets a std::length_error escape on "{ :a: 1 }".
    throw DataError(name + ": not a valid YAML file (" + e.what() + ")");
  }
  if (!fs.isOpened()) throw DataError(name + ": not a valid YAML file");
  return fs;
}

// OpenCV 4 formats "<file>(<line>): <what>" and passes it as the exception's
// function name (FileStorage::Impl::parseError swaps its arguments), with the
// parser function's name as the message; look in both.
std::string YamlSyntaxError(const cv::Exception& e) {
  static const std::regex kLine(R"(\((\d+)\): ([^\n]*))");
  for (const std::string* text : {&e.func, &e.err}) {
    std::smatch m;
    if (std::regex_search(*text, m, kLine)) return "line " + m[1].str() + ": " + m[2].str();
  }
  std::string text = e.err;
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

}  // namespace rrslam
