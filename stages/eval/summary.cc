#include "stages/eval/summary.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <map>
#include <ostream>
#include <string_view>
#include <utility>

#include "common/atomic_file.h"
#include "common/cli.h"
#include "common/errors.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/path_check.h"
#include "common/text.h"

namespace rrslam {
namespace fs = std::filesystem;
namespace {

constexpr char kReferenceHeader[] = "sequence,ate_rmse_cm,source";

// " line N" of the character at offset `at` of `text`; empty for npos.
std::string LineOf(const std::string& text, size_t at) {
  if (at == std::string::npos) return "";
  return " line " + std::to_string(1 + std::count(text.begin(), text.begin() + at, '\n'));
}

nlohmann::json ReadJson(const fs::path& path) {
  const std::string text = ReadFileToString(path);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) {
    // nlohmann::json refuses a number beyond a double ("1e999") as it
    // refuses a syntax error; an infinite ATE is no measurement: say where.
    try {
      [[maybe_unused]] const nlohmann::json again = nlohmann::json::parse(text);
    } catch (const nlohmann::json::out_of_range& e) {
      const std::string message = e.what();  // "... number overflow parsing '1e999'".
      const size_t open = message.find('\''), close = message.rfind('\'');
      if (open != std::string::npos && close > open) {
        const std::string token = message.substr(open + 1, close - open - 1);
        throw DataError(path.string() + LineOf(text, text.find(token)) + ": " + token +
                        " is not a finite number");
      }
    } catch (const nlohmann::json::exception&) {
    }
  }
  if (j.is_discarded() || !j.is_object()) throw DataError(path.string() + ": not a JSON object");
  return j;
}

// The first line of a text file; `if_empty` when it has none.
std::string FirstLine(const fs::path& path, const std::string& if_empty) {
  const std::string text = ReadFileToString(path);
  const std::string line = text.substr(0, text.find_first_of("\r\n"));
  return line.empty() ? if_empty : line;
}

// The number at `pointer` in `j`, or nullopt when absent; DataError when present
// but not a number.
template <typename T>
std::optional<T> Number(const nlohmann::json& j, const char* pointer, const fs::path& path) {
  const nlohmann::json::json_pointer p(pointer);
  if (!j.contains(p)) return std::nullopt;
  const nlohmann::json& value = j.at(p);
  if (!value.is_number()) throw DataError(path.string() + ": " + pointer + " is not a number");
  return value.get<T>();
}

// " line N" of the JSON key `keys.back()`, found after each key before it
// ("ate_m", then "rmse"), by text search (nlohmann::json keeps no
// positions); empty when not found.
std::string LineOfKeys(const std::string& text, std::initializer_list<std::string> keys) {
  size_t at = 0;
  for (const std::string& key : keys) {
    at = text.find('"' + key + '"', at);
    if (at == std::string::npos) return "";
  }
  return LineOf(text, at);
}

std::string Cell(const std::optional<int64_t>& value) {
  return value ? std::to_string(*value) : "-";
}

std::string Fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

// A published figure as it is usually written (1.6, 0.9, 1.0, 4.75): no digits
// beyond those it has, which Fixed() would add.
std::string Shortest(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.4g", value);
  const std::string text = buffer;
  return text.find_first_of(".e") == std::string::npos ? text + ".0" : text;
}

// Text put in a Markdown table cell: a '|' would end the cell.
std::string Escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

std::string_view Trimmed(std::string_view text) {
  const size_t begin = text.find_first_not_of(" \t");
  if (begin == std::string_view::npos) return {};
  return text.substr(begin, text.find_last_not_of(" \t") - begin + 1);
}

// Splits one CSV line into `fields` (RFC 4180: a field in double quotes may
// hold commas, and "" in it stands for one quote; unquoted fields are trimmed
// of spaces). Returns what is wrong with the line, or an empty string.
std::string SplitCsvLine(std::string_view line, std::vector<std::string>* fields) {
  fields->clear();
  size_t i = 0;
  while (true) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::string field;
    if (i < line.size() && line[i] == '"') {
      bool closed = false;
      for (++i; i < line.size(); ++i) {
        if (line[i] != '"') {
          field += line[i];
        } else if (i + 1 < line.size() && line[i + 1] == '"') {
          field += '"';
          ++i;
        } else {
          closed = true;
          ++i;
          break;
        }
      }
      if (!closed) return "unterminated quoted field";
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i < line.size() && line[i] != ',') return "text after a closing quote";
    } else {
      const size_t end = std::min(line.find(',', i), line.size());
      field = std::string(Trimmed(line.substr(i, end - i)));
      i = end;
    }
    fields->push_back(std::move(field));
    if (i >= line.size()) return "";
    ++i;  // The comma.
  }
}

}  // namespace

