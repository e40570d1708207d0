// JSON text of rrslam's outputs (run.json, reports, --json, metadata held in
// files) for strings that are bytes, not necessarily UTF-8.
//
// A Linux file name is a string of bytes: "caf\xe9" (Latin-1) is a legal
// folder name but not UTF-8, and nlohmann::json refuses to write a string
// that is not UTF-8 (type_error 316, an internal error to the tools). Every
// JSON writer of rrslam therefore writes through DumpJson, the one place of
// the rule:
//  - a string that is valid UTF-8 is written as it is;
//  - any other string is written quoted, as git quotes a path: between double
//    quotes, with `\` and `"` escaped by a backslash and every byte that is
//    not part of a valid UTF-8 sequence as a 3-digit octal escape ("caf\xe9"
//    -> "\"caf\\351\"" in the JSON text, i.e. the string `"caf\351"`);
//  - a valid UTF-8 string that itself starts and ends with `"` is quoted too,
//    so that UnquoteJsonString(s) gives the original bytes of every string.
// Valid UTF-8 characters are kept as they are inside the quotes.
//
// Thread-safety: pure functions.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace rrslam {

// True when `bytes` is valid UTF-8 (no overlong forms, surrogates or code
// points above U+10FFFF: what nlohmann::json accepts).
bool IsValidUtf8(std::string_view bytes);

// `bytes` as DumpJson writes it: unchanged when valid UTF-8 (and not itself in
// quoted form), else the quoted form described above. Always valid UTF-8.
std::string JsonString(std::string_view bytes);

// The bytes of a string JsonString wrote: the quoted form unquoted, anything
// else as it is.
std::string UnquoteJsonString(std::string_view text);

// A path in JSON (JsonString of its bytes) and back.
inline std::string PathToJson(const std::filesystem::path& path) {
  return JsonString(path.native());
}
inline std::filesystem::path PathFromJson(std::string_view text) {
  return std::filesystem::path(UnquoteJsonString(text));
}

// j.dump(indent) with every string and object key passed through JsonString:
// never throws for strings that are not UTF-8.
std::string DumpJson(const nlohmann::json& j, int indent = -1);
std::string DumpJson(const nlohmann::ordered_json& j, int indent = -1);

}  // namespace rrslam
