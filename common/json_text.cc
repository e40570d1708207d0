#include "common/json_text.h"

#include <cstdint>
#include <cstdio>

namespace rrslam {
namespace {

// Length of the valid UTF-8 sequence starting at s[i] (1 to 4), or 0 when
// the byte there starts none (RFC 3629's table of well-formed sequences).
size_t Utf8SequenceLength(std::string_view s, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = byte(i);
  if (c < 0x80) return 1;
  size_t n = 0;
  unsigned char low = 0x80, high = 0xBF;  // Range of the second byte.
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) low = 0xA0;   // No overlong forms.
    if (c == 0xED) high = 0x9F;  // No surrogates.
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) low = 0x90;   // No overlong forms.
    if (c == 0xF4) high = 0x8F;  // Nothing above U+10FFFF.
  } else {
    return 0;
  }
  if (n > s.size() - i) return 0;
  if (byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (size_t k = 2; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
  }
  return n;
}

bool LooksQuoted(std::string_view s) {
  return s.size() >= 2 && s.front() == '"' && s.back() == '"';
}

bool NeedsQuoting(std::string_view s) { return !IsValidUtf8(s) || LooksQuoted(s); }

template <typename Json>
bool AnyNeedsQuoting(const Json& j) {
  if (j.is_string()) return NeedsQuoting(j.template get_ref<const std::string&>());
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (NeedsQuoting(it.key()) || AnyNeedsQuoting(it.value())) return true;
    }
  } else if (j.is_array()) {
    for (const Json& v : j) {
      if (AnyNeedsQuoting(v)) return true;
    }
  }
  return false;
}

template <typename Json>
Json WithJsonStrings(const Json& j) {
  if (j.is_string()) return Json(JsonString(j.template get_ref<const std::string&>()));
  if (j.is_object()) {
    Json out = Json::object();
    for (auto it = j.begin(); it != j.end(); ++it) {
      out[JsonString(it.key())] = WithJsonStrings(it.value());
    }
    return out;
  }
  if (j.is_array()) {
    Json out = Json::array();
    for (const Json& v : j) out.push_back(WithJsonStrings(v));
    return out;
  }
  return j;
}

template <typename Json>
std::string Dump(const Json& j, int indent) {
  // The copy is made only when a string needs it (rare: paths in Latin-1).
  return AnyNeedsQuoting(j) ? WithJsonStrings(j).dump(indent) : j.dump(indent);
}

}  // namespace

bool IsValidUtf8(std::string_view bytes) {
  for (size_t i = 0; i < bytes.size();) {
    const size_t n = Utf8SequenceLength(bytes, i);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::string JsonString(std::string_view bytes) {
  if (!NeedsQuoting(bytes)) return std::string(bytes);
  std::string out = "\"";
  for (size_t i = 0; i < bytes.size();) {
    const size_t n = Utf8SequenceLength(bytes, i);
    if (n == 0) {
      char escape[8];
      std::snprintf(escape, sizeof(escape), "\\%03o", static_cast<unsigned char>(bytes[i]));
      out += escape;
      ++i;
      continue;
    }
    if (n == 1 && (bytes[i] == '\\' || bytes[i] == '"')) out += '\\';
    out.append(bytes.substr(i, n));
    i += n;
  }
  out += '"';
  return out;
}

std::string UnquoteJsonString(std::string_view text) {
  if (!LooksQuoted(text)) return std::string(text);
  const std::string_view body = text.substr(1, text.size() - 2);
  const auto octal = [](char c) { return c >= '0' && c <= '7'; };
  std::string out;
  out.reserve(body.size());
  for (size_t i = 0; i < body.size(); ++i) {
    if (body[i] != '\\' || i + 1 == body.size()) {
      out += body[i];
    } else if (body[i + 1] == '\\' || body[i + 1] == '"') {
      out += body[++i];
    } else if (i + 3 < body.size() && body[i + 1] >= '0' && body[i + 1] <= '3' &&
               octal(body[i + 2]) && octal(body[i + 3])) {
      out += static_cast<char>((body[i + 1] - '0') * 64 + (body[i + 2] - '0') * 8 +
                               (body[i + 3] - '0'));
      i += 3;
    } else {
      out += body[i];  // Not written by JsonString: kept as it is.
    }
  }
  return out;
}

std::string DumpJson(const nlohmann::json& j, int indent) { return Dump(j, indent); }

std::string DumpJson(const nlohmann::ordered_json& j, int indent) { return Dump(j, indent); }

}  // namespace rrslam