RunSummary ReadRunSummary(const fs::path& dir) {
  std::error_code ec;
  RequireFolder(dir, "run folder");
  RunSummary run;
  run.name = fs::absolute(dir).lexically_normal().filename().string();
  if (run.name.empty()) run.name = fs::absolute(dir).lexically_normal().parent_path().filename();
  // skipped.txt says the run was not attempted this time, so an ate.json or
  // run.json beside it is left over from an earlier run and not shown.
  const fs::path skipped = dir / "skipped.txt";
  if (fs::is_regular_file(skipped, ec)) {
    run.skipped = true;
    run.failure = FirstLine(skipped, "no reason given");
    return run;
  }
  for (const fs::path& candidate : {dir / "run.json", dir / "track" / "run.json"}) {
    if (!fs::is_regular_file(candidate, ec)) continue;
    const nlohmann::json j = ReadJson(candidate);
    run.frames = Number<int64_t>(j, "/counts/frames", candidate);
    run.tracked = Number<int64_t>(j, "/counts/tracked", candidate);
    run.lost = Number<int64_t>(j, "/counts/lost", candidate);
    run.keyframes = Number<int64_t>(j, "/counts/keyframes", candidate);
    run.tracking_median_ms = Number<double>(j, "/timings/tracking/median_ms", candidate);
    break;
  }
  const fs::path ate = dir / "ate.json";
  if (!fs::is_regular_file(ate, ec)) {
    run.failure = "no ate.json";
    const fs::path error = dir / "error.txt";
    if (fs::is_regular_file(error, ec)) run.failure = FirstLine(error, run.failure);
    return run;
  }
  const nlohmann::json j = ReadJson(ate);
  const auto pairs = Number<int64_t>(j, "/pairs", ate);
  const auto rmse = Number<double>(j, "/ate_m/rmse", ate);
  const auto mean = Number<double>(j, "/ate_m/mean", ate);
  const auto max = Number<double>(j, "/ate_m/max", ate);
  if (!pairs || !rmse || !mean || !max) {
    throw DataError(ate.string() + ": not an `rrslam-eval ate --json` result (pairs, ate_m)");
  }
  // A negative error is no measurement (an infinite one, 1e999 in the text,
  // is refused by ReadJson), and either would stall the charts drawn from it.
  for (const auto& [key, value] :
       {std::pair<const char*, double>{"rmse", *rmse}, {"mean", *mean}, {"max", *max}}) {
    if (!(std::isfinite(value) && value >= 0)) {
      char text[32];
      std::snprintf(text, sizeof(text), "%g", value);
      throw DataError(ate.string() + LineOfKeys(ReadFileToString(ate), {"ate_m", key}) +
                      ": ate_m." + key + " = " + text + "; must be a finite distance >= 0 m");
    }
  }
  run.evaluated = true;
  run.pairs = *pairs;
  run.ate_rmse_m = *rmse;
  run.ate_mean_m = *mean;
  run.ate_max_m = *max;
  return run;
}

std::string CanonicalSequenceName(const std::string& name) {
  constexpr std::string_view kTumPrefix = "rgbd_dataset_freiburg";
  if (name.compare(0, kTumPrefix.size(), kTumPrefix) != 0) return name;
  size_t i = kTumPrefix.size();
  while (i < name.size() && name[i] >= '0' && name[i] <= '9') ++i;
  if (i == kTumPrefix.size() || i >= name.size() || name[i] != '_') return name;
  return "fr" + name.substr(kTumPrefix.size());
}

std::vector<ReferenceAte> ReadReferenceAte(const fs::path& path) {
  std::string text = ReadFileToString(path);
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);  // A spreadsheet's UTF-8 BOM.
  const std::string source = path.string();
  std::vector<ReferenceAte> references;
  std::map<std::string, int> line_of;  // Canonical sequence name -> its line.
  std::vector<std::string> fields;
  bool header_seen = false;
  int line_number = 0;
  for (size_t pos = 0; pos < text.size();) {
    size_t end = std::min(text.find('\n', pos), text.size());
    std::string_view line(text.data() + pos, end - pos);
    pos = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (Trimmed(line).empty() || Trimmed(line).front() == '#') continue;
    const std::string at = source + " line " + std::to_string(line_number) + ": ";
    const std::string wrong = SplitCsvLine(line, &fields);
    if (!wrong.empty()) throw DataError(at + wrong);
    if (!header_seen) {
      if (fields != std::vector<std::string>{"sequence", "ate_rmse_cm", "source"}) {
        throw DataError(at + "expected the header '" + kReferenceHeader + "'");
      }
      header_seen = true;
      continue;
    }
    if (fields.size() != 3) {
      throw DataError(at + "expected 3 fields '" + kReferenceHeader + "', got " +
                      std::to_string(fields.size()));
    }
    ReferenceAte reference;
    reference.sequence = fields[0];
    if (reference.sequence.empty()) throw DataError(at + "empty sequence name");
    const double cm = ParseDouble(fields[1], source, line_number);
    if (!(cm > 0)) throw DataError(at + "ATE RMSE " + fields[1] + " cm; must be > 0");
    reference.ate_rmse_m = cm / 100;
    reference.source = fields[2];
    if (reference.source.empty()) {
      throw DataError(at + "no source for " + reference.sequence + "'s figure");
    }
    const auto [it, inserted] =
        line_of.emplace(CanonicalSequenceName(reference.sequence), line_number);
    if (!inserted) {
      throw DataError(at + "sequence " + reference.sequence + " is already listed on line " +
                      std::to_string(it->second));
    }
    references.push_back(std::move(reference));
  }
  if (!header_seen) {
    throw DataError(source + ": empty; expected the header '" + kReferenceHeader + "'");
  }
  return references;
}

void AttachReferences(const std::vector<ReferenceAte>& references, std::vector<RunSummary>* runs) {
  std::map<std::string, const ReferenceAte*> by_name;
  for (const ReferenceAte& r : references) by_name[CanonicalSequenceName(r.sequence)] = &r;
  for (RunSummary& run : *runs) {
    const auto it = by_name.find(CanonicalSequenceName(run.name));
    run.reference = it == by_name.end() ? std::nullopt : std::optional(*it->second);
  }
}

std::string FormatSummaryTable(const std::vector<RunSummary>& runs,
                               const std::optional<ReferenceColumn>& reference) {
  // Columns: run, status, frames, tracked, lost, keyframes, ATE RMSE, [reference,]
  // ATE mean, ATE max, tracking median.
  const size_t kReferenceColumn = 7;
  const auto row = [&](std::vector<std::string> cells) {
    if (!reference) cells.erase(cells.begin() + kReferenceColumn);
    std::string line = "|";
    for (const std::string& cell : cells) line += cell.empty() ? " |" : " " + cell + " |";
    return line + "\n";
  };
  std::string out =
      row({"run", "status", "frames", "tracked", "lost", "keyframes", "ATE RMSE cm",
           reference ? reference->name + " ATE RMSE cm" : "", "ATE mean cm", "ATE max cm",
           "tracking median ms"}) +
      row({"---", "---", "---:", "---:", "---:", "---:", "---:", "---:", "---:", "---:", "---:"});
  double sum = 0;
  int evaluated = 0, failed = 0, skipped = 0;
  std::vector<std::string> sources;  // Distinct sources of the reference figures, numbered [1]...
  for (const RunSummary& r : runs) {
    std::string status;
    if (r.evaluated) {
      status = "evaluated";
      sum += r.ate_rmse_m;
      ++evaluated;
    } else if (r.skipped) {
      status = "skipped: " + Escaped(r.failure);
      ++skipped;
    } else {
      status = "failed: " + Escaped(r.failure);
      ++failed;
    }
    std::string reference_cell;
    if (reference && r.reference) {
      size_t k = 0;
      while (k < sources.size() && sources[k] != r.reference->source) ++k;
      if (k == sources.size()) sources.push_back(r.reference->source);
      reference_cell = Shortest(100 * r.reference->ate_rmse_m) + " [" + std::to_string(k + 1) + "]";
    }
    out += row({Escaped(r.name), status, Cell(r.frames), Cell(r.tracked), Cell(r.lost),
                Cell(r.keyframes), r.evaluated ? Fixed(100 * r.ate_rmse_m, 2) : "-", reference_cell,
                r.evaluated ? Fixed(100 * r.ate_mean_m, 2) : "-",
                r.evaluated ? Fixed(100 * r.ate_max_m, 2) : "-",
                r.tracking_median_ms ? Fixed(*r.tracking_median_ms, 1) : "-"});
  }
  std::string counts;
  if (failed > 0) counts = std::to_string(failed) + " failed";
  if (skipped > 0) counts += (counts.empty() ? "" : ", ") + std::to_string(skipped) + " skipped";
  out += row({"mean of " + std::to_string(evaluated) + " evaluated", counts, "", "", "", "",
              evaluated > 0 ? Fixed(100 * sum / evaluated, 2) : "-", "", "", "", ""});
  if (reference) {
    out += "\n" + reference->name + " ATE RMSE from " + reference->file.string() +
           (sources.empty() ? ": no figure for these sequences" : ":") + "\n";
    for (size_t k = 0; k < sources.size(); ++k) {
      out += "- [" + std::to_string(k + 1) + "] " + sources[k] + "\n";
    }
  }
  return out;
}

nlohmann::ordered_json SummaryToJson(const std::vector<RunSummary>& runs,
                                     const std::optional<ReferenceColumn>& reference) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const RunSummary& r : runs) {
    nlohmann::ordered_json row = {
        {"run", r.name},
        {"status", r.evaluated ? "evaluated" : (r.skipped ? "skipped" : "failed")},
        {"evaluated", r.evaluated}};
    if (r.skipped) row["skipped"] = r.failure;
    if (!r.evaluated && !r.skipped) row["failure"] = r.failure;
    if (r.frames) row["frames"] = *r.frames;
    if (r.tracked) row["tracked"] = *r.tracked;
    if (r.lost) row["lost"] = *r.lost;
    if (r.keyframes) row["keyframes"] = *r.keyframes;
    if (r.tracking_median_ms) row["tracking_median_ms"] = *r.tracking_median_ms;
    if (r.evaluated) {
      row["pairs"] = r.pairs;
      row["ate_m"] = {{"rmse", r.ate_rmse_m}, {"mean", r.ate_mean_m}, {"max", r.ate_max_m}};
    }
    if (reference && r.reference) {
      row["reference_ate_m"] = {{"rmse", r.reference->ate_rmse_m}, {"source", r.reference->source}};
    }
    rows.push_back(row);
  }
  nlohmann::ordered_json json = {{"producer", Producer("eval")}};
  if (reference)
    json["reference"] = {{"name", reference->name}, {"file", reference->file.string()}};
  json["runs"] = rows;
  return json;
}

bool EvalSummaryOptions::Check(std::string* why) const {
  if (run_dirs.empty()) {
    *why = "give at least one run folder";
    return false;
  }
  if (reference_name.empty() || reference_name.find_first_of("|\r\n") != std::string::npos) {
    *why =
        "--reference-name '" + reference_name + "'; must be non-empty, without '|' or line breaks";
    return false;
  }
  std::vector<NamedPath> inputs = {{"--reference", reference}};
  for (const auto& dir : run_dirs) inputs.push_back({"run folder", dir});
  return CheckOutputNotInput({"--out", out}, inputs, why);
}

void RunEvalSummary(const EvalSummaryOptions& options, std::ostream& out) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  std::vector<RunSummary> runs;
  for (const fs::path& dir : options.run_dirs) runs.push_back(ReadRunSummary(dir));
  std::optional<ReferenceColumn> reference;
  if (!options.reference.empty()) {
    AttachReferences(ReadReferenceAte(options.reference), &runs);
    reference = ReferenceColumn{options.reference_name, options.reference};
  }
  const std::string text = options.json ? DumpJson(SummaryToJson(runs, reference), 2) + "\n"
                                        : FormatSummaryTable(runs, reference);
  if (options.out.empty()) {
    out << text;
    out.flush();
  } else {
    WriteFileAtomically(options.out, text);
  }
}

}  // namespace rrslam
